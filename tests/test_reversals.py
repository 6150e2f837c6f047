"""reversals.py: where a motor with play reverses, and where its part stands.

Each function is held against an independent reference: the roots of the
Hermite cubic's velocity against numpy's polynomial roots; the part's position
along the controller's cubics against the contract's play model stepped over a
dense sampling of the same cubics (a Turbo PMAC PVT segment is the cubic through
its end positions and velocities: Software Reference, PVT{data}); the crossing
windows against their stated bounds.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import kernel, reversals
from prsxy_post.axiscomp import MotorTable
from prsxy_post.profile import AxisComp


def hermite(P0: float, V0: float, P1: float, V1: float, h: float, s: np.ndarray) -> np.ndarray:
    """The PVT segment's position at s = t / h (cubic Hermite basis)."""
    return (
        (2 * s**3 - 3 * s**2 + 1) * P0
        + (s**3 - 2 * s**2 + s) * h * V0
        + (-2 * s**3 + 3 * s**2) * P1
        + (s**3 - s**2) * h * V1
    )


def velocity_poly(p0: float, v0: float, p1: float, v1: float, h: float) -> list[float]:
    """The cubic's coefficients in s expanded and differentiated (highest power
    first, for numpy.roots): independent of the module's algebra."""
    c3 = 2 * p0 + h * v0 - 2 * p1 + h * v1
    c2 = -3 * p0 - 2 * h * v0 + 3 * p1 - h * v1
    return [3 * c3, 2 * c2, h * v0]


@settings(max_examples=300, deadline=None)
@given(
    h=st.floats(2e-3, 0.02),
    s_root=st.floats(0.0, 1.0),
    accel=st.floats(1e-3, 1e4),
    allowed=st.floats(1e-5, 1.0),
    fast_before=st.booleans(),
    chords=st.booleans(),
)
def test_a_window_keeps_its_motor_below_the_speed_its_part_may_stand_out(
    h: float, s_root: float, accel: float, allowed: float, fast_before: bool, chords: bool
) -> None:
    """While its part stands, the motor would have moved at |A| |t − t_root|. On
    the side of the root where that pushes the tip on, it stays within ``allowed``
    (what plan_insertions' edge_speed gives from the tip's speed) at the window's
    edge, the other side taking the rest of the controller's shortest segment,
    wherever the step leaves room for that (no sliver shorter than a servo cycle
    beside it); the part stands no longer than the tolerance allows on either side,
    unless the window is a servo cycle. Between straight lines (``chords``) a
    window inside its step stands no longer before its root than after it: the
    part, left where its motor left it, is then never ahead of the path at the
    window's end."""
    tol, longest = 5e-5, 1e-3
    t0, t1 = np.array([0.3]), np.array([0.3 + h])
    t_root = t0 + s_root * h
    A = np.array([accel])
    fast, slow = np.array([allowed]), np.array([np.inf])
    rb, ra = reversals.reach((fast, slow) if fast_before else (slow, fast), A)
    ta, tb = reversals.windows(t0, t1, t_root, A, tol, longest, (rb, ra), chords)
    assert t0[0] <= ta[0] <= t_root[0] <= tb[0] <= t1[0] and ta[0] < tb[0]
    d_fast, room_fast, room_slow = (
        (t_root[0] - ta[0], t_root[0] - t0[0], t1[0] - t_root[0])
        if fast_before
        else (tb[0] - t_root[0], t1[0] - t_root[0], t_root[0] - t0[0])
    )
    r_fast = allowed / accel
    if chords and t0[0] < ta[0] and tb[0] < t1[0]:
        assert t_root[0] - ta[0] <= tb[0] - t_root[0] + 1e-12
    # (between straight lines a window stands as long before its root as after it
    # at least, so where the side after is the fast one a servo cycle takes both)
    tight = chords and not fast_before and 2 * r_fast < reversals.MIN_WINDOW_S
    if room_fast >= r_fast + reversals.MIN_WINDOW_S and room_slow >= longest and not tight:
        assert accel * d_fast <= allowed * (1 + 1e-9) + accel * 1e-12  # t of 0.3 s: 1e-16 s
    half = np.sqrt(2 * tol / accel)
    if tb[0] - ta[0] > reversals.MIN_WINDOW_S * (1 + 1e-9) and ta[0] > t0[0] and tb[0] < t1[0]:
        assert max(t_root[0] - ta[0], tb[0] - t_root[0]) <= half * (1 + 1e-9)


def test_a_motor_that_stood_and_sets_off_the_old_way_first_reverses_in_the_step() -> None:
    """A motor stands for two steps and the third step's chord goes its old way
    (up) though it ends moving down: the step's cubic sets off up and turns inside
    it. Its crossing is a window about the cubic's root, not one at the end of the
    standing step (a head motor through the extreme of a tilt: crossing down before
    it set off up left its part behind, 1.0022 x F, test_controller_truth's found
    programs). A chord going the new way keeps the crossing at the standing step's
    end."""
    dt = np.full(3, 0.01)
    t_end = np.cumsum(dt)
    V = np.zeros((3, 5))
    V[2, 0] = -0.0037
    for chord, where in ((132e-6, "root"), (-132e-6, "stood")):
        P = np.zeros((3, 5))
        P[2, 0] = chord
        ins = reversals.plan_insertions(
            t_end, dt, P, V, np.zeros(3, dtype=bool), None, [0],
            np.array([1] * 5), np.full(5, np.nan), 5e-5, 1e-3,
        )  # fmt: skip
        assert ins.w_new.tolist() == [-1]
        if where == "stood":
            assert ins.w_k.tolist() == [1] and ins.w_tb[0] == pytest.approx(t_end[1])
        else:
            zero, down = np.array([0.0]), np.array([-1])
            sr, _ = reversals.velocity_roots(zero, zero, np.array([chord]), V[2:, 0], dt[2:], down)
            root = t_end[1] + sr[0] * dt[2]
            assert 0 < sr[0] < 1
            assert ins.w_k.tolist() == [2] and ins.w_ta[0] < root < ins.w_tb[0]


