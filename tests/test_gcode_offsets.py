"""Offsets from the program (G10, G92 family, G52, G28.1/G30.1) against rs274.

Both interpreters run each program; their motions must agree (the oracle adds
the G5x and G92 offsets rs274 prints apart). Work offsets and tools start as in
the oracle's parameter file and tool table.
"""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import gcode

from . import oracle
from .test_gcode_macros import TOOLS, agree, ours
from .test_gcode_oracle import _require_rs274, verdict

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
        ("G21\nG10 L1 P1 X1\nM2\n", "tool offsets in X"),
        # the arc would lie in a vertical plane turned about Z, neither XZ nor YZ
        ("G21\nG10 L2 P1 R30\nG18 G2 X1 Z1 R5 F9\nM2\n", "arcs in G18 in a rotated"),
        ("G21\n#5250 = 10\nG55\nG19 G3 Y1 Z1 R5 F9\nM2\n", "arcs in G19 in a rotated"),
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


# ------------------------------------------------------- rotated coordinate systems
#
# G10 L2 P<n> R<deg> turns system n about Z (LinuxCNC 2.9.0~pre1, f1270d6ed7, the
# rs274 installed here):
# - convert_setup (interp_convert.cc:4180-4374): R goes to #[5210 + 20 n]
#   (:4224-4229); "R not allowed in G10 L20" (:4225); "I J words not allowed with
#   G10 L2" (:4196); L20 turns the difference of the current and the wanted
#   point by the system's R before it moves the origin (:4231-4263); when n is the
#   active system the current point is carried into the new frame, turned
#   without the G92 offset (:4328-4366).
# - convert_coordinate_system (:1752-1845): selecting a system reads its R
#   (:1820); selecting the active one again does nothing (:1792-1798).
# - find_current_in_system (interp_find.cc:467-526): the point in another system,
#   turned back by its R; find_ends for G53 (:170-197) and find_relative for
#   G28/G30 (:427-431) take machine coordinates through the rotation;
#   convert_savehome (G28.1, interp_convert.cc:2446-2450) turns the point out.
# - the canon (task/emccanon.cc:242-274, rotate_and_offset_pos): a point is the
#   program point plus the G92 offset, turned by R, plus the work offset; rs274
#   prints SET_XY_ROTATION and the program point, and tests/oracle.py places it so.

