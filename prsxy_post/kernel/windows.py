"""The crossings about motors' reversals, elementwise: where a step's cubic turns
(:func:`velocity_roots`, :func:`turning_points`), which steps dip and where
(:func:`dip_roots`), and a window's edges from the
root, the acceleration there, the tolerance and the reach on each side
(:func:`crossing_windows`); a motor's reversals in a chunk and their kinds
(:func:`motor_turns`), its dips and settings-off back (:func:`motor_dips`); the
corners a PVT program blends (:func:`corner_blends`).

The numpy reference; ``_windows.pyx`` is its compiled twin, the same operations in
the same order (the same bits). The rules (why each) are
:func:`prsxy_post.reversals.windows`'; this module only computes them.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from .play import carried, creeps, hermite, velocity_quadratic

#: A reversal's kind (:func:`motor_turns`): in motion (the window about the root
#: of its step's cubic), at rest (a standing point), creeping back over a step's
#: end, after the motor stood through the step before.
MID, AT_REST, CREPT, STOOD = 0, 1, 2, 3


def velocity_roots(
    P0: np.ndarray,
    V0: np.ndarray,
    P1: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    new: np.ndarray,
    has_new: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """Where the cubic through (P0, V0) and (P1, V1) over time h (n,) has zero
    velocity: the first root in [0, 1] of its velocity's quadratic (with
    ``has_new``, the first where it turns the way ``new`` (n,), where one does),
    the linear estimate V0 / (V0 − V1) where rounding hides the root; and the
    cubic's acceleration there [mm/s²]. The rules are
    :func:`prsxy_post.reversals.velocity_roots`'.

    Returns
    -------
    s, accel : (n,)
    """
    a, b, c = velocity_quadratic(P0, V0, P1, V1, h)
    disc = b * b - 4.0 * a * c
    lin = np.abs(a) < 1e-12 * (np.abs(b) + np.abs(c) + 1e-300)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        qq = -0.5 * (b + np.copysign(np.sqrt(np.maximum(disc, 0.0)), b))
        r1 = np.where(lin, np.where(b != 0, -c / b, np.nan), qq / a)
        r2 = np.where(lin, np.nan, np.where(qq != 0, c / qq, -b / (2 * a)))
        r1 = np.where(disc >= 0, r1, np.nan)
        r2 = np.where(disc >= 0, r2, np.nan)
        ok1 = (r1 >= -1e-9) & (r1 <= 1 + 1e-9)
        ok2 = (r2 >= -1e-9) & (r2 <= 1 + 1e-9)
        if has_new:
            turn1 = ok1 & (new * (2.0 * a * r1 + b) >= 0)
            turn2 = ok2 & (new * (2.0 * a * r2 + b) >= 0)
            either = turn1 | turn2
            ok1, ok2 = np.where(either, turn1, ok1), np.where(either, turn2, ok2)
        best = np.where(ok1 & ok2, np.minimum(r1, r2), np.where(ok1, r1, np.where(ok2, r2, np.nan)))
        linear = np.where(V0 != V1, V0 / (V0 - V1), 0.5)
    s = np.clip(np.where(np.isnan(best), linear, best), 0.0, 1.0)
    acc: np.ndarray = (2.0 * a * s + b) / h
    return s, acc


def turning_points(
    P0: np.ndarray, V0: np.ndarray, P1: np.ndarray, V1: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Both roots of the cubic's velocity (:func:`velocity_roots`) where both lie
    strictly inside the step, in time order; NaN elsewhere."""
    a, b, c = velocity_quadratic(P0, V0, P1, V1, h)
    disc = b * b - 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        qq = -0.5 * (b + np.copysign(sq, b))
        r1, r2 = qq / a, c / qq
    lo, hi = np.minimum(r1, r2), np.maximum(r1, r2)
    ok = (disc > 0) & (np.abs(a) > 0) & (lo > 0) & (hi < 1) & (hi > lo)
    return np.where(ok, lo, np.nan), np.where(ok, hi, np.nan)


