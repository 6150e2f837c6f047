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
import math
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import errormap, kinematics
from .errors import LimitError, PrsxyError, ReachError
from .profile import MOTORS, Profile

if TYPE_CHECKING:
    from . import chain  # imported where used: the chain may use this module's rules
    from .gcode import FileLines, Motion

#: the kinds of problem, in the order they are listed for a line
KINDS = ("feed", "reach", "tilt", "travel")

#: motions fed to the chain at a time (the result does not depend on it)
CHUNK = 4096

#: a point is beyond a bound when it is beyond by more than this (mm, deg), as in
#: the chain's own checks: rounding is not a problem
TOLERANCE = 1e-9


@dataclass(frozen=True)
class Problem:
    """One kind of problem on one G-code line, at the line's worst point.

    kind : "feed", "reach", "tilt" or "travel"
    line : the G-code line
    value : the worst figure on the line: the motor command [mm] (travel), the
        tool-axis tilt [deg] (tilt), the programmed feed [mm/min] (feed), how far
        how much longer the worst strut would have to be [mm] (reach; inf where
        no platform pose exists)
    excess : how far ``value`` is beyond what the profile allows (same unit)
    motor : the motor (travel only)
    """

    kind: str
    line: int
    value: float
    excess: float
    motor: int | None = None

    def error(self, profile: Profile, source: str | None = None) -> PrsxyError:
        """The problem as the located error ``convert`` stops with."""
        what, _, expected = _words(self, profile)
        cls = ReachError if self.kind in ("reach", "travel") else LimitError
        return cls(what, source=source, line=self.line, expected=expected)


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
        what, figure, expected = _words(self.worst, profile, group=True)
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
    from . import chain, program
    from .convert import few_gc_passes

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
    from . import program

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
    from . import program

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


