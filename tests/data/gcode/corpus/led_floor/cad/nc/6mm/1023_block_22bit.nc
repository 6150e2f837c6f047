(1023_block_22bit)
(T1  D=2.2 CR=0 - ZMIN=-3 - flat end mill)
G90 G94
G17
G21
(When using Fusion 360 for Personal Use, the feedrate of)
(rapid moves is reduced to match the feedrate of cutting)
(moves, which can increase machining time. Unrestricted rapid)
(moves are available with a Fusion 360 Subscription.)

(2D Contour5)
T1
S5000 M3
G54
G0 X-1.1 Y-1.1
Z10
G1 Z5 F1000
Z2 F333.3
Z-1
Y21.1 F1000
X21.1
Y0
Y-1.1
X0
X-1.1
Z-2 F333.3
Y21.1 F1000
X21.1
Y0
Y-1.1
X0
X-1.1
Z-3 F333.3
Y21.1 F1000
X21.1
Y0
Y-1.1
X0
X-1.1
Z10
M5
M30
