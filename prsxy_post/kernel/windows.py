"""The crossing windows about motors' reversals: a window's edges from the root,
the acceleration there, the tolerance and the reach on each side, elementwise.

The numpy reference; ``_windows.pyx`` is its compiled twin, the same operations in
the same order (the same bits). The rules (why each) are
:func:`prsxy_post.reversals.windows`'; this module only computes them.
"""

from __future__ import annotations

import numpy as np


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
