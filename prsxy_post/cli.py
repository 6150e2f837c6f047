"""The ``prsxy-post`` command line: the only module that reads files, prints or exits.

Exit codes: 0 success, 1 bad input, 2 bad usage, 3 internal error (a bug:
rerun with ``--debug`` for the traceback and report it).
"""

from __future__ import annotations

import hashlib
import json
import os
import sys
import tempfile
import traceback
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import click
import numpy as np

from . import __version__
from . import profile as profile_mod
from .errors import EXIT_INTERNAL, PrsxyError, UsageError

# ------------------------------------------------------------------ file helpers


def read_text(path: str, kind: str = "file") -> str:
    """Read a text file for a parser: binary files and unreadable paths are errors.

    Bytes that are not UTF-8 are read as Latin-1 (G-code from older CAM systems
    has such bytes in comments; outside comments every parser rejects them).
    """
    try:
        data = Path(path).read_bytes() if path != "-" else sys.stdin.buffer.read()
    except OSError as exc:
        raise PrsxyError(f"cannot read {kind}: {exc.strerror}", source=path,
                         expected=f"a readable {kind}") from None
    if b"\0" in data:
        line = data[: data.index(b"\0")].count(b"\n") + 1
        raise PrsxyError(f"binary data (a NUL byte) in the {kind}", source=path, line=line,
                         expected=f"a text {kind}")
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def sha256_of(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def write_atomic(files: dict[Path, str]) -> None:
    """Write every file or none: temp files beside the targets, then renames.

    An existing output is replaced only once every new file is complete on disk.
    """
    temps: list[tuple[str, Path]] = []
    try:
        for path, text in files.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            temps.append((tmp, path))
            with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
        for tmp, path in temps:
            os.replace(tmp, path)
    except OSError as exc:
        for tmp, _ in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise PrsxyError(f"cannot write output: {exc.strerror}", source=str(exc.filename or ""),
                         expected="a writable location") from None


def load_profile(path: str) -> profile_mod.Profile:
    return profile_mod.loads(read_text(path, "profile"), path)


def parse_pose(text: str, option: str) -> tuple[float, ...]:
    parts = text.replace(" ", "").split(",")
    try:
        vals = tuple(float(p) for p in parts)
    except ValueError:
        raise UsageError(f"{option} {text!r} is not five numbers",
                         expected="x,y,z,a,b in mm and degrees") from None
    if len(vals) != 5 or not all(np.isfinite(vals)):
        raise UsageError(f"{option} {text!r} is not five finite numbers",
                         expected="x,y,z,a,b in mm and degrees")
    return vals


# ------------------------------------------------------------------ error handling


@dataclass
class Ctx:
    debug: bool = False
    quiet: bool = False


def fail(err: PrsxyError) -> NoReturn:
    click.echo(str(err), err=True)
    sys.exit(err.exit_code)


def guarded(fn: Callable[..., Any]) -> Callable[..., Any]:
    """Run a command: user errors become one located line, bugs exit 3."""
    import functools

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        ctx = click.get_current_context().find_object(Ctx) or Ctx()
        try:
            return fn(*args, **kwargs)
        except PrsxyError as err:
            if ctx.debug:
                traceback.print_exc()
            fail(err)
        except (click.exceptions.Exit, click.exceptions.Abort, click.ClickException):
            raise
        except KeyboardInterrupt:
            click.echo("interrupted; no output written", err=True)
            sys.exit(130)
        except Exception as exc:  # a bug: say so plainly
            if ctx.debug:
                traceback.print_exc()
            click.echo(f"internal error: {type(exc).__name__}: {exc} (this is a bug in "
                       f"prsxy-post {__version__}; rerun with --debug and report it)", err=True)
            sys.exit(EXIT_INTERNAL)

    return wrapper


# ------------------------------------------------------------------ the group


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="prsxy-post")
@click.option("--debug", is_flag=True, help="Show a traceback with errors.")
@click.pass_context
def main(ctx: click.Context, debug: bool) -> None:
    """Error-compensating post-processor for the PRS-XY hybrid machine tool.

    Exit codes: 0 success, 1 bad input, 2 bad usage, 3 internal error.
    """
    ctx.obj = Ctx(debug=debug)


profile_option = click.option(
    "--profile", "profile_path", required=True, type=click.Path(dir_okay=False),
    help="Machine profile (TOML).")
start_option = click.option("--start", default=None, metavar="X,Y,Z,A,B",
                            help="Start pose (workpiece frame); default the profile's.")


