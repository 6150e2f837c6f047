"""The stream's point types: what the chain hands the writers.

:class:`Columns` is a record of equal-length arrays, one row per item (a point, a
block), whose rows are taken and whose records are joined field by field (the
planner's blocks and samples are such records too). :class:`PointChunk` is a run
of consecutive points with everything the chain computed for them;
:class:`Written` says how a dialect rounds its numbers, which the chain must know
to end a crossing of a motor's play beyond their rounding. All sit below the chain
and the writers, so neither imports the other.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, ClassVar, NamedTuple, TypeVar

import numpy as np

R = TypeVar("R", bound="Columns")


class Columns:
    """A record of arrays with one row per item: :data:`FIELDS` names them in the
    order the constructor takes them (a plain class, not a dataclass: equality and
    repr of arrays are of no use, and a dataclass's generated methods cost every
    command start-up to make)."""

    #: the fields, in the order the constructor takes them
    FIELDS: ClassVar[tuple[str, ...]] = ()

    def take(self: R, sel: slice | np.ndarray) -> R:
        """The rows ``sel`` (a slice, a mask or row numbers) of every field."""
        make: Any = type(self)
        if isinstance(sel, np.ndarray) and sel.dtype.kind in "iu":
            # rows by position: np.take gathers an (n, 5) array's rows several
            # times faster than fancy indexing does, the same values
            out: R = make(**{f: _rows(getattr(self, f), sel) for f in self.FIELDS})
        else:
            out = make(**{f: getattr(self, f)[sel] for f in self.FIELDS})
        return out

    @classmethod
    def joined(cls, parts: Sequence[Columns]) -> dict[str, np.ndarray]:
        """Every field of ``parts`` (records of this class) joined, by name."""
        return {f: np.concatenate([getattr(p, f) for p in parts]) for f in cls.FIELDS}


class PointChunk(Columns):
    """A run of consecutive points with everything the chain computed.

    q : (n, 5) [mm, mm, mm, deg, deg] the programmed path (workpiece frame)
    qdot : (n, 5) [mm/s, deg/s] its planned velocity
    dt : (n,) [s] time of the segment that ends at each point
    t : (n,) [s] time at each point from the program start
    line : (n,) source line
    first : (n,) bool, first point of its block
    tool_length : (n,) active G43 offset [mm]
    speed : (n,) planned path speed [mm/s or deg/s]
    dwell : (n,) bool, the path stands for dt here (a dwell, a machine function,
        or a motor crossing its play at rest)
    fn : (n,) object, the machine-function words at function points, else None
    block_end : (n,) bool, the last point of its block
    split : (n,) int8, a split program's part ends at rest at this point (1: a stop
        the program makes, 2: one put there for the split), else 0
    q_target : (n, 5) the pose handed to the IK, after the virtual-axis map
    P_ideal, V_ideal : (n, 5) [mm, mm/s] where the motors must be and how fast
    P_cmd, V_cmd : (n, 5) the commands after the real-axis tables and servo lead

    A :class:`~prsxy_post.points.Columns` record (rows taken, records joined field
    by field).
    """

    #: the fields, in the order the constructor takes them
    FIELDS: ClassVar[tuple[str, ...]] = (
        "q",
        "qdot",
        "dt",
        "t",
        "line",
        "first",
        "tool_length",
        "speed",
        "dwell",
        "fn",
        "block_end",
        "split",
        "q_target",
        "P_ideal",
        "V_ideal",
        "P_cmd",
        "V_cmd",
    )

    def __init__(
        self,
        q: np.ndarray,
        qdot: np.ndarray,
        dt: np.ndarray,
        t: np.ndarray,
        line: np.ndarray,
        first: np.ndarray,
        tool_length: np.ndarray,
        speed: np.ndarray,
        dwell: np.ndarray,
        fn: np.ndarray,
        block_end: np.ndarray,
        split: np.ndarray,
        q_target: np.ndarray,
        P_ideal: np.ndarray,
        V_ideal: np.ndarray,
        P_cmd: np.ndarray,
        V_cmd: np.ndarray,
    ) -> None:
        self.q = q
        self.qdot = qdot
        self.dt = dt
        self.t = t
        self.line = line
        self.first = first
        self.tool_length = tool_length
        self.speed = speed
        self.dwell = dwell
        self.fn = fn
        self.block_end = block_end
        self.split = split
        self.q_target = q_target
        self.P_ideal = P_ideal
        self.V_ideal = V_ideal
        self.P_cmd = P_cmd
        self.V_cmd = V_cmd

    def __len__(self) -> int:
        return len(self.dt)

    @staticmethod
    def concat(chunks: Sequence[PointChunk]) -> PointChunk:
        return PointChunk(**PointChunk.joined(chunks))

    @staticmethod
    def empty() -> PointChunk:
        def z(name: str) -> np.ndarray:
            if name in ("q", "qdot", "q_target", "P_ideal", "V_ideal", "P_cmd", "V_cmd"):
                return np.zeros((0, 5))
            if name == "split":
                return np.zeros(0, dtype=np.int8)
            if name in ("first", "dwell", "block_end"):
                return np.zeros(0, dtype=bool)
            if name == "line":
                return np.zeros(0, dtype=int)
            if name == "fn":
                return np.empty(0, dtype=object)
            return np.zeros(0)

        return PointChunk(**{f: z(f) for f in PointChunk.FIELDS})


class Written(NamedTuple):
    """How the output writes its numbers, for what must survive their rounding.

    space : "motor": each motor's position is written (a PVT program); "pose": the
        tip's pose x y z A B [mm, mm, mm, deg, deg], which the controller's own
        inverse kinematics turns into motor positions (corrected G-code)
    digit : the last written digit's value (10^-decimals)
    """

    space: str = "motor"
    digit: float = 1e-7


def _rows(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``a[idx]`` for integer rows ``idx``: np.take along the first axis for a
    table, plain indexing (faster there) for a column."""
    out: np.ndarray = np.take(a, idx, axis=0) if a.ndim > 1 else a[idx]
    return out
