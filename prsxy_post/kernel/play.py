"""The real-axis play model over arrays: one motor's table as a flat record, its
lo/hi envelopes, their inverses and slopes, the clamp scan, and the part followed
along the cubics a controller runs through commands.

This is the numpy reference; ``_play.pyx`` is its compiled twin (the same operations
in the same order, so the two agree to the bit). The contract's model, for forward
errors F(p) and reverse errors R(p) of a motor (linear between table points, end
values held outside) and periodic terms c(p) = Σ a sin(2π p / L + φ):

    lo(p) = p + min(F(p), R(p)) + c(p),   hi(p) = p + max(F(p), R(p)) + c(p)
    y_0 = lo(p_0),   y_k = min(max(y_(k−1), lo(p_k)), hi(p_k))

The sine and cosine of the periodic terms are the C library's (:mod:`.libm`), as the
compiled twin's; ``s**3`` of a turning point's fraction is numpy's power, which the
twin calls too (on this machine it differs from the C library's pow in the last bit).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from . import libm


class PlayTable(NamedTuple):
    """One motor's play model, flattened once (``axiscomp.MotorTable.flat``).

    breaks : (b,) ascending positions [mm] between which lo_err and hi_err are linear
    lo_err, hi_err : (b,) min(F, R) and max(F, R) at the breaks [mm]
    lo_vals, hi_vals : (b,) breaks + lo_err, breaks + hi_err: the inverses' abscissae
        (strictly increasing: the profile rejects slopes <= −0.5)
    s_lo, s_hi : (b − 1,) the slopes of lo_err and hi_err between the breaks
    amp, period, phase : (c,) the periodic terms [mm, mm, rad]
    """

    breaks: np.ndarray
    lo_err: np.ndarray
    hi_err: np.ndarray
    lo_vals: np.ndarray
    hi_vals: np.ndarray
    s_lo: np.ndarray
    s_hi: np.ndarray
    amp: np.ndarray
    period: np.ndarray
    phase: np.ndarray


def play_table(
    breaks: np.ndarray,
    lo_err: np.ndarray,
    hi_err: np.ndarray,
    cyclic: tuple[tuple[float, float, float], ...] = (),
) -> PlayTable:
    """The flat record of a motor's envelopes and its periodic terms (amplitude mm,
    period mm, phase deg)."""
    b = np.ascontiguousarray(breaks, dtype=float)
    lo = np.ascontiguousarray(lo_err, dtype=float)
    hi = np.ascontiguousarray(hi_err, dtype=float)
    db = np.diff(b)
    terms = np.array(cyclic, dtype=float).reshape(-1, 3)
    return PlayTable(
        b,
        lo,
        hi,
        b + lo,
        b + hi,
        np.diff(lo) / db,
        np.diff(hi) / db,
        np.ascontiguousarray(terms[:, 0]),
        np.ascontiguousarray(terms[:, 1]),
        np.array([float(np.radians(ph)) for ph in terms[:, 2].tolist()]),
    )


def cyclic(t: PlayTable, p: np.ndarray) -> np.ndarray | float:
    """c(p) [mm] at positions ``p`` [mm] (0.0 without terms): Σ a sin(2π p / L + φ)."""
    out: np.ndarray | float = 0.0
    for a, per, ph in zip(t.amp.tolist(), t.period.tolist(), t.phase.tolist(), strict=True):
        out = out + a * libm.sin(2 * np.pi * p / per + ph)
    return out


def lo(t: PlayTable, p: np.ndarray) -> np.ndarray:
    """lo(p) [mm]: where the part ends when approached moving + (forward error)."""
    out: np.ndarray = p + np.interp(p, t.breaks, t.lo_err) + cyclic(t, p)
    return out


def hi(t: PlayTable, p: np.ndarray) -> np.ndarray:
    """hi(p) [mm]: where the part ends when approached moving − (reverse error)."""
    out: np.ndarray = p + np.interp(p, t.breaks, t.hi_err) + cyclic(t, p)
    return out


def _invert(
    target: np.ndarray, vals: np.ndarray, breaks: np.ndarray, err: np.ndarray
) -> np.ndarray:
    """p with p + err(p) = target for the piecewise-linear err alone (``vals`` =
    breaks + err, strictly increasing); end values held outside."""
    out = np.interp(target, vals, breaks)
    below = target < vals[0]
    above = target > vals[-1]
    out[below] = target[below] - err[0]
    out[above] = target[above] - err[-1]
    return out


def _solve(t: PlayTable, target: np.ndarray, vals: np.ndarray, err: np.ndarray) -> np.ndarray:
    p = _invert(target, vals, t.breaks, err)
    if len(t.amp):
        # p = inv(T − c(p)): a contraction while |c'| ≪ 1 (µm over mm); the whole
        # array iterates until its largest change is below 1e-13 mm
        for _ in range(30):
            p_new = _invert(target - cyclic(t, p), vals, t.breaks, err)
            if np.max(np.abs(p_new - p), initial=0.0) < 1e-13:
                p = p_new
                break
            p = p_new
    return p


def lo_inv(t: PlayTable, target: np.ndarray) -> np.ndarray:
    """p [mm] with lo(p) = target [mm]."""
    return _solve(t, target, t.lo_vals, t.lo_err)


def hi_inv(t: PlayTable, target: np.ndarray) -> np.ndarray:
    """p [mm] with hi(p) = target [mm]."""
    return _solve(t, target, t.hi_vals, t.hi_err)


def slope(t: PlayTable, p: np.ndarray, side: np.ndarray) -> np.ndarray:
    """d lo/dp (side > 0) or d hi/dp (side ≤ 0) at ``p`` (n,) [mm]: the slope of the
    table's interval holding p (the one above it at a break), zero outside the
    table, plus the periodic terms' a (2π/L) cos(2π p / L + φ)."""
    out = np.ones_like(p)
    nb = len(t.breaks)
    if nb > 1:
        i = np.clip(np.searchsorted(t.breaks, p, side="right") - 1, 0, nb - 2)
        inside = (p >= t.breaks[0]) & (p < t.breaks[-1])
        out = out + np.where(inside, np.where(side > 0, t.s_lo[i], t.s_hi[i]), 0.0)
    for a, per, ph in zip(t.amp.tolist(), t.period.tolist(), t.phase.tolist(), strict=True):
        w = 2 * np.pi / per
        out = out + a * w * libm.cos(w * p + ph)
    return out


