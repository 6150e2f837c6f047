"""The chain's pose rules (prsxy_post/rules.py): tilt and reach problems found as
the whole computation finds them, with the shortcuts that skip it."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import kinematics, profile, rules

from .conftest import ROOT

PROF = profile.loads((ROOT / "profiles" / "prsxy-shop.toml").read_text(), "shop")
LIM = float(PROF.limits.max_tilt_deg)


def _all_tilts(q: np.ndarray, line: np.ndarray) -> list[rules.Problem]:
    """Every pose's tilt measured, worst per line (the rule without its bound)."""
    a, b = np.radians(q[:, 3]), np.radians(q[:, 4])
    tilt = np.degrees(np.arccos(np.clip(np.cos(a) * np.cos(b), -1.0, 1.0)))
    return [
        rules.Problem("tilt", int(line[i]), float(tilt[i]), float(tilt[i] - LIM))
        for i in rules._worst_per_line(tilt - LIM, line)
    ]


ANGLE = st.one_of(
    st.floats(-LIM, LIM),  # around the limit from both sides
    st.floats(-2 * LIM, 2 * LIM),
    st.floats(-400, 400),
    st.sampled_from([LIM, -LIM, LIM - 1e-3, LIM + 1e-9, LIM + 2e-9, 0.0, np.nan]),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(ANGLE, ANGLE, st.integers(1, 6)), min_size=1, max_size=40))
def test_tilt_problems_are_those_of_every_pose_measured(
    rows: list[tuple[float, float, int]],
) -> None:
    q = np.zeros((len(rows), 5))
    q[:, 3] = [r[0] for r in rows]
    q[:, 4] = [r[1] for r in rows]
    line = np.array([r[2] for r in rows])
    assert rules.tilt_problems(PROF, q, line) == _all_tilts(q, line)


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.float64, (50, 2), elements=st.floats(-179, 179)))
def test_the_axis_leans_no_more_than_both_tilts_together(ab: np.ndarray) -> None:
    """The bound the rule skips poses by: the tool axis (cos A sin B, −sin A,
    cos A cos B) leans from vertical by at most |A| + |B|, here measured as the
    angle between the axis and z (atan2 of the cross and the dot product)."""
    axis = kinematics.tool_axis(ab[:, 0], ab[:, 1])
    lean = np.degrees(np.arctan2(np.hypot(axis[:, 0], axis[:, 1]), axis[:, 2]))
    assert np.all(lean <= np.abs(ab[:, 0]) + np.abs(ab[:, 1]) + 1e-9)


def test_reach_problems_only_where_a_position_is_not_finite() -> None:
    geo = kinematics.Geometry.from_params(PROF.kinematics, PROF.origin)
    q = np.zeros((4, 5))
    tool = np.zeros(4)
    line = np.array([1, 2, 3, 4])
    P = kinematics.inverse(geo, q, tool).P
    assert rules.reach_problems(geo, q, tool, P, line) == []
    # finite positions whose sum is not (it overflows): still reachable
    huge = np.full((4, 5), 1e308)
    assert rules.reach_problems(geo, q, tool, huge, line) == []
    q_far = q.copy()
    q_far[2] = [-49.2, -104.9, 31.4, -133.3, 52.7]  # no platform pose reaches it
    P_far = kinematics.inverse(geo, q_far, tool).P
    probs = rules.reach_problems(geo, q_far, tool, P_far, line)
    assert [(p.kind, p.line) for p in probs] == [("reach", 3)]
    assert probs[0].excess > 0


def _all_travel(P_cmd: np.ndarray, line: np.ndarray) -> list[rules.Problem]:
    """Every point's excess over its motor's travel measured, worst per line and
    motor (the rule without its shortcut by the motors' extremes)."""
    bad = np.flatnonzero(~np.all(np.isfinite(P_cmd), axis=1))
    out: list[rules.Problem] = []
    for col, m in enumerate(profile.MOTORS):
        mc = PROF.motor(m)
        p = P_cmd[:, col]
        with np.errstate(invalid="ignore"):
            excess = np.maximum(p - mc.max, mc.min - p)
        excess[bad] = -np.inf
        out += [
            rules.Problem("travel", int(line[i]), float(p[i]), float(excess[i]), m)
            for i in rules._worst_per_line(excess, line)
        ]
    return out


def _near_travel() -> st.SearchStrategy[float]:
    """Commands about every motor's travel ends, within and beyond the tolerance."""
    ends = sorted(
        {float(v) for m in profile.MOTORS for v in (PROF.motor(m).min, PROF.motor(m).max)}
    )
    t = rules.TOLERANCE
    edges = [e + d for e in ends for d in (0.0, t, -t, 2 * t, -2 * t, 0.5 * t, 1e-3, -1e-3)]
    return st.one_of(st.sampled_from(edges), st.floats(-400, 400), st.sampled_from([np.nan]))


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(*[_near_travel()] * 5, st.integers(1, 6)), min_size=0, max_size=30))
def test_travel_problems_are_those_of_every_point_measured(
    rows: list[tuple[float, float, float, float, float, int]],
) -> None:
    P_cmd = np.array([r[:5] for r in rows], dtype=float).reshape(len(rows), 5)
    line = np.array([r[5] for r in rows], dtype=int)
    assert rules.travel_problems(PROF, P_cmd, line) == _all_travel(P_cmd, line)


def test_travel_problems_at_the_tolerance_about_every_end() -> None:
    """Each motor commanded just within and just beyond each end of its travel by
    fractions of the tolerance (the other motors mid-travel): a problem exactly
    where the point's own excess is above it."""
    t = rules.TOLERANCE
    mid = [0.5 * (PROF.motor(m).min + PROF.motor(m).max) for m in profile.MOTORS]
    found = 0
    for col, m in enumerate(profile.MOTORS):
        mc = PROF.motor(m)
        for end, way in ((mc.max, 1.0), (mc.min, -1.0)):
            for k in (0.0, 0.5, 1.0, 1.5, 2.0, 4.0):
                P = np.array([mid, mid], dtype=float)
                P[1, col] = end + way * k * t
                got = rules.travel_problems(PROF, P, np.array([1, 2]))
                assert got == _all_travel(P, np.array([1, 2]))
                found += len(got)
    assert found >= 2 * len(profile.MOTORS) * 3  # 1.5, 2 and 4 tolerances beyond