def dip_roots(
    P0: np.ndarray,
    V0: np.ndarray,
    P1: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    sg: np.ndarray,
    tol: float,
    sets_off: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The steps (n,) whose cubic turns back and on again deeper than ``tol``
    [mm] while the motor moves the way ``sg`` at both ends, or (``sets_off``)
    that the motor leaves going back first further than ``tol``, and where they
    turn; the rules are :func:`prsxy_post.reversals._motor_dips`'.

    Returns
    -------
    keep : (n,) bool, the steps that dip
    s1, s2 : (m,) their turning points [fraction of the step] (s1 = 0 setting off)
    A1, A2 : (m,) the cubic's accelerations there [mm/s²]
    """
    if sets_off:
        s2, _ = velocity_roots(P0, V0, P1, V1, h, sg, True)
        s1 = np.zeros(len(h))
        keep = (np.abs(hermite(P0, V0, P1, V1, h, s2[:, None])[:, 0] - P0) > tol) & (s2 > 0)
        s1, s2 = s1[keep], s2[keep]
    else:
        s1, s2 = turning_points(P0, V0, P1, V1, h)
        keep = np.isfinite(s1)
        s1, s2 = s1[keep], s2[keep]
        p = hermite(P0[keep], V0[keep], P1[keep], V1[keep], h[keep], np.column_stack([s1, s2]))
        deep = np.abs(p[:, 1] - p[:, 0]) > tol
        keep[keep] = deep
        s1, s2 = s1[deep], s2[deep]
    hk = h[keep]
    a, b, _ = velocity_quadratic(P0[keep], V0[keep], P1[keep], V1[keep], hk)
    return keep, s1, s2, (2 * a * s1 + b) / hk, (2 * a * s2 + b) / hk


def motor_turns(
    V: np.ndarray,
    P: np.ndarray,
    rest: np.ndarray,
    side: int,
    ref: float,
    drift: float,
    off: int,
    eps: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, float]:
    """One motor's reversals in a chunk and their kinds; the rules are
    :func:`prsxy_post.reversals._turns`'.

    Parameters
    ----------
    V, P : (off + n,) its wanted velocity [mm/s] and position [mm] at each row (the
        point before the chunk first where ``off`` is 1)
    rest : (off + n,) bool, the path stands at the row
    side : the side it is on before the chunk (+1, −1)
    ref, drift : where it got farthest its last way [mm] and the drift back that
        makes a creeping motor cross [mm] (:func:`.play.creeps`)
    eps : the slowest velocity with a direction [mm/s]

    Returns
    -------
    sg : (off + n,) its direction at each row (creeps back made reversals)
    came : (off + n,) the direction each row comes from
    r : (m,) the rows where it reverses (rows of V, inside the chunk)
    kind : (m,) int8, MID, AT_REST, CREPT or STOOD
    reach : the ``ref`` carried to the next chunk
    """
    n = len(V) - off
    sg = np.where(rest, 0, np.where(V > eps, 1, np.where(V < -eps, -1, 0)))
    crept, reach = creeps(sg, P, side, ref, drift)
    sg = np.where(crept != 0, crept, sg)
    came = np.concatenate([[side], carried(sg, side)[:-1]])[: len(sg)]
    r = np.flatnonzero((sg != 0) & (sg != came))
    r = r[(r - off >= 0) & (r - off < n)]
    new = sg[r]
    b1, b2 = np.maximum(r - 1, 0), np.maximum(r - 2, 0)
    old_way = new * (P[r] - P[b1]) < 0.0
    at_rest = (r == 0) | (rest[b1] & ~old_way)
    crept_f = (crept[r] != 0) & ~at_rest & (sg[b1] != -new)
    stood = (
        ~at_rest
        & ~crept_f
        & (r - off >= 1)
        & (r >= 2)
        & (sg[b1] == 0)
        & (sg[b2] == 0)
        & (np.abs(P[b1] - P[b2]) < 1e-9)
        & ~old_way
    )
    kind = np.where(at_rest, AT_REST, np.where(crept_f, CREPT, np.where(stood, STOOD, MID)))
    return sg, came, r, kind.astype(np.int8), reach


def motor_dips(
    P: np.ndarray,
    V: np.ndarray,
    h: np.ndarray,
    sg: np.ndarray,
    came: np.ndarray,
    off: int,
    tol: float,
    sets_off: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One motor's dips (or, ``sets_off``, its settings-off back) in a chunk: the
    rows j of ``P``, ``V``, ``sg``, ``came`` (off + n,) (:func:`motor_turns`) whose
    step (``h`` (n,) [s], row j − off) the motor ends moving the way it began it
    (or leaves from rest or standing, the way it comes from, with its chord
    against it), and :func:`dip_roots` of those. The rules are
    :func:`prsxy_post.reversals._motor_dips`'.

    Returns
    -------
    j : (m,) the rows that dip
    s1, s2, A1, A2 : (m,) as :func:`dip_roots`
    """
    n = len(h)
    if sets_off:
        j = np.flatnonzero((sg[1:] != 0) & (sg[:-1] == 0)) + 1
        j = j[(j - off >= 0) & (j - off < n) & (came[j] == sg[j])]
        j = j[sg[j] * (P[j] - P[j - 1]) < 0.0]
    else:
        j = np.flatnonzero((sg[1:] == sg[:-1]) & (sg[1:] != 0)) + 1
        j = j[(j - off >= 0) & (j - off < n)]
    keep, s1, s2, A1, A2 = dip_roots(
        P[j - 1], V[j - 1], P[j], V[j], h[j - off], sg[j], tol, sets_off
    )
    return j[keep], s1, s2, A1, A2


class Reversals(NamedTuple):
    """Every motor's reversals, dips and settings-off back in a chunk
    (:func:`motor_reversals`), motor after motor.

    sg, came : (c, N) each motor's direction at each row and the one it comes from
        (:func:`motor_turns`)
    r, kind : (M,) the rows where the motors reverse and the reversals' kinds,
        motor ``i``'s from ``turns[i]`` to ``turns[i + 1]``
    turns : (c + 1,) where each motor's reversals begin in ``r``, ``kind``
    reach : (c,) the ``ref`` each motor carries to the next chunk [mm]
    j, s1, s2, A1, A2 : (D,) the rows that dip or set off back, their turning
        points and accelerations (:func:`motor_dips`): motor ``i``'s dips from
        ``dips[2 i]`` to ``dips[2 i + 1]``, its settings-off back on to
        ``dips[2 i + 2]``
    dips : (2 c + 1,) where they begin
    """

    sg: np.ndarray
    came: np.ndarray
    r: np.ndarray
    kind: np.ndarray
    turns: np.ndarray
    reach: np.ndarray
    j: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    A1: np.ndarray
    A2: np.ndarray
    dips: np.ndarray


def motor_reversals(
    V: np.ndarray,
    P: np.ndarray,
    rest: np.ndarray,
    cols: np.ndarray,
    side: np.ndarray,
    ref: np.ndarray,
    drift: float,
    off: int,
    eps: float,
    h: np.ndarray,
    tol: float,
) -> Reversals:
    """The reversals and their kinds (:func:`motor_turns`), the dips and the
    settings-off back (:func:`motor_dips`) of every motor ``cols`` (c,) in a
    chunk, in one call; the rules are :func:`prsxy_post.reversals.find_reversals`'.

    Parameters
    ----------
    V, P : (R, off + n) the motors' wanted velocities [mm/s] and positions [mm], a
        motor a row (the point before the chunk first where ``off`` is 1)
    rest : (off + n,) bool, the path stands at the row
    side, ref : (R,) the side each motor is on before the chunk and where it got
        farthest its last way [mm]
    drift, eps : as :func:`motor_turns`'
    h : (n,) each step's duration [s]
    tol : the dips' depth left alone [mm]
    """
    sgs, cames, rs, kinds, reach = [], [], [], [], []
    parts: list[tuple[np.ndarray, ...]] = []
    for col in cols.tolist():
        sg, came, r, kind, rc = motor_turns(
            V[col], P[col], rest, int(side[col]), float(ref[col]), drift, off, eps
        )
        sgs.append(sg)
        cames.append(came)
        rs.append(r)
        kinds.append(kind)
        reach.append(rc)
        for sets_off in (False, True):
            parts.append(motor_dips(P[col], V[col], h, sg, came, off, tol, sets_off))
    N = P.shape[1]
    at = np.cumsum([0] + [len(r) for r in rs])
    dip_at = np.cumsum([0] + [len(p[0]) for p in parts])
    none = (np.zeros(0, dtype=np.intp),) + (np.zeros(0),) * 4
    j, s1, s2, A1, A2 = (np.concatenate([none[f]] + [p[f] for p in parts]) for f in range(5))
    return Reversals(
        np.array(sgs, dtype=int).reshape(len(sgs), N),
        np.array(cames, dtype=int).reshape(len(cames), N),
        np.concatenate([np.zeros(0, dtype=np.intp), *rs]),
        np.concatenate([np.zeros(0, dtype=np.int8), *kinds]),
        at,
        np.array(reach, dtype=float),
        j,
        s1,
        s2,
        A1,
        A2,
        dip_at,
    )


def corner_blends(
    V_in: np.ndarray,
    V_out: np.ndarray,
    cols: np.ndarray,
    h: np.ndarray,
    accel: float,
    v_eps: float,
    turn_mm: float,
    blend_min: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The corners blended and their τ; the rules are
    :func:`prsxy_post.reversals.corners`'.

    Parameters
    ----------
    V_in, V_out : (k, 5) the motors' velocities each side of each corner [mm/s]
    cols : (c,) ints, the motors with play
    h : (k,) the standing side's step [s]
    accel : the blend's acceleration [mm/s²]
    v_eps, turn_mm, blend_min : reversals.V_EPS, CORNER_TURN_MM, BLEND_MIN_S

    Returns
    -------
    blend : (k,) bool
    tau : (k,) [s]
    """
    dV = np.abs(V_out - V_in)
    vi, vo = V_in[:, cols], V_out[:, cols]
    # the slower side's velocity, signed along the faster side's way
    fast = np.where(np.abs(vo) >= np.abs(vi), vo, vi)
    slow = np.where(np.abs(vo) >= np.abs(vi), vi, vo) * np.where(fast < 0, -1.0, 1.0)
    moves = (np.abs(fast) >= v_eps) & (slow > -v_eps)
    d = dV[:, cols]
    with np.errstate(divide="ignore", invalid="ignore"):
        left = np.clip(np.where(d > 0, 1.0 - 6.0 * slow / d, 0.0), 0.0, 1.0)
    turn = (4.0 / 27.0) * h[:, None] * d / 2.0 * left**1.5
    tau = np.maximum(blend_min, np.max(dV, axis=1, initial=0.0) / (2.0 * accel))
    blend = np.any(moves & (turn > turn_mm), axis=1) & (tau <= 0.5 * h)
    return blend, tau


def crossing_windows(
    t0: np.ndarray,
    t1: np.ndarray,
    t_root: np.ndarray,
    accel: np.ndarray,
    rb: np.ndarray,
    ra: np.ndarray,
    tol: float,
    longest: float,
    chords: bool,
    min_w: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The windows [a, b] about reversals at ``t_root`` inside steps [t0, t1].

    Each side d of the root is sqrt(2 tol / |A|) (the part standing misses the
    path by |A| d² / 2 there), at most the reach ``rb`` before and ``ra`` after,
    the width at most ``longest`` and at least ``min_w`` (the missing time to the
    side with more reach to spare; with ``chords`` after the root first, then
    before it no longer than after); cut at the step's ends, grown to a servo
    cycle where cut, and over a sliver of the step shorter than half the window
    where the reach allows (or shorter than ``min_w``); a window as wide as its
    step is the step.

    Parameters
    ----------
    t0, t1, t_root : (n,) the steps' starts, ends and the roots [s]
    accel : (n,) the motors' accelerations at the roots [mm/s²]
    rb, ra : (n,) the reach before and after the roots [s] (inf: none)
    tol : the path error allowed [mm]
    longest, min_w : the longest and shortest windows [s]
    chords : straight lines between the points (a window stands no longer before
        its root than after it)

    Returns
    -------
    a, b : (n,) the windows' starts and ends [s]
    """
    with np.errstate(divide="ignore", over="ignore"):
        half = np.where(accel == 0, 0.5 * longest, np.sqrt(2.0 * tol / np.abs(accel)))
    db, da = np.minimum(half, rb), np.minimum(half, ra)
    if chords:
        db = np.minimum(db, da)
    db = np.minimum(db, longest - np.minimum(da, 0.5 * longest))
    da = np.minimum(da, longest - db)
    extra = np.maximum(min_w - (db + da), 0.0)
    spare_b, spare_a = rb - db, ra - da
    with np.errstate(invalid="ignore"):
        even = (spare_b == spare_a) | (np.isinf(spare_b) & np.isinf(spare_a))
    if chords:
        add_a = np.where(even, 0.5 * extra, np.minimum(extra, spare_a))
        rest = extra - add_a
        add_b = np.where(even, 0.5 * extra, np.minimum(rest, da + add_a - db))
        rest = np.where(even, 0.0, rest - add_b)
        db, da = db + add_b + 0.5 * rest, da + add_a + 0.5 * rest
    else:
        more_b = spare_b > spare_a
        add_b = np.where(
            even,
            0.5 * extra,
            np.where(more_b, np.minimum(extra, spare_b), extra - np.minimum(extra, spare_a)),
        )
        db, da = db + add_b, da + (extra - add_b)
    width = db + da
    whole = width >= t1 - t0
    a = np.maximum(t_root - db, t0)
    b = np.minimum(t_root + da, t1)
    short = b - a < min_w
    b = np.where(short & (a <= t0), np.minimum(a + min_w, t1), b)
    a = np.where(short & (a > t0), np.maximum(b - min_w, t0), a)
    grow_b = (t1 - b < 0.5 * width) & ((t1 - t_root <= ra) | (t1 - b < min_w))
    b = np.where(grow_b, t1, b)
    before_ok = t_root - t0 <= rb
    if chords:
        before_ok &= t_root - t0 <= b - t_root
    grow_a = (a - t0 < 0.5 * width) & (before_ok | (a - t0 < min_w))
    a = np.where(grow_a, t0, a)
    return np.where(whole, t0, a), np.where(whole, t1, b)


def chord_windows(
    t0: np.ndarray,
    t1: np.ndarray,
    t_root: np.ndarray,
    accel: np.ndarray,
    rb: np.ndarray,
    ra: np.ndarray,
    tol: float,
    longest: float,
    t_before: np.ndarray,
    t_after: np.ndarray,
    min_w: float,
    snap: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The windows [a, b] about reversals in motion at ``t_root`` inside steps
    [t0, t1] for straight lines between the points (the rules, and why, are
    :func:`prsxy_post.reversals.chord_windows`').

    Each side d of the root is sqrt(2 tol / |A|), at most half the ``longest``
    and the reach ``rb``, ``ra`` on either side, at least half of ``min_w``; a
    window passing its step's end by more than ``snap`` is no longer than its step
    (at least ``min_w``) and reaches over no further than ``t_before``,
    ``t_after``; cut there, it is ``min_w`` long on the other side; a sliver of its
    step beside it shorter than ``min_w`` is taken in (twice: both sides alike
    where the reach allows), then on its side alone.

    Parameters
    ----------
    t0, t1, t_root : (n,) the steps' starts, ends and the roots [s]
    accel : (n,) the motors' accelerations at the roots [mm/s²]
    rb, ra : (n,) the reach before and after the roots [s] (inf: none)
    tol : the path error allowed [mm]
    longest, min_w : the longest and shortest windows [s]
    t_before, t_after : (n,) how far the window may reach before and after its
        step [s]
    snap : how far past its step's end a window still is inside it [s]

    Returns
    -------
    a, b : (n,) the windows' starts and ends [s]
    """
    with np.errstate(divide="ignore", over="ignore"):  # inf: a tiny acceleration
        half = np.where(accel == 0, 0.5 * longest, np.sqrt(2.0 * tol / np.abs(accel)))
    d = np.minimum(np.minimum(half, 0.5 * longest), np.minimum(rb, ra))
    d = np.maximum(d, 0.5 * min_w)
    lim_b, lim_a = np.minimum(t_before, t0), np.maximum(t_after, t1)
    # over into a step beside: no longer than its own step (whose chord the
    # sampler sized to the curve: chain.Pipeline._straight_through), or a servo
    # cycle
    over = (t_root - d < t0 - snap) | (t_root + d > t1 + snap)
    d = np.where(over, np.maximum(np.minimum(d, 0.5 * (t1 - t0)), 0.5 * min_w), d)
    a = np.maximum(t_root - d, lim_b)
    b = np.minimum(t_root + d, lim_a)
    # cut on a side, still a servo cycle: longer on the other
    short = b - a < min_w
    b = np.where(short & (a <= lim_b), np.minimum(a + min_w, lim_a), b)
    a = np.where(short & (a > lim_b), np.maximum(b - min_w, lim_b), a)
    # slivers of its step beside it taken in: both sides alike where there is room
    # (twice: grown over one sliver, the window may leave one on its other side)
    for _ in range(2):
        sl_b = (a > t0) & (a - t0 < min_w)
        sl_a = (b < t1) & (t1 - b < min_w)
        # as far on the other side as the sliver's end is on this one
        grow = np.maximum(np.where(sl_b, t_root - t0, 0.0), np.where(sl_a, t1 - t_root, 0.0))
        even = (sl_b | sl_a) & (t_root - grow >= lim_b) & (t_root + grow <= lim_a)
        a = np.where(even, np.minimum(a, t_root - grow), a)
        b = np.where(even, np.maximum(b, t_root + grow), b)
    a = np.where((a > t0) & (a - t0 < min_w), t0, a)
    b = np.where((b < t1) & (t1 - b < min_w), t1, b)
    return a, b


def in_sorted(x: np.ndarray, pool: np.ndarray) -> np.ndarray:
    """(m,) bool, each of ``x`` (m,) ints is in ``pool`` (sorted ints): np.isin's
    answer by binary search (np.isin builds a table as long as the pool's range,
    every motor's every chunk again)."""
    if not len(pool):
        return np.zeros(len(x), dtype=bool)
    i = np.minimum(np.searchsorted(pool, x), len(pool) - 1)
    found: np.ndarray = pool[i] == x
    return found


def chord_room(
    km: np.ndarray,
    t0: np.ndarray,
    t1: np.ndarray,
    dt: np.ndarray,
    resting: np.ndarray,
    busy: np.ndarray,
    bent: np.ndarray,
    min_w: float,
) -> tuple[np.ndarray, np.ndarray]:
    """How far [s] a window in step ``km`` (m,) [t0, t1] may reach before and after
    its step, for :func:`chord_windows` (the rules, and why, are
    :func:`prsxy_post.reversals.chord_windows`'): into the step beside, less
    ``min_w``, where the path moves through both (``dt`` (n,) > 0, not ``resting``
    (n,) at either end of it), the motor has no window in it (steps ``busy``,
    sorted) and no corner is between (rows ``bent``, sorted); else not at all.

    Returns
    -------
    t_before, t_after : (m,) [s]
    """
    n = len(dt)
    prv, nxt = np.maximum(km - 1, 0), np.minimum(km + 1, n - 1)
    free_prev = (
        (km >= 2)
        & ~resting[prv]
        & ~resting[np.maximum(km - 2, 0)]
        & (dt[prv] > 0)
        & ~in_sorted(km - 1, busy)
        & ~in_sorted(km - 1, bent)
    )
    free_next = (
        (km + 1 < n)
        & ~resting[km]
        & ~resting[nxt]
        & (dt[nxt] > 0)
        & ~in_sorted(km + 1, busy)
        & ~in_sorted(km, bent)
    )
    t_before = t0 - np.where(free_prev, np.clip(dt[prv] - min_w, 0.0, None), 0.0)
    t_after = t1 + np.where(free_next, np.clip(dt[nxt] - min_w, 0.0, None), 0.0)
    return t_before, t_after