def test_a_motor_setting_off_from_rest_the_other_way_first_crosses_twice() -> None:
    """A motor at rest, its part on its down side, leaves with a chord 0.47 µm up
    though it ends its step moving down (a head motor through the extreme of a
    tilt, from rest): it goes up first and turns inside the step. It crosses up as
    it sets off and down again at its cubic's root, each window in its own part of
    the step (without them its part stood through the step, 0.5 µm off the path,
    test_controller_truth's found programs). Within the tolerance it is left
    alone."""
    dt = np.array([0.01, 0.00977])
    t_end = np.cumsum(dt)
    resting = np.array([True, False])
    V = np.zeros((2, 5))
    V[1, 0] = -0.0226
    side = np.array([-1] * 5)
    for chord, tol in ((0.47e-3, 5e-5), (0.47e-3, 1e-3)):
        P = np.zeros((2, 5))
        P[1, 0] = chord
        ins = reversals.plan_insertions(
            t_end, dt, P, V, resting, None, [0], side.copy(), np.full(5, np.nan), tol, 1e-3,
        )  # fmt: skip
        if tol > chord:
            assert not ins
            continue
        assert ins.w_k.tolist() == [1, 1] and ins.w_new.tolist() == [1, -1]
        sr, _ = reversals.velocity_roots(
            np.array([0.0]), np.array([0.0]), np.array([chord]), V[1:, 0], dt[1:], np.array([-1])
        )
        t0, root = t_end[0], t_end[0] + sr[0] * dt[1]
        assert ins.w_ta[0] == pytest.approx(t0) and ins.w_tb[0] <= ins.w_ta[1]
        assert ins.w_ta[1] < root < ins.w_tb[1] <= t_end[1]


@settings(max_examples=300, deadline=None)
@given(
    h=st.floats(0.0001, 0.02),
    s_root=st.floats(0, 1),
    accel=st.floats(1.0, 1e5),
    tol=st.floats(1e-6, 1e-4),
    reach_b=st.floats(1e-5, 1e-2),
    reach_a=st.floats(1e-5, 1e-2),
    room_b=st.floats(0.0, 0.02),
    room_a=st.floats(0.0, 0.02),
)
def test_a_window_of_straight_lines_is_symmetric_about_its_root(
    h: float,
    s_root: float,
    accel: float,
    tol: float,
    reach_b: float,
    reach_a: float,
    room_b: float,
    room_a: float,
) -> None:
    """A straight line over a window averages the velocity its standing part lacks,
    A (t − t_root): none where it stands as long after the root as before it
    (test_controller_truth's found programs). So a window of straight lines is
    symmetric about its root, within the tolerance and the reach on both sides (at
    least half a servo cycle each), reaching into the steps beside as far as
    room_b and room_a allow (no longer than its step there, or a servo cycle);
    asymmetric only where an end is cut at a step's end it may not pass, or a
    sliver of its step is taken in on one side. It leaves no sliver shorter than a
    servo cycle of its step beside it."""
    longest = 1e-3
    t0, t1 = np.array([0.3]), np.array([0.3 + h])
    t_root = t0 + s_root * h
    ta, tb = reversals.chord_windows(
        t0,
        t1,
        t_root,
        np.array([accel]),
        tol,
        longest,
        (np.array([reach_b]), np.array([reach_a])),
        t0 - room_b,
        t1 + room_a,
    )
    a, b, r = ta[0], tb[0], t_root[0]
    eps = 1e-12
    assert t0[0] - room_b - eps <= a <= r <= b <= t1[0] + room_a + eps
    assert a <= t0[0] + eps or a - t0[0] >= reversals.MIN_WINDOW_S - eps
    assert b >= t1[0] - eps or t1[0] - b >= reversals.MIN_WINDOW_S - eps
    ends = (t0[0], t1[0], t0[0] - room_b, t1[0] + room_a)
    at_end = min(abs(x - e) for x in (a, b) for e in ends) <= eps
    if not at_end:
        assert r - a == pytest.approx(b - r, abs=eps)
        d = b - r
        natural = min(np.sqrt(2 * tol / accel), reach_b, reach_a, 0.5 * longest)
        assert d <= max(natural, 0.5 * reversals.MIN_WINDOW_S) * (1 + 1e-9)
    if a < t0[0] - eps or b > t1[0] + eps:
        # no longer than its step, or a servo cycle; twice that at most where a
        # sliver of its step was taken in (the whole step then in the window)
        whole = a <= t0[0] + eps and b >= t1[0] - eps
        assert b - a <= (2 if whole else 1) * max(h, reversals.MIN_WINDOW_S) + eps
    # at least a servo cycle, where its step and those beside leave room for one
    assert b - a >= min(reversals.MIN_WINDOW_S, h + room_b + room_a) - eps
    # given no room, never over its step's ends
    ta, tb = reversals.chord_windows(t0, t1, t_root, np.array([accel]), tol, longest, None, t0, t1)
    assert t0[0] <= ta[0] <= tb[0] <= t1[0]


@settings(max_examples=200, deadline=None)
@given(
    p0=st.floats(-5, 5),
    dp=st.floats(-0.05, 0.05),
    v0=st.floats(0.5, 100),
    v1=st.floats(0.5, 100),
    h=st.floats(0.001, 0.02),
)
def test_velocity_root_is_the_cubics_turning_point(
    p0: float, dp: float, v0: float, v1: float, h: float
) -> None:
    """V0 > 0 > V1: the first root in [0, 1] of the cubic's velocity (numpy.roots of
    its derivative), and the acceleration there."""
    V1 = -v1
    s, acc = reversals.velocity_roots(
        np.array([p0]), np.array([v0]), np.array([p0 + dp]), np.array([V1]), np.array([h])
    )
    poly = velocity_poly(p0, v0, p0 + dp, V1, h)
    roots = np.roots(poly)
    real = np.sort(roots[np.isreal(roots)].real)
    first = real[(real >= -1e-9) & (real <= 1 + 1e-9)][0]
    assert abs(s[0] - first) < 1e-7
    # the acceleration from the same expanded polynomial: d²x/dt² = x''(s) / h²
    a_ref = float(np.polyval(np.polyder(poly), first)) / h**2
    assert abs(acc[0] - a_ref) <= 1e-6 * max(1.0, abs(a_ref))


def _table(backlash: float) -> MotorTable:
    """A motor with play ``backlash`` [mm] and a slope error of 20 µm/m."""
    pos = [-100.0, 0.0, 100.0]
    fwd = [-0.002, 0.0, 0.002]
    rev = [f + backlash for f in fwd]
    return MotorTable.from_comp(AxisComp(1, np.array(pos), np.array(fwd), np.array(rev)))


