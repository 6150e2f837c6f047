"""Motions as rows of one float table: what planning reads of them, without a
Python object per move.

In rows mode (:func:`.stream.iter_motion_items`) the compiled fast path writes
the moves it takes straight into a ``(n, WIDTH)`` float array instead of making a
:class:`~.motion.Motion` each; every other motion still comes as a Motion. A
stream of both is cut into chunks of a given number of motions
(:func:`chunks`) and a chunk made into one :class:`MotionTable`
(:func:`table`), the same whichever way its motions came.

A row holds the fields planning and the program checks read (``ROW_*``
columns): line, kind (``KIND_*``), start and end [mm, mm, mm, deg, deg], feed
(NaN for rapids, dwells and functions), the arc's plane, centre and rotation
(zero on other kinds), tool length [mm], path tolerance (NaN where the program
set none) and dwell duration [s]. A Motion's tool, spindle and inverse-time flag
are not in it; machine-function words and curves are kept beside the rows.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Iterator, Sequence
from typing import NamedTuple

import numpy as np

from .motion import Motion

KIND_RAPID, KIND_FEED, KIND_ARC, KIND_DWELL, KIND_FUNCTION, KIND_CURVE = 0, 1, 2, 3, 4, 5
#: a Motion's kind to its code
KIND = {
    "rapid": KIND_RAPID,
    "feed": KIND_FEED,
    "arc": KIND_ARC,
    "dwell": KIND_DWELL,
    "function": KIND_FUNCTION,
    "curve": KIND_CURVE,
}

#: the columns of a row (slices: start, end, centre)
ROW_LINE = 0
ROW_KIND = 1
ROW_START = slice(2, 7)
ROW_END = slice(7, 12)
ROW_FEED = 12
ROW_PLANE = 13
ROW_CENTER = slice(14, 17)
ROW_ROTATION = 17
ROW_TOOL_LENGTH = 18
ROW_PATH_TOL = 19
ROW_DURATION = 20
WIDTH = 21

#: what the stream yields in rows mode: a motion, or a run of moves as rows
Item = Motion | np.ndarray


def new_rows(shape: tuple[int, int]) -> np.ndarray:
    """Room for a run of rows (the compiled fast path fills it)."""
    return np.empty(shape)


def row_of(m: Motion) -> tuple[float, ...]:
    """One motion as a row (``ROW_*`` columns)."""
    if m.kind == "arc":
        assert m.center is not None
        plane, center, rotation = m.plane, m.center, m.rotation
    else:
        plane, center, rotation = 0, (0.0, 0.0, 0.0), 0
    return (
        m.line,
        KIND[m.kind],
        *m.start,
        *m.end,
        m.feed,
        plane,
        *center,
        rotation,
        m.tool_length,
        math.nan if m.path_tol is None else m.path_tol,
        m.duration,
    )


def rows_of(motions: Sequence[Motion]) -> np.ndarray:
    """(n, WIDTH) the rows of motions (:func:`row_of` of each, filled a column at
    a time)."""
    n = len(motions)
    out = np.zeros((n, WIDTH))
    if not n:
        return out
    # one pass over the motions (Motion is a tuple): a column per field
    cols = list(zip(*motions, strict=True))
    f = Motion._fields.index
    out[:, ROW_LINE] = np.fromiter(cols[f("line")], float, n)
    kinds = cols[f("kind")]
    out[:, ROW_KIND] = np.fromiter((KIND[k] for k in kinds), float, n)
    out[:, ROW_START] = _poses(cols[f("start")])
    out[:, ROW_END] = _poses(cols[f("end")])
    out[:, ROW_FEED] = np.fromiter(cols[f("feed")], float, n)
    arcs = [i for i, k in enumerate(kinds) if k == "arc"]
    if arcs:
        planes, centers, turns = cols[f("plane")], cols[f("center")], cols[f("rotation")]
        out[arcs, ROW_PLANE] = [planes[i] for i in arcs]
        out[arcs, ROW_CENTER] = [centers[i] for i in arcs]
        out[arcs, ROW_ROTATION] = [turns[i] for i in arcs]
    out[:, ROW_TOOL_LENGTH] = np.fromiter(cols[f("tool_length")], float, n)
    out[:, ROW_PATH_TOL] = np.fromiter(
        (math.nan if t is None else t for t in cols[f("path_tol")]), float, n
    )
    out[:, ROW_DURATION] = np.fromiter(cols[f("duration")], float, n)
    return out


def _poses(col: Sequence[Sequence[float]]) -> np.ndarray:
    """(n, 5) the poses of a column of them (each five numbers)."""
    return np.fromiter(itertools.chain.from_iterable(col), float, 5 * len(col)).reshape(-1, 5)


class MotionTable(NamedTuple):
    """A chunk of motions as rows.

    rows : (n, WIDTH) float, ``ROW_*`` columns
    objects : (row, motion) of the function and curve motions, whose words and
        curve the rows cannot hold
    """

    rows: np.ndarray
    objects: list[tuple[int, Motion]]

    def __len__(self) -> int:
        return len(self.rows)


def _special(m: Motion) -> bool:
    return m.kind == "function" or m.kind == "curve"


def table(items: Sequence[Item]) -> MotionTable:
    """The rows of a chunk of motions and runs of rows, in order."""
    parts: list[np.ndarray] = []
    objects: list[tuple[int, Motion]] = []
    at = 0
    group: list[Motion] = []  # the Motions since the last run of rows

    def close() -> None:
        nonlocal at, group
        objects.extend((at + j, m) for j, m in enumerate(group) if _special(m))
        parts.append(rows_of(group))
        at += len(group)
        group = []

    for item in items:
        if type(item) is np.ndarray:
            if group:
                close()
            parts.append(item)
            at += len(item)
        else:
            group.append(item)  # type: ignore[arg-type]
    if group:
        close()
    if not parts:
        return MotionTable(np.empty((0, WIDTH)), objects)
    rows = parts[0] if len(parts) == 1 else np.concatenate(parts)
    return MotionTable(rows, objects)


def count(item: Item) -> int:
    """Motions in an item."""
    return len(item) if type(item) is np.ndarray else 1


def chunks(items: Iterable[Item], size: int) -> Iterator[list[Item]]:
    """The items in chunks of ``size`` motions (runs of rows cut where a chunk
    ends), the last one shorter (empty when the motions fill the chunks before
    it), as ``itertools.islice`` cuts a stream of motions. An error the items
    raise is raised as it comes, the chunk under way dropped."""
    chunk: list[Item] = []
    held = 0
    for item in items:
        if type(item) is not np.ndarray:  # a Motion
            chunk.append(item)
            held += 1
            if held == size:
                yield chunk
                chunk, held = [], 0
            continue
        n = len(item)
        while held + n >= size:
            cut = size - held
            chunk.append(item[:cut])
            item = item[cut:]
            yield chunk
            chunk, held, n = [], 0, n - cut
        if n:
            chunk.append(item)
            held += n
    yield chunk
