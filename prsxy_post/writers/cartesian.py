"""The Cartesian step every Cartesian dialect shares.

A controller with its own inverse kinematics (``[controller_kinematics]``, the
nominal design when absent, with an ideal table) is given, at every point, the
pose its kinematics turn into the compensated motor commands:
q_written = FK_controller(P_cmd) (contract, "The compensation chain"). Its own IK
then reproduces the commands, and with them the compensation.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import kinematics
from ..errors import ReachError
from .numbers import format_fixed_rows

if TYPE_CHECKING:
    from ..points import PointChunk


class WrittenPoints:
    """The Cartesian step of one program's points, fed chunk after chunk in order:
    the FK of the controller's geometry at the motor commands, started at the pose
    the chain aimed for (:func:`kinematics.fk_start`) moved by the anchored offset
    (:func:`kinematics.forward_anchored`, its anchors counted from the program's
    first point, so the poses do not depend on where its chunks are cut)."""

    def __init__(self, cgeo: kinematics.Geometry) -> None:
        self.cgeo = cgeo
        self.points = 0
        self.carry = np.zeros(6)

    def __call__(self, chunk: PointChunk) -> np.ndarray:
        """(n, 5) [mm, mm, mm, deg, deg] the poses written for ``chunk``'s points."""
        every = kinematics.FK_ANCHOR_EVERY
        q, ok, self.carry = kinematics.forward_anchored(
            self.cgeo,
            chunk.P_cmd,
            kinematics.fk_start(self.cgeo, chunk.q_target),
            every,
            self.points % every,
            self.carry,
        )
        self.points += len(q)
        if not np.all(ok):
            k = int(np.argmin(ok))
            raise ReachError(
                "the controller's kinematics cannot express this point",
                line=int(chunk.line[k]),
                expected="a pose within reach of [controller_kinematics]",
            )
        return q


def feed_words(dt: np.ndarray) -> dict[float, str]:
    """G93's feed word for each distinct segment time t > 0 [s] of ``dt``:
    ``F`` 60 / t (inverse time: 1 / minutes) with three decimals, the text of
    ``f"F{60.0 / t:.3f}"``, made for the whole chunk in one kernel call.

    A line whose time is a sum of segments (points dropped in between) is not
    here: the writer formats it itself.
    """
    # the distinct times, ascending: np.unique's, without its import of numpy.ma
    # (10 ms of a short program's conversion)
    t = np.array(sorted(set(dt[(dt > 0.0) & np.isfinite(dt)].tolist())), dtype=float)
    with np.errstate(over="ignore"):  # as Python's 60.0 / t: inf, no error
        f = 60.0 / t
    words = format_fixed_rows([("F", f, 3)])
    return dict(zip(t.tolist(), [w[:-1] for w in words], strict=True))