def _random_commands(seed: int):  # type: ignore[no-untyped-def]
    """40 random commands with reversals for a motor with 4 µm of play: (table, P,
    V, dt, P0, V0, y0), from rest at 1 mm with its part on the low side."""
    rng = np.random.default_rng(seed)
    table = _table(0.004)
    n = 40
    dt = rng.uniform(0.002, 0.01, n)
    V = rng.normal(0, 20, n)
    P = 1.0 + np.cumsum(rng.normal(0, 0.05, n))
    return table, P, V, dt, 1.0, 0.0, float(table.lo(np.array([1.0]))[0])


def test_follow_is_the_play_model_on_the_dense_cubics() -> None:
    """Random commands with reversals: the part's position at each point and its
    extremes within each step equal the contract's play model, y_k = clamp(y_{k-1},
    lo(p_k), hi(p_k)), stepped over 2000 samples of every segment's cubic."""
    table, P, V, dt, P0, V0, y0 = _random_commands(5)
    n = len(P)
    y_end, y_min, y_max = reversals.follow(table.flat, y0, P0, V0, P, V, dt)
    y = y_start = y0
    Pa, Va = np.concatenate([[P0], P[:-1]]), np.concatenate([[V0], V[:-1]])
    for k in range(n):
        s = np.linspace(0, 1, 2001)[1:]
        c = hermite(Pa[k], Va[k], P[k], V[k], dt[k], s)
        lo, hi = table.lo(c), table.hi(c)
        ys = []
        for a, b in zip(lo, hi, strict=True):
            y = min(max(y, a), b)
            ys.append(y)
        # dense sampling misses a turning point by (ds h)² |A| / 2: below 1e-7 mm here
        assert abs(y_end[k] - ys[-1]) < 1e-7
        # the extremes over the step from its start (the part is continuous)
        lo_k, hi_k = min(y_min[k], y_start), max(y_max[k], y_start)
        assert abs(lo_k - min([y_start, *ys])) < 1e-7, k
        assert abs(hi_k - max([y_start, *ys])) < 1e-7, k
        y_start = ys[-1]


def test_follow_along_chords_is_the_play_model_on_the_straight_lines() -> None:
    """The same commands run as straight lines between the points (LinuxCNC's
    G1s): the play model stepped over 200 samples of every chord. The velocities
    are ignored, and the cubics through them would give another part: the
    velocities here swing each step's cubic well past its points."""
    table, P, V, dt, P0, V0, y0 = _random_commands(6)
    n = len(P)
    y_end, y_min, y_max = reversals.follow(table.flat, y0, P0, V0, P, V, dt, cubic=False)
    Pa = np.concatenate([[P0], P[:-1]])
    y = y_start = y0
    for k in range(n):
        c = Pa[k] + (P[k] - Pa[k]) * np.linspace(0, 1, 201)[1:]
        ys = []
        for a, b in zip(table.lo(c), table.hi(c), strict=True):
            y = min(max(y, a), b)
            ys.append(y)
        assert abs(y_end[k] - ys[-1]) < 1e-12
        assert abs(min(y_min[k], y_start) - min([y_start, *ys])) < 1e-12
        assert abs(max(y_max[k], y_start) - max([y_start, *ys])) < 1e-12
        y_start = ys[-1]
    cubics = reversals.follow(table.flat, y0, P0, V0, P, V, dt)[0]
    assert np.max(np.abs(cubics - y_end)) > 1e-3


@settings(max_examples=300, deadline=None)
@given(
    h=st.floats(0.002, 0.02),
    s_root=st.floats(0, 1),
    accel=st.floats(1.0, 1e5),
    tol=st.floats(1e-6, 1e-4),
)
def test_windows_stay_in_their_step_and_bound_the_error(
    h: float, s_root: float, accel: float, tol: float
) -> None:
    """A window lies inside its step, holds the root, lasts at least the
    controller's shortest segment and at most the step or the longest allowed. The
    part stands at the extreme meanwhile, so on each side of the root it misses the
    path by |A| d² / 2 for the time d it stands there: within the tolerance, or 4 x
    on a side grown to its step's end (no sliver left beside a window). A window
    cut by its step's end is cut, not shifted: a root at a corner's point (s = 0)
    leaves the part no further behind than the tolerance."""
    longest = 1e-3
    t0, t1 = np.array([0.3]), np.array([0.3 + h])
    t_root = t0 + s_root * h
    ta, tb = reversals.windows(t0, t1, t_root, np.array([accel]), tol, longest)
    assert t0[0] <= ta[0] <= t_root[0] <= tb[0] <= t1[0] and ta[0] < tb[0]
    width = tb[0] - ta[0]
    assert width >= min(reversals.MIN_WINDOW_S, h) - 1e-15
    assert width <= 1.5 * longest + 1e-15 or (ta[0] == t0[0] and tb[0] == t1[0])
    natural = np.sqrt(8 * tol / accel)
    if reversals.MIN_WINDOW_S < natural < longest and width < h:
        # how long the part may stand on a side: half the natural width (error
        # within tol), or the servo cycle a window never undercuts, or a whole
        # width on a side grown to its step's end (error within 4 tol)
        for d, grown in ((t_root[0] - ta[0], ta[0] == t0[0]), (tb[0] - t_root[0], tb[0] == t1[0])):
            allowed = max(natural if grown else natural / 2, reversals.MIN_WINDOW_S)
            assert d <= allowed * (1 + 1e-9)
        if s_root == 0.0 and tb[0] < t1[0]:
            assert tb[0] - t_root[0] <= max(natural / 2, reversals.MIN_WINDOW_S) * (1 + 1e-9)


@settings(max_examples=200, deadline=None)
@given(
    p0=st.floats(-5, 5),
    dp=st.floats(-0.05, 0.05),
    v0=st.floats(0.01, 100),
    v1=st.floats(0.01, 100),
    h=st.floats(0.001, 0.02),
)
def test_turning_points_are_the_cubics_both_roots_inside_the_step(
    p0: float, dp: float, v0: float, v1: float, h: float
) -> None:
    """Both ends move up; the cubic turns back and on again inside the step exactly
    when numpy finds two roots of its derivative strictly inside (0, 1)."""
    s1, s2 = kernel.turning_points(
        np.array([p0]), np.array([v0]), np.array([p0 + dp]), np.array([v1]), np.array([h])
    )
    roots = np.roots(velocity_poly(p0, v0, p0 + dp, v1, h))
    real = np.sort(roots[np.abs(roots.imag) < 1e-12].real)
    inside = real[(real > 1e-9) & (real < 1 - 1e-9)]
    if len(inside) == 2 and inside[1] - inside[0] > 1e-6:
        assert abs(s1[0] - inside[0]) < 1e-7 and abs(s2[0] - inside[1]) < 1e-7
    elif len(inside) < 2:
        assert np.isnan(s1[0]) and np.isnan(s2[0])


