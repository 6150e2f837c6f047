"""G and M codes: LinuxCNC 2.9's modal groups (``interp_array.cc``: ``_gees``,
``_ems``), and the ones outside what this machine runs."""

from __future__ import annotations

#: G code (×10, as LinuxCNC keys them: G43.1 is 431) → modal group
G_GROUPS: dict[int, int] = {
    **dict.fromkeys([40, 100, 280, 281, 300, 301, 520, 530, 920, 53], 0),
    **dict.fromkeys(
        [
            0,
            10,
            20,
            30,
            50,
            51,
            52,
            330,
            331,
            382,
            383,
            384,
            385,
            700,
            710,
            711,
            712,
            720,
            721,
            722,
            730,
            740,
            760,
            *list(range(800, 900, 10)),
        ],
        1,
    ),
    **dict.fromkeys([170, 171, 180, 181, 190, 191], 2),
    900: 3,
    910: 3,
    901: 4,
    911: 4,
    930: 5,
    940: 5,
    950: 5,
    200: 6,
    210: 6,
    **dict.fromkeys([400, 410, 411, 420, 421], 7),
    **dict.fromkeys([430, 431, 432, 490], 8),
    980: 10,
    990: 10,
    **dict.fromkeys([540, 550, 560, 570, 580, 590, 591, 592, 593], 12),
    610: 13,
    611: 13,
    640: 13,
    960: 14,
    970: 14,
    70: 15,
    80: 15,
    921: 16,
    922: 16,
    923: 16,
}

#: G codes LinuxCNC knows that this machine does not run (×10 → why)
G_OUT_OF_SCOPE: dict[int, str] = {
    70: "lathe diameter mode (G7) is out of scope for this machine",
    80: "lathe radius mode (G8) is out of scope for this machine",
    330: "spindle-synchronised motion (G33) is out of scope for this machine",
    331: "rigid tapping (G33.1) is out of scope for this machine",
    760: "threading (G76) is out of scope for this machine",
    382: "probing (G38.2) is out of scope for this machine",
    383: "probing (G38.3) is out of scope for this machine",
    384: "probing (G38.4) is out of scope for this machine",
    385: "probing (G38.5) is out of scope for this machine",
    700: "lathe finishing cycles (G70) are out of scope for this machine",
    710: "lathe roughing cycles (G71) are out of scope for this machine",
    711: "lathe roughing cycles (G71.1) are out of scope for this machine",
    712: "lathe roughing cycles (G71.2) are out of scope for this machine",
    720: "lathe roughing cycles (G72) are out of scope for this machine",
    721: "lathe roughing cycles (G72.1) are out of scope for this machine",
    722: "lathe roughing cycles (G72.2) are out of scope for this machine",
    171: "U-V planes (G17.1) are out of scope (no U, V, W axes)",
    181: "U-W planes (G18.1) are out of scope (no U, V, W axes)",
    191: "V-W planes (G19.1) are out of scope (no U, V, W axes)",
    950: "feed per revolution (G95) is out of scope for this machine (no spindle feedback)",
    870: "back boring (G87) is not supported",
    880: "G88 (boring with a manual retract) is not supported",
}

#: not yet: removed as each lands
G_NOT_YET: dict[int, str] = {
    432: "G43.2 (additional offsets) is not supported",
}

#: M code → modal group (LinuxCNC's _ems; M98 is read as an O-word)
M_GROUPS: dict[int, int] = {
    **dict.fromkeys([0, 1, 2, 30, 60, 99], 4),
    **dict.fromkeys([62, 63, 64, 65, 66, 67, 68], 5),
    6: 6,
    61: 6,
    **dict.fromkeys([3, 4, 5, 19, 70, 71, 72, 73], 7),
    **dict.fromkeys([7, 8, 9], 8),
    **dict.fromkeys([48, 49, 50, 51, 52, 53], 9),
    **dict.fromkeys(range(100, 200), 10),
}
M_OUT_OF_SCOPE: dict[int, str] = {
    19: "spindle orientation (M19) is out of scope for this machine",
}
M_NOT_YET: dict[int, str] = {}

CYCLES = {73, 74, 81, 82, 83, 84, 85, 86, 89}
#: canned cycles of one plunge: (dwell at the bottom, retract at feed rate)
CYCLE_SHAPE = {
    81: (False, False),
    82: (True, False),
    84: (True, True),
    86: (True, False),
    89: (True, True),
}
AXES = "XYZAB"


def g_code10(v: float) -> int | None:
    """LinuxCNC's read_g: ten times the value, within 0.001 of an integer (else
    None: not a G code)."""
    import math

    x = v * 10.0
    n = math.floor(x)
    if x - n > 0.999:
        return math.ceil(x)
    if x - n > 0.001:
        return None
    return int(n)


def code_of(code10: int) -> float:
    """G/M number as used in the interpreter's state: G1 is 1, G43.1 is 43.1."""
    return code10 // 10 if code10 % 10 == 0 else code10 / 10.0