ROTATED = [
    # every system, lines and G17 arcs (R and IJ, helical, two turns), P0 = active
    *(
        f"G21\nG10 L2 P{n} X{3 * n} Y{-2 * n} Z1 R{15 * n - 40}\n{code}\nG0 X10 Y5 Z2\n"
        "G1 X20 Y5 F300\nG2 X20 Y-5 R5\nG3 X10 Y-5 I-5 J0 Z-1\nG2 X10 Y-5 I0 J5 P2\n"
        "G10 L2 P0 R7.5\nG1 X0 Y0\nM2\n"
        for n, code in enumerate(
            ["G54", "G54", "G55", "G56", "G57", "G58", "G59", "G59.1", "G59.2", "G59.3"]
        )
    ),
    # a rotation set while the system is in use: the tool stays where it is
    "G21\nG0 X10 Y0\nG10 L2 P1 R90\nG0 X10 Y0\nG2 X0 Y10 R10 F100\nG10 L2 P1 R0\nG0 X1\nM2\n",
    "G20\nG0 X1 Y2\nG10 L2 P0 X0.5 R-30\nG1 X2 F10\nG91 G1 X1 Y1\nG90 G0 X0 Y0\nM2\n",
    # G91 and absolute arc centres (G90.1) in the turned frame
    "G21\nG10 L2 P1 X5 Y3 R30\nG0 X10 Y0\nG91 G1 X5 Y5 F100\nG90 G3 X0 Y0 I-7.5 J-2.5\n"
    "G90.1 G2 X10 Y0 I5 J0\nG91.1\nM2\n",
    # L20 in a turned system, active and not, and with G92 on
    "G20\nG10 L2 P1 R-12.5 X1\nG0 X1 Y1\nG10 L20 P1 X0 Y0\nG0 X1 Y0\nG10 L20 P2 X2 Y3\n"
    "G55 G0 X0 Y0\nM2\n",
    "G21\nG10 L2 P2 R40 X10\nG0 X7 Y-3 Z2\nG10 L20 P2 Y4\nG55 G0 X0 Y0\nG10 L20 P0 X1 Z0\n"
    "G0 X2 Y2 Z1\nM2\n",
    "G21\nG10 L2 P1 R25\nG0 X5 Y5\nG92 X0 Y0\nG10 L20 P1 X2 Y-1\nG0 X1 Y1\nG10 L20 P3 X0\n"
    "G56 G0 X0 Y0\nM2\n",
    # G92 and G52 inside the turned frame, and a system switch with G92 on
    "G21\nG10 L2 P2 X5 Y3 R30\nG55 G0 X10 Y0\nG54 G0 X1\nG55 G92 X0 Y0\nG0 X3 Y4\nG92.1\n"
    "G0 X1 Y1\nM2\n",
    "G21\nG10 L2 P1 R60\nG52 X10 Y5\nG0 X0 Y0\nG1 X5 F100\nG92.2\nG0 X0\nG92.3\nG0 Y2\nM2\n",
    "G21\nG0 X4 Y4\nG92 X0 Y0\nG10 L2 P1 R-45\nG0 X1 Y0\nG10 L2 P0 R45 Y2\nG0 X0 Y0\nM2\n",
    # G10 L2/L20 of the active system turn the program point without the G92
    # offset (interp_convert.cc:4328-4366): found by the random rotated programs
    "G21\nG0 X1 Y1\nG52 X1\nG10 L2 P0 R12.5\nG53 G0 Y0.5\nG0 X0\nG10 L20 P0 X1\nG0 Y2\nM2\n",
    # tool length offsets, G10 L10/L11 in a turned system
    "G21\nG10 L2 P1 R30\nT1 M6\nG43 G0 X5 Y5 Z10\nG10 L10 P1 Z2\nG43\nG0 X0 Z5\nG49 G0 Z0\nM2\n",
    "G21\nG10 L2 P1 R30 Z-2\nG10 L2 P9 R10 Z-3\nT2 M6\nG0 Z10\nG10 L11 P2 Z2\nG43 G0 X1 Z10\nM2\n",
    # G53 in machine coordinates, not turned; an axis not given stays on the machine
    "G21\nG10 L2 P1 X2 Y1 R30\nG0 X5 Y5 Z1\nG53 G0 X1\nG53 G1 Y2 F100\nG53 G0 X3 Y4 Z-1\n"
    "G0 X0 Y0\nT1 M6\nG43\nG53 G0 Z0\nG0 Y1\nM2\n",
    # G28/G30 through the turned frame, with and without axes; G28.1 stores it out
    "G21\nG10 L2 P1 X2 Y1 R30\nG0 X5 Y5 Z1\nG28 X6\nG0 X1 Y1\nG30 Y0\nG0 X1 Y1\nG28\nM2\n",
    "G21\nG10 L2 P1 R45\nG0 X4 Y4 Z6\nG28.1\nG0 X0 Y0 Z0\nG28\nG10 L2 P1 R0\nG28 X0\nM2\n",
    # canned cycles (G17, and G18's straight moves), polar coordinates, inches
    "G21\nG10 L2 P1 X10 R20\nG0 Z5\nG81 X1 Y2 Z-1 R2 F100\nX3\nG91 X1 Y1 L2\nG90 G80\n"
    "G18 G83 X2 Z1 Y-3 R2 Q1\nG80 G17\nM2\n",
    "G21\nG10 L2 P1 R30\nG1 @10 ^45 F100\nG91 ^45\nG90 G0 @5 ^0\nM2\n",
    "G20\nG10 L2 P1 X0.5 Y0.25 R33.3333\nG0 X1 Y1\nG2 X2 Y2 R1 F10\nG21 G0 X10 Y0\nM2\n",
    # cutter compensation in the turned frame
    "G21\nG10 L2 P1 R30\nG0 X-10 Y-10\nG41 D1 G1 X0 Y0 F200\nG1 X20\nG3 X30 Y10 R10\n"
    "G1 Y20\nG40 G1 X40 Y30\nM2\n",
    "G21\nG10 L2 P1 R-70\nG0 X-5 Y0\nG42.1 D4 G1 X0 Y0 F200\nG2 X10 Y0 I5 J0\nG1 Y-10\n"
    "G40 G0 X20\nM2\n",
    # #5230.. as a parameter: read at a switch of system, not when it is in use
    "G21\n#5230 = 30\nG54 G0 X10\nG55\nG54 G0 X10\n#5250 = -20\nG55 G0 X10\nM2\n",
]


@pytest.mark.parametrize("program", ROTATED)
def test_rotated_systems_agree_with_rs274(program: str) -> None:
    """Every move, arc centre, offset and tool length as rs274 makes them."""
    _, err = agree(program)
    assert err is None, err


def test_rotation_parameters_read_back() -> None:
    """#5230 + 20 n hold each system's R as written (degrees, no units), #5420/
    #5421 the program point in the turned frame (LinuxCNC's current_x, y)."""
    program = (
        "G21\nG10 L2 P1 R30\nG10 L2 P9 R-12.5\nG10 L2 P0 X1\nG0 X3 Y4\n"
        "(PRINT,%.4f#5230 #5250 #5390 #5420 #5421 #<_x> #<_y>)\nG20\n(PRINT,%.4f#5420 #5421)\nM2\n"
    )
    printed, err = agree(program)
    assert err is None
    assert [float(v) for v in printed[0].split()] == [30, 0, -12.5, 3, 4, 3, 4]
    assert [float(v) for v in printed[1].split()] == pytest.approx([3 / 25.4, 4 / 25.4], abs=1e-4)


