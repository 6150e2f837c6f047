"""Coarse interpolation in virtual-axis space: from interpreted motions to points.

- :mod:`.geometry`: the blocks and their exact paths q(s) (lines, arcs, helices);
- :mod:`.lookahead`: junction speeds (corners within the tolerance), the backward
  and forward passes, streaming with bounded memory;
- :mod:`.timelaw`: the speed along each block (trapezoids with no short phases);
- :mod:`.sampling`: the points and the planned velocity at each.

Their per-block and per-point arithmetic (the trapezoids and their bisections,
the look-ahead's passes and play stops, the points' times, distances, speeds,
poses on lines and arcs and velocities) runs in the kernel
(:mod:`prsxy_post.kernel.timelaw`, :mod:`prsxy_post.kernel.path`), compiled.

The path is exact regardless of the speed plan: points are evaluated on the
programmed geometry, and the velocity at each is the plan's, so the cubic a
PVT controller runs between two points stays on the path (see the modules for
the bounds).
"""

from .geometry import (
    ANGULAR_EPS_DEG,
    KIND_ARC,
    KIND_CURVE,
    KIND_DWELL,
    KIND_FEED,
    KIND_FUNCTION,
    KIND_RAPID,
    LINEAR_EPS_MM,
    PLANE_AXES,
    Blocks,
    PlanLimits,
    blocks_from_motions,
    pose_at,
)
from .lookahead import Plan, Planner, backward_pass, forward_pass, junction_limits
from .sampling import Samples, at_times, junctions, next_tangent, sample
from .timelaw import TimeLaw, time_law

__all__ = [
    "ANGULAR_EPS_DEG",
    "KIND_ARC",
    "KIND_CURVE",
    "KIND_DWELL",
    "KIND_FEED",
    "KIND_FUNCTION",
    "KIND_RAPID",
    "LINEAR_EPS_MM",
    "PLANE_AXES",
    "Blocks",
    "Plan",
    "PlanLimits",
    "Planner",
    "Samples",
    "TimeLaw",
    "at_times",
    "backward_pass",
    "blocks_from_motions",
    "forward_pass",
    "junction_limits",
    "junctions",
    "next_tangent",
    "pose_at",
    "sample",
    "time_law",
]