# ------------------------------------------------------------------ inspect


@main.command()
@click.argument("program", type=click.Path(dir_okay=False, allow_dash=True))
@click.option("--profile", "profile_path", default=None, type=click.Path(dir_okay=False),
              help="Profile for work offsets, tools, G28/G30 and start pose.")
@start_option
@click.option("--json", "as_json", is_flag=True, help="One JSON object per motion and line.")
@guarded
def inspect(program: str, profile_path: str | None, start: str | None, as_json: bool) -> None:
    """Print the interpreted motions of PROGRAM (workpiece frame, mm, degrees)."""
    from . import chain, gcode

    text = read_text(program, "G-code program")
    if profile_path:
        prof = load_profile(profile_path)
        cfg = chain.interpreter_config(prof, parse_pose(start, "--start") if start else None)
    else:
        cfg = gcode.InterpreterConfig(start=parse_pose(start, "--start")) if start else \
            gcode.InterpreterConfig()
    out = sys.stdout
    for m in gcode.iter_motions(gcode.split_lines(text), cfg, program):
        d = gcode.motion_to_json(m)
        if as_json:
            out.write(json.dumps(d) + "\n")
        else:
            end = " ".join(f"{v:.4f}" for v in d["end"])
            extra = ""
            if d["kind"] == "arc":
                extra = f" G{d['plane']} centre {d['center']} rotation {d['rotation']}"
            feed = "" if d.get("feed") is None else f" F{d['feed']:g}"
            out.write(f"{d['line']:>6} {d['kind']:<5} {end}{feed}{extra}\n")


# ------------------------------------------------------------------ convert


@dataclass(frozen=True)
class ConvertJob:
    program: str
    profile_path: str
    fmt: str
    outputs: tuple[str, ...]  # one path, or "-" for stdout; parts get .partN
    start: tuple[float, ...] | None
    stages: tuple[bool, bool, bool]
    options: str


def _convert_one(job: ConvertJob) -> dict[str, str]:
    """Convert one program; returns {output path: text}. Pure but for reading inputs."""
    from . import chain, errormap, gcode, kinematics, writers

    prof = load_profile(job.profile_path)
    text = read_text(job.program, "G-code program")
    cfg = chain.interpreter_config(prof, job.start)
    try:
        motions = list(gcode.iter_motions(gcode.split_lines(text), cfg, job.program))
        stages = chain.Stages(*job.stages)
        emap = errormap.from_profile(prof) if stages.error_map else None
        result = chain.run_chain(motions, prof, stages, emap, start=job.start)
    except PrsxyError as err:
        raise err.located(source=job.program) from None
    prov = writers.Provenance(
        source=job.program, source_sha256=hashlib.sha256(text.encode()).hexdigest(),
        profile_name=prof.name, profile_source=job.profile_path,
        profile_sha256=sha256_of(job.profile_path), options=job.options)
    out = job.outputs[0]
    if job.fmt == "pmac":
        texts = writers.write_pmac(result, prof, prov)
        if len(texts) == 1:
            return {out: texts[0]}
        if out == "-":
            return {"-": "".join(texts)}
        base, ext = os.path.splitext(out)
        return {f"{base}.part{i + 1}{ext}": t for i, t in enumerate(texts)}
    cgeo = chain.controller_geometry(prof)
    guess = kinematics.platform_guess(
        kinematics.solve_platform(cgeo, result.q_target), result.q_target)
    q_written, ok = kinematics.forward(cgeo, result.P_cmd, guess=guess)
    if not np.all(ok):
        bad = int(np.argmin(ok))
        raise PrsxyError(
            "the controller's kinematics cannot express this point",
            source=job.program, line=int(result.samples.line[bad]),
            expected="a pose within reach of [controller_kinematics]")
    return {out: writers.write_gcode(result, q_written, prof, prov,
                                     float(prof.output["gcode_tolerance_mm"]))}


def _run_job(job: ConvertJob) -> tuple[dict[str, str] | None, str | None, int]:
    try:
        return _convert_one(job), None, 0
    except PrsxyError as err:
        return None, str(err), err.exit_code


@main.command()
@click.argument("programs", nargs=-1, required=True,
                type=click.Path(dir_okay=False, allow_dash=True))
@profile_option
@click.option("--format", "fmt", type=click.Choice(["pmac", "gcode"]), default="pmac",
              show_default=True, help="Motor-space PMAC program or corrected Cartesian G-code.")
@click.option("-o", "--output", default=None,
              help="Output file for one program ('-' for standard output).")
