"""The ``prsxy-post`` command line: the only module that reads files, prints or exits.

Exit codes: 0 success, 1 bad input, 2 bad usage, 3 internal error (a bug:
rerun with ``--debug`` for the traceback and report it).
"""

from __future__ import annotations

import functools
import os
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NoReturn

from . import blas_threads  # noqa: F401  (before numpy: OpenBLAS reads it once)

# isort: split
import click
import numpy as np

from . import __version__, allocator, kernel
from .errors import EXIT_INTERNAL, PrsxyError, UsageError
from .files import clash, read_text, sha256_of
from .files import load_profile as _load_profile
from .files import write_atomic as _write_atomic
from .profile import MOTORS, Profile
from .writers import DIALECTS

if TYPE_CHECKING:
    from .measure import AxisData, BallbarRun, PoseData


#: the exit code after Ctrl-C (128 + SIGINT, as shells report it)
EXIT_INTERRUPTED = 130


def load_profile(path: str) -> Profile:
    """A profile, with what the user should know about it said on stderr."""
    prof = _load_profile(path)
    for note in prof.notes:
        click.echo(f"{path}: {note}", err=True)
    return prof


def parse_pose(text: str, option: str) -> tuple[float, ...]:
    parts = text.replace(" ", "").split(",")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise UsageError(
            f"{option} {text!r} is not five numbers", expected="x,y,z,a,b in mm and degrees"
        ) from None
    if len(vals) != 5 or not all(np.isfinite(vals)):
        raise UsageError(
            f"{option} {text!r} is not five finite numbers", expected="x,y,z,a,b in mm and degrees"
        )
    return vals


# ------------------------------------------------------------------ error handling


class Ctx:
    """The command's context object: --debug, and the files the command has
    written (whole), for what Ctrl-C says."""

    def __init__(self, debug: bool = False, quiet: bool = False) -> None:
        self.debug = debug
        self.quiet = quiet
        self.written: list[str] = []


def write_atomic(files: dict[Path, str] | dict[Path, bytes] | dict[Path, str | bytes]) -> None:
    """:func:`files.write_atomic`, remembering what the command wrote."""
    _write_atomic(files)
    ctx = click.get_current_context(silent=True)
    obj = ctx.find_object(Ctx) if ctx is not None else None
    if obj is not None:
        obj.written += [str(p) for p in files]


def fail(err: PrsxyError) -> NoReturn:
    click.echo(str(err), err=True)
    sys.exit(err.exit_code)


def say(source: str, line: int, kind: str, text: str) -> None:
    """A program's (MSG,…), (DEBUG,…), (PRINT,…) on standard error, as LinuxCNC
    shows them to the operator (module level: it crosses to worker processes)."""
    sys.stderr.write(f"{source}:{line}: ({kind}) {text.strip()}\n")
    sys.stderr.flush()


def guarded(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Run a command: user errors become one located line, bugs exit 3."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        ctx = click.get_current_context().find_object(Ctx) or Ctx()
        try:
            return fn(*args, **kwargs)
        except PrsxyError as err:
            if ctx.debug:
                import traceback

                traceback.print_exc()
            fail(err)
        except (click.exceptions.Exit, click.exceptions.Abort, click.ClickException):
            raise
        except KeyboardInterrupt:
            if ctx.written:  # Ctrl-C after the writing, while it printed
                click.echo(f"interrupted; written whole: {', '.join(ctx.written)}", err=True)
            else:
                click.echo("interrupted; no output written", err=True)
            sys.exit(EXIT_INTERRUPTED)
        except BrokenPipeError:
            # the reader went away (prsxy-post inspect big.ngc | head): stop quietly,
            # and keep Python from complaining when it flushes stdout at exit
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, sys.stdout.fileno())
            sys.exit(1)
        except Exception as exc:  # a bug: say so plainly
            if ctx.debug:
                import traceback

                traceback.print_exc()
            click.echo(
                f"internal error: {type(exc).__name__}: {exc} (this is a bug in "
                f"prsxy-post {__version__}; rerun with --debug and report it)",
                err=True,
            )
            sys.exit(EXIT_INTERNAL)

    return wrapper


# ------------------------------------------------------------------ the group

#: The examples each command's --help ends with, by command ("" is the program).
#: tests/test_cli_everyday.py parses every one against the command's options.
EXAMPLES: dict[str, tuple[str, ...]] = {
    "": (
        "prsxy-post convert part.ngc --profile shop.toml -o part.pmc",
        "prsxy-post check part.ngc --profile shop.toml",
        "prsxy-post COMMAND --help",
    ),
    "inspect": (
        "prsxy-post inspect part.ngc",
        "prsxy-post inspect part.ngc --profile shop.toml --json",
    ),
    "convert": (
        "prsxy-post convert part.ngc --profile shop.toml -o part.pmc",
        "prsxy-post convert part.ngc --profile shop.toml            # writes part.pmc",
        "prsxy-post convert *.ngc --profile shop.toml --out-dir pmc/ --jobs 2",
        "prsxy-post convert part.ngc --profile shop.toml --format gcode -o part-comp.ngc",
        "prsxy-post convert part.ngc --profile shop.toml -o - | less",
    ),
    "check": (
        "prsxy-post check part.ngc --profile shop.toml",
        "prsxy-post check part.ngc --profile shop.toml --each-line",
    ),
    "simulate": (
        "prsxy-post simulate --truth machine.toml --profile shop.toml -o measured/",
        "prsxy-post simulate --truth machine.toml --profile shop.toml -o bb/ --only-xy",
    ),
    "calibrate": (
        "prsxy-post calibrate measured/*.csv --profile shop.toml -o calibrated.toml",
        "prsxy-post calibrate axis.csv --profile shop.toml --stages tables -o shop.toml --in-place",
    ),
    "diagnose": (
        "prsxy-post diagnose measured/*.csv --profile calibrated.toml",
        "prsxy-post diagnose measured/*.csv --profile cal.toml -o updated.toml --report rep/",
    ),
    "ballbar": (
        "prsxy-post ballbar xy-r50-ccw.csv xy-r50-cw.csv",
        "prsxy-post ballbar run*.csv --plot ballbar.png --profile shop.toml",
        "prsxy-post ballbar ballbar-*.csv --report bb-report/",
    ),
    "kinematics": (
        "prsxy-post kinematics --profile shop.toml -o kinematics.pmc",
        "prsxy-post kinematics --profile shop.toml -o kinematics.pmc --program part.ngc",
    ),
    "tables": (
        "prsxy-post tables export --profile shop.toml --format linuxcnc1 --out-dir comp/",
        "prsxy-post tables export --profile shop.toml --format pmac --out-dir pmac/",
        "prsxy-post tables import comp/motor5.comp --profile a.toml --format linuxcnc1 -o b.toml",
    ),
    "tables export": (
        "prsxy-post tables export --profile shop.toml --format linuxcnc1 --out-dir comp/",
        "prsxy-post tables export --profile shop.toml --format pmac --out-dir pmac/",
    ),
    "tables import": (
        "prsxy-post tables import comp/motor5.comp --profile a.toml --format linuxcnc1 -o b.toml",
        "prsxy-post tables import pmac/axis-tables.pmc --profile shop.toml --format pmac -o b.toml",
    ),
}