def test_a_dip_inside_a_step_gets_two_crossings() -> None:
    """The motor moves up at both ends of a 10 ms step but goes back 2 µm inside it
    (the extreme of a tight arc between two points, where it was left standing in
    its play, 2 µm off the path): two windows, down then up, each holding its
    turning point, in time order, not overlapping. A dip shallower than the
    tolerance is left alone."""
    h, tol = 0.01, 5e-5
    P0, V0, V1 = 1.0, 0.2, 0.2

    # the end position for a 2 µm dip: the cubic's depth from its two turning points
    def depth(P1: float) -> float:
        s1, s2 = kernel.turning_points(*map(np.array, ([P0], [V0], [P1], [V1], [h])))
        if np.isnan(s1[0]):
            return 0.0
        x = hermite(P0, V0, P1, V1, h, np.array([s1[0], s2[0]]))
        return float(x[0] - x[1])

    P1 = P0 - 1.5e-3
    assert depth(P1) > 1.5e-3
    t_end, dt = np.array([0.01, 0.02]), np.array([0.01, h])
    P = np.array([[P0] * 5, [P1] * 5])
    V = np.array([[V0] * 5, [V1] * 5])
    ins = reversals.plan_insertions(
        t_end,
        dt,
        P,
        V,
        np.zeros(2, dtype=bool),
        None,
        [3],
        np.array([1] * 5),
        np.full(5, np.nan),
        tol,
        1e-3,
    )
    assert ins.w_k.tolist() == [1, 1] and ins.w_new.tolist() == [-1, 1]
    s1, s2 = kernel.turning_points(*map(np.array, ([P0], [V0], [P1], [V1], [h])))
    roots = 0.01 + np.array([s1[0], s2[0]]) * h
    assert np.all(ins.w_ta <= roots) and np.all(roots <= ins.w_tb)
    assert ins.w_tb[0] <= ins.w_ta[1]
    # sides: up before the first window's end, down until the second's, up after
    rows = reversals.Rows(
        np.concatenate([[0], ins.mid_k, [1]]),
        np.concatenate([[0.01], ins.mid_t, [0.02]]),
        np.zeros(2 + len(ins.mid_k), dtype=bool),
    )
    Vr = np.full((len(rows.step), 5), V0)
    side = reversals.sides(rows, Vr, np.zeros(len(rows.step), dtype=bool), ins, [3], np.ones(5))
    e = rows.at(ins.w_k, ins.w_tb, ins.w_t0)
    col = side[:, 3]
    assert np.all(col[: e[0]] == 1) and np.all(col[e[0] : e[1]] == -1) and np.all(col[e[1] :] == 1)
    # the crossings' ends the chain takes from sides_and_ends are the rows' own
    same, w_end, s_first = reversals.sides_and_ends(
        rows, Vr, np.zeros(len(rows.step), dtype=bool), ins, [3], np.ones(5)
    )
    assert np.array_equal(same, side)
    assert np.array_equal(w_end, rows.at(ins.w_kb, ins.w_tb, ins.w_t0b))
    assert np.array_equal(s_first, rows.first(ins.s_k))
    # shallow: the part standing through it misses the path by less than the tolerance
    P_shallow = np.array([[P0] * 5, [P0 + 0.6e-3] * 5])
    assert 0 < depth(P0 + 0.6e-3) < tol
    ins = reversals.plan_insertions(
        t_end,
        dt,
        P_shallow,
        V,
        np.zeros(2, dtype=bool),
        None,
        [3],
        np.array([1] * 5),
        np.full(5, np.nan),
        tol,
        1e-3,
    )
    assert not ins


def test_a_window_at_its_steps_start_is_found_whatever_the_rounding() -> None:
    """The point where a crossing begins, for a window that starts where its step
    starts, is the step's previous point, also when the step's start computed as
    t_end − dt differs from the previous point's time in the last bit (the times
    are relative to the chunk's start, so this depended on where chunks began)."""
    dt = np.array([0.01, 0.01, 0.003, 0.01])
    when = np.cumsum(dt)
    rows = reversals.Rows(np.arange(4), when, np.zeros(4, dtype=bool))
    k = np.array([2, 2, 0])
    t0 = np.array([when[1] + 2e-17, when[1] - 2e-17, 0.0])
    begs = rows.at(k, t0, t0)
    assert begs.tolist() == [1, 1, -1]
    ends = rows.at(k[:2], np.array([when[2], when[2]]), t0[:2])
    assert ends.tolist() == [2, 2]


def test_a_creep_back_is_measured_from_the_farthest_the_motor_went() -> None:
    """A motor moving down reaches its stop through rows without a direction (the
    last steps of its deceleration, the stop itself), then creeps back up while the
    path moves on (a table axis following the other's squareness). Its part stands
    at the farthest point down; a creep back past the allowance (0.05 µm) from there
    is a reversal, though the motor is still below where it last had a direction."""
    drift = 0.05e-3
    sg = np.array([-1, -1, 0, 0, 0, 0, 0, 0])
    P = np.array([-1.0, -1.010, -1.017, -1.0170, -1.01699, -1.01694, -1.01690, -1.01680])
    out, _ = kernel.creeps(sg, P, side=-1, ref=np.nan, drift=drift)
    # back by more than 0.05 µm from -1.017 first at -1.01694 (0.06 µm back)
    assert out.tolist() == [0, 0, 0, 0, 0, 1, 0, 0]
    # carried to the next chunk: the farthest, not the last row with a direction
    assert kernel.creeps(sg[:4], P[:4], -1, np.nan, drift)[1] == pytest.approx(-1.017, abs=1e-12)
    assert np.isnan(kernel.creeps(np.zeros(3, int), P[:3], -1, np.nan, drift)[1])
    # a motor creeping on its way is no reversal
    ahead = np.array([-1.0, -1.010, -1.017, -1.0171, -1.0172])
    assert not kernel.creeps(sg[:5], ahead, -1, np.nan, drift)[0].any()


