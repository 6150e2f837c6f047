"""Arcs among written points (prsxy_post.writers.arcs): closed-form circles and
helices are found and written so that LinuxCNC runs them through every point they
replace; points off the circle by more than the tolerance are not replaced.

The written arc is judged as LinuxCNC runs it, by the tests' own model of its arc
(``tests.controllers.GcodeArc``: the radius linear in the angle from the start's to
the end's, the axis and A, B linear; emccanon.cc ARC_FEED, _posemath.c
pmCircleInit), read back from the written words, and LinuxCNC's interpreter
``rs274`` reads the words as the same arc (plane, center, direction).
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post.writers import arcs

from . import controllers as ctl
from . import oracle

TOL = 1e-4  # mm: the shop profile's chord tolerance
TOL_DEG = 2.8e-5  # deg: 0.2 of 0.5 arcsec
DEC = 7


def circle_points(
    center: tuple[float, float, float],
    r: float,
    th0: float,
    sweep: float,
    n: int,
    plane: int = 17,
    rise: float = 0.0,
    ab: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """(n + 1, 5) points on a circle (a helix with ``rise`` along its axis), rounded
    to the written decimals."""
    iu, iv, iw = arcs.PLANES[plane]
    th = th0 + sweep * np.linspace(0.0, 1.0, n + 1)
    q = np.zeros((n + 1, 5))
    q[:, iu] = center[iu] + r * np.cos(th)
    q[:, iv] = center[iv] + r * np.sin(th)
    q[:, iw] = center[iw] + rise * np.linspace(0.0, 1.0, n + 1)
    q[:, 3], q[:, 4] = ab
    return np.round(q, DEC) + 0.0


def as_linuxcnc_runs(arc: arcs.Arc, q: np.ndarray) -> np.ndarray:
    """Each replaced point's distance from the arc LinuxCNC runs from the written
    words [mm, a degree as a mm]: the words read back by the tests' G-code reader."""
    start, end = q[arc.start], q[arc.end]
    head, tail = arcs.arc_words(arc, list(start), DEC)
    words = " ".join(f"{a}{v:.{DEC}f}" for a, v in zip("XYZAB", end, strict=True))
    text = (
        "G21 G90 G17\n"
        + "G0 "
        + " ".join(f"{a}{v:.{DEC}f}" for a, v in zip("XYZAB", start, strict=True))
        + f"\nG93\nG{arc.plane}\n{head} {words}{tail} F100\nM2\n"
    )
    run = ctl.run_gcode(text)
    (g,) = run.arcs.values()
    return g.distance(run.q[0], run.q[1], q[arc.start : arc.end + 1], 1.0)


@pytest.mark.parametrize("plane", [17, 18, 19])
@pytest.mark.parametrize("sweep", [0.4, -2.5, 4.5])
def test_a_circle_is_found_in_its_plane(plane: int, sweep: float) -> None:
    """Points on a circle in G17, G18 or G19, either way round: one arc in that
    plane, the right way round, its center where the circle's is, every point on
    the arc LinuxCNC runs."""
    center = (3.0, -4.0, 7.0)
    q = circle_points(center, 12.5, 0.3, sweep, 60, plane)
    arc = arcs.fit_arc(q, plane, TOL, TOL_DEG, DEC)
    assert arc is not None
    assert arc.plane == plane and arc.ccw == (sweep > 0)
    iu, iv, _ = arcs.PLANES[plane]
    assert abs(arc.center[iu] - center[iu]) < 1e-6 and abs(arc.center[iv] - center[iv]) < 1e-6
    assert abs(arc.length - 12.5 * abs(sweep)) < 1e-5
    assert as_linuxcnc_runs(arc, q).max() < 2e-7


def test_a_helix_is_a_circle_and_its_axis() -> None:
    """A helix (Z falling linearly with the angle) is one G17 arc whose Z runs
    along; its length LinuxCNC's, √((r φ)² + h²)."""
    q = circle_points((0.0, 0.0, 0.0), 10.0, 0.0, -3.0, 200, 17, rise=-1.5)
    arc = arcs.fit_arc(q, 17, TOL, TOL_DEG, DEC)
    assert arc is not None and not arc.ccw
    assert abs(arc.length - math.hypot(30.0, 1.5)) < 1e-5
    assert as_linuxcnc_runs(arc, q).max() < 2e-7
    # not a circle in the other planes
    assert arcs.fit_arc(q, 18, TOL, TOL_DEG, DEC) is None
    assert arcs.fit_arc(q, 19, TOL, TOL_DEG, DEC) is None


@pytest.mark.parametrize(("bump", "found"), [(0.5 * TOL, True), (2.0 * TOL, False)])
def test_a_point_off_the_circle_is_judged_against_the_tolerance(bump: float, found: bool) -> None:
    """One point pushed out radially: within the tolerance the arc still replaces
    it (and runs within the tolerance of it), beyond it no arc does."""
    q = circle_points((0.0, 0.0, 0.0), 10.0, 0.0, 1.5, 40)
    th = 1.5 * 17 / 40
    q[17, 0] += bump * math.cos(th)
    q[17, 1] += bump * math.sin(th)
    arc = arcs.fit_arc(q, 17, TOL, TOL_DEG, DEC)
    assert (arc is not None) == found
    if arc is not None:
        assert as_linuxcnc_runs(arc, q).max() <= TOL


