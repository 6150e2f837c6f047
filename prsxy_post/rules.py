"""What the machine cannot do at a point: the rules the chain and ``check`` judge by.

Each rule takes arrays (poses, motor commands, their G-code lines) and returns
:class:`Problem` s, one per line at its worst point: a feed above the machine's
maximum, a tool axis tilted beyond the limit, a pose the struts cannot reach, a
motor commanded beyond its travel. The chain stops ``convert`` at the first; the
``check`` driver (:mod:`prsxy_post.check`) gathers them all.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from . import kinematics
from .errors import LimitError, PrsxyError, ReachError
from .gcode import rows
from .profile import MOTORS, Profile

if TYPE_CHECKING:
    from .gcode import Motion
    from .points import PointChunk

#: the kinds of problem, in the order they are listed for a line
KINDS = ("feed", "reach", "tilt", "travel")

#: a point is beyond a bound when it is beyond by more than this (mm, deg), as in
#: the chain's own checks: rounding is not a problem
TOLERANCE = 1e-9
#: How far below the tilt limit |A| + |B| must stay for a pose to be left unmeasured [deg].
TILT_SLACK_DEG = 1e-3


class Problem(NamedTuple):
    """One kind of problem on one G-code line, at the line's worst point.

    kind : "feed", "reach", "tilt" or "travel"
    line : the G-code line
    value : the worst figure on the line: the motor command [mm] (travel), the
        tool-axis tilt [deg] (tilt), the programmed feed [mm/min] (feed), how far
        how much longer the worst strut would have to be [mm] (reach; inf where
        no platform pose exists)
    excess : how far ``value`` is beyond what the profile allows (same unit)
    motor : the motor (travel only)
    """

    kind: str
    line: int
    value: float
    excess: float
    motor: int | None = None

    def error(self, profile: Profile, source: str | None = None) -> PrsxyError:
        """The problem as the located error ``convert`` stops with."""
        what, _, expected = problem_words(self, profile)
        cls = ReachError if self.kind in ("reach", "travel") else LimitError
        return cls(what, source=source, line=self.line, expected=expected)


def _worst_per_line(excess: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Index of the largest excess of each distinct line (among points with
    excess > TOLERANCE), in line order; ties go to the earlier point."""
    bad = np.nonzero(excess > TOLERANCE)[0]
    if bad.size == 0:
        return bad
    order = np.lexsort((bad, -excess[bad], lines[bad]))
    ranked = bad[order]
    _, first = np.unique(lines[ranked], return_index=True)
    return np.asarray(ranked[first])


def feed_problems(profile: Profile, motions: Sequence[Motion] | rows.MotionTable) -> list[Problem]:
    """Programmed feeds above ``limits.max_feed_mm_min``, one per motion (or row of
    their table, :mod:`prsxy_post.gcode.rows`)."""
    fmax = float(profile.limits.max_feed_mm_min)
    if isinstance(motions, rows.MotionTable):
        r = motions.rows
        kind, feed = r[:, rows.ROW_KIND], r[:, rows.ROW_FEED]
        over = ((kind == rows.KIND_FEED) | (kind == rows.KIND_ARC)) & (feed > fmax)
        return [
            Problem("feed", int(r[i, rows.ROW_LINE]), float(feed[i]), float(feed[i]) - fmax)
            for i in np.flatnonzero(over).tolist()
        ]
    return [
        Problem("feed", m.line, m.feed, m.feed - fmax)
        for m in motions
        if m.kind in ("feed", "arc") and m.feed > fmax
    ]


def tilt_problems(profile: Profile, q: np.ndarray, line: np.ndarray) -> list[Problem]:
    """Tool-axis tilts beyond ``limits.max_tilt_deg``, worst point per line.

    q : (N, 5) programmed poses [mm, mm, mm, deg, deg]; line : (N,) their lines.
    The tool axis (cos A sin B, −sin A, cos A cos B) leans from vertical by
    arccos(cos A cos B).
    """
    lim = float(profile.limits.max_tilt_deg)
    # the axis leans by at most |A| + |B| (Rx(A) turns it by |A|, Ry(B) then by at
    # most |B|): only poses within TILT_SLACK_DEG of the limit by that bound are
    # measured (the arccos's rounding is below 1e-6°), the same answer
    near = np.flatnonzero(np.abs(q[:, 3]) + np.abs(q[:, 4]) > lim - TILT_SLACK_DEG)
    if not near.size:
        return []
    a, b = np.radians(q[near, 3]), np.radians(q[near, 4])
    tilt = np.degrees(np.arccos(np.clip(np.cos(a) * np.cos(b), -1.0, 1.0)))
    return [
        Problem("tilt", int(line[near[i]]), float(tilt[i]), float(tilt[i] - lim))
        for i in _worst_per_line(tilt - lim, line[near])
    ]


