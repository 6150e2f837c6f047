"""Benchmark: the whole chain on generated finishing programs, beside rs274 and pygcode.

Usage::

    python bench/bench.py                 # 200 k and 2 M lines
    python bench/bench.py --lines 200000  # one size
    python bench/bench.py --json out.json
    python bench/bench.py --format gcode  # corrected G-code for LinuxCNC instead

For each size it generates a five-axis finishing program (short G1 moves at F2000,
five-axis passes, small R arcs), converts it with every compensation stage on and PMAC
output (or ``--format gcode``; a calibrated profile with real-axis tables and an error
map), in a child process so peak resident memory is that conversion's alone, and
reports lines/s, interpolation points/s, the CPU time of the conversion's processes
together (``chain CPU``), and per stage its CPU seconds in the process that runs it
and its CPU µs per output point. Two times: ``chain`` is the
conversion inside the process (what ``convert_file`` takes: read, interpret, plan,
compensate, write), ``command`` is the whole ``prsxy-post convert`` command as a user
runs it (Python's start and imports included). In the same run and on the same file it
times LinuxCNC's ``rs274 -g`` (a whole command too) and pygcode's ``Machine`` when
they are installed; the command and ``rs274 -g`` run ``--runs`` times in turns (default
3), the table gives their medians and each run's ratio is listed under it. Large
programs are written by a second process and, where the output's dialect keeps its
interpreter apart (PMAC), interpreted in a third (docs/architecture.md); peak memory
is reported for each: main + interpreter + writer (0 where none ran).

It is a script, not a test: the figures depend on the machine. docs/measurements.md
shows the latest figures with the machine they were taken on (``--markdown`` prints
its section).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def generate(n_lines: int, seed: int = 0) -> str:
    """A finishing program: raster passes of short G1 moves, tilted passes, small R arcs."""
    rng = np.random.default_rng(seed)
    out = [
        "(generated finishing program)",
        "G21 G90 G17 G94",
        "G0 X-60 Y-60 Z5 A0 B0",
        "G1 Z0 F2000",
    ]
    x, y, a, b = -60.0, -60.0, 0.0, 0.0
    direction = 1.0
    while len(out) < n_lines - 2:
        kind = rng.random()
        if abs(x) > 60:  # end of a raster line: step over and turn
            direction = -1.0 if x > 0 else 1.0
            y = y + 0.5 if y < 60 else -60.0
            out.append(f"G1 X{x:.4f} Y{y:.4f}")
            x += direction * 0.1
            continue
        if kind < 0.80:
            x += direction * rng.uniform(0.05, 0.3)
            z = 0.2 * np.sin(x / 7.0) * np.cos(y / 9.0)
            out.append(f"G1 X{x:.4f} Z{z:.4f}")
        elif kind < 0.92:
            a = float(np.clip(a + rng.normal(0, 0.3), -15, 15))
            b = float(np.clip(b + rng.normal(0, 0.3), -15, 15))
            x += direction * rng.uniform(0.05, 0.3)
            out.append(f"G1 X{x:.4f} A{a:.4f} B{b:.4f}")
        else:
            r = rng.uniform(0.5, 2.0)
            x += direction * r * 0.8
            code = "G2" if rng.random() < 0.5 else "G3"
            out.append(f"{code} X{x:.4f} Y{y:.4f} R{r:.4f}")
    out += ["G0 Z5", "M2"]
    return "\n".join(out) + "\n"


def bench_profile(path: Path) -> Path:
    """A calibrated-looking profile: perturbed geometry, tables for every motor, a map."""
    sys.path.insert(0, str(ROOT))
    from prsxy_post import errormap, profile, simulate

    nominal = profile.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    rng = np.random.default_rng(1)
    truth = simulate.random_machine(nominal, rng, axis_errors=True, name="bench machine")
    q = np.column_stack(
        [
            rng.uniform(-150, 150, (300, 2)),
            rng.uniform(-60, 40, 300),
            rng.uniform(-25, 25, (300, 2)),
        ]
    )
    err = rng.normal(0, 1e-3, q.shape) + 1e-3 * np.sin(q / 50.0)
    emap = errormap.fit(q, err, rng=rng, degrees=(3,), lambdas=[1e-4])
    doc = dict(truth.raw, error_map=emap.to_dict())
    path.write_text(profile.dumps(doc))
    return path


def child_convert(program: str, prof: str, out: str, fmt: str) -> None:
    """Run in a child process: convert and print the stats as JSON."""
    sys.path.insert(0, str(ROOT))
    from prsxy_post import allocator
    from prsxy_post.convert import ConvertJob, convert_file
    from prsxy_post.runtime import peak_rss_mb

    # the process as the command sets it up (cli.run; OPENBLAS_NUM_THREADS comes
    # with the environment, user_env, as numpy is loaded before this runs)
    allocator.keep_freed_memory()
    t0, c0 = time.perf_counter(), os.times()
    st = convert_file(ConvertJob(program, prof, fmt, out, options="bench", parallel=True))
    total, c1 = time.perf_counter() - t0, os.times()
    # CPU of this process and of the interpreter and writer processes it waited for
    cpu = sum(c1[k] - c0[k] for k in range(4))
    rss = peak_rss_mb() or resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(
        json.dumps(
            {
                "total_s": total,
                "cpu_s": cpu,
                "lines": st.lines,
                "motions": st.motions,
                "points": st.points,
                "timings": st.timings,
                "peak_rss_mb": rss,
                "helper_peak_rss_mb": st.helper_peak_rss_mb,
                "writer_peak_rss_mb": st.writer_peak_rss_mb,
            }
        )
    )


def program_parser(description: str) -> argparse.ArgumentParser:
    """The options of a script that runs one program on one profile: a generated
    program (``--lines``, :func:`generate`) or a file (``--program``), a profile
    (``--profile``, else :func:`bench_profile`), the output format, the runs."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--lines", type=int, default=200_000, help="generated program's size")
    ap.add_argument("--program", help="a G-code file instead of a generated one")
    ap.add_argument("--profile", help="a profile (default: bench.py's bench_profile)")
    ap.add_argument("--format", choices=["pmac", "gcode"], default="pmac")
    ap.add_argument("--runs", type=int, default=1)
    return ap


