"""The speed along blocks over arrays: the numpy reference kernel of the time law.

Each block runs through at most three phases (:mod:`prsxy_post.interpolate.timelaw`
says why): constant acceleration a1 from the entry speed v0 to a peak vp, a cruise
at vp, constant deceleration a3 to the exit speed v1. Here, for a batch of blocks:

- :func:`trapezoids`: the peak and the phase times t1, t2, t3 from v0, v1, the
  length L, the acceleration limit a and the speed limit (a bisection of 60 halvings
  for the blocks whose peak the limits do not give directly);
- :func:`along`: the distance s(τ) and the speed v(τ) at local times τ;
- :func:`phase_times`: the points' local times, each phase cut into equal steps;
- :func:`backward_pass`, :func:`forward_pass`: the look-ahead's limits on the
  junction speeds, v² changing by at most 2aL per block;
- :func:`play_stops`: the junctions where a motor with play must cross it at rest
  (:func:`prsxy_post.interpolate.lookahead.junction_limits` says why);
- :func:`junction_speeds`: the fastest each junction may be taken and which are
  corners (the look-ahead's junction limits, :mod:`prsxy_post.interpolate.lookahead`
  says why).

Every block's arithmetic depends on its own values only (so a program cut into
chunks gets the same bits as one planned at once), and every operation is written
elementwise in an order a loop over blocks can keep: ``_timelaw.pyx`` is the same
arithmetic in C, operation for operation, and the two agree to the bit
(``tests/test_kernel_timelaw.py``). Only +, −, ×, ÷, sqrt and comparisons: IEEE
rounds them the same in numpy and in C.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np

#: Halvings of the bisection for a block's peak speed (2⁻⁶⁰ of the interval: the
#: last bit).
BISECT_STEPS = 60


class TimeLaw(NamedTuple):
    """Per block (n,): entry v0, exit v1, peak vp [mm/s or deg/s], the accelerations
    of the first and last phase a1, a3 (≤ the block's limit) [mm/s² or deg/s²], the
    phase times t1, t2, t3 and the duration [s]. Dwells and machine functions stand
    still for their duration (t2 = duration)."""

    v0: np.ndarray
    v1: np.ndarray
    vp: np.ndarray
    a1: np.ndarray
    a3: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    t3: np.ndarray
    duration: np.ndarray


def _phases(
    vp: np.ndarray, v0: np.ndarray, v1: np.ndarray, a: np.ndarray, hmin: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Phase times and distances of the rising and falling phases for peak vp:
    t = max(Δv / a, hmin) where the speed changes, s = (v + vp) t / 2."""
    d0 = vp - v0
    d1 = vp - v1
    t1 = np.where(d0 > 0, np.maximum(d0 / a, hmin), 0.0)
    t3 = np.where(d1 > 0, np.maximum(d1 / a, hmin), 0.0)
    return t1, t3, 0.5 * (v0 + vp) * t1, 0.5 * (v1 + vp) * t3


def _bisect(
    lo: np.ndarray, hi: np.ndarray, ok_at: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """Largest x in [lo, hi] with ok(x), for ok monotone (true below a threshold)."""
    lo = lo.copy()
    hi = hi.copy()
    for _ in range(BISECT_STEPS):
        mid = 0.5 * (lo + hi)
        good = ok_at(mid)
        lo = np.where(good, mid, lo)
        hi = np.where(good, hi, mid)
    return lo


def trapezoids(
    v0: np.ndarray,
    v1: np.ndarray,
    length: np.ndarray,
    accel: np.ndarray,
    vmax: np.ndarray,
    stop: np.ndarray,
    duration: np.ndarray,
    min_phase: float,
) -> TimeLaw:
    """The trapezoid of each block between its entry and exit speeds.

    Parameters
    ----------
    v0, v1 : (n,) entry and exit speed [mm/s or deg/s] (0 for stops)
    length : (n,) path length L [mm or deg]
    accel, vmax : (n,) the block's acceleration and speed limits
    stop : (n,) bool, the block stands (a dwell or a machine function) for
        ``duration`` (n,) [s]
    min_phase : shortest phase [s]

    The peak is the highest with the rising and falling phases fitting in the
    block, then lowered where the cruise between them would be shorter than
    ``min_phase``; a block too short for phases of ``min_phase`` at any peak is one
    phase from v0 to v1 (:func:`prsxy_post.interpolate.timelaw.time_law`).
    """
    a = accel
    L = length
    vmax = np.maximum(vmax, np.maximum(v0, v1))
    lo = np.maximum(v0, v1)

    def room(vp: np.ndarray, k: slice | np.ndarray = slice(None)) -> np.ndarray:
        """What blocks k leave for the cruise at peaks vp [mm]."""
        _, _, s1, s3 = _phases(vp, v0[k], v1[k], a[k], min_phase)
        return L[k] - s1 - s3

    # highest peak with the rising and falling phases fitting in the block; each
    # bisection runs over the blocks that need it only (elementwise: the same bits)
    top = vmax.copy()
    k = np.flatnonzero(~(room(vmax) >= 0))
    if k.size:
        top[k] = _bisect(lo[k], vmax[k], lambda x: room(x, k) >= 0)
    # the cruise between them: none, or at least min_phase long
    with np.errstate(invalid="ignore", divide="ignore"):
        t2_top = np.where(top > 0, room(top) / top, np.inf)
        short_cruise = (t2_top * top > 1e-9 * np.maximum(1.0, L)) & (t2_top < min_phase)
    k = np.flatnonzero(short_cruise)
    if k.size:
        with np.errstate(invalid="ignore", divide="ignore"):
            top[k] = _bisect(lo[k], top[k], lambda x: room(x, k) >= min_phase * x)
    vp = top
    t1, t3, s1, s3 = _phases(vp, v0, v1, a, min_phase)
    # what the bisection leaves of the block at the top of a triangle is rounding
    left = L - s1 - s3
    left = np.where(left <= 1e-9 * np.maximum(L, 1.0), 0.0, left)
    with np.errstate(invalid="ignore", divide="ignore"):
        t2 = np.where(vp > 0, left / vp, 0.0)
    # one phase from v0 to v1 (time_law's docstring says which blocks)
    single = ~stop & ((room(lo) < 0) | ((t2 > 0) & (t2 < min_phase) & (t1 + t3 > 0)))
    single &= v0 + v1 > 0
    if np.any(single):
        with np.errstate(invalid="ignore", divide="ignore"):
            tau = 2.0 * L / (v0 + v1)
        rise = single & (v1 >= v0)
        fall = single & (v1 < v0)
        vp = np.where(rise, v1, np.where(fall, v0, vp))
        t1 = np.where(rise, tau, np.where(fall, 0.0, t1))
        t3 = np.where(fall, tau, np.where(rise, 0.0, t3))
        t2 = np.where(single, 0.0, t2)
    with np.errstate(invalid="ignore", divide="ignore"):
        a1 = np.where(t1 > 0, (vp - v0) / t1, 0.0)
        a3 = np.where(t3 > 0, (vp - v1) / t3, 0.0)
    t2 = np.where(stop, duration, t2)
    t1 = np.where(stop, 0.0, t1)
    t3 = np.where(stop, 0.0, t3)
    return TimeLaw(v0, v1, vp, a1, a3, t1, t2, t3, t1 + t2 + t3)


def along(law: TimeLaw, k: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance s(τ) [mm or deg] and speed ds/dt at local times ``tau`` (N,) of
    blocks ``k`` (N,).

    s = v0 τ + a1 τ²/2 in the first phase, s1 + vp (τ − t1) in the cruise,
    s1 + vp t2 + vp τ' − a3 τ'²/2 in the last (τ' = τ − t1 − t2 ≤ t3); τ before 0
    counts as 0. The speed is not taken below v1 in the last phase.
    """
    v0, vp, a1, a3 = law.v0[k], law.vp[k], law.a1[k], law.a3[k]
    t1, t2, t3 = law.t1[k], law.t2[k], law.t3[k]
    s1 = v0 * t1 + 0.5 * a1 * t1**2
    tc = np.clip(tau, 0.0, None)
    in1 = tc <= t1
    in2 = (~in1) & (tc <= t1 + t2)
    td = np.clip(tc - t1 - t2, 0.0, t3)
    s = np.where(
        in1,
        v0 * tc + 0.5 * a1 * tc**2,
        np.where(in2, s1 + vp * (tc - t1), s1 + vp * t2 + vp * td - 0.5 * a3 * td**2),
    )
    v = np.where(
        tau <= t1,
        v0 + a1 * tau,
        np.where(tau <= t1 + t2, vp, np.maximum(vp - a3 * (tau - t1 - t2), law.v1[k])),
    )
    return s, v


def phase_times(
    law: TimeLaw, counts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The points of blocks whose phases are cut into ``counts`` (n, 3) equal steps.

    Returns
    -------
    blk : (N,) the block of each point, in time order (N = counts.sum())
    tau : (N,) [s] its local time: the phase's start + j · step for the j-th
        (1-based) step of the phase; a block's last point at its duration
    step : (N,) [s] the step that ends at it, the phase's time / its count
    last : (N,) bool, the block's last point
    """
    nb = len(counts)
    flat = counts.reshape(-1)
    blk = np.repeat(np.repeat(np.arange(nb), 3), flat)
    phase = np.repeat(np.tile(np.arange(3), nb), flat)
    starts = np.cumsum(flat) - flat
    j = np.arange(len(blk)) - np.repeat(starts, flat) + 1  # 1..n within the phase
    t_ph = np.column_stack([law.t1, law.t2, law.t3])
    t_before = np.column_stack([np.zeros(nb), law.t1, law.t1 + law.t2])
    nj = counts[blk, phase]
    step = t_ph[blk, phase] / nj
    tau = t_before[blk, phase] + j * step
    last = np.zeros(len(blk), dtype=bool)
    if len(blk):
        last[np.cumsum(flat.reshape(nb, 3).sum(axis=1)) - 1] = True
    tau = np.where(last, law.duration[blk], tau)
    return blk, tau, step, last


def backward_pass(length: np.ndarray, accel: np.ndarray, vj: np.ndarray) -> np.ndarray:
    """v_out[k] ≤ sqrt(v_out[k+1]² + 2 a_{k+1} L_{k+1}): every block can slow down in time.

    A plain loop over Python floats (each step needs the one after it): its
    arithmetic does not depend on where a stream was cut, which keeps streamed
    output identical to one-shot output.
    """
    n = len(vj)
    v = vj.tolist()
    two_al = (2.0 * accel * length).tolist()
    sqrt = math.sqrt
    nxt = v[-1] if n else 0.0
    for k in range(n - 2, -1, -1):
        lim = sqrt(nxt * nxt + two_al[k + 1])
        if v[k] > lim:
            v[k] = lim
        nxt = v[k]
    return np.array(v, dtype=float)


def forward_pass(
    length: np.ndarray, accel: np.ndarray, v_back: np.ndarray, v_start: float = 0.0
) -> np.ndarray:
    """v_out[k] ≤ sqrt(v_out[k−1]² + 2 a_k L_k): every block can speed up in time."""
    v = v_back.tolist()
    two_al = (2.0 * accel * length).tolist()
    sqrt = math.sqrt
    prev = v_start
    for k in range(len(v)):
        lim = sqrt(prev * prev + two_al[k])
        if v[k] > lim:
            v[k] = lim
        prev = v[k]
    return np.array(v, dtype=float)


def play_stops(
    dq_out: np.ndarray,
    dq_in: np.ndarray,
    dP_out: np.ndarray,
    dP_in: np.ndarray,
    cross_in: np.ndarray,
    head: int,
    reversal_slope: float,
    stand_slope: float,
    gain_max: float,
) -> np.ndarray:
    """(n − 1,) bool, the junctions between n blocks where a motor with play crosses
    its play at rest.

    Parameters
    ----------
    dq_out, dq_in : (n, 5) the path's tangents at each block's end and start
    dP_out, dP_in : (n, 5) the motors' dP/ds there [mm/mm] (zero for motors
        without play); the first ``head`` (3: the contract's) columns move the
        head, the last two the table along x and y
    cross_in : (n,) bool, a motor sets off at the block's start against the way
        it last moved
    reversal_slope, stand_slope : a motor reverses where it moves faster than the
        first on one side and the other way faster than the second on the other
    gain_max : the largest squared speed-up of the tip a table motor standing in
        its play may cause, 1 − 2 t p + p² (t the tangent along its axis, p its dP/ds)

    A junction is a stop where a head motor reverses; where a table motor reverses
    and a head motor sets off or stops there, or its standing would speed the tip
    up by more than ``gain_max``; where a motor sets off against the way it last
    moved and a head motor sets off or stops.
    """
    if head != 3:
        raise ValueError("the head's motors must be the first three")
    lo = np.minimum(np.abs(dP_out[:-1]), np.abs(dP_in[1:]))
    hi = np.maximum(np.abs(dP_out[:-1]), np.abs(dP_in[1:]))
    reverses = (dP_out[:-1] * dP_in[1:] < 0.0) & (hi > reversal_slope) & (lo > stand_slope)
    head_sets_off = (hi > reversal_slope) & (lo <= stand_slope)
    stop = np.any(reverses[:, :head], axis=1)
    stop |= np.any(reverses[:, head:], axis=1) & np.any(head_sets_off[:, :head], axis=1)
    faster = np.zeros(len(lo), dtype=bool)
    for t, p in ((dq_out[:-1], dP_out[:-1]), (dq_in[1:], dP_in[1:])):
        tt, pp = t[:, 0:2], p[:, head:]
        gain = 1.0 - 2.0 * tt * pp + pp * pp
        faster |= np.any(reverses[:, head:] & (gain > gain_max), axis=1)
    stop |= faster
    stop |= cross_in[1:] & np.any(head_sets_off[:, :head], axis=1)
    out: np.ndarray = stop
    return out


def set_offs(
    d_in: np.ndarray,
    d_out: np.ndarray,
    vmax: np.ndarray,
    way: np.ndarray,
    stood: np.ndarray,
    reversal_slope: float,
    stand_slope: float,
    v_eps: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a motor with play sets off against the way it last moved: (cross (n,)
    bool, way (k,), stood (k,) bool after the last block), for n moving blocks.

    Parameters
    ----------
    d_in, d_out : (n, k) the k motors' dP/ds at each block's start and end [mm/mm]
    vmax : (n,) each block's speed limit [mm/s]
    way : (k,) the way each motor last moved (±1) before the first block
    stood : (k,) bool, each motor stood at the end of the moving block before
    reversal_slope : a motor moves a way where |dP/ds| is above it (a creep,
        below, does not set the way)
    stand_slope : a motor stands at a block's end where |dP/ds| is at most this
    v_eps : a block's start sets a motor off where |dP/ds| times the block's
        speed limit is above it

    A block's start crosses where a motor that stood at the block before's end
    sets off faster than ``v_eps`` against the way it last moved, that way carried
    through the blocks' starts and ends in turn (and across chunks: the ``way``
    and ``stood`` returned).
    """
    n, k = d_in.shape
    # each block's start, then its end, in order: the way each motor last moved
    # clearly up to it, carried on from before the first
    ends = np.empty((2 * n, k))
    ends[0::2], ends[1::2] = d_in, d_out
    moved = np.where(np.abs(ends) > reversal_slope, np.sign(ends), 0.0)
    rows = np.arange(2 * n)[:, None]
    last = np.maximum.accumulate(np.where(moved != 0, rows, -1), axis=0)
    came = np.where(last >= 0, np.take_along_axis(moved, np.maximum(last, 0), 0), way)
    # the way before each start: the way given before the first, else the way
    # after the block before's end
    before = np.empty((n, k))
    before[0], before[1:] = way, came[1:-1:2]
    still = np.abs(d_out) <= stand_slope
    was = np.empty((n, k), dtype=bool)
    was[0], was[1:] = stood, still[:-1]
    sets_off = np.abs(d_in) * vmax[:, None] > v_eps
    against = sets_off & (np.sign(d_in) == -before) & was
    cross: np.ndarray = np.any(against, axis=1)
    return cross, came[-1].copy(), still[-1].copy()


class JunctionRules(NamedTuple):
    """The numbers :func:`junction_speeds` takes from the plan's limits (each a
    Python float made as :mod:`prsxy_post.interpolate.lookahead` makes it).

    period : the servo period [s]; min_phase : the shortest phase [s]
    a_xyz, a_ab : κ of the accelerations [mm/s², deg/s²]
    an : sqrt(0.75) of the XYZ acceleration [mm/s²] (what a blend next to an arc may
        take of it)
    tol_gain : 27 · CORNER_SHARE, of the tolerance a corner's blend may take
    eps : the tangents' difference below which a junction is tangent
    exact : the block tolerance that asks an exact stop (G61.1)
    """

    period: float
    min_phase: float
    a_xyz: float
    a_ab: float
    an: float
    tol_gain: float
    eps: float
    exact: float


def junction_speeds(
    dq_in: np.ndarray,
    dq_out: np.ndarray,
    dot: np.ndarray,
    vmax: np.ndarray,
    length: np.ndarray,
    seg: np.ndarray,
    stops: np.ndarray,
    angular: np.ndarray,
    tool_length: np.ndarray,
    tol: np.ndarray,
    tol_deg: np.ndarray,
    curv_r: np.ndarray,
    play: np.ndarray,
    r: JunctionRules,
) -> tuple[np.ndarray, np.ndarray]:
    """The speed limit at the end of each of n blocks and the corners: the
    fastest each junction's corner may be taken with the mean velocity, within
    both blocks' speed limits, the path tolerance (27 · CORNER_SHARE · tol /
    (2 T d)) and κ of the acceleration (κ a h / (2 d), h the shortest step beside
    it; next to an arc, v² / r + 2 v d / h ≤ sqrt(0.75) a), d = |t_in − t_out| of
    the XYZ and the A/B tangents; 0 at a stop (a corner of 90° or more, a dwell or
    function, a rotary-only move beside, a change of tool length, G61.1, or a
    motor crossing its play at rest).

    Parameters
    ----------
    dq_in, dq_out : (n, 5) the tangents at each block's start and end
    dot : (n − 1,) t_in · t_out of the XYZ tangents at each junction
    vmax, length : (n,) the blocks' speed limits and lengths
    seg : (n,) the longest step at speed 1 on each block
        (:func:`prsxy_post.interpolate.geometry.segment_limit`)
    stops, angular : (n,) bool, a dwell or function; a rotary-only move
    tool_length, tol, tol_deg, curv_r : (n,) each block's
    play : (n − 1,) bool, a motor crosses its play at rest at the junction
        (:func:`play_stops`)

    Returns
    -------
    vj : (n,) the junction speeds, the last 0; corner : (n + 1,) bool, the
    junctions taken as corners with the mean velocity (the first and last False)
    """
    n = len(vmax)
    vj = np.zeros(n)
    corner = np.zeros(n + 1, dtype=bool)
    if n < 2:
        return vj, corner
    d_xyz = row_norm(dq_in[1:, :3] - dq_out[:-1, :3])
    d_ab = row_norm(dq_in[1:, 3:] - dq_out[:-1, 3:])
    with np.errstate(divide="ignore", invalid="ignore"):
        dur = np.where(stops, 0.0, length / vmax)
        h_curve = 0.5 * seg / vmax
    h_blk = np.minimum(np.minimum(dur, h_curve), r.min_phase)
    h_lo = np.minimum(h_blk[:-1], h_blk[1:])
    tol, tol_deg = tol[:-1], tol_deg[:-1]
    eps = r.eps
    with np.errstate(divide="ignore", invalid="ignore"):
        v_tol = np.minimum(
            np.where(d_xyz > eps, r.tol_gain * tol / (2.0 * r.period * d_xyz), np.inf),
            np.where(d_ab > eps, r.tol_gain * tol_deg / (2.0 * r.period * d_ab), np.inf),
        )
        v_acc = np.minimum(
            np.where(d_xyz > eps, r.a_xyz * h_lo / (2.0 * d_xyz), np.inf),
            np.where(d_ab > eps, r.a_ab * h_lo / (2.0 * d_ab), np.inf),
        )
    r_min = np.minimum(curv_r[:-1], curv_r[1:])
    curved = np.isfinite(r_min) & (d_xyz > eps)
    if np.any(curved):
        c = np.flatnonzero(curved)
        p = 2.0 * d_xyz[c] / np.where(h_lo[c] > 0, h_lo[c], np.inf)
        rc = r_min[c]
        # v² / r + p v − an = 0
        v_acc[c] = np.minimum(v_acc[c], 0.5 * rc * (-p + np.sqrt(p * p + 4.0 * r.an / rc)))
    v = np.minimum(np.minimum(vmax[:-1], vmax[1:]), np.minimum(v_tol, v_acc))
    sharp = (dot <= 0.0) & (d_xyz > eps) & ~angular[:-1] & ~angular[1:]
    stop = (
        sharp
        | stops[:-1]
        | stops[1:]
        | angular[:-1]
        | angular[1:]
        | (tool_length[:-1] != tool_length[1:])
        | (tol == r.exact)
        | play
    )
    vj[:-1] = np.where(stop, 0.0, v)
    corner[1:-1] = ~stop & ((d_xyz > eps) | (d_ab > eps))
    return vj, corner


def row_norm(x: np.ndarray) -> np.ndarray:
    """(n,) the Euclidean norm of each row of ``x`` (n, k), k small: the squares
    summed in column order, as ``np.linalg.norm(x, axis=1)`` sums them (the same
    bits), without numpy's reduction machinery over rows of a few (several times
    its cost on a chunk's blocks)."""
    sq = x * x
    total = sq[:, 0].copy()
    for j in range(1, x.shape[1]):
        total += sq[:, j]
    out: np.ndarray = np.sqrt(total)
    return out
