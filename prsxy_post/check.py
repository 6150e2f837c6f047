"""Checking a program: everything the machine cannot do, found without writing.

The program runs through the same chain as ``convert`` (:mod:`prsxy_post.chain`,
every compensation stage the profile holds), streamed in bounded memory, and the
points it makes are judged exactly as written: a motor's travel on the motor
command after the real-axis tables and the servo lead (what a PMAC program
holds), the tilt on the programmed tool axis, the reach on the pose handed to
the inverse kinematics, the feed on the programmed F. Each problem is reported
once per G-code line at its worst point, and :meth:`CheckReport.groups` gathers
them by kind into line ranges with a count and the worst value.

Example
-------
>>> from prsxy_post import check, files
>>> prof = files.load_profile("profiles/prsxy-nominal.toml")
>>> report = check.check_text("G0 X304.8\\nM2\\n", prof, source="far.ngc")
>>> [str(g) for g in report.groups()]  # doctest: +SKIP
['far.ngc:1: motor 5 (X) commanded beyond its travel on line 1, worst 304.8000 mm ...']
"""

from __future__ import annotations

import contextlib
import itertools
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import chain, errormap, kinematics, program
from .errors import PrsxyError
from .profile import Profile
from .rules import KINDS, Problem, feed_problems, point_problems, problem_words
from .runtime import few_gc_passes

if TYPE_CHECKING:
    from .gcode import FileLines, Motion
    from .points import PointChunk

#: motions fed to the chain at a time (the result does not depend on it)
CHUNK = 4096


@dataclass(frozen=True)
class ProblemGroup:
    """Problems of one kind (and motor) over a program.

    ranges : (first, last) G-code lines of each run of lines with the problem; a
        run ends at a line that made points without it
    count : lines with the problem
    worst : the line whose problem is the largest
    """

    kind: str
    motor: int | None
    ranges: tuple[tuple[int, int], ...]
    count: int
    worst: Problem

    def describe(self, profile: Profile, source: str | None = None, max_ranges: int = 8) -> str:
        """``part.ngc:12: motor 5 (X) commanded beyond its travel on 40 lines
        (12-40, 52-63), worst 304.8000 mm at line 40 (expected -300 to 300 mm ...)``."""
        shown = [f"{a}" if a == b else f"{a}-{b}" for a, b in self.ranges[:max_ranges]]
        if len(self.ranges) > max_ranges:
            shown.append(f"and {len(self.ranges) - max_ranges} more runs")
        where = (
            f"on line {self.worst.line}"
            if self.count == 1
            else f"on {self.count} lines ({', '.join(shown)})"
        )
        what, figure, expected = problem_words(self.worst, profile, group=True)
        at = "" if self.count == 1 else f" at line {self.worst.line}"
        first = self.ranges[0][0]
        err = PrsxyError(
            f"{what} {where}, worst {figure}{at}",
            source=source,
            line=first,
            expected=expected,
        )
        return str(err)


@dataclass
class CheckReport:
    """What :func:`check_batches` found.

    problems : per line and kind (and motor), in line order
    stopped : the error that ended the check early (a G-code error, or a program
        beyond ``limits.max_points`` / ``max_time_s``); the problems before it are
        in ``problems``
    motions, points : how many the program made (up to ``stopped``)
    seconds : the program's running time by the interpolation [s]
    moved_lines : (n,) the G-code lines that made points, ascending
    """

    source: str
    problems: list[Problem]
    stopped: PrsxyError | None
    motions: int
    points: int
    seconds: float
    moved_lines: np.ndarray = field(repr=False)

    @property
    def ok(self) -> bool:
        return not self.problems and self.stopped is None

    def groups(self) -> list[ProblemGroup]:
        """The problems by kind (and motor), each with its runs of lines, in the
        order of their first line."""
        by: dict[tuple[str, int | None], list[Problem]] = {}
        for p in self.problems:
            by.setdefault((p.kind, p.motor), []).append(p)
        out = []
        for (kind, motor), ps in by.items():
            lines = np.array([p.line for p in ps])
            idx = np.searchsorted(self.moved_lines, lines)
            # a run goes on while the next problem line is the next line that moved
            cuts = np.nonzero(np.diff(idx) != 1)[0] + 1
            starts = np.concatenate([[0], cuts])
            ends = np.concatenate([cuts - 1, [len(lines) - 1]])
            ranges = tuple(
                (int(lines[a]), int(lines[b])) for a, b in zip(starts, ends, strict=True)
            )
            worst = max(ps, key=lambda p: (p.excess, -p.line))
            out.append(ProblemGroup(kind, motor, ranges, len(ps), worst))
        return sorted(out, key=lambda g: (g.ranges[0][0], KINDS.index(g.kind), g.motor or 0))