def test_a_part_behind_its_motor_is_brought_back_at_a_share_of_the_path_speed() -> None:
    """A crossing at point 2 leaves the part 0.05 µm behind a motor moving down
    (above it: offset +0.05 µm, side −1). Steps of 10 ms at 5 mm/s (0.05 mm of path
    each): the offset shrinks by 2e-4 of the path, 0.01 µm a step, and is gone 5
    steps later (0.25 mm); at 5 mm/s its rate is 1 µm/s, 0.02 % of the speed where
    the one step it took before made it 5 µm/s (0.1 %)."""
    share = 2e-4
    s_path = 0.05 * np.arange(1, 21)
    idx, off, slope, left = reversals.catch_up(
        np.array([0.05e-3]), np.array([-1]), np.array([2]), np.array([20]), s_path, share
    )
    assert idx.tolist() == [3, 4, 5, 6]
    np.testing.assert_allclose(off, [0.04e-3, 0.03e-3, 0.02e-3, 0.01e-3], atol=1e-15)
    np.testing.assert_allclose(slope * 5.0, -1e-3)  # mm/s: 1 µm/s, back up
    assert left.tolist() == [0.0]
    # the same part ahead of its motor (a blend carried it past): left alone, it waits
    ahead = reversals.catch_up(
        np.array([0.05e-3]), np.array([1]), np.array([2]), np.array([20]), s_path, share
    )
    assert len(ahead[0]) == 0


@given(
    t_star=st.floats(0.1, 0.9),
    accel=st.floats(50.0, 5000.0),
    bend=st.floats(-0.9, 4.0),
    new=st.sampled_from([-1, 1]),
)
def test_a_reversal_is_put_where_the_paths_own_velocity_turns(
    t_star: float, accel: float, bend: float, new: int
) -> None:
    """A path whose motor velocity is new (A u + c u³), u = t − t*, over a 10 ms
    step h, the cubic term up to 4 x the linear one a step away (c = bend A / h²;
    no less than −0.9 x, so that the velocity turns only at t*):
    the step's cubic, from the ends' positions and velocities alone, puts the
    root elsewhere (it sees no c), and false position from there puts it within
    1 µs of t* (a 250th of the shortest window), with the acceleration A there (a
    central difference about it)."""
    h = 0.01
    c = bend * accel / h**2

    def v(t: np.ndarray) -> np.ndarray:
        u = t - t_star * h
        return new * (accel * u + c * u**3)

    def p(t: float) -> float:
        u = t - t_star * h
        return new * (accel * u**2 / 2 + c * u**4 / 4)

    V0, V1 = v(np.array([0.0])), v(np.array([h]))
    s, a = reversals.velocity_roots(
        np.array([p(0.0)]), V0, np.array([p(h)]), V1, np.array([h]), np.array([new])
    )

    def velocity(k: np.ndarray, frac: np.ndarray, cols: np.ndarray) -> np.ndarray:
        assert set(cols.tolist()) == {3} and set(k.tolist()) == {7}
        return v(frac * h)

    s2, a2 = reversals.path_roots(
        s, a, V0, V1, np.array([h]), np.array([new]), np.array([7]), np.array([3]), velocity
    )
    assert abs(s2[0] - t_star) * h < 1e-6
    if s2[0] != s[0]:  # moved: the path's acceleration there, dv/dt at u = 0
        assert new * a2[0] == pytest.approx(accel, rel=1e-2)
    else:  # the cubic's root was within ROOT_TIME_S: its acceleration is kept
        assert abs(v(s[:1] * h)[0]) <= abs(a[0]) * reversals.ROOT_TIME_S


def test_a_reversal_keeps_its_cubics_root_where_the_path_is_not_known() -> None:
    """A motor setting off from a stand (V0 = 0: no old way to bracket) and a step
    whose path velocity is not known (NaN) keep the root of the step's cubic."""
    s, a = np.array([0.4, 0.6]), np.array([100.0, 100.0])

    def velocity(k: np.ndarray, frac: np.ndarray, cols: np.ndarray) -> np.ndarray:
        return np.full(len(k), np.nan)

    out = reversals.path_roots(
        s,
        a,
        np.array([0.0, -1.0]),
        np.array([1.0, 1.0]),
        np.array([0.01, 0.01]),
        np.array([1, 1]),
        np.array([0, 1]),
        np.array([0, 0]),
        velocity,
    )
    np.testing.assert_array_equal(out[0], s)
    np.testing.assert_array_equal(out[1], a)


