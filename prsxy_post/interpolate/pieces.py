"""Planned blocks cut into the pieces the chain turns into points.

The look-ahead commits blocks in runs whose length depends on how the program
was fed to it (a chunk of motions at a time, or one); their values do not. The
chain makes a piece's points knowing only the points before it (a motor's
crossing of its play near the piece's end cannot see the next piece), so the
points would depend on where the runs end. Cutting them again at whole multiples
of :data:`PIECE_BLOCKS` from the program's first block makes the pieces, and so
the output, the same however the program was fed.
"""

from __future__ import annotations

import numpy as np

from .lookahead import Plan
from .sampling import Samples

#: blocks in a piece: large enough that the chain's fixed cost per piece does not
#: count, small enough that a piece's points stay a few MB
PIECE_BLOCKS = 4096


class Pieces:
    """Committed plans and their points in, pieces of :data:`PIECE_BLOCKS` out.

    ``add`` the runs in program order; ``take`` returns the pieces that are whole
    (every piece, the last one short, once ``final``)."""

    def __init__(
        self,
        size: int | None = None,
        runs: list[tuple[Plan, Samples]] | None = None,
        held: int = 0,
    ) -> None:
        self.size = PIECE_BLOCKS if size is None else size
        self.runs = [] if runs is None else runs
        self.held = held  # blocks in ``runs``

    def add(self, plan: Plan, samples: Samples) -> None:
        if len(plan.blocks):
            self.runs.append((plan, samples))
            self.held += len(plan.blocks)

    def take(self, final: bool = False) -> list[tuple[Plan, Samples]]:
        """The whole pieces held, in order (and the rest as one, with ``final``)."""
        if self.held < self.size and not (final and self.held):
            return []
        plan, samples = _joined(self.runs)
        out = []
        start = 0
        while self.held - start >= self.size or (final and start < self.held):
            stop = min(start + self.size, self.held)
            out.append(_between(plan, samples, start, stop))
            start = stop
        self.runs = [_between(plan, samples, start, self.held)] if start < self.held else []
        self.held -= start
        return out


def _joined(runs: list[tuple[Plan, Samples]]) -> tuple[Plan, Samples]:
    if len(runs) == 1:
        return runs[0]
    offsets = np.cumsum([0] + [len(p.blocks) for p, _ in runs[:-1]])
    plan = Plan.concat([p for p, _ in runs])
    return plan, Samples.concat([s for _, s in runs], [int(o) for o in offsets])


def _between(plan: Plan, samples: Samples, start: int, stop: int) -> tuple[Plan, Samples]:
    """Blocks start..stop of a plan, with their points (``block`` counted from
    ``start``)."""
    if start == 0 and stop == len(plan.blocks):
        return plan, samples
    lo, hi = np.searchsorted(samples.block, [start, stop])
    part = samples.take(slice(int(lo), int(hi)))
    part.block = part.block - start  # part is new: samples' own block stays as it is
    return plan.head(stop).tail(start), part