def _worst_per_line(excess: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """Index of the largest excess of each distinct line (among points with
    excess > TOLERANCE), in line order; ties go to the earlier point."""
    bad = np.nonzero(excess > TOLERANCE)[0]
    if bad.size == 0:
        return bad
    order = np.lexsort((bad, -excess[bad], lines[bad]))
    ranked = bad[order]
    _, first = np.unique(lines[ranked], return_index=True)
    return np.asarray(ranked[first])


def feed_problems(profile: Profile, motions: Sequence[Motion]) -> list[Problem]:
    """Programmed feeds above ``limits.max_feed_mm_min``, one per motion."""
    fmax = float(profile.limits.max_feed_mm_min)
    return [
        Problem("feed", m.line, m.feed, m.feed - fmax)
        for m in motions
        if m.kind in ("feed", "arc") and m.feed > fmax
    ]


def tilt_problems(profile: Profile, q: np.ndarray, line: np.ndarray) -> list[Problem]:
    """Tool-axis tilts beyond ``limits.max_tilt_deg``, worst point per line.

    q : (N, 5) programmed poses [mm, mm, mm, deg, deg]; line : (N,) their lines.
    The tool axis (cos A sin B, −sin A, cos A cos B) leans from vertical by
    arccos(cos A cos B).
    """
    lim = float(profile.limits.max_tilt_deg)
    a, b = np.radians(q[:, 3]), np.radians(q[:, 4])
    tilt = np.degrees(np.arccos(np.clip(np.cos(a) * np.cos(b), -1.0, 1.0)))
    return [
        Problem("tilt", int(line[i]), float(tilt[i]), float(tilt[i] - lim))
        for i in _worst_per_line(tilt - lim, line)
    ]


def reach_problems(
    geo: kinematics.Geometry,
    q_target: np.ndarray,
    tool_length: np.ndarray,
    P_ideal: np.ndarray,
    line: np.ndarray,
) -> list[Problem]:
    """Poses the struts cannot reach (NaN rows of the IK's ``P_ideal``), worst point
    per line, sized by how much longer the worst strut would have to be [mm].

    The ball joint of leg i is sqrt(L_i² − disc_i) from its guide line (disc_i the
    contract's (d·v)² − |v|² + L²), so the strut lacks that minus L_i; inf where
    no platform pose exists at all.
    """
    out = ~np.all(np.isfinite(P_ideal), axis=1)
    if not np.any(out):
        return []
    idx = np.nonzero(out)[0]
    pose = kinematics.solve_platform(geo, q_target[idx], tool_length[idx])
    disc = kinematics.strut_discriminant(geo, pose)
    with np.errstate(invalid="ignore"):
        lack = np.sqrt(geo.L[None, :] ** 2 - disc) - geo.L[None, :]
        short = np.max(lack, axis=1)
    short = np.where(np.isfinite(short), short, np.inf)
    excess = np.zeros(len(P_ideal))
    excess[idx] = np.maximum(short, 2 * TOLERANCE)
    return [
        Problem("reach", int(line[i]), float(excess[i]), float(excess[i]))
        for i in _worst_per_line(excess, line)
    ]


def travel_problems(profile: Profile, P_cmd: np.ndarray, line: np.ndarray) -> list[Problem]:
    """Motors commanded beyond their travel (``[[motors]] min/max``), worst point
    per line and motor.

    P_cmd : (N, 5) motor commands [mm], columns :data:`MOTORS`; NaN rows (out of
    reach) are left to :func:`reach_problems`.
    """
    lo = np.array([profile.motor(m).min for m in MOTORS])
    hi = np.array([profile.motor(m).max for m in MOTORS])
    ok = np.all(np.isfinite(P_cmd), axis=1)
    with np.errstate(invalid="ignore"):
        excess = np.maximum(P_cmd - hi[None, :], lo[None, :] - P_cmd)
    excess[~ok] = -np.inf
    return [
        Problem("travel", int(line[i]), float(P_cmd[i, col]), float(excess[i, col]), m)
        for col, m in enumerate(MOTORS)
        for i in _worst_per_line(excess[:, col], line)
    ]


def point_problems(
    profile: Profile, geo: kinematics.Geometry, pc: chain.PointChunk
) -> list[Problem]:
    """Tilt, reach and travel problems of a run of points from the chain."""
    return [
        *tilt_problems(profile, pc.q, pc.line),
        *reach_problems(geo, pc.q_target, pc.tool_length, pc.P_ideal, pc.line),
        *travel_problems(profile, pc.P_cmd, pc.line),
    ]


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

    def points(self, chunks: Sequence[chain.PointChunk]) -> None:
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


def _words(p: Problem, profile: Profile, group: bool = False) -> tuple[str, str, str]:
    """(what, figure, expected) of a problem: ``what`` as the chain says it for one
    point, or for a group; ``figure`` its worst value with its unit."""
    if p.kind == "travel":
        assert p.motor is not None
        mc = profile.motor(p.motor)
        what = (
            f"motor {p.motor} ({mc.axis}) commanded beyond its travel"
            if group
            else f"motor {p.motor} ({mc.axis}) commanded to {p.value:.4f} mm, beyond its travel"
        )
        expected = f"{mc.min:g} to {mc.max:g} mm (motors[{p.motor}].min/max)"
        return what, f"{p.value:.4f} mm", expected
    if p.kind == "tilt":
        lim = profile.limits.max_tilt_deg
        what = "tool axis tilted beyond the limit" if group else f"tool axis tilted {p.value:.3f}°"
        return what, f"{p.value:.3f}°", f"at most {lim:g}° (limits.max_tilt_deg)"
    if p.kind == "feed":
        lim = profile.limits.max_feed_mm_min
        what = (
            "feed above the machine's maximum"
            if group
            else f"feed F{p.value:g} mm/min is above the machine's maximum"
        )
        return what, f"F{p.value:g}", f"at most {lim:g} mm/min (limits.max_feed_mm_min)"
    short = "no platform pose" if math.isinf(p.value) else f"a strut short by {p.value:.4f} mm"
    what = (
        "pose out of the machine's reach" if group else f"pose out of the machine's reach ({short})"
    )
    return what, short, "a pose the struts can reach (see the profile's [kinematics])"
