%
(prsxy-post 0.1.0)
(source: samples/five-axis.ngc)
(source sha256: a30460f0f55439e4c21c3e2781c190dc5d201104b394d737cb509379db11b488)
(profile: PRS-XY nominal, shop settings [profiles/prsxy-shop.toml])
(profile sha256: 4787b168347e43f127564b3aa33a2cdcdc69574bde22fbf8c63fb57fe7c6719e)
(options: --format gcode)
(interpolation period: 10 ms; path tolerance 0.0005 mm and 0.5 arcsec where the program sets none [a G64 P in the program sets its own])
(For a controller whose inverse kinematics is the nominal design, with an ideal table.)
(Run with no tool length offset [G49] and no work offset: tool lengths and)
(offsets are in the points. Timing is G93 inverse time per segment.)
(Corners blend within G64 P0.00025 [LinuxCNC's G64 without P would)
(cut them by any amount]; a line that ends where the motion stands, or at)
(a corner LinuxCNC would blend too far, runs in G61 [exact path] and is)
(followed by G4 P0, so that the next line [in G61 too] starts where it ends.)
G21 G90 G17 G40 G49 G94
G64 P0.00025
G0 X0.0000000 Y0.0000000 Z20.0000000 A0.0000000 B0.0000000
G93
(line 3)
G61
G1 X-30.0000000 Y-30.0000000 Z10.0000000 A0.0000000 B0.0000000 F229.416
G4 P0
(line 4)
G1 X-30.0000000 Y-30.0000000 Z0.0000000 A0.0000000 B0.0000000 F80.000
G4 P0
(line 6)
G1 X-30.0000000 Y-30.0000000 Z0.0000000 A10.0000000 B-5.0000000 F160.997
G4 P0
(line 7)
G1 X30.0000000 Y-30.0000000 Z0.0000000 A10.0000000 B-5.0000000 F25.000
G4 P0
(line 8)
G1 X30.0000000 Y30.0000000 Z0.0000000 A-10.0000000 B5.0000000 F25.000
G4 P0
(line 9)
G1 X-30.0000000 Y30.0000000 Z0.0000000 A-15.0000000 B15.0000000 F25.000
G4 P0
(line 10)
G1 X-30.0000000 Y-30.0000000 Z0.0000000 A0.0000000 B0.0000000 F25.000
G4 P0
(line 12)
G1 X40.0000000 Y0.0000000 Z0.0000000 A0.0000000 B15.0000000 F19.696
G4 P0
(line 13)
G1 X39.9999927 Y0.0241882 Z0.0000000 A0.0000000 B15.0000000 F8417.052
G64 P0.00025
G3 X-0.1357162 Y-39.9997698 Z0.0000000 A0.0000000 B15.0000000 I-39.9999927 J-0.0241882 F7.964
G3 X39.9999974 Y-0.0144338 Z0.0000000 A0.0000000 B15.0000000 I0.1357161 J39.9997698 F23.827
G61
G1 X40.0000000 Y0.0000000 Z0.0000000 A0.0000000 B15.0000000 F10392.305
G4 P0
(line 14)
G1 X40.0000000 Y0.0000000 Z0.0000000 A0.0000000 B0.0000000 F100.000
G4 P0
(line 15)
G1 X40.0000000 Y0.0000000 Z10.0000000 A0.0000000 B0.0000000 F795.495
G4 P0
(line 16)
G94
M30
(end: 15 points, 25.037 s)
%
