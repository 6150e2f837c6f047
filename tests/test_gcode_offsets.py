"""Offsets from the program (G10, G92 family, G52, G28.1/G30.1) against rs274.

Both interpreters run each program; their motions must agree (the oracle adds
the G5x and G92 offsets rs274 prints apart). Work offsets and tools start as in
the oracle's parameter file and tool table.
"""

from __future__ import annotations

import pytest

from prsxy_post import gcode

from . import oracle
from .test_gcode_macros import TOOLS, agree, ours
from .test_gcode_oracle import _require_rs274

pytestmark = pytest.mark.linuxcnc


@pytest.mark.parametrize(
    "program",
    [
        # G10 L2: set a system's offsets (P0: the active one), then use it
        "G21\nG10 L2 P2 X10 Y-5 Z1 A5\nG55 G0 X1 Y1 Z1 A1\nG10 L2 P0 X20\nG0 X1\nM2\n",
        "G20\nG10 L2 P1 X1 Y2\nG0 X0 Y0\nG21 G0 X5\nM2\n",
        "G21\nG10 L2 P7 X3\nG59.1 G0 X0 Y0\nG10 L2 P9 Y4\nG59.3 G0 X1\nG54 G0 X0\nM2\n",
        # G10 L20: the current position becomes the given one
        "G21\nG0 X10 Y10 Z5\nG10 L20 P1 X0 Y0\nG0 X1 Y1\nG10 L20 P2 Z0\nG55 G0 Z1\nM2\n",
        "G21\nG0 X10\nG92 X0\nG10 L20 P1 X0\nG0 X1\nM2\n",
        # G92 family and G52
        "G21\nG0 X5 Y5\nG92 X0 Y0\nG0 X1\nG92.2\nG0 X1\nG92.3\nG0 X1\nG92.1\nG0 X1\nM2\n",
        "G21\nG0 X5 Y5 A10\nG92 A0\nG0 A5\nG91 G92 X1\nG0 X1\nM2\n",
        "G20\nG0 X1\nG92 X0\nG21 G0 X10\nG92 X2\nG0 X0\nM2\n",
        "G21\nG52 X10 Y20\nG0 X0 Y0\nG52 X0\nG0 X0 Y0\nG55 G0 X0\nM2\n",
        "G21\nG92 X10\nG55 G0 X0\nG54 G0 X0\nM2\n",
        "G21\nG0 X3\nG92 X1\nG2 X3 Y0 I1 J0 F100\nG81 X5 Y0 Z-1 R1\nG80\nM2\n",
        # stored positions
        "G21\nG0 X4 Y5 Z6\nG28.1\nG0 X0 Y0 Z0\nG28\nG0 X1 Y1 Z1\nG30.1\nG0 X9\nG30\nM2\n",
        "G21\nT1 M6\nG43\nG0 X2 Z3\nG28.1\nG49\nG28 X0\nM2\n",
        # tool table from the program
        "G21\nG10 L1 P1 Z20 R3\nT1 M6\nG43 G0 Z5\nG10 L1 P1 Z30\nG43\nG0 Z5\nM2\n",
        "G21\nT2 M6\nG0 Z10\nG10 L10 P2 Z0\nG43 G0 Z10\nM2\n",
        "G21\nG10 L2 P9 Z-3\nT1 M6\nG0 Z10\nG10 L11 P1 Z2\nG43 G0 Z10\nM2\n",
        "G21\nG0 Z10\nG92 Z0\nG10 L10 P1 Z0\nT1 M6\nG43 G0 Z4\nM2\n",
    ],
)
def test_offsets_from_the_program(program: str) -> None:
    _, err = agree(program)
    assert err is None, err


@pytest.mark.parametrize(
    "program",
    [
        "G21\nG92\nM2\n",  # no axes
        "G21\nG52\nM2\n",
        "G21\nG10 L2 P10 X1\nM2\n",  # no such system
        "G21\nG10 L5 P1 X1\nM2\n",
        "G21\nG10 L2 P1.5 X1\nM2\n",
        "G21\nG10 L20 P1 R1\nM2\n",
        "G21\nG10 L1 P1\nM2\n",  # nothing to set
        "G21\nG10 L1 P50 Z1\nM2\n",  # no such tool
        "G21\nG10 L1 P0 Z1\nM2\n",
        "G21\nG92 X0 G0 X1\nM2\n",  # two codes that use the axis words
        "G21\nG10 L2 P1 I1 X1\nM2\n",
    ],
)
def test_offset_errors_refused_by_both(program: str) -> None:
    _require_rs274()
    ref = oracle.run(program, tools=TOOLS)
    _, _, err = ours(program)
    assert (err is None) == (ref.error is None), f"rs274: {ref.error!r}, ours: {err}"


def test_not_on_this_machine() -> None:
    for program, why in [
        ("G21\nG10 L2 P1 R30\nM2\n", "rotated coordinate systems"),
        ("G21\nG10 L1 P1 X1\nM2\n", "tool offsets in X"),
        ("G21\n#5230 = 10\nG54\nM2\n", "rotated coordinate systems"),
    ]:
        _, _, err = ours(program)
        assert err is not None and why in str(err), program


def test_parameters_hold_the_offsets_in_machine_units() -> None:
    """A known difference: parameters in machine units are in inches in
    standalone rs274 (its canon's GET_EXTERNAL_LENGTH_UNITS is 1/25.4,
    saicanon.cc) and in mm on this machine (and on a LinuxCNC configured with
    ``[TRAJ] LINEAR_UNITS = mm``). Program units do not matter."""
    program = (
        "G21\nG10 L2 P2 X10 Y-5\nG0 X5 Z2\nG92 X0\nT1 M6\nG10 L1 P1 Z20\n"
        "G20\nG28.1\n(PRINT,%.6f#5241 #5242 #5211 #5403 #5161 #5163)\nM2\n"
    )
    _require_rs274()
    ref = oracle.run(program, tools=TOOLS)
    _, msgs, err = ours(program)
    assert err is None and ref.error is None
    theirs = [float(v) * 25.4 for v in ref.prints[0].split()]
    mine = [float(v) for v in msgs[-1][1].split()]
    assert mine == pytest.approx(theirs, abs=1e-4)
    assert mine == pytest.approx([10.0, -5.0, 5.0, 20.0, 5.0, 2.0])


def test_offsets_last_for_the_run_only() -> None:
    """G10 changes the program's copy of the profile's offsets and tools."""
    cfg = gcode.InterpreterConfig(
        work_offsets={54: (1.0, 0.0, 0.0, 0.0, 0.0)}, tool_table={1: gcode.ToolEntry(5.0)}
    )
    gcode.interpret("G21\nG10 L2 P1 X50\nG10 L1 P1 Z9\nM2\n", cfg)
    assert cfg.work_offsets[54][0] == 1.0 and cfg.tool_table[1].length == 5.0
    m = gcode.interpret("G21\nG0 X0\nM2\n", cfg)[0]
    assert m.end[0] == 1.0
