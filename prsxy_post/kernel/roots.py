"""The root search's false-position step, elementwise: the reversals' roots moved
from the steps' cubics towards the path's own velocity, one look at the path at a
time (:func:`seek_step`; the rules, and why, are
:func:`prsxy_post.reversals.root_search`'s).

The numpy reference; ``_roots.pyx`` is its compiled twin, the same operations in
the same order (the same bits).
"""

from __future__ import annotations

import numpy as np


def seek_step(
    x: np.ndarray,
    v: np.ndarray,
    going: np.ndarray,
    ok: np.ndarray,
    moved: np.ndarray,
    new: np.ndarray,
    accel: np.ndarray,
    h: np.ndarray,
    s_a: np.ndarray,
    v_a: np.ndarray,
    s_b: np.ndarray,
    v_b: np.ndarray,
    last: np.ndarray,
    margin: float,
    time_s: float,
) -> tuple[np.ndarray, ...]:
    """One false-position step of m roots with the path's velocity ``v`` (q,)
    [mm/s] at the roots still ``going`` (q of the m, in their order; NaN where
    not known).

    A root is found where the path's velocity vm there is what the acceleration
    makes in ``time_s``: |vm| · margin ≤ fmin(|accel|, |vm − v_o| / (|x − s_o| h))
    · time_s, (s_o, v_o) the bracket's end on the other side; elsewhere the
    bracket's end on vm's side moves to x (Illinois: an end kept twice running
    has its velocity halved) and x to the false position

        x' = s_a − v_a (s_b − s_a) / (v_b − v_a)

    within the bracket (where finite).

    Parameters
    ----------
    x : (m,) the roots so far [fraction of the step]
    v : (q,) the path's velocity at the roots going [mm/s]
    going, ok, moved : (m,) bool, roots sought, bracketed and known so far,
        moved off the cubic's root
    new : (m,) the way each motor turns to (+1, −1)
    accel, h : (m,) the cubic's acceleration [mm/s²], the step's duration [s]
    s_a, v_a, s_b, v_b : (m,) the bracket: the fractions where the velocity is
        still the old way and the new way, and the velocities there
    last : (m,) ints, the bracket's end moved last (−1 a, +1 b, 0 neither)

    Returns
    -------
    x, going, ok, moved, s_a, v_a, s_b, v_b, last : (m,) after the step (going,
    ok and moved new arrays; the others the inputs themselves where no root is
    still sought, as the caller only rebinds them)
    """
    n = len(x)
    going, ok, moved = going.copy(), ok.copy(), moved.copy()
    known = np.zeros(n, dtype=bool)
    known[going] = np.isfinite(v)
    vm = np.zeros(n)
    vm[going] = np.where(np.isfinite(v), v, 0.0)
    ok &= known | ~going
    new_way = new * vm > 0
    # found: the velocity there is what the acceleration makes in time_s, the
    # acceleration the cubic's or the secant to the bracket's other end,
    # whichever is less
    s_o, v_o = np.where(new_way, s_a, s_b), np.where(new_way, v_a, v_b)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        secant = np.abs(vm - v_o) / (np.abs(x - s_o) * h)
        slow = np.fmin(np.abs(accel), secant)
        found = going & known & (np.abs(vm) * margin <= slow * time_s)
    going &= known & ~found
    if not np.any(going):
        return x, going, ok, moved, s_a, v_a, s_b, v_b, last
    moved |= going
    turned, old = going & new_way, going & ~new_way
    # Illinois: an end kept twice running has its velocity halved, so that false
    # position closes in from both sides
    v_a = np.where(turned & (last == 1), 0.5 * v_a, v_a)
    v_b = np.where(old & (last == -1), 0.5 * v_b, v_b)
    last = np.where(turned, 1, np.where(old, -1, last))
    s_b, v_b = np.where(turned, x, s_b), np.where(turned, vm, v_b)
    s_a, v_a = np.where(old, x, s_a), np.where(old, vm, v_a)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        x_new = s_a - v_a * (s_b - s_a) / (v_b - v_a)
    x = np.where(going & np.isfinite(x_new), np.clip(x_new, s_a, s_b), x)
    return x, going, ok, moved, s_a, v_a, s_b, v_b, last
