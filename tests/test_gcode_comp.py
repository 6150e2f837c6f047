"""Cutter radius compensation against rs274: entries, exits, corners of every
kind, arcs inside and outside, errors.

Tools (length, diameter) as in test_gcode_macros.TOOLS: T1 6 mm, T2 3 mm,
T3 12.7 mm in diameter. Every program runs through both; the motions (ends,
arc centres and turns, feeds) and the refusals must agree.
"""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from . import oracle
from .test_gcode_macros import TOOLS, agree, ours
from .test_gcode_oracle import _require_rs274

pytestmark = pytest.mark.linuxcnc

SQUARE = "X0 Y0 F100\nX20\nY20\nX0\nY0\n"

PROGRAMS = {
    "left outside square": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 " + SQUARE + "G40 G0 X-10 Y-10\nM2\n",
    "right outside square": "G21 T1 M6\nG0 X-10 Y-10\nG42 G1 " + SQUARE + "G40 G0 X-10\nM2\n",
    "left inside (concave)": (
        "G21 T2 M6\nG0 X5 Y5\nG42 G1 X0 Y0 F100\nX20\nY20\nX0\nY0\nG40 G1 X5 Y5\nM2\n"
    ),
    "D word, G41.1 diameter": "G21\nG0 X-10 Y-10\nG41.1 D4 G1 " + SQUARE + "G40 X-10\nM2\n",
    "D from the table": "G21\nG0 X-10 Y-10\nG42 D3 G1 " + SQUARE + "G40 X-10\nM2\n",
    "negative diameter swaps sides": "G21\nG0 X-10 Y-10\nG41.1 D-4 G1 " + SQUARE + "G40 X-10\nM2\n",
    "circle outside": (
        "G21 T1 M6\nG0 X-20 Y0\nG41 G1 X-10 Y0 F200\nG2 X-10 Y0 I10 J0\nG40 G1 X-20\nM2\n"
    ),
    "circle inside": "G21 T1 M6\nG0 X0 Y0\nG41 G1 X10 Y0 F200\nG3 X10 Y0 I-10 J0\nG40 G1 X0\nM2\n",
    "arc entry": "G21 T2 M6\nG0 X-10 Y0\nG42 G2 X0 Y10 R10 F100\nG1 X10\nG40 G1 Y20\nM2\n",
    "line to arc to line": (
        "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nX10\nG3 X20 Y10 I0 J10\nG1 Y20\n"
        "G2 X30 Y30 R10\nG1 X40\nG40 G1 X50 Y50\nM2\n"
    ),
    "concave arc corners": (
        "G21 T2 M6\nG0 X0 Y-10\nG42 G1 X0 Y0 F100\nG2 X20 Y0 R10\nG2 X40 Y0 R10\n"
        "G1 Y-10\nG40 G1 Y-20\nM2\n"
    ),
    "arc to line concave": (
        "G21 T2 M6\nG0 X0 Y-10\nG41 G1 X0 Y0 F100\nG3 X10 Y10 I10 J0\nG1 X0 Y20\nG40 G1 Y30\nM2\n"
    ),
    "z and rotary during comp": (
        "G21 T1 M6\nG0 X-10 Y-10 Z5\nG41 G1 X0 Y0 Z0 F100\nX20 Z-1 A10\nY20 B5\nX0 Z-2\n"
        "G40 G0 Z10\nM2\n"
    ),
    "g0 corners": "G21 T1 M6\nG0 X-10 Y-10\nG41 G0 X0 Y0\nX20\nY20\nG40 G0 X30 Y30\nM2\n",
    "incremental": (
        "G21 T1 M6\nG0 X-10 Y-10\nG91 G41 G1 X10 Y10 F100\nX20\nY20\nX-20\nG40 X-10\nM2\n"
    ),
    "inch": "G20 T1 M6\nG0 X-1 Y-1\nG41 G1 X0 Y0 F10\nX2\nY2\nG40 X3\nM2\n",
    "xz plane": "G21 G18 T1 M6\nG0 X-10 Z-10\nG41 G1 X0 Z0 F100\nX20\nZ20\nG40 X30\nM2\n",
    "functions while comp holds a move": (
        "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nX20 M8\nG4 P0.5\nY20 S1000\nG40 X30\nM2\n"
    ),
    "program end with comp on": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nX20\nY20\nM2\n",
    "comp of zero radius": "G21\nG0 X-10 Y-10\nG41 G1 " + SQUARE + "G40 X-10\nM2\n",
    "reentry": (
        "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nX20\nG40 G0 X30\nG42 G1 X40 Y0\nY10\n"
        "G40 G0 X50\nM2\n"
    ),
    "shallow corners": (
        "G21 T1 M6\nG0 X-10 Y0\nG41 G1 X0 Y0 F100\nX10 Y0.1\nX20 Y0.3\nX30 Y0\nG40 X40\nM2\n"
    ),
    # a straight move after G40 allows arcs again, on the fast path too
    "arc after G40 and a straight move": (
        "G21 T1 M6\nG0 X-10 Y0\nG41 G1 X0 F100\nX10\nG40 G1 X20\nG0 X30\nG0 X0 Y0\n"
        "G2 X10 I5 J0\nM2\n"
    ),
    # a tool change reads the position back (read_inputs, refresh_actual_position):
    # where G40 left the tool is the current position from there on
    "tool change after G40": (
        "G21 T1 M6\nG0 X-10 Y0\nG41 G1 X0 F100\nX10\nG40\nT2 M6\nG0 Z5\nG0 X0 Y0\nM2\n"
    ),
    # G93: the rate of a move is its programmed length times F
    # (inverse_time_rate_straight from program_x), set before the corner's arc
    "inverse time": (
        "G20\nG0 X0 Y0\nG42.1 D0.4 G93 G1 X1 F30\nY1 F20\nX-1 F20\nY2 F40\nG94 X1 F33\n"
        "G93 G3 Y3 J0.5 F6\nG40 G94 G1 Y4 F25\nM2\n"
    ),
}