def test_a_tilt_that_strays_is_not_replaced() -> None:
    """A and B run linearly along a G2/G3: a tilt that bows by more than the tilt
    tolerance between the ends keeps its points; a linear one is carried."""
    q = circle_points((0.0, 0.0, 0.0), 10.0, 0.0, 1.0, 30)
    q[:, 3] = np.linspace(0.0, 1e-3, 31)
    assert arcs.fit_arc(q, 17, TOL, TOL_DEG, DEC) is not None
    q[15, 3] += 2.0 * TOL_DEG
    assert arcs.fit_arc(q, 17, TOL, TOL_DEG, DEC) is None


def test_points_on_a_line_are_no_arc() -> None:
    """Points on a straight line: no arc, whatever the plane."""
    q = np.zeros((30, 5))
    q[:, 0] = np.linspace(0.0, 5.0, 30)
    q[:, 1] = 0.5 * q[:, 0]
    q[:, 2] = 2.0
    free = np.ones(30, dtype=bool)
    free[[0, -1]] = False
    found = arcs.find_arcs(q, free, ~free, np.ones(30), np.zeros((30, 5)), TOL, TOL_DEG, DEC, 1e-3)
    assert found == []


def _find(q: np.ndarray, rate: np.ndarray | None = None) -> list[arcs.Arc]:
    n = len(q)
    free = np.ones(n, dtype=bool)
    free[[0, -1]] = False
    ends = ~free  # both ends in motion: an arc may start and end there
    r = np.ones(n) if rate is None else rate
    return arcs.find_arcs(q, free, ends, r, np.zeros((n, 5)), TOL, TOL_DEG, DEC, 1e-3)


def test_a_line_then_an_arc_then_a_line() -> None:
    """A line into a tangent quarter circle and out of it: the arc is found where
    the circle is (its ends within a point of the circle's), the lines are not."""
    line_in = np.c_[np.linspace(-5.0, 0.0, 20, endpoint=False), np.full(20, -10.0)]
    th = np.linspace(-math.pi / 2, 0.0, 50)
    circ = np.c_[10.0 * np.cos(th), 10.0 * np.sin(th)]
    line_out = np.c_[np.full(20, 10.0), np.linspace(0.0, 5.0, 21)[1:]]
    xy = np.vstack([line_in, circ, line_out])
    q = np.round(np.c_[xy, np.zeros((len(xy), 3))], DEC) + 0.0
    found = _find(q)
    assert len(found) == 1
    (arc,) = found
    assert 18 <= arc.start <= 20 and 68 <= arc.end <= 70
    assert arc.ccw and abs(arc.center[0]) < 1e-6 and abs(arc.center[1]) < 1e-6
    assert as_linuxcnc_runs(arc, q).max() <= TOL


def test_a_dip_of_the_rates_splits_the_arc() -> None:
    """An arc carries one speed: where the points' rates fall and rise again, the
    arc ends at the dip (the writer's chords do the same)."""
    q = circle_points((0.0, 0.0, 0.0), 10.0, 0.0, 3.0, 120)
    rate = np.ones(len(q))
    rate[50:60] = 0.5
    found = _find(q, rate)
    assert found and all(not (a.start < 50 and a.end > 60) for a in found)
    for a in found:
        assert as_linuxcnc_runs(a, q).max() <= TOL


@settings(max_examples=60, deadline=None)
@given(
    r=st.floats(0.5, 200.0),
    th0=st.floats(-math.pi, math.pi),
    sweep=st.floats(0.2, 6.0),
    ccw=st.booleans(),
    n=st.integers(8, 400),
    plane=st.sampled_from([17, 18, 19]),
    rise=st.floats(-5.0, 5.0),
    noise=st.floats(0.0, 0.4),
    seed=st.integers(0, 2**16),
)
def test_every_replaced_point_is_within_the_tolerance(
    r: float,
    th0: float,
    sweep: float,
    ccw: bool,
    n: int,
    plane: int,
    rise: float,
    noise: float,
    seed: int,
) -> None:
    """Circles and helices of any size in any plane, with noise up to 0.4 of the
    tolerance on every point: the arcs found do not overlap, each starts where
    the last ended or later, and every point each replaces lies within the
    tolerance of the arc LinuxCNC runs from its words."""
    rng = np.random.default_rng(seed)
    q = circle_points((1.0, 2.0, 3.0), r, th0, sweep if ccw else -sweep, n, plane, rise)
    q[:, :3] += rng.normal(0.0, noise * TOL / 3.0, (len(q), 3)).clip(-noise * TOL, noise * TOL)
    q = np.round(q, DEC) + 0.0
    found = _find(q)
    last = 0
    for a in found:
        assert a.start >= last and a.end > a.start
        last = a.end
        assert as_linuxcnc_runs(a, q).max() <= TOL * (1 + 1e-9)


