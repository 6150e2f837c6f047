"""The speed along each block: acceleration-limited trapezoids with no short phases.

Each block runs through at most three phases: constant acceleration from the
entry speed v0 to a peak vp, cruise at vp, constant deceleration to the exit speed
v1. The look-ahead (:mod:`.lookahead`) fixes v0 and v1; here the peak and the phase
times are chosen so that

- no acceleration exceeds the block's limit a, no speed its limit vmax;
- every phase that exists lasts at least ``min_phase`` (a quarter period), unless
  it is the whole block. The controller's cubic between two points is exact only
  while the acceleration is constant over the step, so the sampler puts a point
  at every phase boundary; a phase of a few microseconds would make a step so
  short that the controller's velocity mismatch at a corner becomes a large
  acceleration. A phase that would be shorter is stretched (a gentler
  acceleration) or the peak lowered;
- among those, the peak is the highest (the block is as fast as it can be).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .geometry import Blocks


@dataclass(frozen=True)
class TimeLaw:
    """Per block: entry v0, exit v1, peak vp, the accelerations of the first and last
    phase a1, a3 (≤ the block's limit), the phase times t1, t2, t3 and the duration.
    Dwells and machine functions stand still for their duration (t2 = duration)."""

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
    """Phase times and distances of the rising and falling phases for peak vp."""
    d0 = vp - v0
    d1 = vp - v1
    t1 = np.where(d0 > 0, np.maximum(d0 / a, hmin), 0.0)
    t3 = np.where(d1 > 0, np.maximum(d1 / a, hmin), 0.0)
    return t1, t3, 0.5 * (v0 + vp) * t1, 0.5 * (v1 + vp) * t3


def _bisect(lo: np.ndarray, hi: np.ndarray, ok_at: object, steps: int = 60) -> np.ndarray:
    """Largest x in [lo, hi] with ok(x), for ok monotone (true below a threshold)."""
    lo = lo.copy()
    hi = hi.copy()
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        good = ok_at(mid)  # type: ignore[operator]
        lo = np.where(good, mid, lo)
        hi = np.where(good, hi, mid)
    return lo


def time_law(b: Blocks, v_out: np.ndarray, v_start: float, min_phase: float) -> TimeLaw:
    """Trapezoids between the planned junction speeds (module docstring).

    Parameters
    ----------
    b : Blocks
    v_out : (n,) speed at the end of each block [mm/s or deg/s]
    v_start : speed at the start of the first block
    min_phase : shortest phase [s]

    Every block's arithmetic depends on its own v0, v1, L, a, vmax only, so a
    program cut into chunks gets the same bits as one planned at once.
    """
    n = len(b)
    v0 = np.concatenate([[v_start], v_out[:-1]]) if n else np.zeros(0)
    v1 = v_out.copy()
    stop = b.stops
    v0[stop] = 0.0
    v1[stop] = 0.0
    a = b.accel
    L = b.length
    vmax = np.maximum(b.vmax, np.maximum(v0, v1))
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
    # a block too short for phases of min_phase at any peak is one phase: the speed
    # goes straight from v0 to v1 (the look-ahead made that reachable). Not one that
    # starts and ends at rest: it must rise and fall, and its peak's cruise short of
    # min_phase by a rounding is left as it is (made one phase, it took forever: a
    # 0.12 mm tilt between two junctions where a head motor reverses, bench.py's
    # program)
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
    t2 = np.where(stop, b.duration, t2)
    t1 = np.where(stop, 0.0, t1)
    t3 = np.where(stop, 0.0, t3)
    return TimeLaw(v0, v1, vp, a1, a3, t1, t2, t3, t1 + t2 + t3)


def distance(law: TimeLaw, k: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Path distance s(τ) into blocks ``k`` at local times ``τ``."""
    v0, vp, a1, a3 = law.v0[k], law.vp[k], law.a1[k], law.a3[k]
    t1, t2, t3 = law.t1[k], law.t2[k], law.t3[k]
    s1 = v0 * t1 + 0.5 * a1 * t1**2
    tc = np.clip(tau, 0.0, None)
    in1 = tc <= t1
    in2 = (~in1) & (tc <= t1 + t2)
    td = np.clip(tc - t1 - t2, 0.0, t3)
    return np.where(
        in1,
        v0 * tc + 0.5 * a1 * tc**2,
        np.where(in2, s1 + vp * (tc - t1), s1 + vp * t2 + vp * td - 0.5 * a3 * td**2),
    )


def speed(law: TimeLaw, k: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Planned speed ds/dt at local times ``τ`` of blocks ``k``."""
    v0, vp, a1, a3 = law.v0[k], law.vp[k], law.a1[k], law.a3[k]
    t1, t2 = law.t1[k], law.t2[k]
    return np.where(
        tau <= t1,
        v0 + a1 * tau,
        np.where(tau <= t1 + t2, vp, np.maximum(vp - a3 * (tau - t1 - t2), law.v1[k])),
    )