@pytest.mark.parametrize("program", list(PROGRAMS.values()), ids=list(PROGRAMS))
def test_compensated_paths_agree_with_linuxcnc(program: str) -> None:
    _, err = agree(program)
    assert err is None, err


ERRORS = {
    "entry shorter than the radius": "G21 T3 M6\nG0 X0 Y0\nG41 G1 X3 Y0 F100\nG40 X10\nM2\n",
    "tool bigger than the inside arc": (
        "G21 T3 M6\nG0 X0 Y0\nG41 G1 X10 Y0 F100\nG3 X10 Y0 I-5 J0\nG40 X0\nM2\n"
    ),
    "gouging concave corner": "G21 T3 M6\nG0 X-10 Y5\nG42 G1 X0 Y0 F100\nX2\nY-10\nG40 X10\nM2\n",
    "arc right after G40": (
        "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nX10\nG40 G2 X20 Y0 R10\nM2\n"
    ),
    "on twice": "G21 T1 M6\nG41 G1 X10 F100\nG42 X20\nM2\n",
    "in G19": "G21 G19 T1 M6\nG41 G1 Y10 F100\nM2\n",
    "canned cycle": "G21 T1 M6\nG0 X-10 Y-10 Z5\nG41 G1 X0 Y0 F100\nG81 X5 Z-1 R1\nM2\n",
    "G28": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nG28\nM2\n",
    "tool change": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nT2 M6\nM2\n",
    "G92": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nG92 X0\nM2\n",
    "coordinate system": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nG55\nM2\n",
    "reading the position": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\n#1=#5420\nM2\n",
    "G41.1 without D": "G21\nG41.1 G1 X10 F100\nM2\n",
    "D word without comp": "G21\nG1 X10 D1 F100\nM2\n",
    "no such tool": "G21\nG41 D9 G1 X10 F100\nM2\n",
}


@pytest.mark.parametrize("program", list(ERRORS.values()), ids=list(ERRORS))
def test_compensation_errors_refused_by_both(program: str) -> None:
    _require_rs274()
    ref = oracle.run(program, tools=TOOLS)
    _, _, err = ours(program)
    assert ref.error is not None, "rs274 accepts it"
    assert err is not None, f"we accept what rs274 refuses: {ref.error}"


# ---------------------------------------------------------------- random paths

#: coordinates of the random paths' straight moves [mm]
_GRID = (-30.0, -20.0, -12.5, -10.0, -5.0, 0.0, 5.0, 7.5, 10.0, 15.0, 20.0, 30.0)
#: arc centre offsets from the arc's start [mm]
_OFFSET = (-10.0, -5.0, -2.5, 0.0, 2.5, 5.0, 10.0, 15.0)