@settings(max_examples=30, deadline=None)
@given(
    r=st.floats(2.0, 100.0),
    sweep=st.floats(0.5, 4.5),
    plane=st.sampled_from([17, 18, 19]),
)
def test_an_exact_circle_is_one_or_few_arcs(r: float, sweep: float, plane: int) -> None:
    """Points exactly on a circle, 0.05 rad apart: arcs replace them all, at most
    one per 1.5 pi of sweep and one more."""
    n = max(8, int(sweep / 0.05))
    q = circle_points((0.0, 0.0, 0.0), r, 0.2, sweep, n, plane)
    found = _find(q)
    assert found and found[0].start == 0 and found[-1].end == n
    assert all(b.start == a.end for a, b in itertools.pairwise(found))
    assert len(found) <= math.ceil(sweep / arcs.MAX_SWEEP) + 1


@pytest.mark.skipif(oracle.RS274 is None, reason="rs274 (LinuxCNC) not installed")
@pytest.mark.parametrize("plane", [17, 18, 19])
@pytest.mark.parametrize("sweep", [1.0, -1.0])
def test_linuxcnc_reads_the_words_as_the_arc(plane: int, sweep: float) -> None:
    """LinuxCNC's interpreter reads the written G2/G3 and its I J K in each plane as
    the arc fitted: its ARC_FEED's plane, center and direction (rotation +1 for G3,
    counterclockwise from the plane's first axis to its second)."""
    q = circle_points((1.0, -2.0, 0.5), 8.0, 0.4, sweep, 30, plane)
    arc = arcs.fit_arc(q, plane, TOL, TOL_DEG, DEC)
    assert arc is not None
    head, tail = arcs.arc_words(arc, list(q[0]), DEC)
    start = " ".join(f"{a}{v:.{DEC}f}" for a, v in zip("XYZAB", q[0], strict=True))
    end = " ".join(f"{a}{v:.{DEC}f}" for a, v in zip("XYZAB", q[-1], strict=True))
    res = oracle.run(f"G21 G90\nG0 {start}\nG{plane}\n{head} {end}{tail} F100\nM2\n")
    assert res.error is None
    (m,) = [m for m in res.motions if m.kind == "arc"]
    assert m.rotation == (1 if arc.ccw else -1)
    assert m.center is not None
    iu, iv, _ = arcs.PLANES[plane]
    for i in (iu, iv):  # rs274 prints 4 decimals
        assert abs(m.center[i] - arc.center[i]) < 1e-4


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([3, 4, 7]))
def test_arc_lines_write_what_arc_words_write(seed: int, dec: int) -> None:
    """The writer's G2/G3 lines made for many arcs at once (``arcs.arc_lines``) are,
    row for row, the motion word and center words of ``arc_words`` around the
    end's words (``%.{d}f``) and F: on every plane and turn, with center offsets
    that round to zero either side of it (``arc_words`` writes ``0.000`` where
    ``%.3f`` writes ``-0.000``), exact zeros and ties of the last decimal."""
    rng = np.random.default_rng(seed)
    n = 40
    start = np.round(rng.uniform(-300.0, 300.0, (n, 5)), dec) + 0.0
    end = np.round(rng.uniform(-300.0, 300.0, (n, 5)), dec) + 0.0
    off = rng.uniform(-50.0, 50.0, (n, 3))
    # offsets at and about zero, and halves of the last decimal (binary ties)
    small = rng.choice([0.0, -0.0, 1e-12, -1e-12, 0.4, -0.4, 0.5, -0.5, -0.6], (n, 3))
    pick = rng.random((n, 3)) < 0.4
    off[pick] = small[pick] * 10.0**-dec
    # exact binary ties of the last decimal, from a start at 0 (the offset exact)
    tie = rng.random(n) < 0.2
    start[tie, :3] = 0.0
    off[tie] = rng.choice([-1.0, 1.0], (int(tie.sum()), 3)) * {3: 0.0625, 4: 0.03125, 7: 2**-8}[dec]
    center = start[:, :3] + off
    ai = np.column_stack(
        [np.zeros(n), np.ones(n), rng.choice([17, 18, 19], n), rng.integers(0, 2, n)]
    ).astype(np.int64)
    af = np.column_stack([center, rng.uniform(0, 9, (n, 3))])
    f = rng.uniform(0.0, 1e5, n)
    got = arcs.arc_lines(end, f, start, ai, af, dec)
    for j in range(n):
        arc = arcs.Arc(
            0, 1, int(ai[j, 2]), bool(ai[j, 3]), tuple(center[j].tolist()), 1.0, 0.0, 1.0
        )
        head, tail = arcs.arc_words(arc, start[j].tolist(), dec)
        words = "".join(f" {a}{v:.{dec}f}" for a, v in zip("XYZAB", end[j].tolist(), strict=True))
        assert got[j] == f"{head}{words}{tail} F{f[j]:.3f}\n"
