"""What crosses between a conversion's processes, in its narrowest exact form.

The interpreter process sends the chain each planned chunk (:class:`chain.Ready`:
pieces of plan, points and their poses through the map and the IK), and the chain
sends the writer process each chunk's points (the fields its writer reads,
:class:`.points.PointChunk`). Pickled whole, a Ready carries about 445 bytes a
point, its object columns pickled element by element. Here each crosses as what
the receiver reads, in forms that arrive bit for bit as they left:

- a field the receiver never reads does not cross; it arrives None, so a read of
  one fails loudly (:data:`chain.BLOCKS_READ`, a writer's ``reads``);
- a column the receiver makes again exactly from others crosses as nothing: a
  point's source line and tool length are its block's (as
  :func:`.interpolate.sampling.sample` makes them);
- a column zero in every bit on most rows (arc data on lines, split marks, the
  standing points) crosses as the rows that are not (:class:`Sparse`), an object
  column (machine functions, curves) as its rows that are not None, looked for
  only where the contract lets them be (function points stand, curves are at
  curve blocks).

Integer columns are not narrowed: checking that the values fit, and widening
them again, cost more CPU than the 4 bytes a point save in the pipe (measured
with bench/wire.py).

Floats cross as they are (float64 stays float64). A Ready made in this process
(one process) is not packed at all: both paths give the same points.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import numpy as np

from .chain import BLOCKS_READ, LAW_READ, Piece, Ready, Solved
from .interpolate import KIND_CURVE, Blocks, Plan, Samples, TimeLaw
from .points import PointChunk

#: a column crosses as its rows not zero where at most this share of them are not
SPARSE_SHARE = 0.25


class Sparse(NamedTuple):
    """A column of ``n`` rows, zero in every bit (None in an object column) but at
    rows ``at`` (k,), whose values are ``rows`` (k, ...)."""

    n: int
    at: np.ndarray
    rows: np.ndarray


Column = np.ndarray | Sparse | None


def _nonzero_rows(a: np.ndarray) -> np.ndarray:
    """(n,) bool: the rows of ``a`` (n, ...) with a bit set (−0.0 and NaN are not
    zero: the bits are compared, as unsigned integers of the same size)."""
    bits = a.view(f"u{a.dtype.itemsize}") != 0
    if bits.ndim == 1:
        return bits
    out: np.ndarray = bits.reshape(len(a), int(np.prod(a.shape[1:]))).any(axis=1)
    return out


def packed(a: np.ndarray | None) -> Column:
    """A numeric column (n, ...) as its rows not zero (:class:`Sparse`) where at
    most :data:`SPARSE_SHARE` of them are, else itself; an object column as its
    rows not None."""
    if a is None:
        return None
    if a.dtype == object:
        return _present(a, np.arange(len(a)))
    at = _nonzero_rows(a).nonzero()[0]
    return Sparse(len(a), at, a[at]) if len(at) <= SPARSE_SHARE * len(a) else a


def _present(values: np.ndarray, maybe: np.ndarray) -> Sparse:
    """An object column (n,) as its rows not None, which are among rows ``maybe``
    (k,) (the contract says where a value may be: only those are looked at)."""
    at = maybe[np.asarray(values[maybe] != None, dtype=bool)]  # noqa: E711 (elementwise)
    return Sparse(len(values), at, values[at])


#: the columns that are zero (or None) on most rows, the only ones looked at row
#: by row (:func:`packed`): arc data and the plane are zero on lines, the tool
#: length without G43; the standing points and split ends are few
MOSTLY_ZERO = frozenset(
    {"plane", "center", "sweep", "r0", "r1", "theta0", "tool_length", "dwell", "split"}
)


def _column(name: str, a: np.ndarray | None) -> Column:
    """Column ``name``: :func:`packed` if it is among :data:`MOSTLY_ZERO`, else as
    it is."""
    return packed(a) if name in MOSTLY_ZERO else a


def _nones(n: int) -> np.ndarray:
    """(n,) object, every row None: a view of one array that cannot be written to
    (what reads a chunk's machine functions only reads them; a write would raise),
    made again only when a longer one is asked for."""
    global _NONES
    if len(_NONES) < n:
        _NONES = np.empty(max(n, 2 * len(_NONES)), dtype=object)
        _NONES.flags.writeable = False
    return _NONES[:n]


_NONES = np.empty(0, dtype=object)


def unpacked(c: Column) -> Any:
    """A column as it was before :func:`packed` (the same bits, dtype and shape),
    or None where None was packed (an ndarray or None: typed Any, so that a record
    whose unread fields are None can be made)."""
    if not isinstance(c, Sparse):
        return c
    if c.rows.dtype == object:
        if not len(c.at):
            return _nones(c.n)
        out = np.empty(c.n, dtype=object)
    else:
        out = np.zeros((c.n, *c.rows.shape[1:]), dtype=c.rows.dtype)
    out[c.at] = c.rows
    return out


# -- a planned chunk, interpreter process -> chain
@dataclasses.dataclass
class SentReady:
    """A :class:`chain.Ready` as it crosses: its pieces packed (:func:`pack_ready`),
    the rest (problems, flags) as it is in ``ready``."""

    ready: Ready
    earlier: list[tuple[dict[str, Any], ...]]
    pieces: list[tuple[dict[str, Any], ...]]


def pack_ready(ready: Ready, plan_read: bool) -> SentReady:
    """A planned chunk as the chain reads it; ``plan_read``: a motor has play, and
    the chain reads the pieces' plans (:data:`chain.BLOCKS_READ`)."""
    return SentReady(
        dataclasses.replace(ready, earlier=[], pieces=[]),
        [_pack_piece(p, plan_read) for p in ready.earlier],
        [_pack_piece(p, plan_read) for p in ready.pieces],
    )


def unpack_ready(sent: SentReady) -> Ready:
    """The :class:`chain.Ready` :func:`pack_ready` was given, every field the chain
    reads the same bits."""
    return dataclasses.replace(
        sent.ready,
        earlier=[_unpack_piece(*p) for p in sent.earlier],
        pieces=[_unpack_piece(*p) for p in sent.pieces],
    )


def _pack_piece(piece: Piece, plan_read: bool) -> tuple[dict[str, Any], ...]:
    """A piece's plan (the blocks' fields read, and those its points are made
    again from), points and poses solved, packed."""
    plan, s, solved = piece
    b = plan.blocks
    fields = (*BLOCKS_READ, "line", "tool_length") if plan_read else ("line", "tool_length")
    blocks = {f: _column(f, getattr(b, f)) for f in fields}
    if "curve" in blocks:  # a spline's Nurbs, at curve blocks only (Blocks says)
        blocks["curve"] = _present(b.curve, (b.kind == KIND_CURVE).nonzero()[0])
    law = {f: getattr(plan.law, f) for f in (LAW_READ if plan_read else ())}
    points = {
        "q": s.q,
        "qdot": s.qdot,
        "dt": s.dt,
        "block": s.block,
        "tau": s.tau,
        "first": s.first,  # 1 B a point: cheaper to send than to make again
        "speed": s.speed,
        "dwell": packed(s.dwell),
        "fn": _present(s.fn, s.dwell.nonzero()[0]),  # a function point stands
        "block_end": s.block_end,
        "split": packed(s.split),
    }
    plan_ = {"blocks": blocks, "law": law, "next_dq_in": plan.next_dq_in}
    if solved is None:
        return plan_, points
    # the fields themselves (dataclasses.asdict would copy every array)
    poses = dict(vars(solved))
    if solved.q_target is s.q:  # no map: the points' own poses, crossing once
        poses["q_target"] = None
    return plan_, points, poses


def _unpack_piece(
    plan_: dict[str, Any], points: dict[str, Any], poses: dict[str, Any] | None = None
) -> Piece:
    blocks = Blocks(**{f: unpacked(plan_["blocks"].get(f)) for f in Blocks.FIELDS})
    law = TimeLaw(*(unpacked(plan_["law"].get(f)) for f in TimeLaw._fields))
    tool = plan_["blocks"]["tool_length"]
    s = _unpack_samples(points, blocks, isinstance(tool, Sparse) and not len(tool.at))
    solved = None
    if poses is not None:
        q_target = s.q if poses["q_target"] is None else poses["q_target"]
        solved = Solved(**(poses | {"q_target": q_target}))
    return Plan(blocks, law, plan_["next_dq_in"]), s, solved


def _unpack_samples(points: dict[str, Any], blocks: Blocks, no_tool: bool) -> Samples:
    """A piece's points from :func:`_pack_piece`'s: the line and tool length of
    each point its block's (as :func:`.interpolate.sampling.sample` makes them);
    ``no_tool``: every block's tool length is 0.0."""
    block = points["block"]
    # no tool length offset in the piece (most programs): zeros, not gathered
    tool = np.zeros(len(block)) if no_tool else blocks.tool_length[block]
    return Samples(
        q=points["q"],
        qdot=points["qdot"],
        dt=points["dt"],
        line=blocks.line[block],
        block=block,
        tau=points["tau"],
        first=points["first"],
        tool_length=tool,
        speed=points["speed"],
        dwell=unpacked(points["dwell"]),
        fn=unpacked(points["fn"]),
        block_end=points["block_end"],
        split=unpacked(points["split"]),
    )


# -- a chunk of points, chain -> writer process
def pack_points(chunk: PointChunk, names: tuple[str, ...]) -> dict[str, Column]:
    """The fields ``names`` of a point chunk, packed (:func:`packed`); the machine
    functions looked for at the standing points only, where the dwell column is
    among them."""
    out: dict[str, Column] = {}
    for name in names:
        if name == "fn" and "dwell" in names:  # a function point stands (PointChunk)
            out[name] = _present(chunk.fn, chunk.dwell.nonzero()[0])
        else:
            out[name] = _column(name, getattr(chunk, name))
    return out


def unpack_points(sent: dict[str, Column]) -> PointChunk:
    """A point chunk from :func:`pack_points`'s fields, the others None (so that a
    writer reading one it did not declare fails loudly)."""
    given: dict[str, Any] = {name: unpacked(sent.get(name)) for name in PointChunk.FIELDS}
    return PointChunk(**given)