@st.composite
def _compensated_path(draw: st.DrawFn) -> str:
    """A random path in G17 with compensation switched on and off along it: lines,
    IJK arcs whose end is on their circle (to 4 decimals), R arcs, moves out of the
    plane, dwells and spindle words; comp on with every way to give the tool (table
    or D, left or right, G41/G42 and G41.1/G42.1). Straight moves after G40, as
    LinuxCNC requires; everything else (entries too short, gouges, arcs the tool
    cannot follow) is left to both interpreters to refuse alike."""
    x, y = -40.0, -40.0
    lines = ["G21 G90 G17 G94 G40 G49 G54 G80 F500", "T1 M6", "G0 X-40 Y-40 Z0"]
    comp = False
    for _ in range(draw(st.integers(1, 30))):
        kind = draw(
            st.sampled_from(["line", "line", "line", "arc", "arc", "r arc", "comp", "misc"])
        )
        if kind == "line":
            nx, ny = draw(st.sampled_from(_GRID)), draw(st.sampled_from(_GRID))
            g = draw(st.sampled_from(["G1", "G1", "G0"]))
            extra = draw(st.sampled_from(["", "", "Z-1", "Z0", "A5", "B-2", "F300"]))
            words = [f"X{nx:g}"] if nx != x else []
            if ny != y or not words:
                words.append(f"Y{ny:g}")
            lines.append(" ".join([g, *words, extra]).strip())
            x, y = nx, ny
        elif kind == "arc":
            i, j = draw(st.sampled_from(_OFFSET)), draw(st.sampled_from(_OFFSET))
            i = 5.0 if i == 0.0 and j == 0.0 else i
            cx, cy, r = x + i, y + j, math.hypot(i, j)
            turn = draw(st.sampled_from([0.0, 30.0, 45.0, 90.0, 135.0, 180.0, 270.0, -90.0, 359.9]))
            a = math.atan2(y - cy, x - cx) + math.radians(turn)
            x, y = round(cx + r * math.cos(a), 4), round(cy + r * math.sin(a), 4)
            g = draw(st.sampled_from(["G2", "G3"]))
            z = draw(st.sampled_from(["", "", "Z-0.5", "Z0"]))
            lines.append(f"{g} X{x:.4f} Y{y:.4f} I{i:g} J{j:g} {z}".strip())
        elif kind == "r arc":
            r = draw(st.sampled_from([5.0, 8.0, 10.0, 20.0, -10.0, -20.0]))
            a = math.radians(draw(st.sampled_from([0.0, 45.0, 90.0, 180.0, 270.0, 300.0])))
            chord = draw(st.sampled_from([0.5, 1.0, 1.5, 1.9])) * abs(r)
            x, y = round(x + chord * math.cos(a), 4), round(y + chord * math.sin(a), 4)
            lines.append(f"{draw(st.sampled_from(['G2', 'G3']))} X{x:.4f} Y{y:.4f} R{r:g}")
        elif kind == "comp" and comp:
            x, y = x + 0.5, y - 25.0
            lines += ["G40", f"G1 X{x:g} Y{y:g}"]
            comp = False
        elif kind == "comp":
            lines.append(
                draw(
                    st.sampled_from(
                        ["G41.1 D2", "G42.1 D2", "G41 D1", "G42 D1", "G42.1 D6", "G41 D3", "G42"]
                    )
                )
            )
            comp = True
        else:
            lines.append(
                draw(
                    st.sampled_from(
                        ["G4 P0.1", "M3 S100", "G1 Z2", "G0 Z1", "G91 G1 Z-1", "G90", "G1 Z-1 A3"]
                    )
                )
            )
    return "\n".join([*lines, "G40", "G0 X50 Y50", "M2"]) + "\n"


# derandomized, as the other rs274 searches: the same programs on every run, so that
# CI judges the code and not the draw (a new draw found the program below in CI)
@settings(
    max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(_compensated_path())
def test_random_compensated_paths_agree_with_linuxcnc(program: str) -> None:
    """Both run it with the same motions (every corner arc, every moved end), or
    both refuse it. Run with max_examples=2000 while writing it: 1 056 ran in
    both, the other 944 both refused, none differed."""
    agree(program)


def test_an_arc_entering_compensation_has_linuxcncs_centre() -> None:
    """Found by the random compensated paths in CI, 2026-11-24: after G40 and a
    move, G41 D1 then a G3 as the first compensated move, nearly straight once
    compensated (convert_arc_comp1 moves its centre 1400 mm away: cos A = 0.0026,
    above its 1e-4 limit). The centres differed by 4e-4 mm; the cause was this
    test's tool table, written in inches to 9 decimals, which gave rs274 a tool
    5.6e-9 mm small in radius (oracle.run now writes every digit)."""
    agree(
        "G21 G90 G17 G94 G40 G49 G54 G80 F500\nT1 M6\nG0 X-40 Y-40 Z0\nG41.1 D2\n"
        "G1 X-30 Y-30\nG1 Y-30\nG4 P0.1\nG1 Y-30\nG4 P0.1\nG2 X-30.0000 Y-30.0000 I-10 J-10\n"
        "G1 Y-30\nG4 P0.1\nG40\nG1 X-29.5 Y-55\nG41 D1\nG3 X-34.1967 Y-48.6612 I-10 J-2.5\n"
        "G40\nG0 X50 Y50\nM2\n"
    )
