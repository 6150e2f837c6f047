"""Poses on programmed lines and arcs over arrays: the numpy reference kernel.

A block's path q(s), s ∈ [0, L] the path length, in the five virtual axes
(:mod:`prsxy_post.interpolate.geometry`): lines are linear in all five axes; arcs
and helices lie on the arc, at angle θ = θ0 + φ f and radius r = r0 + (r1 − r0) f
(f = s / L, φ the signed sweep) in their plane (u, v), linear in f along its normal
and in A/B:

    q_u = c_u + r cos θ,  q_v = c_v + r sin θ
    dq_u/ds = ((r1 − r0) cos θ − r φ sin θ) / L,  dq_v/ds = ((r1 − r0) sin θ + r φ cos θ) / L

and an arc's end is its programmed end point exactly (not cos/sin of an angle that
lands a rounding off it). Curves (G5 splines, NURBS) are not here: their caller
evaluates them.

Every operation is written elementwise in an order a loop over points can keep:
``_path.pyx`` is the same arithmetic in C, operation for operation, and the two
agree to the bit (``tests/test_kernel_timelaw.py``). cos and sin are the C
library's on both sides (:mod:`.libm`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import libm


class PathArrays(NamedTuple):
    """Blocks' paths, one row per block (n of them).

    start, end : (n, 5) [mm, mm, mm, deg, deg]
    length : (n,) path length L [mm, or deg for rotary-only moves]
    arc : (n,) bool, the block is an arc or a helix
    theta0, sweep : (n,) start angle and signed sweep of arcs [rad]
    r0, r1 : (n,) start and end radius of arcs [mm]
    center : (n, 3) arc centres [mm]
    iu, iv : (n,) int, the arc plane's in-plane axes (columns 0–2 of q)
    """

    start: np.ndarray
    end: np.ndarray
    length: np.ndarray
    arc: np.ndarray
    theta0: np.ndarray
    sweep: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    center: np.ndarray
    iu: np.ndarray
    iv: np.ndarray


def poses(p: PathArrays, k: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pose q (N, 5) and tangent dq/ds (N, 5) at path distances ``s`` (N,) into
    blocks ``k`` (N,): s is clipped to [0, L]; a block of no length is at its end
    with a zero tangent."""
    k = np.asarray(k, dtype=np.intp)
    s = np.asarray(s, dtype=float)
    st, en = p.start[k], p.end[k]
    L = p.length[k]
    with np.errstate(invalid="ignore", divide="ignore"):
        frac = np.where(L > 0, np.clip(s / L, 0.0, 1.0), 1.0)
        dq = np.where(L[:, None] > 0, (en - st) / L[:, None], 0.0)
    q = st + (en - st) * frac[:, None]
    arc = p.arc[k]
    if np.any(arc):
        ka = k[arc]
        fa = frac[arc]
        La = L[arc]
        th = p.theta0[ka] + p.sweep[ka] * fa
        dr = p.r1[ka] - p.r0[ka]
        r = p.r0[ka] + dr * fa
        c, sn = libm.cos(th), libm.sin(th)
        iu, iv = p.iu[ka], p.iv[ka]
        rows = np.flatnonzero(arc)
        cen = p.center[ka]
        m = np.arange(len(ka))
        q[rows, iu] = cen[m, iu] + r * c
        q[rows, iv] = cen[m, iv] + r * sn
        with np.errstate(invalid="ignore", divide="ignore"):
            dq[rows, iu] = (dr * c - r * p.sweep[ka] * sn) / La
            dq[rows, iv] = (dr * sn + r * p.sweep[ka] * c) / La
        end_hit = fa >= 1.0
        q[rows[end_hit]] = en[arc][end_hit]
    return q, dq


def velocities(
    v: np.ndarray,
    dq: np.ndarray,
    blk: np.ndarray,
    corner: np.ndarray,
    dq_out: np.ndarray,
    dq_next: np.ndarray,
) -> np.ndarray:
    """(N, 5) the planned velocity dq/dt = v · dq/ds at each point [mm/s, deg/s].

    v : (N,) planned speed;  dq : (N, 5) tangent at the point;  blk : (N,) its block
    corner : (N,) bool, the point is a junction taken at speed: its velocity is the
        mean of its two sides', v (t_out + t_in) / 2, with t_out = ``dq_out[blk]``
        (n, 5) the block's end tangent and t_in = ``dq_next[blk]`` (n, 5) the next
        block's start tangent
    """
    qdot = v[:, None] * dq
    at = np.flatnonzero(corner)
    if at.size:
        kb = blk[at]
        qdot[at] = 0.5 * v[at, None] * (dq_out[kb] + dq_next[kb])
    return qdot