def test_abs_position_is_the_machine_point() -> None:
    """#<_abs_x> and #<_abs_y> are the point on the machine, turned
    (interp_namedparams.cc:726-741). Ours in mm: rs274's standalone canon keeps
    machine units in inches (the known difference above), so the closed form."""
    _, msgs, err = ours(
        "G21\nG10 L2 P1 X10 Y20 R90\nG0 X3 Y4\n(PRINT,%.6f#<_abs_x> #<_abs_y>)\nM2\n"
    )
    assert err is None
    assert [float(v) for v in msgs[-1][1].split()] == pytest.approx([10 - 4, 20 + 3], abs=1e-9)


def test_a_square_turns_about_the_system_origin() -> None:
    """Closed form, apart from rs274: the corners of a square and the centre of a
    G17 arc are the program's turned by R about the work offset."""
    import math

    got, _, err = ours(
        "G21\nG10 L2 P1 X100 Y50 R30\nG0 X0 Y0\nG1 X10 F100\nY10\nG2 X0 Y10 I-5 J0\nM2\n"
    )
    assert err is None
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))

    def turned(x: float, y: float) -> tuple[float, float]:
        return 100 + x * c - y * s, 50 + x * s + y * c

    for m, (x, y) in zip(got, [(0, 0), (10, 0), (10, 10), (0, 10)], strict=True):
        assert m.end[:2] == pytest.approx(turned(x, y), abs=1e-12)
    arc = got[-1]
    assert arc.kind == "arc" and arc.plane == 17 and arc.rotation == -1
    assert arc.center is not None and arc.center[:2] == pytest.approx(turned(5, 10), abs=1e-12)


@pytest.mark.parametrize(
    "program",
    [
        "G21\nG10 L20 P1 R30 X1\nM2\n",  # R not allowed in G10 L20
        "G21\nG10 L2 P1 R30 J1\nM2\n",  # I J words not allowed with G10 L2
        "G21\nG10 L2 P10 R30\nM2\n",  # P out of range
        "G21\nG0 X-5 Y0\nG41 D1 G1 X0 F100\nG10 L2 P0 R30\nM2\n",  # the active one, comp on
        "G21\nG0 X-5 Y0\nG41 D1 G1 X0 F100\nG10 L2 P1 R30\nM2\n",
    ],
)
def test_rotation_errors_refused_by_both(program: str) -> None:
    _require_rs274()
    ref = oracle.run(program, tools=TOOLS)
    _, _, err = ours(program)
    assert err is not None and ref.error is not None, f"rs274: {ref.error!r}, ours: {err}"


def test_rotation_on_another_system_with_compensation_on() -> None:
    """A system not in use may be turned with compensation on (only the active
    one may not: interp_convert.cc:4216-4217)."""
    _, err = agree("G21\nG0 X-5 Y0\nG41 D1 G1 X0 F100\nG10 L2 P2 R30\nG1 X10\nG40 G0 X20\nM2\n")
    assert err is None


@pytest.mark.parametrize(
    "program",
    [
        "G21\nG10 L2 P1 R30\nG0 X1\nG18 G2 X1 Z1 R5 F9\nM2\n",
        "G21\nG10 L2 P2 R-5\nG55 G0 X1\nG19 G91 G3 Y2 Z0 J1 K0 F9\nM2\n",
    ],
)
def test_arcs_off_xy_in_a_turned_system_are_refused_as_unsupported(program: str) -> None:
    """rs274 makes them; we refuse them as not supported, after the same moves."""
    v = verdict(program)
    assert v.status == "not supported" and v.rs274_ran, v


def test_curves_turn_with_the_system() -> None:
    """A G5 and a G5.2 curve in a turned system are the unturned ones turned
    about the work offset (the canon turns NURBS control points as it turns
    every point; rs274 prints only their number, so the closed form)."""
    import math

    body = "G0 X1 Y2\nG5 X10 Y5 I2 J3 P-2 Q1\nG5.2 X12 Y6 P1\nX14 Y2 P2\nX16 Y7 P1\nG5.3\nM2\n"
    flat, _, err0 = ours("G21 G1 F100\nG10 L2 P1 X7 Y-3\n" + body)
    turned, _, err1 = ours("G21 G1 F100\nG10 L2 P1 X7 Y-3 R-35\n" + body)
    assert err0 is None and err1 is None
    c, s = math.cos(math.radians(-35)), math.sin(math.radians(-35))
    curves = [(a, b) for a, b in zip(flat, turned, strict=True) if a.kind == "curve"]
    assert len(curves) == 2
    for a, b in curves:
        assert a.curve is not None and b.curve is not None
        origin = np.array([7.0, -3.0])
        rel = a.curve.control[:, :2] - origin
        want = np.column_stack([rel[:, 0] * c - rel[:, 1] * s, rel[:, 0] * s + rel[:, 1] * c])
        assert b.curve.control[:, :2] == pytest.approx(want + origin, abs=1e-12)
        assert list(b.curve.weights) == list(a.curve.weights)
        assert b.end[:2] == pytest.approx(tuple(b.curve.control[-1, :2]), abs=1e-12)
        assert b.feed == a.feed