def reach_problems(
    geo: kinematics.Geometry,
    q_target: np.ndarray,
    tool_length: np.ndarray,
    P_ideal: np.ndarray,
    line: np.ndarray,
) -> list[Problem]:
    """Poses the struts cannot reach (NaN rows of the IK's ``P_ideal``), worst point
    per line, sized by how much longer the worst strut would have to be [mm].

    The ball joint of leg i is sqrt(L_i² − disc_i) from its guide line (disc_i the
    contract's (d·v)² − |v|² + L²), so the strut lacks that minus L_i; inf where
    no platform pose exists at all.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        # a finite sum: every position finite (a NaN or inf would not be)
        if np.isfinite(P_ideal.sum()):
            return []
    out = ~np.all(np.isfinite(P_ideal), axis=1)
    if not np.any(out):
        return []
    idx = np.nonzero(out)[0]
    pose = kinematics.solve_platform(geo, q_target[idx], tool_length[idx])
    disc = kinematics.strut_discriminant(geo, pose)
    with np.errstate(invalid="ignore"):
        lack = np.sqrt(geo.L[None, :] ** 2 - disc) - geo.L[None, :]
        short = np.max(lack, axis=1)
    short = np.where(np.isfinite(short), short, np.inf)
    excess = np.zeros(len(P_ideal))
    excess[idx] = np.maximum(short, 2 * TOLERANCE)
    return [
        Problem("reach", int(line[i]), float(excess[i]), float(excess[i]))
        for i in _worst_per_line(excess, line)
    ]


def travel_problems(profile: Profile, P_cmd: np.ndarray, line: np.ndarray) -> list[Problem]:
    """Motors commanded beyond their travel (``[[motors]] min/max``), worst point
    per line and motor.

    P_cmd : (N, 5) motor commands [mm], columns :data:`MOTORS`; NaN rows (out of
    reach) are left to :func:`reach_problems`.
    """
    with np.errstate(over="ignore", invalid="ignore"):
        # a finite sum: every command finite (a NaN or inf would not be), the rule
        finite = bool(np.isfinite(P_cmd.sum()))
    bad = None if finite else np.flatnonzero(~np.all(np.isfinite(P_cmd), axis=1))
    out: list[Problem] = []
    # a column at a time: an (N, 5) array against (5,) bounds broadcast costs
    # several times the same subtractions on columns against scalars (the same bits)
    for col, m in enumerate(MOTORS):
        mc = profile.motor(m)
        p = P_cmd[:, col]
        # its extremes first: rounding is monotone, so where the largest command
        # less max (and min less the least) is within the tolerance, so is every
        # point's, and the motor has no problem (most chunks, every motor)
        if finite and (
            not len(p) or (p.max() - mc.max <= TOLERANCE and mc.min - p.min() <= TOLERANCE)
        ):
            continue
        with np.errstate(invalid="ignore"):
            excess = np.maximum(p - mc.max, mc.min - p)
        if bad is not None:
            excess[bad] = -np.inf
        out += [
            Problem("travel", int(line[i]), float(p[i]), float(excess[i]), m)
            for i in _worst_per_line(excess, line)
        ]
    return out


def point_problems(profile: Profile, geo: kinematics.Geometry, pc: PointChunk) -> list[Problem]:
    """Tilt, reach and travel problems of a run of points from the chain."""
    return [
        *tilt_problems(profile, pc.q, pc.line),
        *reach_problems(geo, pc.q_target, pc.tool_length, pc.P_ideal, pc.line),
        *travel_problems(profile, pc.P_cmd, pc.line),
    ]


def problem_words(p: Problem, profile: Profile, group: bool = False) -> tuple[str, str, str]:
    """(what, figure, expected) of a problem: ``what`` as the chain says it for one
    point, or for a group; ``figure`` its worst value with its unit."""
    if p.kind == "travel":
        assert p.motor is not None
        mc = profile.motor(p.motor)
        what = (
            f"motor {p.motor} ({mc.axis}) commanded beyond its travel"
            if group
            else f"motor {p.motor} ({mc.axis}) commanded to {p.value:.4f} mm, beyond its travel"
        )
        expected = f"{mc.min:g} to {mc.max:g} mm (motors[{p.motor}].min/max)"
        return what, f"{p.value:.4f} mm", expected
    if p.kind == "tilt":
        lim = profile.limits.max_tilt_deg
        what = "tool axis tilted beyond the limit" if group else f"tool axis tilted {p.value:.3f}°"
        return what, f"{p.value:.3f}°", f"at most {lim:g}° (limits.max_tilt_deg)"
    if p.kind == "feed":
        lim = profile.limits.max_feed_mm_min
        what = (
            "feed above the machine's maximum"
            if group
            else f"feed F{p.value:g} mm/min is above the machine's maximum"
        )
        return what, f"F{p.value:g}", f"at most {lim:g} mm/min (limits.max_feed_mm_min)"
    short = "no platform pose" if math.isinf(p.value) else f"a strut short by {p.value:.4f} mm"
    what = (
        "pose out of the machine's reach" if group else f"pose out of the machine's reach ({short})"
    )
    return what, short, "a pose the struts can reach (see the profile's [kinematics])"