def check_batches(
    batches: Iterable[list[str]],
    profile: Profile,
    *,
    stages: chain.Stages | None = None,
    start: Sequence[float] | None = None,
    source: str = "<program>",
    on_message: Callable[[str, int, str, str], None] | None = None,
    lines_from: FileLines | None = None,
) -> CheckReport:
    """Run a program through the conversion chain and find what the machine cannot do.

    Parameters
    ----------
    batches : the program's lines in lists (:func:`prsxy_post.program.file_batches`)
    profile : the machine
    stages : which compensation stages run (default: all, as ``convert``)
    start : (x, y, z, A, B) [mm, deg] start pose instead of the profile's
    source : the program's name in errors
    on_message, lines_from : as :func:`prsxy_post.program.motions`

    Returns
    -------
    CheckReport
        Never raises for a problem of the program: a G-code error ends the
        check and is ``report.stopped``.
    """
    stages = stages or chain.Stages()
    emap = errormap.from_profile(profile) if stages.error_map else None
    pipe = chain.Pipeline(profile, stages, emap, start=start, collect=True)
    judge = _Judge(profile, pipe.geo)
    it = iter(batches)
    motions = program.motions(
        it, profile, start=start, source=source, on_message=on_message, lines_from=lines_from
    )
    stopped: PrsxyError | None = None
    n_motions = 0
    with few_gc_passes(), contextlib.closing(motions):
        try:
            while True:
                batch, stopped = _take(motions, CHUNK)
                n_motions += len(batch)
                judge.motions(batch)
                judge.points(pipe.feed(batch))
                if stopped is not None or len(batch) < CHUNK:
                    break
            if n_motions:  # the points before a G-code error are checked too
                judge.points(pipe.finish())
        except PrsxyError as err:  # the work guard: too many points or too long
            stopped = stopped or err
        finally:
            if isinstance(it, Generator):
                it.close()
    if stopped is not None:
        stopped = stopped.located(source=source)
    return judge.report(source, stopped, n_motions)


def check_file(
    path: str | Path,
    profile: Profile,
    *,
    stages: chain.Stages | None = None,
    start: Sequence[float] | None = None,
) -> CheckReport:
    """:func:`check_batches` of a program file, streamed (a binary file raises)."""
    return check_batches(
        program.file_batches(path),
        profile,
        stages=stages,
        start=start,
        source=str(path),
        lines_from=program.lines_of(path),
    )


def check_text(
    text: str,
    profile: Profile,
    *,
    stages: chain.Stages | None = None,
    start: Sequence[float] | None = None,
    source: str = "<string>",
) -> CheckReport:
    """:func:`check_batches` of program text."""
    return check_batches(
        program.text_batches(text), profile, stages=stages, start=start, source=source
    )


# ---------------------------------------------------------------- the judging


def _take(motions: Iterator[Motion], n: int) -> tuple[list[Motion], PrsxyError | None]:
    """Up to n motions, and the G-code error that ended them early (the motions
    before an error are kept)."""
    out: list[Motion] = []
    try:
        for m in itertools.islice(motions, n):
            out.append(m)
    except PrsxyError as err:
        return out, err
    return out, None


class _Judge:
    """Problems of the points and motions as they come, worst per line."""

    def __init__(self, profile: Profile, geo: kinematics.Geometry) -> None:
        self.profile = profile
        self.geo = geo
        self.found: dict[tuple[int, str, int | None], Problem] = {}
        self.lines: list[np.ndarray] = []
        self.n_points = 0
        self.seconds = 0.0

    def add(self, problems: Iterable[Problem]) -> None:
        for p in problems:
            key = (p.line, p.kind, p.motor)
            old = self.found.get(key)
            if old is None or p.excess > old.excess:  # a line that spans two chunks
                self.found[key] = p

    def motions(self, batch: Sequence[Motion]) -> None:
        found = feed_problems(self.profile, batch)
        self.add(found)
        if found:
            self.lines.append(np.array([p.line for p in found]))

    def points(self, chunks: Sequence[PointChunk]) -> None:
        for pc in chunks:
            if len(pc) == 0:
                continue
            self.n_points += len(pc)
            self.seconds += float(np.sum(pc.dt))
            self.lines.append(np.unique(pc.line))
            self.add(point_problems(self.profile, self.geo, pc))

    def report(self, source: str, stopped: PrsxyError | None, n_motions: int) -> CheckReport:
        problems = sorted(
            self.found.values(), key=lambda p: (p.line, KINDS.index(p.kind), p.motor or 0)
        )
        lines = np.unique(np.concatenate(self.lines)) if self.lines else np.zeros(0, int)
        return CheckReport(source, problems, stopped, n_motions, self.n_points, self.seconds, lines)
