"""G5, G5.1, G5.2/G5.3 against LinuxCNC.

rs274's stand-in canon prints a curve only as ``NURBS_FEED(n, ...)`` (the number
of control points; saicanon.cc), so the comparison with rs274 is on which
programs run, the curves' control point counts, feeds and every motion around
them. The geometry is compared with what a running LinuxCNC moves along:
NURBS_FEED in emccanon.cc joins the points P(u_i), u_i = umax·i/(4n), of its
NURBS (nurbs_point, nurbs_additional_functions.cc, ported in test_curves) with
biarcs, so our curve must pass through every one of them, at the same
parameter; between them LinuxCNC's biarcs approximate the curve, ours is it.
"""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import gcode

from . import oracle
from .test_curves import linuxcnc_point
from .test_gcode_macros import TOOLS, agree, ours
from .test_gcode_oracle import _require_rs274

pytestmark = pytest.mark.linuxcnc


def curves(text: str) -> list[gcode.Motion]:
    return [m for m in gcode.interpret(text, source="s.ngc") if m.kind == "curve"]


def passes_through_linuxcncs_points(
    m: gcode.Motion, pts: np.ndarray, w: np.ndarray, k: int
) -> None:
    c = m.curve
    assert c is not None
    n = len(pts) - 1
    umax = n - k + 2
    div = len(pts) * 4
    for i in range(div + 1):
        u = umax * i / div
        theirs = linuxcnc_point(u, k, pts, w)
        np.testing.assert_allclose(c.point(u), theirs, atol=1e-9)


def test_g5_is_linuxcncs_cubic() -> None:
    text = "G21 G0 X1 Y2 Z3\nG1 F100\nG5 X10 Y0 I3 J4 P-2 Q5\nG5 X20 Y5 P1 Q-2\nM2\n"
    a, b = curves(text)
    # G5: start, start + (I, J), end + (P, Q), end
    p1 = np.array([[1, 2, 3], [4, 6, 3], [8, 5, 3], [10, 0, 3.0]])
    passes_through_linuxcncs_points(a, p1, np.ones(4), 4)
    # without I, J the first control point mirrors the last one of the G5 before
    p2 = np.array([[10, 0, 3], [12, -5, 3], [21, 3, 3], [20, 5, 3.0]])
    passes_through_linuxcncs_points(b, p2, np.ones(4), 4)
    assert a.end == (10.0, 0.0, 3.0, 0.0, 0.0) and b.start == a.end
    assert a.feed == 100.0 and a.curve is not None and a.curve.degree == 3


def test_g51_is_linuxcncs_quadratic() -> None:
    (m,) = curves("G20 G0 X1 Y1\nG1 F10\nG5.1 X3 Y1 I1 J2\nM2\n")
    pts = np.array([[1, 1, 0], [2, 3, 0], [3, 1, 0.0]]) * 25.4
    passes_through_linuxcncs_points(m, pts, np.ones(3), 3)
    assert m.feed == pytest.approx(254.0)


def test_g52_is_linuxcncs_nurbs() -> None:
    text = (
        "G21 G0 X0 Y0 Z-1\nG1 F300\nG5.2 P2 L4\nX10 Y0 P1\nX10 Y10 P0.5\nX20 Y10 P3\nX30 Y0 P1\n"
        "G5.3\nG1 X0\nM2\n"
    )
    (m,) = curves(text)
    pts = np.array([[0, 0, -1], [10, 0, -1], [10, 10, -1], [20, 10, -1], [30, 0, -1.0]])
    passes_through_linuxcncs_points(m, pts, np.array([2, 1, 0.5, 3, 1.0]), 4)
    # order 3 by default, and only L above 3 changes it
    (m3,) = curves("G21 G1 F100\nG5.2 X10 Y0 P1 L2\nX10 Y10 P1\nX20 Y10 P1\nG5.3\nM2\n")
    assert m3.curve is not None and m3.curve.degree == 2


