"""Interpolation points: where the controller is told to be, when, and how fast.

Every block's end is a point, and so is every boundary between its phases of
constant acceleration (:mod:`.timelaw`); each phase is cut into equal steps of at
most the period (shorter on tight curves: :func:`.geometry.segment_limit`). Each
point carries the planned velocity of the motion there, dq/dt = v · dq/ds; at a
corner taken at speed, the mean of the two sides (:mod:`.lookahead`). A dwell is
one point held for its whole duration, a machine function one point of no
duration.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import ClassVar

import numpy as np

from .. import kernel
from ..kernel.path import PathArrays
from ..points import Columns
from .geometry import KIND_DWELL, KIND_FUNCTION, Blocks, PlanLimits, pose_at, segment_limit
from .lookahead import Plan
from .timelaw import TimeLaw


class Samples(Columns):
    """Interpolation points.

    q : (N, 5) [mm, mm, mm, deg, deg] workpiece frame, on the programmed path
    qdot : (N, 5) [mm/s, deg/s] planned velocity at the point
    dt : (N,) [s] time of the segment that ends at each point (a dwell: its length)
    line : (N,) source line of the block the point belongs to
    block : (N,) index of the block in its plan
    tau : (N,) [s] local time in the block
    first : (N,) bool, first point of its block
    tool_length : (N,) active G43 offset [mm]
    speed : (N,) planned path speed at the point [mm/s or deg/s]
    dwell : (N,) bool, the path stands for dt (a dwell or a machine function)
    fn : (N,) object, the machine-function words at function points, else None
    block_end : (N,) bool, the last point of its block
    split : (N,) int8, a split program's part ends at rest at this point (1: a stop
        the program makes, 2: a stop put there for the split), else 0

    A :class:`~prsxy_post.points.Columns` record (rows taken, records joined field
    by field).
    """

    #: the fields, in the order the constructor takes them
    FIELDS: ClassVar[tuple[str, ...]] = (
        "q",
        "qdot",
        "dt",
        "line",
        "block",
        "tau",
        "first",
        "tool_length",
        "speed",
        "dwell",
        "fn",
        "block_end",
        "split",
    )

    def __init__(
        self,
        q: np.ndarray,
        qdot: np.ndarray,
        dt: np.ndarray,
        line: np.ndarray,
        block: np.ndarray,
        tau: np.ndarray,
        first: np.ndarray,
        tool_length: np.ndarray,
        speed: np.ndarray,
        dwell: np.ndarray,
        fn: np.ndarray,
        block_end: np.ndarray,
        split: np.ndarray,
    ) -> None:
        self.q = q
        self.qdot = qdot
        self.dt = dt
        self.line = line
        self.block = block
        self.tau = tau
        self.first = first
        self.tool_length = tool_length
        self.speed = speed
        self.dwell = dwell
        self.fn = fn
        self.block_end = block_end
        self.split = split

    def __len__(self) -> int:
        return len(self.dt)

    @staticmethod
    def concat(parts: Sequence[Samples], offsets: Sequence[int]) -> Samples:
        """Consecutive runs of points as one; ``offsets``: where each run's plan
        begins in the joined plan (its points' ``block`` are moved by that)."""
        out = Samples.joined(parts)
        out["block"] = np.concatenate([p.block + o for p, o in zip(parts, offsets, strict=True)])
        return Samples(**out)


def longest_step(b: Blocks, law: TimeLaw, limits: PlanLimits) -> np.ndarray:
    """(n,) [s] the longest step in each block: the period, shorter on a tight curve."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.minimum(limits.period_s, segment_limit(b, limits) / np.maximum(law.vp, 1e-300))


def steps(b: Blocks, law: TimeLaw, limits: PlanLimits) -> np.ndarray:
    """(n, 3) steps in each phase of each block (0 for a phase that is absent)."""
    h = longest_step(b, law, limits)
    t = np.column_stack([law.t1, law.t2, law.t3])
    n = np.where(t > 0, np.ceil(t / h[:, None] - 1e-9), 0).astype(np.int64)
    n = np.where(t > 0, np.maximum(n, 1), 0)
    stand = np.flatnonzero(b.stops)
    if len(stand):  # one point for a dwell or a function
        n[stand] = [0, 1, 0]
    return n


def junctions(s: Samples) -> np.ndarray:
    """(k,) the points of junctions taken at speed: their velocity is the mean of
    their two sides' (:func:`sample`)."""
    return np.flatnonzero(s.block_end & ~s.dwell & (s.speed > 0))


def next_tangent(plan: Plan, blk: np.ndarray) -> np.ndarray:
    """(k, 5) the tangent dq/ds just past the end of blocks ``blk``: the next
    block's at its start (the plan knows the one past its last block)."""
    nxt = np.vstack([plan.blocks.dq_in[1:], plan.next_dq_in[None, :]])
    # np.take: an (n, 5) array's rows gathered faster than by fancy indexing
    out: np.ndarray = np.take(nxt, blk, axis=0)
    return out


def sample(plan: Plan, limits: PlanLimits, n_steps: np.ndarray | None = None) -> Samples:
    """Points of a plan's blocks, in time order, each block's end point last;
    ``n_steps``: the plan's :func:`steps`, where the caller has them."""
    b, law = plan.blocks, plan.law
    if n_steps is None:
        n_steps = steps(b, law, limits)
    blk, tau, step, last_of_block = kernel.phase_times(law, n_steps)
    first = np.ones(len(blk), dtype=bool)
    first[1:] = blk[1:] != blk[:-1]

    along, v_along = kernel.along(law, blk, tau)
    kind = b.kind[blk]
    if np.any(b.stops):
        stand = b.stops[blk]
        s = np.where(last_of_block | stand, b.length[blk], along)
        v = np.where(stand, 0.0, v_along)
        v = np.where(last_of_block & ~stand, law.v1[blk], v)
        dt = np.where(stand, np.where(kind == KIND_DWELL, b.duration[blk], 0.0), step)
    else:  # the same with no point standing (most chunks of a CAM program)
        stand = np.zeros(len(blk), dtype=bool)
        s = np.where(last_of_block, b.length[blk], along)
        v = np.where(last_of_block, law.v1[blk], v_along)
        dt = step
    q, dq = pose_at(b, blk, s)
    # a junction taken at speed: the mean of the velocities on its two sides (the
    # same vector where the path is tangent)
    at_speed = last_of_block & ~stand & (v > 0)
    dq_next = np.vstack([b.dq_in[1:], plan.next_dq_in[None, :]])[: len(b)]
    qdot = kernel.velocities(v, dq, blk, at_speed, b.dq_out, dq_next)
    fn = np.empty(len(blk), dtype=object)
    is_fn = kind == KIND_FUNCTION
    if np.any(is_fn):
        fn[is_fn] = b.fn[blk[is_fn]]
    if np.any(b.split_after):
        split = np.where(last_of_block, b.split_after[blk], 0).astype(np.int8)
    else:
        split = np.zeros(len(blk), dtype=np.int8)
    return Samples(
        q=q,
        qdot=qdot,
        dt=dt,
        line=b.line[blk],
        block=blk,
        tau=tau,
        first=first,
        tool_length=b.tool_length[blk],
        speed=v,
        dwell=stand,
        fn=fn,
        block_end=last_of_block,
        split=split,
    )


def at_times(
    plan: Plan, k: np.ndarray, tau: np.ndarray, paths: PathArrays | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Pose and planned velocity at local times ``tau`` inside blocks ``k`` (no corner
    averaging: for points strictly inside a block). ``paths``: the plan's
    ``path_arrays(plan.blocks)`` where the caller asks the same plan many times
    (:func:`.geometry.pose_at`)."""
    b, law = plan.blocks, plan.law
    s, v = kernel.along(law, k, tau)
    q, dq = pose_at(b, k, s, paths)
    return q, v[:, None] * dq