@click.option("--out-dir", default=None, type=click.Path(file_okay=False),
              help="Directory for the outputs (one per program, named after it).")
@click.option("--jobs", "-j", default=1, show_default=True, type=click.IntRange(1, 64),
              help="Programs converted in parallel processes.")
@start_option
@click.option("--no-error-map", is_flag=True, help="Skip the virtual-axis error map stage.")
@click.option("--no-axis-comp", is_flag=True, help="Skip the real-axis tables stage.")
@click.option("--nominal-kinematics", is_flag=True,
              help="Use the nominal design in the IK instead of the calibrated geometry.")
@click.option("--quiet", "-q", is_flag=True, help="Print nothing but errors.")
@guarded
def convert(programs: Sequence[str], profile_path: str, fmt: str, output: str | None,
            out_dir: str | None, jobs: int, start: str | None, no_error_map: bool,
            no_axis_comp: bool, nominal_kinematics: bool, quiet: bool) -> None:
    """Convert G-code PROGRAMS into compensated motor programs (or corrected G-code).

    Outputs are written atomically: a failed conversion leaves no partial file and
    never replaces an existing one.
    """
    if output and out_dir:
        raise UsageError("-o and --out-dir given together", expected="one of them")
    if output and len(programs) > 1:
        raise UsageError(f"-o names one output but {len(programs)} programs were given",
                         expected="--out-dir DIR for several programs")
    if not output and not out_dir and len(programs) > 1:
        raise UsageError("several programs and no --out-dir",
                         expected="--out-dir DIR for several programs")
    load_profile(profile_path)  # fail once, early, on a bad profile
    st = parse_pose(start, "--start") if start else None
    stages = (not no_error_map, not nominal_kinematics, not no_axis_comp)
    opts = [f"--format {fmt}"]
    opts += [f for f, on in (("--no-error-map", no_error_map), ("--no-axis-comp", no_axis_comp),
                             ("--nominal-kinematics", nominal_kinematics)) if on]
    if start:
        opts.append(f"--start {start}")
    ext = ".pmc" if fmt == "pmac" else ".ngc"
    jobs_list = []
    for prog in programs:
        if out_dir:
            out = str(Path(out_dir) / (Path(prog).stem + ext))
        else:
            out = output or "-"
        jobs_list.append(ConvertJob(prog, profile_path, fmt, (out,), st, stages, " ".join(opts)))
    if jobs > 1 and len(jobs_list) > 1:
        with ProcessPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(_run_job, jobs_list))
    else:
        results = [_run_job(j) for j in jobs_list]
    worst = 0
    for job, (files, err, code) in zip(jobs_list, results, strict=True):
        if err is not None:
            click.echo(err, err=True)
            worst = max(worst, code)
            continue
        assert files is not None
        if "-" in files:
            sys.stdout.write(files["-"])
            continue
        write_atomic({Path(p): t for p, t in files.items()})
        if not quiet:
            click.echo(f"{job.program} -> {', '.join(files)}", err=True)
    if worst:
        sys.exit(worst)


# ------------------------------------------------------------------ check


@main.command()
@click.argument("program", type=click.Path(dir_okay=False, allow_dash=True))
@profile_option
@start_option
@click.option("--no-error-map", is_flag=True)
@click.option("--no-axis-comp", is_flag=True)
@click.option("--nominal-kinematics", is_flag=True)
@guarded
def check(program: str, profile_path: str, start: str | None, no_error_map: bool,
          no_axis_comp: bool, nominal_kinematics: bool) -> None:
    """Run the whole chain without writing and list every problem with its line."""
    from . import chain, errormap, gcode

    prof = load_profile(profile_path)
    st = parse_pose(start, "--start") if start else None
    text = read_text(program, "G-code program")
    cfg = chain.interpreter_config(prof, st)
    motions = list(gcode.iter_motions(gcode.split_lines(text), cfg, program))
    stages = chain.Stages(not no_error_map, not nominal_kinematics, not no_axis_comp)
    emap = errormap.from_profile(prof) if stages.error_map else None
    result = chain.run_chain(motions, prof, stages, emap, start=st, collect=True)
    for p in result.problems:
        click.echo(str(p.located(source=program)))
    n = len(result.problems)
    s = result.samples
    if n:
        click.echo(f"{program}: {n} problem{'s' * (n != 1)}", err=True)
        sys.exit(1)
    click.echo(f"{program}: ok ({len(motions)} motions, {len(s)} points, "
               f"{float(np.sum(s.dt)):.2f} s)", err=True)
