"""The interpreter alone beside LinuxCNC's ``rs274 -g``, on the same files, in one run.

Usage::

    python bench/gcode_speed.py                  # 200 k lines, three programs
    python bench/gcode_speed.py --lines 50000 --repeat 3
    python bench/gcode_speed.py --convert        # and the whole convert command

Three programs of about the same number of motions:

- ``cam``: bench/bench.py's generated five-axis finishing program (G1 with
  X Y Z A B, small R arcs): plain CAM output, the fast path's;
- ``cam+comp``: the same in cutter radius compensation (``G41.1 D0.01``): every
  block on the general path, held in the compensation queue;
- ``macro``: the same number of moves from a loop (``o100 while``, named and
  numbered parameters, ``SIN``/``COS`` expressions, a subroutine call per move):
  the general path with its expression evaluation and control flow.

``ours`` is :func:`prsxy_post.program.motions_of_file` taking every motion (the
file read in batches of lines, as ``convert`` reads it; the interpreter's start-up
included; Python's start and the imports are not, a warm-up takes them);
``rs274`` is the whole ``rs274 -g`` command with its output thrown away (its
start-up is a few milliseconds). With ``--convert``, also the whole ``prsxy-post
convert`` command on each program (bench.py's profile and stages: every
compensation stage, PMAC output; Python's start included), against the same
``rs274 -g``. Each figure is the best of ``--repeat`` runs, all alternated. It is
a script, not a test: the figures depend on the machine; docs/measurements.md shows
the latest (``--markdown`` prints its section).
"""

from __future__ import annotations

import argparse
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import mdsection  # noqa: E402

from bench import bench_profile, generate, time_command, time_rs274  # noqa: E402

#: the programs as docs/measurements.md names them
NAMES = {
    "cam": "cam: bench.py's five-axis finishing program (the fast path)",
    "cam+comp": "cam+comp: the same under `G41.1 D0.01` (general path, compensation queue)",
    "macro": "macro: a `while` loop calling a subroutine per move, named and numbered "
    "parameters, `SIN`/`COS`",
}


def cam_with_comp(n_lines: int) -> str:
    """The generated program, compensated: G41.1 with a 0.01 mm tool on its path."""
    lines = generate(n_lines).splitlines()
    # after "G1 Z0 F2000" (line 4): compensation on from the next move to the end
    head, body = lines[:4], lines[4:-2]
    return "\n".join([*head, "G41.1 D0.01", *body, "G40", "G0 Z5", "M2"]) + "\n"


def macro(n_moves: int) -> str:
    """A loop of n_moves moves computed by expressions, one subroutine call each."""
    return (
        "(generated macro program: loop, parameters, expressions, calls)\n"
        "G21 G90 G17 G94\n"
        "#<r> = 40\n"
        "#100 = 0\n"
        "o<step> sub\n"
        "  #<a> = [#1 * 0.05]\n"
        "  G1 X[#<_r> * COS[#<a>]] Y[#<_r> * SIN[#<a>]] Z[-0.0001 * #1] "
        "A[5 * SIN[#<a> / 3]] B[5 * COS[#<a> / 7]]\n"
        "o<step> endsub\n"
        "#<_r> = #<r>\n"
        "G0 X#<r> Y0 Z5\n"
        "G1 Z0 F2000\n"
        f"o100 while [#100 lt {n_moves}]\n"
        "  o<step> call [#100]\n"
        "  #100 = [#100 + 1]\n"
        "o100 endwhile\n"
        "G0 Z5\n"
        "M2\n"
    )


def time_ours(path: Path) -> tuple[float, int]:
    from prsxy_post import program

    t0 = time.perf_counter()
    n = sum(1 for _ in program.motions_of_file(path))
    return time.perf_counter() - t0, n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lines", type=int, default=200_000, help="moves per program")
    ap.add_argument("--repeat", type=int, default=5, help="best of this many runs")
    ap.add_argument("--convert", action="store_true", help="time the convert command too")
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    programs = {
        "cam": generate(args.lines),
        "cam+comp": cam_with_comp(args.lines),
        "macro": macro(args.lines),
    }
    if args.markdown:
        print(mdsection.header("The interpreter and convert beside rs274"))
        print(mdsection.machine() + "\n")
    else:
        print(f"{platform.processor() or platform.machine()}, Python {platform.python_version()}")
    head = "| program | lines | motions | ours s | rs274 -g s | ours / rs274 |"
    rule = "|---|---:|---:|---:|---:|---:|"
    if args.convert:
        head += " convert s | convert / rs274 |"
        rule += "---:|---:|"
    print(head)
    print(rule)
    with tempfile.TemporaryDirectory() as d:
        prof = bench_profile(Path(d) / "bench.toml") if args.convert else None
        warm = Path(d) / "warm.ngc"  # imports and first calls out of the figures
        warm.write_text(macro(100) + cam_with_comp(100))
        time_ours(warm)
        for name, text in programs.items():
            path = Path(d) / f"{name}.ngc"
            path.write_text(text)
            # alternated, so a busy moment of a shared machine falls on both
            ours_runs, runs, commands = [], [], []
            for _ in range(args.repeat):
                ours_runs.append(time_ours(path))
                runs.append(time_rs274(path))
                if prof is not None:
                    commands.append(time_command(path, prof, Path(d) / "out.pmc"))
            ours = min(ours_runs)
            theirs = None if runs[0] is None else min(r for r in runs if r is not None)
            ratio = f"{ours[0] / theirs:.2f}" if theirs else "–"
            rs = f"{theirs:.2f}" if theirs else "–"
            n_lines, n_motions = text.count(chr(10)), ours[1]
            if args.markdown:  # the names and thousands as the page writes them
                shown, counts = NAMES[name], f"{n_lines:,} | {n_motions:,}"
            else:
                shown, counts = name, f"{n_lines} | {n_motions}"
            row = f"| {shown} | {counts} | {ours[0]:.2f} | {rs} | {ratio} |"
            if commands:
                cmd = min(commands)
                row += f" {cmd:.2f} | {f'{cmd / theirs:.2f}' if theirs else '–'} |"
            print(row, flush=True)


if __name__ == "__main__":
    main()