def test_a_part_ahead_of_its_motor_is_taken_up_no_faster_than_its_motor_moves() -> None:
    """A window that stood longer before its root than after it leaves the part
    ahead of its motor's way: 0.05 µm above a motor now moving up (offset +0.05 µm,
    side +1). Taken up at the share of the path (0.01 µm a 0.05 mm step), but over
    step 4, where the motor moves up only 0.004 µm, by half that: the command
    (wanted + offset) never goes back down, so the motor never leaves its part."""
    share = 2e-4
    s_path = 0.05 * np.arange(1, 21)
    dP = np.full(20, 1e-3)
    dP[4] = 0.004e-6
    speed = np.full(20, 5.0)

    def ahead(V: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return reversals.catch_up(
            np.array([0.05e-3]),
            np.array([1]),
            np.array([2]),
            np.array([20]),
            s_path,
            share,
            motion=(dP, V, speed),
        )

    idx, off, slope, left = ahead(np.full(20, 0.1))
    assert idx.tolist() == [3, 4, 5, 6, 7]
    np.testing.assert_allclose(
        off, [0.04e-3, 0.039998e-3, 0.029998e-3, 0.019998e-3, 0.009998e-3], atol=1e-15
    )
    # mm/s: 1 µm/s, slower up; the last bit over the step after it
    np.testing.assert_allclose(slope * 5.0, [-1e-3] * 4 + [-0.9998e-3])
    assert left.tolist() == [0.0]
    command = np.cumsum(dP)
    command[idx] += off
    command[2] += 0.05e-3  # where the window ended: the part's own position
    assert np.all(np.diff(command[2:]) > 0)
    # where the motor goes up slower than the share, so does the offset's rate
    _, _, slope, _ = ahead(np.full(20, 0.002))
    np.testing.assert_allclose(slope[:-1] * 5.0, -0.001)  # half the motor's 2 µm/s


@given(
    off=st.floats(1e-6, 1e-3),
    moves=st.lists(st.floats(0.0, 2e-3), min_size=3, max_size=30),
    ds=st.floats(1e-3, 0.5),
    way=st.sampled_from([-1, 1]),
)
def test_a_part_ahead_never_sees_its_command_turn_back(
    off: float, moves: list[float], ds: float, way: int
) -> None:
    """Whatever the motor's moves its way (some none at all): the command, wanted
    plus offset, never goes back; the offset only shrinks, by no more than the
    share of the path a step, and what is left at the chunk's end is carried."""
    share = 5e-5
    n = len(moves)
    dP = way * np.array(moves)
    s_path = ds * np.arange(1, n + 1)
    idx, o, _slope, left = reversals.catch_up(
        np.array([way * off]),
        np.array([way]),
        np.array([0]),
        np.array([n]),
        s_path,
        share,
        motion=(dP, dP / 0.01, np.full(n, ds / 0.01)),
    )
    full = np.zeros(n)
    full[idx] = o
    full[0] = way * off
    mag = way * full[1:]
    assert np.all(mag >= 0)
    taken = np.diff(np.concatenate([[off], mag]))
    assert np.all(taken <= 1e-18)
    assert np.all(-taken <= share * ds * (1 + 1e-9) + 1e-18)
    assert np.all(-taken <= 0.5 * way * dP[1:] * (1 + 1e-9) + 1e-18)
    assert np.all(way * np.diff(np.cumsum(dP) + full) >= -1e-18)
    assert left[0] == pytest.approx(full[-1], abs=1e-18)


def test_what_a_catch_up_leaves_where_the_next_crossing_begins_goes_into_it() -> None:
    """The motor's next crossing begins at point 4, 2 steps (0.1 mm of path) after
    this one ends: the offset shrinks at the share up to there and what is left
    goes into that crossing (its window's first command still carries it), not
    hurried away in the steps before it (in a tight curve's few points that ran a
    part 20 x the share: 1.0013 x F, test_controller_truth's found programs). At
    point 5 (0.15 mm) it would be gone at twice the share (CATCH_UP_HURRY), and is."""
    share = 2e-4
    s_path = 0.05 * np.arange(1, 21)
    idx, off, _slope, left = reversals.catch_up(
        np.array([-0.06e-3]), np.array([1]), np.array([2]), np.array([4]), s_path, share
    )
    assert idx.tolist() == [3, 4]
    np.testing.assert_allclose(off, [-0.05e-3, -0.04e-3], atol=1e-15)
    np.testing.assert_allclose(left, [-0.04e-3], atol=1e-15)
    idx, off, _slope, left = reversals.catch_up(
        np.array([-0.06e-3]), np.array([1]), np.array([2]), np.array([5]), s_path, share
    )
    assert idx.tolist() == [3, 4]
    np.testing.assert_allclose(off, [-0.04e-3, -0.02e-3], atol=1e-15)
    np.testing.assert_allclose(left, [0.0], atol=1e-18)
    # no path run before it (the path stands): all of it goes into the crossing
    stand = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    idx, off, _slope, left = reversals.catch_up(
        np.array([-0.06e-3]), np.array([1]), np.array([1]), np.array([4]), stand, share
    )
    assert idx.tolist() == [2, 3, 4]
    np.testing.assert_allclose(off, [-0.06e-3] * 3, atol=1e-15)
    np.testing.assert_allclose(left, [-0.06e-3], atol=1e-15)
    # a crossing that begins where this one ends takes all of it
    _idx, _off, _slope, left = reversals.catch_up(
        np.array([-0.06e-3]), np.array([1]), np.array([2]), np.array([2]), s_path, share
    )
    np.testing.assert_allclose(left, [-0.06e-3], atol=1e-15)


@settings(deadline=None)
@given(
    moves=st.lists(st.floats(-1e-3, 1e-3), min_size=2, max_size=40),
    cuts=st.lists(st.integers(1, 39), max_size=4),
    within=st.lists(st.floats(0.0, 1.0), min_size=5, max_size=5),
    cubic=st.booleans(),
)
def test_following_stretches_at_once_is_following_each(
    moves: list[float], cuts: list[int], within: list[float], cubic: bool
) -> None:
    """follow_stretches over commands cut into stretches, each from where its part
    stands in the play, against the play model run sample by sample along each step's
    Hermite cubic (2000 samples a step; straight lines where ``cubic`` is false),
    its scan started again at every stretch: the part at every point, and its
    extremes over every step (with where it stood when the step began, as the
    chain takes a window's)."""
    # 2 µm of play, a little more at one end
    table = MotorTable(
        0, np.array([-10.0, 10.0]), np.array([-1e-3, -1.2e-3]), np.array([1e-3, 0.9e-3])
    )
    n, h = len(moves), 0.01
    P = np.cumsum(moves)
    V = np.gradient(P, h)
    dt = np.full(n, h)
    starts = [0, *sorted({c for c in cuts if c < n})]
    steps = np.diff([*starts, n])
    P0 = np.array([P[s - 1] if s else 0.0 for s in starts])
    V0 = np.array([V[s - 1] if s else 0.0 for s in starts])
    # anywhere in the play at the stretch's first command
    low, high = table.lo(P0), table.hi(P0)
    y0 = low + np.array(within[: len(starts)]) * (high - low)
    y, lo, hi = kernel.follow_stretches(table.flat, y0, P0, V0, P, V, dt, steps, cubic)
    u = np.linspace(0.0, 1.0, 2001)[1:]
    for i, s in enumerate(starts):
        yk, pa, va = y0[i], P0[i], V0[i]
        for k in range(s, s + int(steps[i])):
            if cubic:  # the Hermite basis on [0, 1], velocities times the step
                cmd = (
                    (2 * u**3 - 3 * u**2 + 1) * pa
                    + (u**3 - 2 * u**2 + u) * h * va
                    + (-2 * u**3 + 3 * u**2) * P[k]
                    + (u**3 - u**2) * h * V[k]
                )
            else:
                cmd = np.array([P[k]])
            y_before = yk
            seen = [yk]  # the step's extremes over its closed span: its start too
            for c_lo, c_hi in zip(table.lo(cmd).tolist(), table.hi(cmd).tolist(), strict=True):
                yk = min(max(yk, c_lo), c_hi)
                seen.append(yk)
            assert y[k] == pytest.approx(yk, abs=1e-9)
            assert min(lo[k], y_before) == pytest.approx(min(seen), abs=1e-9)
            assert max(hi[k], y_before) == pytest.approx(max(seen), abs=1e-9)
            pa, va = P[k], V[k]


def test_a_catch_up_goes_on_over_the_chunks_end_and_waits_while_the_path_stands() -> None:
    """A catch-up not done by the chunk's last point is left for the next chunk
    (start −1: the point before it); points where the path stands keep the offset."""
    share = 2e-4
    s_path = np.array([0.05, 0.10, 0.10, 0.10])  # the path stands after point 1
    idx, off, _slope, left = reversals.catch_up(
        np.array([0.05e-3]), np.array([-1]), np.array([0]), np.array([4]), s_path, share
    )
    assert idx.tolist() == [1, 2, 3]
    np.testing.assert_allclose(off, [0.04e-3] * 3, atol=1e-15)
    assert left[0] == pytest.approx(0.04e-3, abs=1e-15)
    # the next chunk: from the point before it
    idx, off, _slope, left = reversals.catch_up(
        left, np.array([-1]), np.array([-1]), np.array([3]), 0.05 * np.arange(1, 4), share
    )
    assert idx.tolist() == [0, 1, 2]
    np.testing.assert_allclose(off, [0.03e-3, 0.02e-3, 0.01e-3], atol=1e-15)
    assert left[0] == pytest.approx(0.01e-3, abs=1e-15)


def test_a_corner_where_a_motor_stands_on_one_side_turns_it_back_with_the_mean() -> None:
    """The closed form behind reversals.corners: a corner's point carrying the mean
    of its sides' velocities, V/2, after a step h over which the motor stood, makes
    that step's cubic turn back by (4/27) h V/2 (the basis s³ − s² peaks at 4/27);
    a point of the standing side at τ from the corner leaves the turn to the step
    τ, (4/27) τ V/2, whose cubic's acceleration peaks at 2 V / τ (4 (V/2) / τ, at
    its end)."""
    h, tau, V = 0.01, 0.25e-3, 0.1666
    s = np.linspace(0.0, 1.0, 20001)
    standing_mean = hermite(0.0, 0.0, 0.0, -V / 2, h, s)  # sets off downwards
    assert standing_mean.max() == pytest.approx(4 / 27 * h * V / 2, rel=1e-6)
    near = hermite(0.0, 0.0, 0.0, -V / 2, tau, s)
    assert near.max() == pytest.approx(4 / 27 * tau * V / 2, rel=1e-6)
    accel = np.gradient(np.gradient(near, s * tau), s * tau)
    assert np.abs(accel[5:-5]).max() == pytest.approx(2 * V / tau, rel=1e-3)


@pytest.mark.parametrize(("v_slow", "v_fast"), [(0.0218, 0.17), (0.01, 0.5), (0.02, 0.1)])
def test_a_corner_where_a_motor_with_play_speeds_up_steeply_is_blended(
    v_slow: float, v_fast: float
) -> None:
    """The corner's point carries the mean of its sides' velocities, so the slow
    side's step (its chord at v_slow) dips to v_slow − (v_fast − v_slow)/6: below
    zero, the motor turns back inside the step and leaves its part (a tilt speeding
    up eightfold at F60: 1.0045 x F, test_controller_truth's found programs). The
    turn back, sampled on the step's cubic, is the closed form corners() decides
    by; a dip that stays above zero turns nothing back and is not blended."""
    h = 0.01
    s = np.linspace(0.0, 1.0, 200001)
    x = hermite(0.0, v_slow, v_slow * h, 0.5 * (v_slow + v_fast), h, s)
    back = float(max(np.maximum.accumulate(x) - x))
    dV = v_fast - v_slow
    closed = 4 / 27 * h * dV / 2 * max(0.0, 1 - 6 * v_slow / dV) ** 1.5
    assert back == pytest.approx(closed, rel=1e-3, abs=1e-12)
    V_in = np.array([[v_slow, 0.0, 0.0, 0.0, 0.0]])
    V_out = np.array([[v_fast, 0.0, 0.0, 0.0, 0.0]])
    blend, _ = reversals.corners(V_in, V_out, [0], np.array([h]), 2000.0)
    assert blend[0] == (closed > reversals.CORNER_TURN_MM)
    # and the same corner the other way round (slowing down steeply), downwards
    blend, _ = reversals.corners(-V_out, -V_in, [0], np.array([h]), 2000.0)
    assert blend[0] == (closed > reversals.CORNER_TURN_MM)


def test_a_corner_where_a_motor_with_play_stands_on_one_side_is_blended() -> None:
    h = np.full(7, 0.01)
    V_in = np.zeros((7, 5))
    V_out = np.zeros((7, 5))
    V_in[:6, 0] = [0.0, -0.1666, 0.2, 0.2, 0.0, 0.0]
    V_out[:6, 0] = [-0.1666, 0.0, 0.3, -0.2, 1e-3, 30.0]
    # the last: motor 0 stands on both sides while motor 3, without play, turns
    V_in[6, 3], V_out[6, 3] = 2.0, -2.0
    blend, tau = reversals.corners(V_in, V_out, [0], h, 2000.0)
    # sets off, stops: blended; a motor moving on both sides at 0.2 and 0.3 (its
    # mean's cubic dips to 0.2 − 0.1/6 > 0), or reversing (a crossing's), is left
    # alone, and so is a turn back of (4/27) h 1e-3 / 2 = 0.74 nm; a jump of 30
    # mm/s would need τ = 7.5 ms at 2000 mm/s², more than half the step: none
    assert blend.tolist() == [True, True, False, False, False, False, False]
    assert tau[:2].tolist() == [reversals.BLEND_MIN_S] * 2
    assert tau[5] == pytest.approx(7.5e-3)
    # τ is for the largest jump of any motor, with play or not: 6 mm/s at 1000
    # mm/s² takes 3 ms
    blend, tau = reversals.corners(
        np.array([[0.0, 0.0, 0.0, 0.0, 0.0]]),
        np.array([[0.1666, 0.0, 0.0, 6.0, 0.0]]),
        [0],
        np.array([0.01]),
        1000.0,
    )
    assert blend.tolist() == [True] and tau[0] == pytest.approx(3e-3)


def test_a_point_after_a_window_in_its_step_is_on_the_new_side() -> None:
    """Where the path turns a corner, a motor reversing there has its window at the
    root of the step's cubic, before the corner, while the plan's velocity turns
    only at the corner. A point after the window's end in the same step (another
    motor's window, a blend's point before the corner) is on the new side whatever the sign
    of its velocity: read as the old side, the motor crossed its play back and
    forth three times in 3 ms (1.0125 x F; test_controller_truth, xy-then-plunge)."""
    ins = reversals.Insertions()
    ins.w_k, ins.w_col, ins.w_new = np.array([1]), np.array([0]), np.array([-1])
    ins.w_t0, ins.w_ta, ins.w_tb = np.array([0.01]), np.array([0.012]), np.array([0.013])
    ins.w_kb, ins.w_t0b = ins.w_k, ins.w_t0
    # the end of step 0; in step 1 the window's ends, a blend's point before the corner, and
    # the corner (the step's end, carrying the mean of its sides' velocities)
    rows = reversals.Rows(
        np.array([0, 1, 1, 1, 1]),
        np.array([0.01, 0.012, 0.013, 0.0195, 0.02]),
        np.zeros(5, dtype=bool),
    )
    V = np.zeros((5, 5))
    V[:, 0] = [0.01, 0.008, 0.008, 0.008, -0.05]
    side = reversals.sides(rows, V, np.zeros(5, dtype=bool), ins, [0], np.ones(5, dtype=int))
    assert side[:, 0].tolist() == [1, 1, -1, -1, -1]


@settings(max_examples=100, deadline=None)
@given(
    st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3),
    st.lists(st.floats(-50.0, 50.0), min_size=3, max_size=3),
    st.floats(0.25e-3, 5e-3),
)
def test_a_blended_corner_is_one_parabola_through_its_three_points(
    v_in: list[float], v_out: list[float], tau: float
) -> None:
    """reversals.blend_shift: points of a straight motor path τ before and after a
    corner, with their sides' velocities, and the corner's point moved by the
    shift, with the mean velocity. The controller's two cubics through them (the
    Hermite form, this file's own) are one parabola: the acceleration is the same
    everywhere, (V_out − V_in) / 2τ, so each motor's velocity runs linearly from one
    side's to the other's and never past either."""
    V_in, V_out = np.array([v_in]), np.array([v_out])
    P_c = np.array([1.0, -2.0, 3.0])
    shift = reversals.blend_shift(V_in, V_out, np.array([tau]))[0]
    pts = [
        (P_c - tau * V_in[0], V_in[0]),
        (P_c + shift, (V_in[0] + V_out[0]) / 2),
        (P_c + tau * V_out[0], V_out[0]),
    ]
    s = np.linspace(0.0, 1.0, 201)
    for (Pa, Va), (Pb, Vb) in itertools.pairwise(pts):
        # the Hermite form's first and second derivatives, in closed form
        d = (Pa - Pb)[:, None] / tau
        v = (
            6 * (s**2 - s) * d
            + (3 * s**2 - 4 * s + 1) * Va[:, None]
            + (3 * s**2 - 2 * s) * Vb[:, None]
        )
        a = ((12 * s - 6) * d + (6 * s - 4) * Va[:, None] + (6 * s - 2) * Vb[:, None]) / tau
        want = (V_out[0] - V_in[0])[:, None] / (2 * tau)
        np.testing.assert_allclose(a, np.broadcast_to(want, a.shape), rtol=1e-6, atol=1e-3)
        lo = np.minimum(V_in[0], V_out[0])[:, None]
        hi = np.maximum(V_in[0], V_out[0])[:, None]
        assert np.all(v >= lo - 1e-9) and np.all(v <= hi + 1e-9)