PROGRAMS = {
    "g5 chain": (
        "G21 G0 X0 Y0\nG1 F100\nG5 X10 Y0 I3 J4 P-2 Q5\nG5 X20 Y5 P1 Q-2\n"
        "G5 X30 Y0 I1 J1 P2 Q2\nG1 X0 Y0\nM2\n"
    ),
    "g5.1": "G21 G0 X0 Y0\nG1 F100\nG5.1 X10 Y0 I5 J5\nG5.1 X20 Y0 I5 J-5\nG0 Z5\nM2\n",
    "nurbs": (
        "G21 G0 X0 Y0\nG1 F300\nG5.2 X10 Y0 P1 L4\nX10 Y10 P0.5\nX20 Y10 P3\nX30 Y0 P1\n"
        "G5.3\nG1 X0\nM2\n"
    ),
    "nurbs in inches, G91": (
        "G20 G91 G0 X1 Y1\nG1 F10\nG5.2 X1 Y0 P1\nX0 Y1 P1\nX1 Y0 P2\nG5.3\nG1 X1\nM2\n"
    ),
}


@pytest.mark.parametrize("program", list(PROGRAMS.values()), ids=list(PROGRAMS))
def test_spline_programs_agree_with_rs274(program: str) -> None:
    _, err = agree(program)
    assert err is None, err


ERRORS = {
    "g5 in g18": "G21 G18 G1 F100\nG5 X10 I1 J1 P1 Q1\nM2\n",
    "g5 moves z": "G21 G1 F100\nG5 X10 Y0 Z1 I1 J1 P1 Q1\nM2\n",
    "g5 without p q": "G21 G1 F100\nG5 X10 Y0 I1 J1\nM2\n",
    "g5 with i only": "G21 G1 F100\nG5 X10 Y0 I1 P1 Q1\nM2\n",
    "g5.1 without j": "G21 G1 F100\nG5.1 X10 Y0 I1\nM2\n",
    "g5 with no feed": "G21\nG5 X10 Y0 I1 J1 P1 Q1\nM2\n",
    "nurbs point without y": "G21 G1 F100\nG5.2 X10 P1\nM2\n",
    "nurbs weight zero": "G21 G1 F100\nG5.2 X10 Y0 P1\nX10 Y10 P0\nG5.3\nM2\n",
    "g5.3 without g5.2": "G21 G1 F100\nG5.3\nM2\n",
    "too few points": "G21 G1 F100\nG5.2 X10 Y0 P1 L5\nX10 Y10 P1\nX20 Y10 P1\nG5.3\nM2\n",
    "another motion inside": "G21 G1 F100\nG5.2 X10 Y0 P1\nG1 X10 Y10\nG5.3\nM2\n",
    "spline with comp": "G21 T1 M6\nG0 X-10 Y-10\nG41 G1 X0 Y0 F100\nG5 X10 Y0 I1 J1 P1 Q1\nM2\n",
}


@pytest.mark.parametrize("program", list(ERRORS.values()), ids=list(ERRORS))
def test_spline_errors_refused_by_both(program: str) -> None:
    _require_rs274()
    ref = oracle.run(program, tools=TOOLS)
    _, _, err = ours(program)
    assert ref.error is not None, "rs274 accepts it"
    assert err is not None, f"we accept what rs274 refuses: {ref.error}"


def test_not_in_inverse_time() -> None:
    """LinuxCNC sets no feed rate for a spline in G93 (convert_spline issues no
    SET_FEED_RATE): the curve would run at whatever rate the controller had."""
    _, _, err = ours("G21 G93 G0 X0 Y0\nG5 X10 Y0 I3 J4 P-2 Q5 F2\nM2\n")
    assert err is not None and "inverse time mode (G93) are not supported" in str(err)


def test_inspect_json_has_the_curve() -> None:
    (m,) = curves("G21 G1 F100\nG5.1 X10 Y0 I5 J5\nM2\n")
    d = gcode.motion_to_json(m)
    assert d["kind"] == "curve" and d["end"][:2] == [10.0, 0.0]
    assert d["curve"] == {
        "degree": 2,
        "knots": [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
        "control": [[0.0, 0.0, 0.0], [5.0, 5.0, 0.0], [10.0, 0.0, 0.0]],
        "weights": [1.0, 1.0, 1.0],
    }
