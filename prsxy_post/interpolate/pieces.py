"""Planned blocks cut into the pieces the chain turns into points.

The look-ahead commits blocks in runs whose length depends on how the program
was fed to it (a chunk of motions at a time, or one); their values do not. The
chain makes a piece's points knowing only the points before it (a motor's
crossing of its play near the piece's end cannot see the next piece), so the
points would depend on where the runs end. Cutting them again at whole multiples
of :data:`PIECE_BLOCKS` from the program's first block makes the pieces, and so
the output, the same however the program was fed.

A plan travels with its points (:class:`Samples`), or with an array of rows per
block (the planner's steps per phase, from which the points of a piece are made
once it is whole: :meth:`~prsxy_post.chain.Planning.cut`).
"""

from __future__ import annotations

import numpy as np

from .lookahead import Plan
from .sampling import Samples

#: blocks in a piece: large enough that the chain's fixed cost per piece does not
#: count, small enough that a piece's points stay a few MB
PIECE_BLOCKS = 4096

#: what travels with a plan: its points, or an (n_blocks, ...) array of rows per block
Rows = Samples | np.ndarray


class Pieces:
    """Committed plans and their points (or rows per block: :data:`Rows`) in,
    pieces of :data:`PIECE_BLOCKS` out.

    ``add`` the runs in program order; ``take`` returns the pieces that are whole
    (every piece, the last one short, once ``final``)."""

    def __init__(
        self,
        size: int | None = None,
        runs: list[tuple[Plan, Rows]] | None = None,
        held: int = 0,
    ) -> None:
        self.size = PIECE_BLOCKS if size is None else size
        self.runs = [] if runs is None else runs
        self.held = held  # blocks in ``runs``

    def add(self, plan: Plan, samples: Rows) -> None:
        if len(plan.blocks):
            self.runs.append((plan, samples))
            self.held += len(plan.blocks)

    def take(self, final: bool = False) -> list[tuple[Plan, Rows]]:
        """The whole pieces held, in order (and the rest as one, with ``final``).

        A piece is joined from the parts of the runs it spans only (the rest of
        the last run is kept as it is, a view, until the next pieces need it):
        every point is copied once on its way through, not again with the runs
        held after it."""
        if self.held < self.size and not (final and self.held):
            return []
        # where each run begins among the blocks held
        begins = np.cumsum([0] + [len(p.blocks) for p, _ in self.runs]).tolist()
        out = []
        start = 0
        while self.held - start >= self.size or (final and start < self.held):
            stop = min(start + self.size, self.held)
            out.append(self._span(begins, start, stop))
            start = stop
        rest = self._parts(begins, start, self.held)
        self.runs = [(plan, samples) for plan, samples, _ in rest]
        self.held -= start
        return out

    def _parts(self, begins: list[int], start: int, stop: int) -> list[tuple[Plan, Rows, int]]:
        """Blocks start..stop of the runs held, run by run: (plan, points, index of
        the run) of each run's part."""
        out = []
        for j, (plan, samples) in enumerate(self.runs):
            lo, hi = max(start, begins[j]), min(stop, begins[j + 1])
            if lo < hi:
                out.append((*_between(plan, samples, lo - begins[j], hi - begins[j]), j))
        return out

    def _span(self, begins: list[int], start: int, stop: int) -> tuple[Plan, Rows]:
        """Blocks start..stop of the runs held as one plan and its points, as
        :func:`_between` cuts them out of all the runs joined."""
        parts = self._parts(begins, start, stop)
        plan, samples = _joined([(p, s) for p, s, _ in parts])
        j = parts[-1][2]
        if stop == begins[j + 1] and j + 1 < len(self.runs):
            # the tangent past the end: the next run's first block's (the runs
            # joined would give that block's)
            plan = Plan(plan.blocks, plan.law, self.runs[j + 1][0].blocks.dq_in[0])
        return plan, samples


def _joined(runs: list[tuple[Plan, Rows]]) -> tuple[Plan, Rows]:
    if len(runs) == 1:
        return runs[0]
    plan = Plan.concat([p for p, _ in runs])
    rows = [s for _, s in runs]
    if not isinstance(rows[0], Samples):
        return plan, np.concatenate(rows)  # type: ignore[arg-type]
    offsets = np.cumsum([0] + [len(p.blocks) for p, _ in runs[:-1]])
    return plan, Samples.concat(rows, [int(o) for o in offsets])  # type: ignore[arg-type]


def _between(plan: Plan, samples: Rows, start: int, stop: int) -> tuple[Plan, Rows]:
    """Blocks start..stop of a plan, with their points (``block`` counted from
    ``start``) or rows."""
    if start == 0 and stop == len(plan.blocks):
        return plan, samples
    if not isinstance(samples, Samples):
        return plan.head(stop).tail(start), samples[start:stop]
    lo, hi = np.searchsorted(samples.block, [start, stop])
    part = samples.take(slice(int(lo), int(hi)))
    part.block = part.block - start  # part is new: samples' own block stays as it is
    return plan.head(stop).tail(start), part