def program_and_profile(args: argparse.Namespace, tmp: Path) -> tuple[str, str]:
    """The program and the profile :func:`program_parser`'s ``args`` name, those
    to generate written into ``tmp``."""
    program = args.program
    if program is None:
        program = str(tmp / f"finish-{args.lines}.ngc")
        Path(program).write_text(generate(args.lines))
    return program, args.profile or str(bench_profile(tmp / "bench.toml"))


def time_rs274(program: Path) -> float | None:
    """``rs274 -g`` on a program, as a whole command [s]; None where not installed."""
    exe = shutil.which("rs274")
    if exe is None:
        return None
    with tempfile.TemporaryDirectory() as d:
        tbl = Path(d) / "tool.tbl"
        tbl.write_text("T1 P1 Z0 D6 ;\n")
        t0 = time.perf_counter()
        proc = subprocess.run(
            [exe, "-t", str(tbl), "-g", str(program)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            stdin=subprocess.DEVNULL,
            check=False,
        )
        seconds = time.perf_counter() - t0
    if proc.returncode != 0:  # a failed run's time is no figure
        raise SystemExit(f"rs274 failed on {program}: {proc.stderr.decode()[-300:]}")
    return seconds


def user_env() -> dict[str, str]:
    """This environment as a user's install runs the command: Python writes the
    package's bytecode once and reads it after (without ``PYTHONDONTWRITEBYTECODE``,
    every start with sources newer than their cached bytecode compiles them again:
    about 0.1 s of CPU). One OpenBLAS thread unless set, as the command has
    (prsxy_post.blas_threads), for the child that times the conversion in-process
    and imports numpy first."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    env.setdefault("OPENBLAS_NUM_THREADS", "1")
    return env


def convert_args(program: Path | str, prof: Path | str, out: Path | str, fmt: str) -> list[str]:
    """The ``convert`` command's arguments a user gives, quiet (from ``convert`` on:
    for a script that runs the command wrapped)."""
    opts = ["--profile", str(prof), "--format", fmt, "-o", str(out), "-q"]
    return ["convert", str(program), *opts]


def convert_command(program: Path | str, prof: Path | str, out: Path | str, fmt: str) -> list[str]:
    """The ``prsxy-post convert`` command line a user runs, quiet (run from
    :data:`ROOT` with :func:`user_env`)."""
    return [sys.executable, "-m", "prsxy_post.cli", *convert_args(program, prof, out, fmt)]


def time_command(program: Path, prof: Path, out: Path, fmt: str) -> float:
    """Wall time of the ``prsxy-post convert`` command, start to exit."""
    t0 = time.perf_counter()
    subprocess.run(convert_command(program, prof, out, fmt), check=True, cwd=ROOT, env=user_env())
    return time.perf_counter() - t0


def time_pygcode(program: Path, limit_lines: int) -> float | None:
    try:
        from pygcode import Line, Machine
    except ImportError:
        return None
    lines = program.read_text().splitlines()
    if len(lines) > limit_lines:
        return None
    t0 = time.perf_counter()
    m = Machine()
    for text in lines:
        m.process_block(Line(text).block)
    return time.perf_counter() - t0


def run(sizes: list[int], pygcode_limit: int, fmt: str, runs: int = 1) -> list[dict]:
    results = []
    with tempfile.TemporaryDirectory() as d:
        prof = bench_profile(Path(d) / "bench.toml")
        for n in sizes:
            prog = Path(d) / f"finish-{n}.ngc"
            prog.write_text(generate(n))
            out = Path(d) / f"finish-{n}.{'pmc' if fmt == 'pmac' else 'out.ngc'}"
            proc = subprocess.run(
                [sys.executable, __file__, "--child", str(prog), str(prof), str(out), fmt],
                capture_output=True,
                text=True,
                check=True,
                env=user_env(),
            )
            r = json.loads(proc.stdout.strip().splitlines()[-1])
            r["size_lines"] = n
            r["format"] = fmt
            # the command and rs274 -g in turns, so both meet the machine's changes
            # alike; the medians are the table's, each run's ratio is listed below it
            cmds, rs274s = [], []
            for _ in range(runs):
                cmds.append(time_command(prog, prof, out, fmt))
                rs274s.append(time_rs274(prog))
            r["command_runs"] = cmds
            r["rs274_runs"] = rs274s
            r["command_s"] = statistics.median(cmds)
            r["rs274_s"] = None if None in rs274s else statistics.median(rs274s)
            r["pygcode_s"] = time_pygcode(prog, pygcode_limit)
            r["output_mb"] = out.stat().st_size / 1e6
            results.append(r)
            prog.unlink()
            out.unlink()
    return results


def report(results: list[dict]) -> str:
    cpu = platform.processor() or platform.machine()
    lines = [
        f"Machine: {platform.platform()}, {os.cpu_count()} cores, {cpu}, "
        f"Python {platform.python_version()}",
        f"Output format: {results[0].get('format', 'pmac')}",
        "",
    ]
    lines += [
        "| lines | chain s | chain CPU s | command s | lines/s | points/s | peak RSS MB | "
        "rs274 -g s | pygcode Machine s | chain / rs274 | command / rs274 | pygcode / command |",
        "|" + "---:|" * 12,
    ]

    def f(x: float | None, fmt: str) -> str:
        return format(x, fmt) if x else "-"

    for r in results:
        rs, pg, cmd, tot = r["rs274_s"], r["pygcode_s"], r["command_s"], r["total_s"]
        helper = r.get("helper_peak_rss_mb") or 0.0
        writer = r.get("writer_peak_rss_mb") or 0.0
        lines.append(
            f"| {r['lines']:,} | {tot:.2f} | {r['cpu_s']:.2f} | {cmd:.2f} | "
            f"{r['lines'] / cmd:,.0f} | "
            f"{r['points'] / cmd:,.0f} | {r['peak_rss_mb']:.0f} + {helper:.0f} + {writer:.0f} | "
            f"{f(rs, '.2f')} | {f(pg, '.1f')} | {f(rs and tot / rs, '.2f')} | "
            f"{f(rs and cmd / rs, '.2f')} | {f(pg and pg / cmd, '.1f')} |"
        )
    turns = [r for r in results if len(r.get("command_runs", [])) > 1 and r["rs274_s"]]
    if turns:
        lines += [
            "",
            f"The command and `rs274 -g` in turns, {len(turns[0]['command_runs'])} runs "
            "each (the table: medians); command / rs274 -g run by run:",
            "",
        ]
        for r in turns:
            each = ", ".join(
                f"{c / x:.2f}" for c, x in zip(r["command_runs"], r["rs274_runs"], strict=True)
            )
            lines.append(f"- {r['lines']:,} lines: {each}")
    stages = list(results[0]["timings"])
    lines += [
        "",
        "Per stage: CPU seconds, each in the process that runs it, and CPU µs per output point:",
        "",
        "| lines | points | "
        + " | ".join(stages)
        + " | "
        + " | ".join(f"{k} µs/pt" for k in stages)
        + " |",
        "|---:|---:|" + "---:|" * (2 * len(stages)),
    ]
    for r in results:
        cpu_s = [r["timings"][k] for k in stages]
        per_pt = [1e6 * v / max(r["points"], 1) for v in cpu_s]
        lines.append(
            f"| {r['lines']:,} | {r['points']:,} | "
            + " | ".join(f"{v:.2f}" for v in cpu_s)
            + " | "
            + " | ".join(f"{v:.2f}" for v in per_pt)
            + " |"
        )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lines", type=int, action="append", help="program size (repeatable)")
    ap.add_argument("--json", help="also write the results here")
    ap.add_argument(
        "--pygcode-limit",
        type=int,
        default=250_000,
        help="skip pygcode above this many lines (it needs minutes)",
    )
    ap.add_argument(
        "--format",
        choices=["pmac", "gcode"],
        default="pmac",
        help="output format converted to (default pmac)",
    )
    ap.add_argument(
        "--runs",
        type=int,
        default=3,
        help="times the command and rs274 -g run, in turns (the table: medians; default 3)",
    )
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    ap.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child_convert(*args.child)
        return
    results = run(args.lines or [200_000, 2_000_000], args.pygcode_limit, args.format, args.runs)
    if args.markdown:
        import mdsection  # beside this script: bench.py is imported as bench.bench too

        title = "Conversion speed" if args.format == "pmac" else "Corrected G-code speed"
        print(mdsection.header(title))
    print(report(results))
    if args.json:
        Path(args.json).write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
