"""The corrected G-code writer (prsxy_post/writers/linuxcnc.py), read back.

LinuxCNC's termination modes, from its G-code reference: ``G61`` (exact path)
"Moves will slow or stop as needed to reach every programmed point"; ``G64 P``
blends within P. The mode is modal and each line is queued with the mode active
when it is read; it governs the junction at the line's end. What LinuxCNC does
with the written program is in test_linuxcnc_motion.py.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from .conftest import ROOT
from .test_controller_truth import XY_CORNER_AT_F60
from .test_tracking import convert, truth_machine

PROGRAMS = [
    ("xy-corner-F60", XY_CORNER_AT_F60),
    *[(p.name, p.read_text()) for p in sorted((ROOT / "samples").glob("*.ngc"))],
]


def _moves_and_modes(text: str) -> tuple[list[str], list[bool]]:
    """Every G0/G1/G4 line of the written program, and whether G61 was in force
    when it was read."""
    moves: list[str] = []
    exact: list[bool] = []
    mode = False
    for raw in text.splitlines():
        s = raw.strip()
        if s == "G61":
            mode = True
        elif re.fullmatch(r"G64 P[\d.]+", s):
            mode = False
        elif s.startswith(("G0 ", "G1 ", "G4 ")):
            moves.append(s)
            exact.append(mode)
    return moves, exact


@pytest.mark.parametrize(("name", "text"), PROGRAMS, ids=[n for n, _ in PROGRAMS])
def test_a_line_ending_where_the_motion_stands_runs_in_exact_path_mode(name: str, text: str):
    """Each written move is one of the chain's points (no tolerance set): a G1 that
    ends where the plan stands (speed 0) is read under G61, every other under G64 P."""
    truth = truth_machine("random", 12)
    _, res, texts = convert(truth, text, "gcode")
    moves, exact = _moves_and_modes(texts[0])
    pts = res.points
    written = [k for k in range(len(pts)) if pts.fn[k] is None]
    assert len(written) == len(moves)
    stands = np.array([pts.speed[k] == 0.0 for k in written])
    g1 = np.array([m.startswith("G1 ") for m in moves])
    assert np.array_equal(np.array(exact)[g1], stands[g1])
    # and the program stands somewhere beside its end (a corner, a rapid's end)
    assert np.sum(stands[g1]) >= 2
