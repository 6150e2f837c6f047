"""reversals.py: where a motor with play reverses, and where its part stands.

Each function is held against an independent reference: the roots of the
Hermite cubic's velocity against numpy's polynomial roots; the part's position
along the controller's cubics against the contract's play model stepped over a
dense sampling of the same cubics (a Turbo PMAC PVT segment is the cubic through
its end positions and velocities: Software Reference, PVT{data}); the crossing
windows against their stated bounds.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import reversals
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
    # the cubic's coefficients in s, differentiated: independent of the module's algebra
    c3 = 2 * p0 + h * v0 - 2 * (p0 + dp) + h * V1
    c2 = -3 * p0 - 2 * h * v0 + 3 * (p0 + dp) - h * V1
    c1 = h * v0
    roots = np.roots([3 * c3, 2 * c2, c1])
    real = np.sort(roots[np.isreal(roots)].real)
    first = real[(real >= -1e-9) & (real <= 1 + 1e-9)][0]
    assert abs(s[0] - first) < 1e-7
    # the acceleration from the same expanded polynomial: d²x/dt² = x''(s) / h²
    a_ref = float(np.polyval([6 * c3, 2 * c2], first)) / h**2
    assert abs(acc[0] - a_ref) <= 1e-6 * max(1.0, abs(a_ref))


def _table(backlash: float) -> MotorTable:
    """A motor with play ``backlash`` [mm] and a slope error of 20 µm/m."""
    pos = [-100.0, 0.0, 100.0]
    fwd = [-0.002, 0.0, 0.002]
    rev = [f + backlash for f in fwd]
    return MotorTable.from_comp(AxisComp(1, np.array(pos), np.array(fwd), np.array(rev)))


def test_follow_is_the_play_model_on_the_dense_cubics() -> None:
    """Random commands with reversals: the part's position at each point and its
    extremes within each step equal the contract's play model, y_k = clamp(y_{k-1},
    lo(p_k), hi(p_k)), stepped over 2000 samples of every segment's cubic."""
    rng = np.random.default_rng(5)
    table = _table(0.004)
    n = 40
    dt = rng.uniform(0.002, 0.01, n)
    V = rng.normal(0, 20, n)
    P = 1.0 + np.cumsum(rng.normal(0, 0.05, n))
    P0, V0, y0 = 1.0, 0.0, float(table.lo(np.array([1.0]))[0])
    y_end, y_min, y_max = reversals.follow(table, y0, P0, V0, P, V, dt)
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


@settings(max_examples=200, deadline=None)
@given(
    h=st.floats(0.002, 0.02),
    s_root=st.floats(0, 1),
    accel=st.floats(1.0, 1e5),
    tol=st.floats(1e-6, 1e-4),
)
def test_windows_stay_in_their_step_and_bound_the_error(
    h: float, s_root: float, accel: float, tol: float
) -> None:
    """A window lies inside its step, lasts at least the controller's shortest
    segment, at most the step or the longest allowed, and where it is narrower than
    the step its error |A| (δ/2)² / 2 is within the tolerance times 2.25 (grown by
    at most half its width so that no sliver is left beside it)."""
    longest = 1e-3
    t0, t1 = np.array([0.3]), np.array([0.3 + h])
    ta, tb = reversals.windows(t0, t1, t0 + s_root * h, np.array([accel]), tol, longest)
    assert t0[0] <= ta[0] < tb[0] <= t1[0]
    width = tb[0] - ta[0]
    assert width >= min(reversals.MIN_WINDOW_S, h) - 1e-15
    assert width <= 1.5 * longest + 1e-15 or (ta[0] == t0[0] and tb[0] == t1[0])
    natural = np.sqrt(8 * tol / accel)
    if reversals.MIN_WINDOW_S < natural < longest and width < h:
        assert accel * (width / 2) ** 2 / 2 <= 2.25 * tol * (1 + 1e-9)


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