def test_each_reach_answered_sizes_the_window_it_was_asked_for() -> None:
    """The chain answers the reach questions (reversals.edge_queries: steps,
    fractions, motors, accelerations) in their order, and place_insertions gives
    each answer to the window it was asked for: no reach (inf) is the tolerance
    alone, as without answers; a reach near zero for one motor's reversal makes
    that window a servo cycle and leaves the other motor's alone."""
    dt = np.full(4, 0.01)
    t_end = np.cumsum(dt)
    V, P = np.zeros((4, 5)), np.zeros((4, 5))
    V[:, 0], P[:, 0] = [1.0, 1.0, -1.0, -1.0], [0.0, 0.01, 0.01, 0.0]
    V[:, 1], P[:, 1] = [-1.0, -1.0, -1.0, 1.0], [0.0, -0.01, -0.02, -0.02]
    side = np.array([1, -1, 1, 1, 1])
    found = reversals.find_reversals(
        t_end, dt, P, V, np.zeros(4, dtype=bool), None, [0, 1], side, np.full(5, np.nan), 5e-5
    )
    k, frac, cols, accel = reversals.edge_queries(found)
    assert sorted(zip(k.tolist(), cols.tolist(), strict=True)) == [(2, 0), (3, 1)]
    assert np.all((0 < frac) & (frac < 1)) and np.all(accel[cols == 0] < 0)
    plain = reversals.place_insertions(found, 5e-5, 1e-3)
    free = reversals.place_insertions(found, 5e-5, 1e-3, False, (np.full(2, np.inf),) * 2)
    tight_b = np.where(cols == 1, 1e-9, np.inf)
    tight = reversals.place_insertions(found, 5e-5, 1e-3, False, (tight_b, tight_b))
    for ins in (free, tight):
        assert ins.w_col.tolist() == plain.w_col.tolist() == [0, 1]
    np.testing.assert_array_equal(free.w_ta, plain.w_ta)
    np.testing.assert_array_equal(free.w_tb, plain.w_tb)
    assert tight.w_ta[0] == plain.w_ta[0] and tight.w_tb[0] == plain.w_tb[0]
    assert plain.w_tb[1] - plain.w_ta[1] > 2 * reversals.MIN_WINDOW_S
    assert tight.w_tb[1] - tight.w_ta[1] == pytest.approx(reversals.MIN_WINDOW_S)
    root = t_end[2] + frac[cols == 1][0] * dt[3]
    assert tight.w_ta[1] < root < tight.w_tb[1]
