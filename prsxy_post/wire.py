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
  point's source line and tool length are its block's, a block's first point is
  where the block number changes (as :func:`.interpolate.sampling.sample` makes
  them);
- a column zero in every bit on most rows (arc data on lines, split marks, the
  standing points) crosses as the rows that are not (:class:`Sparse`), an object
  column (machine functions, curves) as its rows that are not None;
- an integer column crosses in the narrowest integer type its values fit
  (:class:`Narrow`) and is widened on arrival.

Floats cross as they are (float64 stays float64). A Ready made in this process
(one process) is not packed at all: both paths give the same points.
"""

from __future__ import annotations

import dataclasses
from typing import Any, NamedTuple

import numpy as np

from .chain import BLOCKS_READ, LAW_READ, Piece, Ready, Solved
from .interpolate import Blocks, Plan, Samples, TimeLaw
from .points import PointChunk

#: a column crosses as its rows not zero where at most this share of them are not
SPARSE_SHARE = 0.25


class Sparse(NamedTuple):
    """A column of ``n`` rows, zero in every bit (None in an object column) but at
    rows ``at`` (k,), whose values are ``rows`` (k, ...)."""

    n: int
    at: np.ndarray
    rows: np.ndarray


class Narrow(NamedTuple):
    """An integer column ``values`` in a narrower type than its own, ``dtype``."""

    values: np.ndarray
    dtype: str


Column = np.ndarray | Sparse | Narrow | None


def _nonzero_rows(a: np.ndarray) -> np.ndarray:
    """(n,) bool: the rows of ``a`` (n, ...) with a bit set (−0.0 and NaN are not
    zero), or not None in an object column."""
    if a.dtype == object:
        return np.asarray(a != None, dtype=bool)  # noqa: E711 (elementwise)
    flat = a.reshape(len(a), int(np.prod(a.shape[1:])))  # (n, 1) for a column
    set_ = flat != 0
    if a.dtype.kind == "f":
        set_ |= np.signbit(flat)
    out: np.ndarray = set_.any(axis=1) if flat.shape[1] != 1 else set_[:, 0]
    return out


def _narrowed(a: np.ndarray) -> np.ndarray | Narrow:
    """An int64 (or int32) column in the narrowest signed type its values fit."""
    if a.dtype.kind not in "iu" or a.dtype.itemsize == 1 or not a.size:
        return a
    lo, hi = int(a.min()), int(a.max())
    for t in (np.int8, np.int16, np.int32):
        if t().itemsize < a.dtype.itemsize and np.iinfo(t).min <= lo and hi <= np.iinfo(t).max:
            return Narrow(a.astype(t), a.dtype.str)
    return a


def _sparse_at(a: np.ndarray, at: np.ndarray) -> Sparse:
    """``a`` (n, ...) as its rows ``at`` (k,) (the others zero, or None)."""
    idx = _narrowed(at.astype(np.int64))
    return Sparse(len(a), idx.values if isinstance(idx, Narrow) else idx, a[at])


def packed(a: np.ndarray | None) -> Column:
    """A column (n, ...) in its narrowest exact form: the rows not zero
    (:class:`Sparse`) where at most :data:`SPARSE_SHARE` of them are, an integer
    column narrowed (:class:`Narrow`), else itself."""
    if a is None:
        return None
    at = np.flatnonzero(_nonzero_rows(a))
    if a.dtype == object or len(at) <= SPARSE_SHARE * len(a):
        return _sparse_at(a, at)
    return _narrowed(a)


def unpacked(c: Column) -> Any:
    """A column as it was before :func:`packed` (the same bits, dtype and shape),
    or None where None was packed (an ndarray or None: typed Any, so that a record
    whose unread fields are None can be made)."""
    if isinstance(c, Narrow):
        return c.values.astype(c.dtype)
    if isinstance(c, Sparse):
        if c.rows.dtype == object:
            out = np.empty(c.n, dtype=object)
        else:
            out = np.zeros((c.n, *c.rows.shape[1:]), dtype=c.rows.dtype)
        out[c.at] = c.rows
        return out
    return c


def _functions(fn: np.ndarray, standing: np.ndarray) -> Sparse:
    """The machine functions (n,) object as the points that have one: they stand
    (``standing`` (n,) bool: a function point stands, PointChunk and Samples say),
    so only those are looked at, not every point of the chunk."""
    k = np.flatnonzero(standing)
    return _sparse_at(fn, k[np.asarray(fn[k] != None, dtype=bool)])  # noqa: E711


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
    blocks = {f: packed(getattr(b, f)) for f in fields}
    law = {f: packed(getattr(plan.law, f)) for f in (LAW_READ if plan_read else ())}
    points = {
        "q": s.q,
        "qdot": s.qdot,
        "dt": s.dt,
        "block": packed(s.block),
        "tau": s.tau,
        "speed": s.speed,
        "dwell": packed(s.dwell),
        "fn": _functions(s.fn, s.dwell),
        "block_end": s.block_end,
        "split": packed(s.split),
    }
    plan_ = {"blocks": blocks, "law": law, "next_dq_in": plan.next_dq_in}
    if solved is None:
        return plan_, points
    # the fields themselves (dataclasses.asdict would copy every array)
    poses = {f.name: getattr(solved, f.name) for f in dataclasses.fields(solved)}
    if solved.q_target is s.q:  # no map: the points' own poses, crossing once
        poses["q_target"] = None
    return plan_, points, poses


def _unpack_piece(
    plan_: dict[str, Any], points: dict[str, Any], poses: dict[str, Any] | None = None
) -> Piece:
    blocks = Blocks(**{f: unpacked(plan_["blocks"].get(f)) for f in Blocks.FIELDS})
    law = TimeLaw(*(unpacked(plan_["law"].get(f)) for f in TimeLaw._fields))
    s = _unpack_samples(points, blocks)
    solved = None
    if poses is not None:
        q_target = s.q if poses["q_target"] is None else poses["q_target"]
        solved = Solved(**(poses | {"q_target": q_target}))
    return Plan(blocks, law, plan_["next_dq_in"]), s, solved


def _unpack_samples(points: dict[str, Any], blocks: Blocks) -> Samples:
    """A piece's points from :func:`_pack_piece`'s: the line and tool length of
    each point its block's, the first point of a block where its number changes
    (as :func:`.interpolate.sampling.sample` makes them, and as a piece, cut at
    block ends, keeps them)."""
    block = unpacked(points["block"])
    assert block is not None
    first = np.ones(len(block), dtype=bool)
    first[1:] = block[1:] != block[:-1]
    return Samples(
        q=points["q"],
        qdot=points["qdot"],
        dt=points["dt"],
        line=blocks.line[block],
        block=block,
        tau=points["tau"],
        first=first,
        tool_length=blocks.tool_length[block],
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
        if name == "fn" and "dwell" in names:
            out[name] = _functions(chunk.fn, chunk.dwell)
        elif name in ("line", "split", "dwell", "fn"):
            out[name] = packed(getattr(chunk, name))
        else:
            out[name] = getattr(chunk, name)  # floats and the bools: as they are
    return out


def unpack_points(sent: dict[str, Column]) -> PointChunk:
    """A point chunk from :func:`pack_points`'s fields, the others None (so that a
    writer reading one it did not declare fails loudly)."""
    given: dict[str, Any] = {name: unpacked(sent.get(name)) for name in PointChunk.FIELDS}
    return PointChunk(**given)
