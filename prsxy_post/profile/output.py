"""The keys of each output dialect's profile section ``[output.<name>]``.

They are declared here, below the writers, so that loading a profile validates
them without importing any dialect: each writer module takes its settings from
:data:`OUTPUT_SETTINGS` under its own name (``writers.DIALECTS`` holds the same
names; a test holds the two registries equal).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import NamedTuple


class Setting(NamedTuple):
    """One key of a dialect's profile section.

    default : value when absent (its type is the key's type: int or float)
    lo, hi : allowed range (inclusive)
    doc : one line for profiles/README.md
    legacy : the key's name in the old flat ``[output]`` section, read with a
        deprecation note
    """

    default: float | int
    lo: float
    hi: float
    doc: str
    legacy: str | None = None


#: ``[output.pmac]``: the Turbo PMAC PVT dialect (:mod:`prsxy_post.writers.pmac`).
PMAC_SETTINGS: Mapping[str, Setting] = {
    "coordinate_system": Setting(1, 1, 16, "coordinate system `&n`", "coordinate_system"),
    "program": Setting(1, 1, 32767, "`OPEN PROG n` (split parts count up from here)", "program"),
    # 7: a 0.1 nm step. At 6 (1 nm) the rounding alone moved a motor 0.15 % faster
    # than planned over a 1 ms segment at F60 (a crossing window). Turbo PMAC keeps
    # program constants as 48-bit floats with a 36-bit mantissa (User Manual,
    # "Computational Features": "P & Q-Variables, Program Constants"), which holds
    # 7 decimals exactly below 2^35 × 1e-7 ≈ 3436 mm.
    "decimals": Setting(7, 4, 9, "decimals of motor positions", "decimals"),
    "max_points_per_program": Setting(
        0,
        0,
        10**9,
        "> 0: split long jobs into programs of at most this many points, each "
        "ending at rest at a block end",
        "max_points_per_program",
    ),
    "backlash_takeup_mm": Setting(
        0.0005,
        1e-9,
        1.0,
        "`tables export --format pmac`: Ixx85, how fast the controller takes up a "
        "backlash [mm per background cycle] (Software Reference, Ixx85: 1/16 count "
        "per background cycle; 0 would disable the backlash)",
    ),
    "rotary_buffer_points": Setting(
        0,
        0,
        10**7,
        "> 0: write for a rotary buffer holding this many lines ahead "
        "(`DEFINE ROT` in words: 12 per line)",
        "rotary_buffer_points",
    ),
}


#: ``[output.gcode]``: corrected G-code for LinuxCNC (:mod:`prsxy_post.writers.linuxcnc`).
GCODE_SETTINGS: Mapping[str, Setting] = {
    # 7: a 0.1 nm step, as the PMAC writer's. At 6 (1 nm) the rounding of x and y
    # alone ran a 1 ms crossing window at F60 1.0018 x F (test_controller_truth's
    # found programs). LinuxCNC reads the words as doubles.
    "decimals": Setting(7, 4, 9, "decimals of positions", "decimals"),
    # 0.0001: a fifth of the path tolerance. LinuxCNC's planner runs a line per
    # chord; at one point a period it ran short lines below the plan's speed and
    # its queue ran dry (bench/linuxcnc_speed.py, docs/measurements.md)
    "tolerance_mm": Setting(
        0.0001,
        0.0,
        10.0,
        "> 0: drop points while the chord through the kept ones stays within this "
        "(it adds to the path error); 0: a line to every point",
        "gcode_tolerance_mm",
    ),
    "g61_every_line": Setting(
        0,
        0,
        1,
        "1: every line runs in G61 (exact path, a stop at every point): LinuxCNC 2.9 then "
        "never blends, and never runs over F, at the cost of time",
    ),
}


#: Every dialect's section keys, by the dialect's ``--format`` name.
OUTPUT_SETTINGS: Mapping[str, Mapping[str, Setting]] = {
    "pmac": PMAC_SETTINGS,
    "gcode": GCODE_SETTINGS,
}