class _Examples(click.Command):
    """Ends --help with the command's :data:`EXAMPLES`, as written."""

    def format_epilog(self, ctx: click.Context, formatter: click.HelpFormatter) -> None:
        super().format_epilog(ctx, formatter)
        names, c = [], ctx
        while c.parent is not None:  # the command's path below the program
            names.append(c.info_name or "")
            c = c.parent
        examples = EXAMPLES.get(" ".join(reversed(names)))
        if examples:
            with formatter.section("Examples"):
                for ex in examples:
                    formatter.write(" " * formatter.current_indent + ex + "\n")


class _Group(_Examples, click.Group):
    command_class = _Examples
    group_class = type  # sub-groups (tables) are made alike


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(
    __version__, prog_name="prsxy-post", message=f"%(prog)s %(version)s\nkernel: {kernel.NAME}"
)
@click.option("--debug", is_flag=True, help="Show a traceback with errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Error-compensating post-processor for the PRS-XY hybrid machine tool.

    Exit codes: 0 success, 1 bad input, 2 bad usage, 3 internal error.
    """
    ctx.obj = Ctx(debug=debug)
    if kernel.MISSING:
        click.echo(
            f"prsxy-post: warning: {kernel.WHY_PURE}; running the pure numpy kernel "
            "(the same output, several times slower)",
            err=True,
        )


profile_option = click.option(
    "--profile",
    "profile_path",
    required=True,
    type=click.Path(dir_okay=False),
    help="Machine profile (TOML).",
)
start_option = click.option(
    "--start",
    default=None,
    metavar="X,Y,Z,A,B",
    help="Start pose (workpiece frame); default the profile's.",
)


# ------------------------------------------------------------------ inspect


@main.command()
@click.argument("program", type=click.Path(dir_okay=False, allow_dash=True))
@click.option(
    "--profile",
    "profile_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="Profile for work offsets, tools, G28/G30 and start pose.",
)
@start_option
@click.option("--json", "as_json", is_flag=True, help="One JSON object per motion and line.")
@guarded
def inspect(program: str, profile_path: str | None, start: str | None, as_json: bool) -> None:
    """Print the interpreted motions of PROGRAM (workpiece frame, mm, degrees)."""
    import json

    from . import gcode
    from . import program as prog

    prof = load_profile(profile_path) if profile_path else None
    st = parse_pose(start, "--start") if start else None
    if program == "-":
        batches = prog.text_batches(read_text(program, "G-code program"))
    else:
        batches = prog.file_batches(program)
    out = sys.stdout
    for m in prog.motions(
        batches, prof, start=st, source=program, on_message=say, lines_from=prog.lines_of(program)
    ):
        d = gcode.motion_to_json(m)
        if as_json:
            out.write(json.dumps(d) + "\n")
        else:
            end = " ".join(f"{v:.4f}" for v in m.end)
            extra = ""
            if d["kind"] == "arc":
                extra = f" G{d['plane']} centre {d['center']} rotation {d['rotation']}"
            if d["kind"] == "function":
                extra = " " + " ".join(str(w) for w in d["words"])  # type: ignore[attr-defined]
            feed = "" if m.kind in ("rapid", "dwell", "function") else f" F{m.feed:g}"
            out.write(f"{d['line']:>6} {d['kind']:<5} {end}{feed}{extra}\n")


# ------------------------------------------------------------------ convert


def _stderr_is_terminal() -> bool:
    """Whether standard error is a terminal (progress bars go only there)."""
    return sys.stderr.isatty()


def _size_of(path: str) -> int:
    try:
        return os.path.getsize(path)
    except OSError:
        return 0


def _clock(seconds: float) -> str:
    """A duration as m:ss, or h:mm:ss from an hour on."""
    s = max(0, round(seconds))
    if s >= 3600:
        return f"{s // 3600}:{s // 60 % 60:02d}:{s % 60:02d}"
    return f"{s // 60}:{s % 60:02d}"


class _Progress:
    """A one-line progress display on a terminal's stderr: the program, how much
    of it is read, and the time left at the rate so far (ETA). The line is
    erased when the program is done, before the next one's."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.job: Any = None
        self.started = 0.0

    def __call__(self, job: Any, done: int, total: int) -> None:
        now = self.clock()
        if job is not self.job:
            self.close()
            self.job, self.started = job, now
        frac = min(1.0, done / max(total, 1))
        elapsed = now - self.started
        eta = ""
        if frac > 0 and elapsed >= 1.0:  # the rate so far, once there is one
            eta = f"  ETA {_clock(elapsed * (1.0 - frac) / frac)}"
        self._show(f"{job.program}: {100.0 * frac:5.1f}%{eta}")

    def close(self) -> None:
        if self.job is not None:
            self._show("")
            self.job = None

    def batch(self, jobs: Sequence[Any]) -> Callable[[Any], None]:
        """``finished(outcome)`` for programs converted in parallel: the line
        shows how many are done and, by their sizes, the time left."""
        size = {id(j): _size_of(j.program) for j in jobs}
        total = sum(size.values())
        state = {"done": 0, "failed": 0, "bytes": 0}
        started = self.clock()

        def finished(outcome: Any) -> None:
            state["done" if outcome.state == "done" else "failed"] += 1
            state["bytes"] += size[id(outcome.job)]
            frac = state["bytes"] / total if total else 1.0
            elapsed = self.clock() - started
            eta = f"  ETA {_clock(elapsed * (1.0 - frac) / frac)}" if frac > 0 else ""
            failed = f", {state['failed']} failed" if state["failed"] else ""
            self._show(f"{len(jobs)} programs: {state['done']} done{failed}{eta}")

        self.job = jobs  # so that close() erases the line
        self._show(f"{len(jobs)} programs: 0 done")
        return finished

    @staticmethod
    def _show(text: str) -> None:
        # written as is: click.echo would strip the erase-line code off a non-tty
        sys.stderr.write(f"\r\x1b[K{text}")
        sys.stderr.flush()


@main.command()
@click.argument(
    "programs", nargs=-1, required=True, type=click.Path(dir_okay=False, allow_dash=True)
)
@profile_option
@click.option(
    "--format",
    "fmt",
    type=click.Choice(sorted(DIALECTS)),
    default="pmac",
    show_default=True,
    help="; ".join(f"{n}: {d.summary}" for n, d in sorted(DIALECTS.items())) + ".",
)
@click.option(
    "-o",
    "--output",
    default=None,
    help="Output file for one program ('-' for standard output); default: beside "
    "the program, with the format's extension (part.ngc -> part.pmc).",
)
@click.option(
    "--out-dir",
    default=None,
    type=click.Path(file_okay=False),
    help="Directory for the outputs (one per program, named after it).",
)
@click.option(
    "--jobs",
    "-j",
    default=1,
    show_default=True,
    type=click.IntRange(1, 64),
    help="Programs converted in parallel processes.",
)
@start_option
@click.option("--no-error-map", is_flag=True, help="Skip the virtual-axis error map stage.")
@click.option("--no-axis-comp", is_flag=True, help="Skip the real-axis tables stage.")
@click.option(
    "--nominal-kinematics",
    is_flag=True,
    help="Use the nominal design in the IK instead of the calibrated geometry.",
)
@click.option("--quiet", "-q", is_flag=True, help="Print nothing but errors.")
@guarded
def convert(
    programs: Sequence[str],
    profile_path: str,
    fmt: str,
    output: str | None,
    out_dir: str | None,
    jobs: int,
    start: str | None,
    no_error_map: bool,
    no_axis_comp: bool,
    nominal_kinematics: bool,
    quiet: bool,
) -> None:
    """Convert G-code PROGRAMS into compensated motor programs (or corrected G-code).

    Each output goes beside its program with the format's extension (part.ngc ->
    part.pmc), to -o FILE, or into --out-dir; -o - writes to standard output. An
    output never replaces an input (a program or the profile). Outputs are written
    atomically: a failed conversion leaves no partial file and never replaces an
    existing one.
    """
    if output and out_dir:
        raise UsageError("-o and --out-dir given together", expected="one of them")
    if output and len(programs) > 1:
        raise UsageError(
            f"-o names one output but {len(programs)} programs were given",
            expected="--out-dir DIR for several programs",
        )
    from . import chain
    from . import convert as conv

    load_profile(profile_path)  # fail once, early, on a bad profile
    st = parse_pose(start, "--start") if start else None
    stages = chain.Stages(not no_error_map, not nominal_kinematics, not no_axis_comp)
    opts = [f"--format {fmt}"]
    opts += [
        f
        for f, on in (
            ("--no-error-map", no_error_map),
            ("--no-axis-comp", no_axis_comp),
            ("--nominal-kinematics", nominal_kinematics),
        )
        if on
    ]
    if start:
        opts.append(f"--start {start}")
    ext = DIALECTS[fmt].extension
    pooled = jobs > 1 and len(programs) > 1
    jobs_list = []
    outs = [_output_of(prog, ext, output, out_dir) for prog in programs]
    seen: dict[Path, str] = {}
    for prog, out in zip(programs, outs, strict=True):
        first = seen.setdefault(Path(out).resolve(), prog)
        if first != prog and out != "-":
            raise UsageError(
                f"{first} and {prog} would both be written to {out}",
                expected="programs with different names, or one convert per directory",
            )
        hit = clash(out, {f"G-code program {prog}": prog, f"profile {profile_path}": profile_path})
        if hit is not None:
            if output:
                raise UsageError(
                    f"-o {output} would overwrite the {hit[0]}", expected="another output file"
                )
            if out_dir:
                raise UsageError(
                    f"--out-dir {out_dir} would write {out} over the {hit[0]}",
                    expected="another directory, or -o FILE",
                )
            raise UsageError(
                f"the default output {out} (the program's name with the {fmt} format's "
                f"extension) would overwrite the {hit[0]}",
                expected="-o FILE or --out-dir DIR for the output",
            )
    for prog, out in zip(programs, outs, strict=True):
        jobs_list.append(
            conv.ConvertJob(
                prog,
                profile_path,
                fmt,
                out,
                st,
                stages,
                " ".join(opts),
                parallel=not pooled and conv.worth_a_second_process(prog),
                on_message=say,
            )
        )
    _run_conversions(jobs_list, jobs if pooled else 1, quiet)


def _run_conversions(jobs: Sequence[Any], workers: int, quiet: bool) -> None:
    """Convert, with a progress line on a terminal (the program being read, or
    with --jobs the programs done), and say what was written; after Ctrl-C, what
    was written whole and what not."""
    from . import batch

    bar = _Progress() if not quiet and _stderr_is_terminal() else None
    try:
        outcomes = batch.convert_many(
            jobs,
            workers=workers,
            progress=bar if workers == 1 else None,
            finished=bar.batch(jobs) if bar is not None and workers > 1 else None,
        )
    except batch.Interrupted as stop:
        if bar is not None:
            bar.close()
        _say_outcomes(stop.outcomes, quiet=True)
        click.echo(_interrupted(stop.outcomes), err=True)
        sys.exit(EXIT_INTERRUPTED)
    try:
        if bar is not None:
            bar.close()
        worst = _say_outcomes(outcomes, quiet)
    except KeyboardInterrupt:  # the outputs are written: say so, not "no output"
        click.echo("\n" + _interrupted(outcomes), err=True)
        sys.exit(EXIT_INTERRUPTED)
    if worst:
        sys.exit(worst)


def _say_outcomes(outcomes: Sequence[Any], quiet: bool) -> int:
    """Each program's error (always) and its outputs (unless quiet); the worst
    exit code."""
    worst = 0
    for o in outcomes:
        if o.error is not None:
            click.echo(str(o.error), err=True)
            worst = max(worst, o.error.exit_code)
        elif o.state == "done" and not quiet and o.written != ["-"]:
            click.echo(f"{o.job.program} -> {', '.join(o.written)}", err=True)
    return worst


def _interrupted(outcomes: Sequence[Any]) -> str:
    """What a Ctrl-C left: every output written whole, and every one not written
    (an existing file of that name is as it was)."""
    lines = ["interrupted: every conversion stopped"]
    why = {
        "stopped": "stopped while being converted",
        "waiting": "not started",
        "failed": "failed, see above",
        "running": "stopped while being converted",
    }
    for o in outcomes:
        if o.state == "done":
            lines += [f"  written whole: {w} (from {o.job.program})" for w in o.written]
    for o in outcomes:
        if o.state != "done":
            out = "standard output" if o.job.output == "-" else o.job.output
            lines.append(f"  not written: {out} ({o.job.program}: {why[o.state]})")
    return "\n".join(lines)


def _output_of(program: str, ext: str, output: str | None, out_dir: str | None) -> str:
    """Where convert writes a program's output: -o, --out-dir/NAME.ext, or beside it."""
    if output:
        return output
    if out_dir:
        return str(Path(out_dir) / (Path(program).stem + ext))
    if program == "-":
        raise UsageError(
            "the program comes from standard input, so there is no file to write beside",
            expected="-o FILE, or -o - for standard output",
        )
    return str(Path(program).with_suffix(ext))


# ------------------------------------------------------------------ check


@main.command()
@click.argument("program", type=click.Path(dir_okay=False, allow_dash=True))
@profile_option
@start_option
@click.option("--no-error-map", is_flag=True, help="Skip the virtual-axis error map stage.")
@click.option("--no-axis-comp", is_flag=True, help="Skip the real-axis tables stage.")
@click.option(
    "--nominal-kinematics",
    is_flag=True,
    help="Use the nominal design in the IK instead of the calibrated geometry.",
)
@click.option("--each-line", is_flag=True, help="List every problem line instead of the groups.")
@guarded
def check(
    program: str,
    profile_path: str,
    start: str | None,
    no_error_map: bool,
    no_axis_comp: bool,
    nominal_kinematics: bool,
    each_line: bool,
) -> None:
    """Run PROGRAM through the whole chain without writing and report what the
    machine cannot do: motors beyond their travel, poses out of reach, tilts and
    feeds beyond the limits.

    Problems are grouped by kind, with the runs of lines, how many lines and the
    worst value (the figures are those of the motor commands convert writes).
    Exit code 1 when there is any.
    """
    from . import chain
    from . import check as chk
    from . import program as prog

    prof = load_profile(profile_path)
    st = parse_pose(start, "--start") if start else None
    stages = chain.Stages(not no_error_map, not nominal_kinematics, not no_axis_comp)
    if program == "-":
        batches = prog.text_batches(read_text(program, "G-code program"))
    else:
        batches = prog.file_batches(program)
    report = chk.check_batches(
        batches,
        prof,
        stages=stages,
        start=st,
        source=program,
        on_message=say,
        lines_from=prog.lines_of(program),
    )
    if each_line:
        for p in report.problems:
            click.echo(str(p.error(prof, program)))
    else:
        for g in report.groups():
            click.echo(g.describe(prof, program))
    if report.stopped is not None:
        click.echo(str(report.stopped), err=True)
    if report.ok:
        click.echo(
            f"{program}: ok ({report.motions} motions, {report.points} points, "
            f"{report.seconds:.2f} s)",
            err=True,
        )
        return
    n = len({p.line for p in report.problems})
    kinds = len(report.groups())
    summary = (
        f"{n} line{'s' * (n != 1)} with problems in {kinds} group{'s' * (kinds != 1)}"
        if n
        else "no problem before it stopped"
    )
    if report.stopped is not None:
        summary += "; the check stopped at the error above"
    click.echo(f"{program}: {summary}", err=True)
    sys.exit(1)


# ------------------------------------------------------------------ measurements


def read_measurements(
    paths: Sequence[str],
    profile_path: str | None = None,
    commanded_with: str | None = None,
    ignore_provenance: bool = True,
) -> tuple[list[PoseData], list[BallbarRun], list[AxisData]]:
    """Read measurement files, sorted by kind: poses, ballbar runs, axis runs.

    With ``profile_path``, refuse files commanded with another profile than
    ``commanded_with`` (default ``profile_path``) unless ``ignore_provenance``.
    """
    from . import measure

    data = [measure.read_measurement(read_text(p, "measurement file"), p) for p in paths]
    if profile_path is not None:
        check_provenance(data, profile_path, commanded_with, ignore_provenance)
    poses: list[PoseData] = []
    runs: list[BallbarRun] = []
    axis: list[AxisData] = []
    for m in data:
        if isinstance(m, measure.PoseData):
            poses.append(m)
        elif isinstance(m, measure.BallbarRun):
            runs.append(m)
        else:
            axis.append(m)
    return poses, runs, axis


def fingerprint(path: str) -> Any:
    """The ``# commanded_with:`` fingerprint of a profile file (name and sha256)."""
    from . import measure

    return measure.CommandedWith(Path(path).name, sha256_of(path))


def check_provenance(
    data: Sequence[PoseData | BallbarRun | AxisData],
    profile_path: str,
    commanded_with: str | None,
    ignore: bool,
) -> None:
    """Refuse data commanded with another profile than the command was told."""
    from . import measure

    if ignore:
        return
    path = commanded_with or profile_path
    option = "--commanded-with" if commanded_with else "--profile"
    measure.check_commanded_with(data, fingerprint(path), option)


ignore_provenance_option = click.option(
    "--ignore-provenance",
    is_flag=True,
    help="Use measurement files even when their '# commanded_with:' names another "
    "profile than --commanded-with (or --profile).",
)


class _Stages:
    """The stages of a long command on stderr, as the library reports them
    (``progress(stage, fraction done)``): on a terminal one line, a bar with the
    stage and the time so far, redrawn every second; otherwise a line per stage
    with the time it began (for logs). Nothing with ``quiet``."""

    WIDTH = 20

    def __init__(
        self,
        command: str,
        quiet: bool = False,
        terminal: bool | None = None,
        clock: Callable[[], float] = time.monotonic,
        tick: float = 1.0,
    ) -> None:
        self.command, self.quiet, self.clock, self.tick = command, quiet, clock, tick
        self.terminal = _stderr_is_terminal() if terminal is None else terminal
        self.started = clock()
        self.stage: str | None = None
        self.fraction = 0.0
        self.lock = threading.Lock()
        self.stopped = threading.Event()
        self.ticker: threading.Thread | None = None

    def __enter__(self) -> _Stages:
        return self

    def __exit__(self, kind: object, *exc: object) -> None:
        self.close(finished=kind is None)

    def __call__(self, stage: str, fraction: float) -> None:
        if self.quiet:
            return
        with self.lock:
            self.stage, self.fraction = stage, min(max(fraction, 0.0), 1.0)
            if not self.terminal:
                elapsed = _clock(self.clock() - self.started)
                click.echo(f"{self.command} [{elapsed}]: {stage}", err=True)
                return
            self._draw()
        if self.ticker is None:
            self.ticker = threading.Thread(target=self._tick, daemon=True)
            self.ticker.start()

    def _draw(self) -> None:
        done = round(self.fraction * self.WIDTH)
        bar = "#" * done + "-" * (self.WIDTH - done)
        elapsed = _clock(self.clock() - self.started)
        sys.stderr.write(f"\r\x1b[K{self.command} [{bar}] {elapsed} {self.stage}")
        sys.stderr.flush()

    def _tick(self) -> None:
        while not self.stopped.wait(self.tick):
            with self.lock:
                self._draw()

    def close(self, finished: bool = True) -> None:
        """Stop redrawing and erase the bar (the results follow); in the plain
        lines, say how long it took."""
        self.stopped.set()
        if self.stage is not None and not self.terminal and finished:
            elapsed = _clock(self.clock() - self.started)
            click.echo(f"{self.command} [{elapsed}]: done", err=True)
            self.stage = None
        if self.ticker is not None:
            self.ticker.join()
            self.ticker = None
            sys.stderr.write("\r\x1b[K")
            sys.stderr.flush()


def _out_dir_files(out_dir: str, files: dict[str, str]) -> None:
    write_atomic({Path(out_dir) / name: text for name, text in files.items()})


@main.command()
@click.option(
    "--truth",
    "truth_path",
    required=True,
    type=click.Path(dir_okay=False),
    help="Profile of the machine as it really is (may hold [effects]).",
)
@profile_option
@click.option(
    "-o",
    "--out-dir",
    required=True,
    type=click.Path(file_okay=False),
    help="Directory for the measurement files.",
)
@click.option("--seed", default=0, show_default=True, type=int, help="Noise seed.")
@click.option(
    "--noise-um",
    default=0.5,
    show_default=True,
    type=click.FloatRange(0),
    help="Ballbar noise (1 sigma) [um].",
)
@click.option(
    "--pose-noise-um",
    default=1.0,
    show_default=True,
    type=click.FloatRange(0),
    help="Pose (laser tracker) noise [um].",
)
@click.option(
    "--laser-noise-um",
    default=0.3,
    show_default=True,
    type=click.FloatRange(0),
    help="Laser interferometer noise [um].",
)
@click.option(
    "--radii", default="50,100", show_default=True, help="X-Y ballbar radii [mm], comma separated."
)
@click.option(
    "--tilts", default="5,15", show_default=True, help="Cone test tilts [deg], comma separated."
)
@click.option(
    "--poses",
    "n_poses",
    default=300,
    show_default=True,
    type=click.IntRange(0),
    help="Number of poses in the pose grid.",
)
@click.option(
    "--feed",
    default=1000.0,
    show_default=True,
    type=click.FloatRange(min=1),
    help="Ballbar feed [mm/min].",
)
@click.option("--no-axis-runs", is_flag=True, help="Write no laser (axis) runs.")
@click.option("--only-xy", is_flag=True, help="Only X-Y ballbar circles (no cones, X-Z, Y-Z).")
@guarded
def simulate(
    truth_path: str,
    profile_path: str,
    out_dir: str,
    seed: int,
    noise_um: float,
    pose_noise_um: float,
    laser_noise_um: float,
    radii: str,
    tilts: str,
    n_poses: int,
    feed: float,
    no_axis_runs: bool,
    only_xy: bool,
) -> None:
    """What the machine TRUTH measures when commanded with PROFILE.

    Writes contract measurement files into OUT_DIR: ballbar runs (X-Y circles,
    cone tests, X-Z and Y-Z circles; each ccw and cw), a pose grid and laser runs
    per motor. Rehearse calibration with them, or hide effects in them.
    """
    from . import experiments

    truth = load_profile(truth_path)
    commanded = load_profile(profile_path)
    try:
        r_list = [float(x) for x in radii.split(",") if x.strip()]
        t_list = [float(x) for x in tilts.split(",") if x.strip()]
    except ValueError:
        raise UsageError(
            "--radii and --tilts take numbers separated by commas", expected="e.g. --radii 40,50,60"
        ) from None
    rng = np.random.default_rng(seed)
    files = experiments.measurement_files(
        truth,
        commanded,
        rng,
        radii=r_list,
        tilts=[] if only_xy else t_list,
        planes=["XY"] if only_xy else ["XY", "XZ", "YZ"],
        n_poses=n_poses,
        feed=feed,
        noise_um=noise_um,
        pose_noise_um=pose_noise_um,
        laser_noise_um=laser_noise_um,
        axis_runs=not no_axis_runs,
        commanded_with=fingerprint(profile_path),
    )
    _out_dir_files(out_dir, files)
    click.echo(f"wrote {len(files)} files to {out_dir}", err=True)


def _fmt_stats(d: dict[str, float]) -> str:
    parts = []
    for k, v in d.items():
        scale, unit = (3600.0, "arcsec") if k == "pose_axis" else (1000.0, "um")
        parts.append(f"{k} {v * scale:.3f} {unit}")
    return ", ".join(parts) or "-"


def _print_stage(rep: Any) -> None:
    click.echo(f"== {rep.name}")
    for c in rep.changed:
        if "change" in c and "from" in c:
            click.echo(
                f"  {c['name']}: {c['from']:.6g} -> {c['to']:.6g} "
                f"({c['change']:+.3g} ± {c['stderr']:.2g} {c['unit']})"
            )
        elif "change" in c:  # an effect of the library added
            period = f", period {c['period_mm']:g} mm" if c.get("period_mm") else ""
            click.echo(f"  {c['name']}: {c['change']:+.4g} ± {c['stderr']:.2g} {c['unit']}{period}")
        elif "cv_rms" in c:
            scale = 3600.0 if c["unit"] == "deg" else 1000.0
            u = "arcsec" if c["unit"] == "deg" else "um"
            click.echo(
                f"  {c['name']}: degree {c['degree']}, cross-validated RMS "
                f"{c['cv_rms'] * scale:.3f} {u}"
            )
        else:
            iso = c.get("iso230_2", {})
            figs = ", ".join(
                f"{k.split('_')[-1]} {np.max(np.abs(v)) * 1000:.2f} um" for k, v in iso.items()
            )
            click.echo(
                f"  {c['name']}: {c['points']} points {c['from']:g}..{c['to']:g} mm"
                + (f"; ISO 230-2 {figs}" if figs else "")
            )
    for n in rep.notes:
        click.echo(f"  note: {n}")
    click.echo(f"  residual RMS before: {_fmt_stats(rep.rms_before)}")
    click.echo(f"  residual RMS after:  {_fmt_stats(rep.rms_after)}")
    click.echo(f"  residual max before: {_fmt_stats(rep.max_before)}")
    click.echo(f"  residual max after:  {_fmt_stats(rep.max_after)}")


def profile_files(
    doc: dict[str, Any], output: str, input_path: str, in_place: bool
) -> dict[Path, str | bytes]:
    """The input profile rewritten to hold ``doc`` (checked to read back) and, when
    it replaces its input, a .bak of the input.

    ``doc`` is the input's document with sections changed; the text is the
    input's with only those changes made (:mod:`prsxy_post.profile.update`), so
    the user's comments and layout survive.
    """
    import tomllib

    from .profile import loads
    from .profile.update import changes_between, update_text

    original = read_text(input_path, "profile")
    text = update_text(original, changes_between(tomllib.loads(original), doc), input_path)
    loads(text, output)  # what we write must read back
    files: dict[Path, str | bytes] = {Path(output): text}
    if in_place and Path(output).resolve() == Path(input_path).resolve():
        files[Path(output + ".bak")] = original
    return files


def _check_output(out: str, inputs: Sequence[str], in_place: bool) -> None:
    """Never overwrite an input profile unless asked; keep a backup when asked."""
    outp = Path(out).resolve()
    for p in inputs:
        if Path(p).resolve() == outp and not in_place:
            raise UsageError(
                f"-o {out} would overwrite the input profile {p}",
                expected="another output file, or --in-place",
            )


@main.command()
@click.argument("data", nargs=-1, required=True, type=click.Path(dir_okay=False))
@profile_option
@click.option("-o", "--output", required=True, help="Calibrated profile to write (TOML).")
@click.option(
    "--commanded-with",
    default=None,
    type=click.Path(dir_okay=False),
    help="Profile the machine was commanded with when measured (default: --profile).",
)
@click.option(
    "--stages",
    default="tables,kinematics,effects,map",
    show_default=True,
    help="Which stages to run (comma separated): tables, kinematics, effects, map.",
)
@click.option(
    "--max-rel-stderr",
    default=0.25,
    show_default=True,
    type=click.FloatRange(0.001),
    help="Leave a parameter combination alone when the data know it worse than "
    "this fraction of its typical size.",
)
@click.option(
    "--seed", default=0, show_default=True, type=int, help="Seed of the cross-validation split."
)
@click.option("--in-place", is_flag=True, help="Allow -o to be the input profile (a .bak is kept).")
@ignore_provenance_option
@click.option("--json", "as_json", is_flag=True, help="Print the stage reports as JSON.")
@click.option("--quiet", "-q", is_flag=True, help="Print no progress (the results still).")
@guarded
def calibrate(
    data: Sequence[str],
    profile_path: str,
    output: str,
    commanded_with: str | None,
    stages: str,
    max_rel_stderr: float,
    seed: int,
    in_place: bool,
    ignore_provenance: bool,
    as_json: bool,
    quiet: bool,
) -> None:
    """Calibrate PROFILE from measurement files DATA (axis, poses, ballbar).

    Real axes first, as in the paper: real-axis tables from laser runs (ISO 230-2
    figures), the kinematic and table parameters from poses and ballbar runs, the
    physical effects of the library beyond them (bowed guides, curved table axes,
    backlash, cyclic error, servo lag; named, sized and compensated), then the
    virtual-axis error map from what remains. Each stage prints what it changed
    and the residuals before and after.
    """
    import json

    from . import calibrate as cal

    _check_output(output, [profile_path], in_place)
    start = load_profile(profile_path)
    commanded = load_profile(commanded_with) if commanded_with else start
    want = [s.strip() for s in stages.split(",") if s.strip()]
    poses, runs, axis = read_measurements(data, profile_path, commanded_with, ignore_provenance)
    with _Stages("calibrate", quiet) as progress:
        result = cal.calibrate(
            start,
            commanded,
            poses,
            runs,
            axis,
            stages=want,
            max_rel_stderr=max_rel_stderr,
            seed=seed,
            commanded_with=fingerprint(commanded_with or profile_path),
            sources=list(data),
            progress=progress,
        )
    write_atomic(profile_files(result.doc, output, profile_path, in_place))
    if as_json:
        click.echo(
            json.dumps({**result.to_json(), "output": output}, default=_json_default, indent=1)
        )
    else:
        for r in result.reports:
            _print_stage(r)
        click.echo(f"wrote {output}")
    for r in result.reports:
        for w in r.warnings:
            click.echo(f"warning: {r.name}: {w}", err=True)


def _json_default(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.floating | np.integer):
        return x.item()
    raise TypeError(type(x).__name__)


@main.command()
@click.argument("data", nargs=-1, required=True, type=click.Path(dir_okay=False))
@profile_option
@click.option("-o", "--output", default=None, help="Write the updated profile here.")
@click.option(
    "--commanded-with",
    default=None,
    type=click.Path(dir_okay=False),
    help="Profile the machine was commanded with (default: --profile).",
)
@click.option("--json", "as_json", is_flag=True, help="Print the diagnosis as JSON.")
@click.option(
    "--report",
    "report_dir",
    default=None,
    type=click.Path(file_okay=False),
    help="Write report.html (self-contained), report.md and the plots into this directory.",
)
@click.option(
    "--alpha",
    default=1e-3,
    show_default=True,
    type=click.FloatRange(1e-12, 0.5),
    help="Significance level of the F-test for each new effect.",
)
@click.option("--in-place", is_flag=True, help="Allow -o to be the input profile (a .bak is kept).")
@ignore_provenance_option
@click.option("--quiet", "-q", is_flag=True, help="Print no progress (the results still).")
@guarded
def diagnose(
    data: Sequence[str],
    profile_path: str,
    output: str | None,
    commanded_with: str | None,
    as_json: bool,
    report_dir: str | None,
    alpha: float,
    in_place: bool,
    ignore_provenance: bool,
    quiet: bool,
) -> None:
    """Find where PROFILE's simulation and the measurements DATA disagree and why."""
    import json

    from . import diagnose as dg

    if output:
        _check_output(output, [profile_path], in_place)
    current = load_profile(profile_path)
    commanded = load_profile(commanded_with) if commanded_with else current
    poses, runs, axis = read_measurements(data, profile_path, commanded_with, ignore_provenance)
    with _Stages("diagnose", quiet) as progress:
        d = dg.Data.build(commanded, poses, runs, axis)
        result = dg.diagnose(
            current,
            d,
            alpha=alpha,
            commanded_with=fingerprint(commanded_with or profile_path),
            progress=progress,
        )
    files: dict[Path, str | bytes] = {}
    if output:
        files.update(profile_files(result.updated, output, profile_path, in_place))
    if report_dir:
        from . import report

        pages = report.diagnose_report(result, d, report_dir)
        files.update({Path(report_dir) / k: v for k, v in pages.items()})
    if files:
        write_atomic(files)
    if as_json:
        click.echo(json.dumps(result.to_json(), default=_json_default, indent=1))
        for u in result.unexplained:
            click.echo(f"warning: {u['sentence']}", err=True)
        _wrote_report(report_dir, err=True)
        return
    click.echo(f"noise: {', '.join(f'{k} {v:.3f}' for k, v in result.to_json()['noise'].items())}")
    for r in result.regions[:5]:
        unit = "arcsec" if r["kind"] == "pose_axis" else "um"
        click.echo(
            f"disagreement: {r['source']} {r['region']}: rms {r[f'rms_{unit}']:.3f} "
            f"{unit} ({r['ratio']:.1f} x noise)"
        )
    if not result.effects:
        click.echo(
            "no missing effect found: the model explains the data to their noise"
            if not result.unexplained
            else "no library effect found, but the data are not explained (see the warnings)"
        )
    for e in result.effects:
        al = f" (cannot be told apart from: {', '.join(e.aliases)})" if e.aliases else ""
        extra = f", period {e.period:g} mm" if e.period else ""
        click.echo(f"effect: {e.name} {e.estimate:+.6g} ± {e.stderr:.2g} {e.unit}{extra}{al}")
        for dep in e.depends_on:
            click.echo(
                f"  note: {e.name} would move by {dep['shift']:+.4g} {e.unit} "
                f"({dep['in_stderr']:+.1f} standard errors) without {dep['name']}"
            )
    click.echo(f"residual RMS: {result.rms_before_um:.3f} um -> {result.rms_after_um:.3f} um")
    for e in result.effects:
        click.echo(e.sentence())
    if result.map_note is not None:
        click.echo(f"error map: {result.map_note['action']} ({result.map_note['reason']})")
    for u in result.unexplained:
        click.echo(f"warning: {u['sentence']}", err=True)
    if output:
        click.echo(f"wrote {output}")
    _wrote_report(report_dir)


def _wrote_report(report_dir: str | None, err: bool = False) -> None:
    """Where a report was written (stderr beside --json, which owns stdout)."""
    if report_dir:
        click.echo(f"wrote the report: {(Path(report_dir) / 'report.html').resolve()}", err=err)


@main.command()
@click.argument("runs", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the figures as JSON.")
@click.option("--plot", "plot_path", default=None, help="Write polar plots to this PNG.")
@click.option(
    "--profile",
    "profile_path",
    default=None,
    type=click.Path(dir_okay=False),
    help="A model of the machine: adds its simulated prediction to the plot.",
)
@click.option(
    "--commanded-with",
    default=None,
    type=click.Path(dir_okay=False),
    help="Profile the machine was commanded with (default: --profile).",
)
@click.option(
    "--report",
    "report_dir",
    default=None,
    type=click.Path(file_okay=False),
    help="Write report.html (self-contained), report.md and the plots into this directory.",
)
@ignore_provenance_option
@guarded
def ballbar(
    runs: Sequence[str],
    as_json: bool,
    plot_path: str | None,
    profile_path: str | None,
    commanded_with: str | None,
    report_dir: str | None,
    ignore_provenance: bool,
) -> None:
    """ISO 230-4 circular deviation and ballbar diagnostics of ballbar RUNS.

    Each figure is printed only when it stands above the noise, with its
    significance; --json has them all. Directions are RS274/NGC's: ccw is G3, cw
    is G2, seen from +Z (XY), +Y (XZ) or +X (YZ). Polar plots overlay a circle's
    ccw and cw runs on one µm/div scale, seen from that side.
    """
    import json

    from . import ballbar as bb
    from . import measure, plots

    data = [measure.read_ballbar(read_text(p, "ballbar file"), p) for p in runs]
    model = commanded = None
    if profile_path:
        check_provenance(data, profile_path, commanded_with, ignore_provenance)
        model = load_profile(profile_path)
        commanded = load_profile(commanded_with) if commanded_with else model
    analysis = bb.analyse(data, model, commanded)
    files: dict[Path, str | bytes] = {}
    if plot_path:
        files[Path(plot_path)] = plots.ballbar_plot(analysis.results, data, analysis.predicted)
    if report_dir:
        from . import report

        pages = report.ballbar_report(analysis, report_dir)
        files.update({Path(report_dir) / k: v for k, v in pages.items()})
    if files:
        write_atomic(files)
    if as_json:
        click.echo(json.dumps(analysis.to_json(), indent=1, default=_json_default))
        _wrote_report(report_dir, err=True)
        return
    for line in analysis.lines():
        click.echo(line)
    _wrote_report(report_dir)


@main.command("kinematics")
@profile_option
@click.option("-o", "--output", required=True, help="Turbo PMAC download file to write (.pmc).")
@click.option(
    "--program",
    type=click.Path(dir_okay=False),
    help="Also write this G-code program as a Cartesian Turbo PMAC motion program "
    "(LINEAR/CIRCLE moves) that runs through these kinematics.",
)
@click.option("--program-output", help="Where to write it (default: PROGRAM.cart.pmc).")
@guarded
def kinematics_export(
    profile_path: str, output: str, program: str | None, program_output: str | None
) -> None:
    """Write the profile's calibrated kinematics as Turbo PMAC OPEN FORWARD / OPEN
    INVERSE programs for coordinate system 1 (the embedded route)."""
    from . import embedded
    from .files import inspect_source
    from .writers import Provenance, pmac_kinematics

    prof = load_profile(profile_path)
    kf = pmac_kinematics.export(prof, profile_path)
    files = {Path(output): kf.text}
    if program:
        sha = inspect_source(program)
        prov = Provenance(program, sha, prof.name, profile_path, sha256_of(profile_path), "")
        out = program_output or str(Path(program).with_suffix(".cart.pmc"))
        text = read_text(program, "program")
        files[Path(out)] = embedded.program_text(text, program, prof, prov)
    write_atomic(files)
    click.echo(
        f"wrote {', '.join(str(f) for f in files)}: download after `tables export --format "
        f"pmac`; work variables Q20-Q{kf.last_q}",
        err=True,
    )


@main.group()
def tables() -> None:
    """Real-axis tables in the files controllers load: LinuxCNC comp files, Turbo PMAC."""


TABLE_FORMATS = click.Choice(["linuxcnc0", "linuxcnc1", "pmac"])


class _Motor(click.ParamType):
    """A motor number of the contract (docs/machine-model.md): 1, 2, 3 (the guides'
    sliders P1, P2, P3) and 5, 6 (the table's P5, P6); there is no motor 4."""

    name = "motor"

    def get_metavar(self, param: click.Parameter, ctx: click.Context | None = None) -> str:
        return "[" + "|".join(str(m) for m in MOTORS) + "]"

    def convert(self, value: Any, param: click.Parameter | None, ctx: click.Context | None) -> int:
        if isinstance(value, int) and value in MOTORS:
            return value
        try:
            motor = int(str(value).strip())
        except ValueError:
            motor = None
        if motor in MOTORS:
            return motor
        names = ", ".join(f"{m} (P{m})" for m in MOTORS)
        self.fail(
            f"{value!r} is not a motor of the PRS-XY machine (expected one of {names}; "
            "there is no motor 4)",
            param,
            ctx,
        )


@tables.command("export")
@profile_option
@click.option(
    "--format",
    "fmt",
    type=TABLE_FORMATS,
    required=True,
    help="linuxcnc0/linuxcnc1: COMP_FILE_TYPE 0/1 files and an INI snippet; "
    "pmac: one Turbo PMAC file (DEFINE COMP, DEFINE BLCOMP, Ixx85/Ixx86, I51).",
)
@click.option("--out-dir", required=True, type=click.Path(file_okay=False))
@guarded
def tables_export(profile_path: str, fmt: str, out_dir: str) -> None:
    """Write the profile's [[axis_comp]] tables as the controller loads them."""
    from .controller_tables import linuxcnc, pmac

    prof = load_profile(profile_path)
    if not prof.axis_comp:
        raise PrsxyError(
            "the profile has no [[axis_comp]] tables",
            source=profile_path,
            key="axis_comp",
            expected="tables to export",
        )
    out = Path(out_dir)
    if fmt == "pmac":
        pm = pmac.export(prof)
        write_atomic({out / pm.name: pm.text})
        click.echo(f"wrote {out / pm.name}", err=True)
        for t in pm.motors:
            click.echo(
                f"motor {t.motor}: {t.entries} entries, I{t.motor}86={t.ixx86}, "
                f"I{t.motor}85={t.ixx85}, within {t.interp_error_mm * 1e3:.4f} µm; "
                f"add {t.home_offset:+d} to I{t.motor}26 (home offset) and home again",
                err=True,
            )
    else:
        lc = linuxcnc.export(prof, int(fmt[-1]))
        files = {out / f.name: f.text for f in lc.files}
        files[out / lc.ini_name] = lc.ini
        write_atomic(files)
        click.echo(f"wrote {len(files)} files to {out_dir} ({lc.ini_name} names them)", err=True)
        for f in lc.files:
            note = f", resampled from {f.resampled_from}" if f.resampled_from else ""
            click.echo(
                f"motor {f.motor} (joint {f.joint}): {f.rows} rows{note}, "
                f"within {f.interp_error_mm * 1e3:.4f} µm",
                err=True,
            )
    cyc = sorted({c.motor for c in prof.effects.cyclic})
    if cyc:
        click.echo(
            "note: the cyclic errors ([[effects.cyclic]]) of motors "
            + ", ".join(str(m) for m in cyc)
            + " are not in these tables",
            err=True,
        )


def _linuxcnc_motor(
    path: str, text: str, file_type: int, motor: int | None, ini: dict[str, tuple[int, int]] | None
) -> int:
    """The motor of a LinuxCNC comp file: --motor, the INI snippet, or the file's notes;
    sources that disagree are an error."""
    from .controller_tables import linuxcnc

    named: dict[str, int] = {}
    if motor is not None:
        named["--motor"] = motor
    if ini is not None and Path(path).name in ini:
        m, ini_type = ini[Path(path).name]
        if ini_type != file_type:
            raise UsageError(
                f"the INI gives {Path(path).name} COMP_FILE_TYPE = {ini_type}",
                source=path,
                expected=f"--format linuxcnc{ini_type}",
            )
        named["the INI"] = m
    in_file = linuxcnc.motor_named_in(text)
    if in_file is not None:
        named["the file"] = in_file
    if not named:
        raise UsageError(
            "a LinuxCNC comp file does not say its motor",
            source=path,
            expected="--motor or --ini with the INI (snippet) naming the file",
        )
    if len(set(named.values())) > 1:
        says = ", ".join(f"{k} motor {v}" for k, v in named.items())
        raise UsageError(f"the motor is contradictory: {says}", source=path, expected="one motor")
    return next(iter(named.values()))


@tables.command("import")
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@profile_option
@click.option("--format", "fmt", type=TABLE_FORMATS, required=True)
@click.option(
    "--motor",
    type=_Motor(),
    default=None,
    help="Motor of a LinuxCNC file (default: from --ini or the file's prsxy-post notes).",
)
@click.option(
    "--ini",
    default=None,
    type=click.Path(dir_okay=False),
    help="LinuxCNC INI (or the exported snippet) whose [JOINT_n] COMP_FILE names the files.",
)
@click.option("-o", "--output", required=True, help="Profile to write with the tables.")
@click.option("--in-place", is_flag=True, help="Allow -o to be the input profile (a .bak is kept).")
@guarded
def tables_import(
    files: Sequence[str],
    profile_path: str,
    fmt: str,
    motor: int | None,
    ini: str | None,
    output: str,
    in_place: bool,
) -> None:
    """Read controller tables into a profile's [[axis_comp]] (replacing those motors')."""
    from .controller_tables import linuxcnc, pmac, with_tables

    _check_output(output, [profile_path], in_place)
    prof = load_profile(profile_path)
    ini_map = linuxcnc.read_ini(read_text(ini, "INI file"), ini) if ini else None
    new: list[Any] = []
    for f in files:
        text = read_text(f, "table file")
        if fmt == "pmac":
            new += pmac.read(text, f, prof)
        else:
            ft = int(fmt[-1])
            m = _linuxcnc_motor(f, text, ft, motor, ini_map)
            new.append(linuxcnc.read_comp(text, f, file_type=ft, motor=m))
    doc = with_tables(dict(prof.raw), new)
    write_atomic(profile_files(doc, output, profile_path, in_place))
    click.echo(
        f"wrote {output} with tables for motors {', '.join(str(t.motor) for t in new)}", err=True
    )


def run() -> NoReturn:
    """The ``prsxy-post`` executable: :func:`main`, then the process ends at once.

    When a command returns, its outputs are published, its processes joined and
    its threads done; what Python's own shutdown would do next is free every
    object one by one in a process about to end (0.033 s against 0.004 s after a
    200 000-line conversion, ``bench/ending.py``; mypy ends the same way). The
    standard streams are flushed first; where that fails (a reader gone), Python
    ends the process as it always does. Before the command, the C allocator is
    told to keep what the chain frees (:mod:`.allocator`: the executable's
    process only, as :mod:`.blas_threads`).
    """
    allocator.keep_freed_memory()
    try:
        main()
        ended = SystemExit(0)
    except SystemExit as exc:
        ended = exc
    code = ended.code
    if code is not None and not isinstance(code, int):
        raise ended  # a message: Python prints it and exits 1
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except BaseException:
        raise ended from None
    os._exit(code or 0)


if __name__ == "__main__":  # python -m prsxy_post.cli
    run()
