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

import numpy as np

from .. import kernel
from ..kernel.timelaw import TimeLaw
from .geometry import Blocks


def time_law(b: Blocks, v_out: np.ndarray, v_start: float, min_phase: float) -> TimeLaw:
    """Trapezoids between the planned junction speeds (module docstring).

    Parameters
    ----------
    b : Blocks
    v_out : (n,) speed at the end of each block [mm/s or deg/s]
    v_start : speed at the start of the first block
    min_phase : shortest phase [s]

    The peak is the highest with the rising and falling phases fitting in the block
    (a bisection where the speed limit does not fit), then lowered where the cruise
    would be shorter than ``min_phase`` (:func:`prsxy_post.kernel.timelaw.trapezoids`).
    A block too short for phases of ``min_phase`` at any peak is one phase: the
    speed goes straight from v0 to v1 (the look-ahead made that reachable). Not one
    that starts and ends at rest: it must rise and fall, and its peak's cruise short
    of ``min_phase`` by a rounding is left as it is (made one phase, it took
    forever: a 0.12 mm tilt between two junctions where a head motor reverses,
    bench.py's program).

    Every block's arithmetic depends on its own v0, v1, L, a, vmax only, so a
    program cut into chunks gets the same bits as one planned at once.
    """
    n = len(b)
    v0 = np.concatenate([[v_start], v_out[:-1]]) if n else np.zeros(0)
    v1 = v_out.copy()
    stop = b.stops
    v0[stop] = 0.0
    v1[stop] = 0.0
    return kernel.trapezoids(v0, v1, b.length, b.accel, b.vmax, stop, b.duration, min_phase)


def distance(law: TimeLaw, k: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Path distance s(τ) into blocks ``k`` at local times ``τ``
    (:func:`prsxy_post.kernel.timelaw.along`)."""
    return kernel.along(law, k, tau)[0]


def speed(law: TimeLaw, k: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """Planned speed ds/dt at local times ``τ`` of blocks ``k``
    (:func:`prsxy_post.kernel.timelaw.along`)."""
    return kernel.along(law, k, tau)[1]


__all__ = ["TimeLaw", "distance", "speed", "time_law"]