def compensate_sided(t: PlayTable, target: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Commands [mm] whose result is ``target`` (n,) [mm] with the part pushed from
    ``side`` (n,) (> 0: lo⁻¹, else hi⁻¹); each side solved as one array."""
    up = side > 0
    out = np.empty_like(target)
    if np.any(up):
        out[up] = lo_inv(t, target[up])
    if not np.all(up):
        out[~up] = hi_inv(t, target[~up])
    return out


def table_commands(
    tables: tuple[PlayTable, ...],
    cols: np.ndarray,
    P_ideal: np.ndarray,
    V_ideal: np.ndarray,
    side: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
) -> None:
    """The commands of the motors ``cols`` (c,) through their tables (``tables``,
    one a motor), a motor a row: P[col] = :func:`compensate_sided` of its wanted
    positions ``P_ideal[col]`` on its sides ``side[col]``, V[col] = its wanted
    velocities ``V_ideal[col]`` over the :func:`slope` there (the tables' dP/dp,
    the commands' rate). ``P``, ``V`` (R, n) [mm, mm/s] are written in place, the
    rows of ``cols`` only."""
    for t, col in zip(tables, cols.tolist(), strict=True):
        P[col] = compensate_sided(t, P_ideal[col], side[col])
        np.divide(V_ideal[col], slope(t, P[col], side[col]), out=V[col])


def clamp_scan(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The play model y_0 = lo_0, y_k = min(max(y_(k−1), lo_k), hi_k) for (n,)
    envelopes.

    Clamps compose into clamps: clamp(clamp(y, a1, b1), a2, b2) =
    clamp(y, clamp(a1, a2, b2), clamp(b1, a2, b2)), so the model is an associative
    scan, done here in log2(n) vectorised doubling steps (every value is one of
    the inputs: the sequential loop of the compiled twin gives the same bits).
    """
    a = lo.copy()
    b = hi.copy()
    n = len(a)
    off = 1
    while off < n:
        lo_k, hi_k = a[off:], b[off:]
        a_new = np.minimum(np.maximum(a[:-off], lo_k), hi_k)
        b_new = np.minimum(np.maximum(b[:-off], lo_k), hi_k)
        a[off:] = a_new
        b[off:] = b_new
        off *= 2
    return a


def velocity_quadratic(
    P0: np.ndarray, V0: np.ndarray, P1: np.ndarray, V1: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(a, b, c) of the Hermite cubic's velocity a s² + b s + c in s = t / h:
    c = V0, a = 6 (P0 − P1)/h + 3 (V0 + V1), b = −6 (P0 − P1)/h − 4 V0 − 2 V1.
    """
    d = (P0 - P1) / h
    return 6.0 * d + 3.0 * (V0 + V1), -6.0 * d - 4.0 * V0 - 2.0 * V1, V0


def hermite(
    P0: np.ndarray, V0: np.ndarray, P1: np.ndarray, V1: np.ndarray, h: np.ndarray, s: np.ndarray
) -> np.ndarray:
    """The cubic through (P0, V0) and (P1, V1) over time h (n,) at fractions s (n, k)
    of each step: (n, k) positions."""
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    out: np.ndarray = (
        h00 * P0[:, None] + h10 * (h * V0)[:, None] + h01 * P1[:, None] + h11 * (h * V1)[:, None]
    )
    return out


def follow_stretches(
    t: PlayTable,
    y0: np.ndarray,
    P0: np.ndarray,
    V0: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    dt: np.ndarray,
    steps: np.ndarray,
    cubic: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a motor's driven part is along the cubics (``cubic``) or straight lines
    a controller runs through commands, over stretches of steps, each from where its
    part stands at its start (the play model's scan starts again at each).

    The play model is rate-independent: its result after a monotone stretch of
    commands depends only on where the stretch ends. So the command's cubic in each
    step is taken at its turning points (the roots of its velocity, a quadratic)
    and its end, and the result is exact, with one to three samples a step.

    Parameters
    ----------
    t : the motor's table
    y0, P0, V0 : (w,) where each stretch's part stands at its start, and the
        command's position and velocity there [mm, mm, mm/s]
    P, V, dt : (k,) the commands and durations of the stretches' steps, stretch
        after stretch [mm, mm/s, s]
    steps : (w,) how many steps each stretch has (summing to k)

    Returns
    -------
    y_end : (k,) the part at each point
    y_min, y_max : (k,) the least and greatest position of the part within each
        step (its end included)
    """
    n = len(P)
    first = (np.cumsum(steps) - steps)[steps > 0]
    opening = np.zeros(n, dtype=np.int64)
    opening[first] = 1
    Pa = np.concatenate([[0.0], P[:-1]])
    Va = np.concatenate([[0.0], V[:-1]])
    Pa[first], Va[first] = P0[steps > 0], V0[steps > 0]
    h = dt
    # a step of no time (a standing point's twin) has no cubic: h = ∞ makes it flat
    a, b, c = velocity_quadratic(Pa, Va, P, V, np.where(h > 0, h, np.inf))
    disc = b * b - 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        r1 = np.where(np.abs(a) > 1e-300, (-b - sq) / (2 * a), np.where(b != 0, -c / b, -1.0))
        r2 = np.where(np.abs(a) > 1e-300, (-b + sq) / (2 * a), -1.0)
    ok1 = (disc >= 0) & (r1 > 0) & (r1 < 1) & (h > 0) & cubic
    ok2 = (disc >= 0) & (r2 > 0) & (r2 < 1) & (h > 0) & (np.abs(r2 - r1) > 0) & cubic
    # samples of each step in time order: its turning points, then its end. Most
    # steps have none, so the cubic is evaluated only where it turns (the end of a
    # step is its point, P). Each stretch opens with one more: where its part
    # stands (lo = hi = y0: the scan is clamped to it, whatever came before).
    count = 1 + opening + ok1 + ok2
    last_of = np.cumsum(count) - 1
    flat = np.empty(int(last_of[-1]) + 1 if n else 0)
    flat[last_of] = P
    turns = np.flatnonzero(ok1 | ok2)
    if turns.size:
        a1, a2 = ok1[turns], ok2[turns]
        q1, q2 = r1[turns], r2[turns]
        early = np.where(a1 & a2, np.minimum(q1, q2), np.where(a1, q1, q2))
        late = np.where(a1 & a2, np.maximum(q1, q2), np.nan)
        cmd = hermite(
            Pa[turns], Va[turns], P[turns], V[turns], h[turns], np.column_stack([early, late])
        )
        at = (last_of - count + 1 + opening)[turns]
        flat[at] = cmd[:, 0]
        two = a1 & a2
        flat[at[two] + 1] = cmd[two, 1]
    y_lo = lo(t, flat)
    y_hi = hi(t, flat)
    opens = (last_of - count + 1)[first]
    y_lo[opens] = y_hi[opens] = y0[steps > 0]
    y = clamp_scan(y_lo, y_hi)
    # each step's samples, a stretch's opening one counted as its first step's
    # next (so that it is no extreme of that step)
    bounds = last_of - count + 1
    inside = y.copy()
    inside[opens] = y[opens + 1]
    if not n:
        return y, y.copy(), y.copy()
    return y[last_of], np.minimum.reduceat(inside, bounds), np.maximum.reduceat(inside, bounds)


def ranges(first: np.ndarray, length: np.ndarray) -> np.ndarray:
    """The indices first[i], first[i] + 1, … (length[i] of them) of every range, one
    after another: one array for all the ranges, without a loop."""
    return np.repeat(first - np.cumsum(length) + length, length) + np.arange(int(length.sum()))


def catch_up(
    off0: np.ndarray,
    way: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    s_path: np.ndarray,
    share: float,
    hurry: float,
    motion: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """How far each part is from its wanted position after its crossings, while it
    is brought back along the path (``reversals.catch_up`` tells the model):

        off_j = sign(off0) · max(0, |off0| − rate · (s_j − s_start)),

    rate = ``share``, or up to ``hurry`` times it where that has the offset gone
    by the point before the next crossing; a part ahead of its motor's way (with
    ``motion``) taken up over no step by more than half the motor's own move.

    Parameters
    ----------
    off0 : (m,) the part's offset at each crossing's end [mm]
    way : (m,) the side each motor is on after its crossing (+1 up, −1 down)
    start : (m,) int, the point where each crossing ends (−1: the point before the chunk)
    stop : (m,) int, the point where the motor's next crossing begins, or n
    s_path : (n,) path length run by each point since the point before the chunk [mm]
    share, hurry : the offset's rate, a share of the path speed, and how many
        times that it may go to be gone by the next crossing
    motion : (dP, V, speed), each (n,): the motor's wanted move into each point
        [mm], its wanted velocity there [mm/s], the path's speed [mm/s]

    Returns
    -------
    idx : (k,) the points start < j ≤ stop (j < n) with an offset left, by crossing
    off : (k,) their offsets [mm]
    slope : (k,) d off / d s there
    left : (m,) the offset left at ``stop`` (or at the chunk's last point) [mm]
    """
    n = len(s_path)
    ahead_way = (off0 * way > 0) & (motion is not None)
    off0 = np.where((off0 * way < 0) | ahead_way, off0, 0.0)
    if n == 0:
        none = np.zeros(0)
        return none.astype(int), none, none, off0
    first = start + 1
    s0 = np.where(start >= 0, s_path[np.maximum(start, 0)], 0.0)
    # the last point whose command carries the offset: the next crossing's start,
    # or the chunk's last point
    last = np.where(stop < n, stop, n - 1)
    rate = _catch_up_rates(off0, start, stop, last, s0, s_path, share, hurry)
    # the points up to where the offset is gone; a part ahead: where it is gone
    # depends on the motor's moves too (below)
    gone = np.searchsorted(s_path, s0 + np.abs(off0) / rate, "left")
    end = np.where(ahead_way, last + 1, np.minimum(last + 1, gone))
    length = np.maximum(end - first, 0)
    idx = ranges(first, length)
    run = s_path[idx] - np.repeat(s0, length)
    mag = np.maximum(np.repeat(np.abs(off0), length) - np.repeat(rate, length) * run, 0.0)
    steep_motor = np.full(len(idx), np.inf)
    if motion is not None and np.any(ahead_way):
        mag, steep_motor = _taken_up_ahead(
            off0, way, ahead_way, rate, idx, length, mag, s_path, motion
        )
    off = np.copysign(mag, np.repeat(off0, length))
    left = _left_at_last(off0, start, last, s0, rate, s_path, ahead_way, length, mag)
    keep = mag > 0
    slope = _catch_up_slopes(idx, off, mag, np.repeat(rate, length), steep_motor, s_path)
    return idx[keep], off[keep], slope[keep], left


def _catch_up_rates(
    off0: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    last: np.ndarray,
    s0: np.ndarray,
    s_path: np.ndarray,
    share: float,
    hurry: float,
) -> np.ndarray:
    """The rate (m,) [mm of offset per mm of path] at which each offset ``off0``
    (m,) [mm] is taken up after the crossing ending at ``start`` (path length
    ``s0`` there [mm]): ``share``, or up to ``hurry`` times it where that has
    it gone by the point ``last`` before the next crossing (``stop`` < n)."""
    n = len(s_path)
    # a little faster where that has it gone by the next crossing
    room = np.where((stop < n) & (last > start), s_path[last] - s0, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        need = np.where(room > 0, np.abs(off0) / room, np.inf)
    return np.where(need <= hurry * share, np.maximum(need, share), share)


def _taken_up_ahead(
    off0: np.ndarray,
    way: np.ndarray,
    ahead_way: np.ndarray,
    rate: np.ndarray,
    idx: np.ndarray,
    length: np.ndarray,
    mag: np.ndarray,
    s_path: np.ndarray,
    motion: tuple[np.ndarray, np.ndarray, np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """The offsets' magnitudes (k,) [mm] at the points ``idx`` (k,) of the
    crossings (``length`` (m,) points each), those of parts ahead of their motor's
    way (``ahead_way`` (m,)) taken up at ``rate`` (m,) but over no step by more
    than half the motor's own move its way; and for those points the steepest
    d off / d s that keeps (half the motor's velocity its way over the path
    speed), inf elsewhere. ``motion`` as :func:`catch_up`'s."""
    dP, V, speed = motion
    which = np.repeat(np.arange(len(off0)), length)
    mine = ahead_way[which]
    # the step into each point takes the share of its path, or half the
    # motor's move its way, whichever is less
    ds = s_path[idx] - np.where(idx >= 1, s_path[np.maximum(idx - 1, 0)], 0.0)
    w = way[which]
    take = np.where(mine, np.minimum(rate[which] * ds, np.maximum(0.5 * w * dP[idx], 0.0)), 0.0)
    # the cumulative take within each range: less what the ranges before took
    cum = np.concatenate([[0.0], np.cumsum(take)])
    before = np.repeat(cum[np.cumsum(length) - length], length)
    mag = np.where(mine, np.maximum(np.abs(off0)[which] - (cum[1:] - before), 0.0), mag)
    with np.errstate(divide="ignore", invalid="ignore"):
        steep_motor = np.where(
            mine & (speed[idx] > 0),
            np.maximum(0.5 * w * V[idx], 0.0) / speed[idx],
            np.inf,
        )
    return mag, steep_motor


def _left_at_last(
    off0: np.ndarray,
    start: np.ndarray,
    last: np.ndarray,
    s0: np.ndarray,
    rate: np.ndarray,
    s_path: np.ndarray,
    ahead_way: np.ndarray,
    length: np.ndarray,
    mag: np.ndarray,
) -> np.ndarray:
    """The offset (m,) [mm] each crossing leaves at its ``last`` point: of
    ``off0`` (m,), taken up at ``rate`` (m,) from the path length ``s0`` (m,) at
    its ``start``; for a part ahead of its motor's way, the magnitude its range's
    last point keeps (``mag``, ``length`` points a crossing)."""
    # left at the last point: a part behind by the closed form (all of it where
    # there is no point to take it), a part ahead what its range's last point keeps
    s_last = np.where(last > start, s_path[np.maximum(last, 0)], s0)
    left_mag = np.maximum(np.abs(off0) - rate * (s_last - s0), 0.0)
    if np.any(ahead_way):
        last_of = np.maximum(np.cumsum(length) - 1, 0)
        kept = mag[last_of] if len(mag) else np.zeros(len(off0))
        left_mag = np.where(ahead_way, np.where(length > 0, kept, np.abs(off0)), left_mag)
    return np.copysign(left_mag, off0)


def _catch_up_slopes(
    idx: np.ndarray,
    off: np.ndarray,
    mag: np.ndarray,
    rate: np.ndarray,
    steep_motor: np.ndarray,
    s_path: np.ndarray,
) -> np.ndarray:
    """d off / d s (k,) at the points ``idx`` (k,) with offsets ``off`` (k,) [mm]
    (magnitudes ``mag``), taken up at ``rate`` (k,) [mm/mm] and no steeper than
    ``steep_motor`` (k,)."""
    n = len(s_path)
    # its slope at each point: over the step after it (a last bit of offset gone
    # early in that step gives the point a velocity to match, not the whole rate),
    # and for a part ahead no more than half its motor's velocity its way
    nxt = np.minimum(idx + 1, n - 1)
    ahead = np.where(idx + 1 < n, s_path[nxt] - s_path[idx], np.inf)
    with np.errstate(divide="ignore", invalid="ignore"):
        steep = np.minimum(rate, np.where(ahead > 0, mag / ahead, np.inf))
    steep = np.minimum(steep, steep_motor)
    out: np.ndarray = -np.sign(off) * steep
    return out


class Motion(NamedTuple):
    """One motor's columns over a chunk of n points, as the settle takes them.

    P_ideal, V_ideal : (n,) its wanted position [mm] and velocity [mm/s]
    dP : (n,) its wanted move into each point [mm] (the first from the point before)
    speed : (n,) the path's planned speed [mm/s]
    dt : (n,) each step's duration [s]
    s_path : (n,) path length run by each point since the point before the chunk [mm]
    side : (n,) the side of its play it is on at each point (+1 up, −1 down)
    """

    P_ideal: np.ndarray
    V_ideal: np.ndarray
    dP: np.ndarray
    speed: np.ndarray
    dt: np.ndarray
    s_path: np.ndarray
    side: np.ndarray


def catch_up_commands(
    t: PlayTable,
    mo: Motion,
    off0: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    share: float,
    hurry: float,
) -> tuple[np.ndarray, float]:
    """Command the motor to bring its part back onto its wanted position after
    crossings that end at ``start`` (m,) with the part off by ``off0`` (m,) [mm]
    (:func:`catch_up`, up to ``stop`` (m,)): ``P``, ``V`` (n,) [mm, mm/s] updated in
    place. Returns the offset (m,) each leaves where the next crossing begins (0
    where it goes on into the next chunk) and the offset the last leaves at the
    chunk's end (NaN: none to carry)."""
    n = len(mo.s_path)
    way = mo.side[np.maximum(start, 0)]
    idx, off, slope_, left = catch_up(
        off0, way, start, stop, mo.s_path, share, hurry, (mo.dP, mo.V_ideal, mo.speed)
    )
    carry = float(left[-1]) if len(left) and stop[-1] >= n and left[-1] != 0.0 else np.nan
    if len(idx):
        sd = mo.side[idx]
        P[idx] = compensate_sided(t, mo.P_ideal[idx] + off, sd)
        V[idx] = (mo.V_ideal[idx] + slope_ * mo.speed[idx]) / slope(t, P[idx], sd)
    return np.where(stop < n, left, 0.0), carry


def _extreme(
    lo: np.ndarray, hi: np.ndarray, cuts: np.ndarray, beg: np.ndarray, up: np.ndarray
) -> np.ndarray:
    """Where each part stands when its motor's crossing ends [mm], (c,): the extreme
    it reached on the old side over the crossing's steps (``cuts`` (2c,): each
    crossing's first and past-last step into the followed part's least and
    greatest positions ``lo``, ``hi``) and where it stood at the crossing's start
    ``beg`` (c,); the least where the crossing is ``up``."""
    lo_x = np.minimum.reduceat(np.append(lo, np.inf), cuts)[::2]
    hi_x = np.maximum.reduceat(np.append(hi, -np.inf), cuts)[::2]
    out: np.ndarray = np.where(up, np.minimum(lo_x, beg), np.maximum(hi_x, beg))
    return out


def _contact(t: PlayTable, y: np.ndarray, up: np.ndarray, short: np.ndarray) -> np.ndarray:
    """The command [mm] that meets the part at ``y`` (c,) [mm] on its new side (lo⁻¹
    where ``up``, else hi⁻¹), ``short`` (c,) [mm] of it."""
    out: np.ndarray = np.where(up, lo_inv(t, y) - short, hi_inv(t, y) + short)
    return out


class Settled(NamedTuple):
    """What :func:`settle_crossings` leaves: the commands (n,) [mm, mm/s], where the
    part stands at the last contact and the command's position and velocity there
    [mm, mm, mm/s], and the offset carried into the next chunk (NaN: none)."""

    P: np.ndarray
    V: np.ndarray
    y: float
    P_last: float
    V_last: float
    carry: float


def settle_crossings(
    t: PlayTable,
    mo: Motion,
    before: tuple[float, float, float],
    e: np.ndarray,
    b: np.ndarray,
    short: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    cubic: bool,
    share: float,
    hurry: float,
) -> Settled:
    """End each of a motor's crossings (ending at points ``e`` (c,), begun at ``b``
    (c,), −1: before the chunk) where its part really stands, followed from
    ``before`` (the part [mm], the command [mm, mm/s] before the chunk) through the
    commands ``P``, ``V`` (n,) as made, ``short`` (c,) [mm] of the contact; take up
    the part's offset after each (:func:`catch_up_commands`); a crossing taking in
    an offset the one before left is reckoned again from where the part then is
    (:func:`_reckon_again`), a round per crossing of a chain. (The method:
    ``chain.Pipeline._settle``.)"""
    P, V = P.copy(), V.copy()
    n = len(P)
    y0, P0, V0 = before
    carry = np.nan
    # followed up to the last contact only (the part's path is causal)
    upto = int(e.max()) + 1
    one = np.ones(1)
    y_pt, lo_, hi_ = follow_stretches(
        t, y0 * one, P0 * one, V0 * one, P[:upto], V[:upto], mo.dt[:upto], np.array([upto]), cubic
    )
    # where the part stands when the crossing begins: the extreme it reached on
    # the old side, over the window (its start included)
    at_beg = np.where(b >= 0, y_pt[np.maximum(b, 0)], y0)
    first = np.maximum(b + 1, 0)
    cuts = np.column_stack([first, e + 1]).ravel()
    u = mo.side[e] > 0  # the new side: up, so it was going down
    y_s = _extreme(lo_, hi_, cuts, at_beg, u)
    stops = np.append(b[1:], n)
    made_e = P[e].copy()
    P[e] = _contact(t, y_s, u, short)
    P_made, V_made = P.copy(), V.copy()
    left, c = catch_up_commands(t, mo, y_s - mo.P_ideal[e], e, stops, P, V, share, hurry)
    carry = c if not np.isnan(c) else carry
    # a part still off where the next crossing begins takes that offset into it
    todo = np.flatnonzero(np.concatenate([[0.0], left[:-1]]))
    while todo.size:
        todo, c = _reckon_again(
            t,
            mo,
            (e, b, u, short, stops, made_e, P_made, V_made),
            todo,
            y_s,
            left,
            P,
            V,
            cubic,
            (share, hurry),
        )
        carry = c if not np.isnan(c) else carry
    k = int(np.argmax(e))
    return Settled(P, V, float(y_s[k]), float(P[upto - 1]), float(V[upto - 1]), carry)


def _reckon_again(
    t: PlayTable,
    mo: Motion,
    x: tuple[np.ndarray, ...],
    todo: np.ndarray,
    y_s: np.ndarray,
    left: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    cubic: bool,
    rates: tuple[float, float],
) -> tuple[np.ndarray, float]:
    """One round of :func:`settle_crossings`: the crossings ``todo``, each taking in
    an offset the crossing before left, ended where the part then stands (followed
    from the crossing before through the commands as now written, its end as
    made) and their take-up made again. Updates ``y_s``, ``left`` (c,) and the
    commands in place; returns the crossings the next round reckons again (after
    one whose offset left changed) and the offset carried into the next chunk."""
    n = len(P)
    e, b, u, short, stops, made_end, P_made, V_made = x
    ep, ej, bj = e[todo - 1], e[todo], b[todo]
    span = ej - ep
    pts = ranges(ep + 1, span)
    P_w = P[pts]
    P_w[np.cumsum(span) - 1] = made_end[todo]  # the crossings' ends as made
    y_w, lo_w, hi_w = follow_stretches(
        t, y_s[todo - 1], P[ep], V[ep], P_w, V[pts], mo.dt[pts], span, cubic
    )
    base = np.cumsum(span) - span
    into = np.maximum(bj - ep, 0)  # the window's first step in its stretch
    beg = np.where(into > 0, y_w[base + into - 1], y_s[todo - 1])
    cuts = np.column_stack([base + into, base + span]).ravel()
    y_s[todo] = _extreme(lo_w, hi_w, cuts, beg, u[todo])
    P[ej] = _contact(t, y_s[todo], u[todo], short[todo])
    # their own take-up again, from the commands as made
    redo = ranges(ej + 1, np.minimum(stops[todo] + 1, n) - ej - 1)
    P[redo], V[redo] = P_made[redo], V_made[redo]
    new_left, carry = catch_up_commands(
        t, mo, y_s[todo] - mo.P_ideal[ej], ej, stops[todo], P, V, *rates
    )
    moved = todo[new_left != left[todo]]
    left[todo] = new_left
    return moved[moved + 1 < len(e)] + 1, carry


class Chunk(NamedTuple):
    """A chunk of n points as :func:`settle_motors` takes it, the motors' columns
    as rows (R motors, R × n, C order).

    P_ideal, V_ideal : (R, n) the motors' wanted positions [mm] and velocities [mm/s]
    side : (R, n) the side of its play each motor is on (+1 up, −1 down)
    speed, dt : (n,) the path's planned speed [mm/s], each step's duration [s]
    s_path : (n,) path length run by each point since the point before the chunk [mm]
    t : (n,) the time of each point since the point before the chunk [s]
    P_before : (R,) the wanted positions at the point before the chunk [mm] (the
        chunk's first where there is none)
    """

    P_ideal: np.ndarray
    V_ideal: np.ndarray
    side: np.ndarray
    speed: np.ndarray
    dt: np.ndarray
    s_path: np.ndarray
    t: np.ndarray
    P_before: np.ndarray


class Contacts(NamedTuple):
    """Every motor's crossings in a chunk, each a row: the point where it ends
    ``e`` and where it began ``b`` (−1: before the chunk), the motor ``col``, and
    how far short of the contact it ends ``short`` [mm]; (M,) each, by their ends
    (a motor's own in their order)."""

    e: np.ndarray
    b: np.ndarray
    col: np.ndarray
    short: np.ndarray


def settle_motors(
    tables: tuple[PlayTable, ...],
    cols: np.ndarray,
    ch: Chunk,
    before: np.ndarray,
    carried_off: np.ndarray,
    x: Contacts,
    P: np.ndarray,
    V: np.ndarray,
    cubic: bool,
    share: float,
    hurry: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Every motor with play through a chunk in one call (``chain.Pipeline._settle``
    tells the method): for motor ``cols[i]`` (table ``tables[i]``), an offset
    ``carried_off[i]`` [mm] left by the chunk before taken up first (0.0: none,
    :func:`catch_up_commands`), its crossings ended where the part stands
    (:func:`settle_crossings`; with straight lines, the points inside each window
    on the window's chord before and after, :func:`across`), and its part followed
    from the last contact to the chunk's end (:func:`follow_stretches`).

    ``before`` (c, 3): each motor's part [mm] and the command [mm, mm/s] at the
    point before the chunk. The commands ``P``, ``V`` (R, n) [mm, mm/s] are
    updated in place. Returns where each part stands at the chunk's end [mm] and
    the offset each carries into the next chunk (c,) [mm] (NaN: none).
    """
    y_end = np.empty(len(cols))
    carry = np.full(len(cols), np.nan)
    for i, col in enumerate(cols.tolist()):
        y_end[i], carry[i] = _settle_motor(
            tables[i], col, ch, before[i], float(carried_off[i]), x, P, V, cubic, (share, hurry)
        )
    return y_end, carry


def chunk_motion(ch: Chunk, col: int) -> Motion:
    """Motor ``col``'s columns of a chunk as the settle takes them (its wanted move
    into the first point from the point before the chunk)."""
    P_ideal = ch.P_ideal[col]
    n = len(P_ideal)
    # np.diff with P_before prepended, without the joined copy
    dP = np.empty(n)
    if n:
        dP[0] = P_ideal[0] - ch.P_before[col]
        np.subtract(P_ideal[1:], P_ideal[:-1], out=dP[1:])
    return Motion(
        *(
            np.ascontiguousarray(a, dtype=float)
            for a in (P_ideal, ch.V_ideal[col], dP, ch.speed, ch.dt, ch.s_path, ch.side[col])
        )
    )


def _settle_motor(
    t: PlayTable,
    col: int,
    ch: Chunk,
    before: np.ndarray,
    carried_off: float,
    x: Contacts,
    P: np.ndarray,
    V: np.ndarray,
    cubic: bool,
    rates: tuple[float, float],
) -> tuple[float, float]:
    """:func:`settle_motors` for motor ``col``: where its part stands at the
    chunk's end, and the offset it carries into the next chunk (NaN: none)."""
    n = len(ch.dt)
    mo = chunk_motion(ch, col)
    mine = x.col == col
    e, b, short = x.e[mine], x.b[mine], x.short[mine]
    carry = math.nan
    if carried_off:
        # what it leaves where the first crossing begins, the follow below sees
        stop = int(b[0]) if len(e) else n
        _, carry = catch_up_commands(
            t, mo, np.array([carried_off]), np.array([-1]), np.array([stop]), P[col], V[col], *rates
        )
    y0, P0, V0 = (float(v) for v in before)
    start = 0
    if len(e):
        rows = None if cubic else across_rows(ch.t, e, b)
        across(rows, P0, P[col], V[col])
        r = settle_crossings(t, mo, (y0, P0, V0), e, b, short, P[col], V[col], cubic, *rates)
        P[col], V[col] = r.P, r.V
        carry = r.carry if not math.isnan(r.carry) else carry
        across(rows, P0, P[col], V[col])
        y0, P0, V0 = r.y, r.P_last, r.V_last
        # from the last contact on, the corrected commands carry the part
        start = int(e.max()) + 1
    if start < n:
        one = np.ones(1)
        y_pt, _, _ = follow_stretches(
            t,
            y0 * one,
            P0 * one,
            V0 * one,
            P[col, start:],
            V[col, start:],
            ch.dt[start:],
            np.array([n - start]),
            cubic,
        )
        y0 = float(y_pt[-1])
    return y0, carry


def across_rows(t: np.ndarray, e: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, ...] | None:
    """The points inside a motor's crossing windows that begin at ``b`` and end at
    ``e`` (c,) for :func:`across`, with what it reckons from the times ``t`` (n,)
    [s] since the point before the chunk: the points, each window's first point
    (clipped to 0) and whether it is in the chunk, its last point, and the time
    from the first to the last and to each point. None where there are none."""
    inner = e - b - 1
    if not np.any(inner > 0):
        return None
    w = np.flatnonzero(inner > 0)
    idx = ranges(b[w] + 1, inner[w])
    bb, ee = np.repeat(b[w], inner[w]), np.repeat(e[w], inner[w])
    inside, b0 = bb >= 0, np.maximum(bb, 0)
    t_b = np.where(inside, t[b0], 0.0)
    return idx, b0, inside, ee, t[ee] - t_b, t[idx] - t_b


def across(rows: tuple[np.ndarray, ...] | None, P0: float, P: np.ndarray, V: np.ndarray) -> None:
    """Straight lines between the points (corrected G-code): the points inside a
    motor's crossing windows (``rows``: :func:`across_rows`; a step's end where the
    window reaches past it, another motor's window edge) on the straight way from
    the window's first command to its last, by time (``P0``: the command before the
    chunk). Commanded on the old side, the motor pushed its part on up to the point
    inside, and the window was one on one side of the root. The motor's commands
    ``P``, ``V`` (n,) [mm, mm/s] are updated in place."""
    if rows is None:
        return
    idx, b0, inside, ee, span, since = rows
    P_b = np.where(inside, P[b0], P0)
    rate = (P[ee] - P_b) / span
    P[idx] = P_b + rate * since
    V[idx] = rate


def carried(sg: np.ndarray, side: np.ndarray | float) -> np.ndarray:
    """The last nonzero direction at or before each row of ``sg`` (along axis 0),
    ``side`` before any: the side a motor is on, carried through the rows where it
    has no direction. ``sg`` (m,) or (m, k); ``side`` a scalar or (k,)."""
    n = len(sg)
    rows = np.arange(n).reshape((n,) + (1,) * (sg.ndim - 1))
    last = np.maximum.accumulate(np.where(sg != 0, rows, -1), axis=0)
    out: np.ndarray = np.where(last >= 0, np.take_along_axis(sg, np.maximum(last, 0), 0), side)
    return out


def creeps(
    sg: np.ndarray, P: np.ndarray, side: int, ref: float, drift: float
) -> tuple[np.ndarray, float]:
    """Rows where a creeping motor (no direction in ``sg`` (n,)) has drifted back
    by more than ``drift`` [mm] from the farthest it went its last way (positions
    ``P`` (n,) [mm]; ``side`` and ``ref`` [mm] its way and reach before the chunk):
    each becomes a reversal (the new sign), and the drift is measured afresh from
    there. Also where the motor got farthest its last way by the last row (NaN
    while it has had no direction).

    The farthest, not where it last had a direction: a motor stopping at a block
    end goes on its way through the rows that stand (speed 0) or creep forward, and
    pushes its part there; measured from the last row with a direction, a motor
    then creeping back (a table axis following the other's squareness while it
    moves alone) was seen to stay 17 µm "ahead" of it and left its part 0.61 µm
    behind (test_controller_truth's found programs).
    """
    out = np.zeros(len(sg), dtype=int)
    start = 0
    cur_side, cur_ref = side, ref
    while start < len(sg):
        seg, p = sg[start:], P[start:]
        came, far = _farthest(seg, p, cur_side, cur_ref)
        hits = np.flatnonzero((seg == 0) & (came * p - far < -drift))
        if not hits.size:
            # the rows from here on keep their signs: the last one's reach holds
            return out, float(came[-1] * far[-1]) if np.isfinite(far[-1]) else math.nan
        r = start + int(hits[0])
        out[r] = -int(came[hits[0]])
        cur_side, cur_ref = out[r], float(P[r])
        start = r + 1
    return out, cur_ref  # no rows, or the last row a reversal: it reaches there


def _farthest(
    sg: np.ndarray, P: np.ndarray, side: int, ref: float
) -> tuple[np.ndarray, np.ndarray]:
    """The direction each row comes from (the last row's with one, else ``side``)
    and how far that way the motor has got by then, as ``direction · position``
    (−inf before any row with a direction when ``ref`` is NaN: nothing to measure
    from). A running maximum that starts afresh at each row with a direction, made
    in one pass by lifting each stretch above the one before (rounding: below a
    picometre)."""
    n = len(sg)
    idx = np.where(sg != 0, np.arange(n), -1)
    last = np.maximum.accumulate(idx)
    came = np.where(last >= 0, sg[np.maximum(last, 0)], side)
    v = came * P
    if n == 0:
        return came, v
    stretch = np.cumsum(np.concatenate([[0], np.diff(last) != 0]))
    lift = stretch * (float(np.max(v) - np.min(v)) + 1.0)
    far = np.maximum.accumulate(v + lift) - lift
    first = last < 0  # before any row with a direction: from where it came in
    if np.any(first):
        far[first] = -np.inf if np.isnan(ref) else np.maximum(far[first], side * ref)
    return came, far


def motor_sides(
    V: np.ndarray,
    resting: np.ndarray,
    f: np.ndarray,
    e: np.ndarray,
    new: np.ndarray,
    last_row: np.ndarray,
    s_first: np.ndarray,
    s_new: np.ndarray,
    side: int,
    eps: float,
) -> np.ndarray:
    """The side (+1, −1) a motor is on at each of a chunk's m points
    (``reversals.sides`` tells the rules): the direction of its planned velocity
    ``V`` (m,) [mm/s] (none while the path is ``resting`` or slower than ``eps``),
    its w crossing windows (sorted by their ends ``e`` (w,), begun at the steps'
    first plain points ``f``, to the side ``new``; ``last_row`` the last point of
    each end's step) and its crossings at standing points (``s_first``, ``s_new``),
    carried through the points without a direction from ``side``."""
    sg = np.where(resting, 0, np.where(V > eps, 1, np.where(V < -eps, -1, 0)))
    # the points after a window's end inside its step are on the new side
    after = np.maximum(last_row - e - 1, 0)
    sg[ranges(e + 1, after)] = np.repeat(new, after)
    # two crossings in one step (a dip): the second's old side starts after the
    # first's end
    f = np.maximum(f, np.concatenate([[0], e[:-1] + 1]))
    length = np.maximum(e - f, 0)
    sg[ranges(f, length)] = np.repeat(-new, length)
    sg[e] = new
    sg[s_first] = s_new
    return carried(sg, side)


def motors_sides(
    V: np.ndarray,
    resting: np.ndarray,
    cols: np.ndarray,
    side: np.ndarray,
    f: np.ndarray,
    e: np.ndarray,
    new: np.ndarray,
    last_row: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    s_first: np.ndarray,
    s_new: np.ndarray,
    s_col: np.ndarray,
    eps: float,
    out: np.ndarray,
) -> None:
    """:func:`motor_sides` of every motor ``cols`` (c,) in one call, into the rows
    ``cols`` of ``out`` (R, m) in place: motor ``cols[i]``'s velocities ``V[col]``
    (V (R, m) [mm/s]), its windows ``f``, ``e``, ``new``, ``last_row`` from
    ``lo[i]`` to ``hi[i]`` (each motor's sorted by their ends), its standing
    crossings those of ``s_first``, ``s_new`` whose ``s_col`` is it, its side
    before the chunk ``side[col]`` (side (R,))."""
    for i, col in enumerate(cols.tolist()):
        a, b = int(lo[i]), int(hi[i])
        here = s_col == col
        out[col] = motor_sides(
            V[col],
            resting,
            f[a:b],
            e[a:b],
            new[a:b],
            last_row[a:b],
            s_first[here],
            s_new[here],
            int(side[col]),
            eps,
        )
