"""Start-up: how long a 10-line program takes to convert, as a whole command.

Usage::

    python bench/startup.py                # 25 runs of each command
    python bench/startup.py --runs 50 --markdown

Issue 31 asks a 10-line program to convert in at most 0.15 s of wall time. A short
program is all start-up: Python's own, the imports (numpy's first), reading the
profile, and the few points. The script times, as whole commands one after the
other: ``python -c pass``, ``python -c "import numpy"``, ``prsxy-post convert`` of a
10-line program to PMAC and to G-code with the nominal profile, and LinuxCNC's
``rs274 -g`` on the same program, in rounds of one run of each. Each figure is the
median and the least of the runs' wall times, beside the median CPU time (user +
system) of the runs' processes.
On a shared machine the wall time follows the load: the least is the figure to
compare with the target, the median says how often it holds.
"""

from __future__ import annotations

import argparse
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

ROOT = Path(__file__).resolve().parent.parent

PROGRAM = """(ten lines)
G21 G90 G17 G94
G0 X0 Y0 Z5
G1 Z0 F600
G1 X10
G1 Y10
G2 X0 Y0 R10
G1 X5 A1 B1
G1 X0 A0 B0
G0 Z5
M2
"""


def timed(cmds: list[tuple[list[str], Path]], runs: int) -> list[tuple[float, float, float]]:
    """(median wall, least wall, median CPU) of each (command, directory it runs in)
    of ``cmds`` [s], each run ``runs`` times, in rounds of one run of each (so that
    on a shared machine every command meets the same load)."""
    walls: list[list[float]] = [[] for _ in cmds]
    cpus: list[list[float]] = [[] for _ in cmds]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    for _ in range(runs):
        for i, (cmd, cwd) in enumerate(cmds):
            r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
            t0 = time.perf_counter()
            subprocess.run(cmd, check=True, capture_output=True, env=env, cwd=cwd)
            walls[i].append(time.perf_counter() - t0)
            r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus[i].append(r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime)
    return [
        (statistics.median(w), min(w), statistics.median(c))
        for w, c in zip(walls, cpus, strict=True)
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=25)
    ap.add_argument("--markdown", action="store_true", help="docs/measurements.md's section")
    ap.add_argument(
        "--against",
        type=Path,
        metavar="DIR",
        help="another checkout of the project (its prsxy_post, run from DIR): its "
        "PMAC conversion timed in the same rounds, for before and after",
    )
    args = ap.parse_args()
    py = sys.executable
    with tempfile.TemporaryDirectory() as d:
        prog = Path(d) / "ten.ngc"
        prog.write_text(PROGRAM)
        prof = str(ROOT / "profiles" / "prsxy-nominal.toml")
        convert = [py, "-m", "prsxy_post.cli", "convert", str(prog), "--profile", prof, "-q"]
        pmac = [*convert, "-o", str(Path(d) / "ten.pmc")]
        rows = [
            ("python -c pass", [py, "-c", "pass"], ROOT),
            ('python -c "import numpy"', [py, "-c", "import numpy"], ROOT),
            ("prsxy-post convert, PMAC", pmac, ROOT),
            (
                "prsxy-post convert, G-code",
                [*convert, "--format", "gcode", "-o", str(Path(d) / "c.ngc")],
                ROOT,
            ),
        ]
        if args.against:
            rows.append((f"prsxy-post convert, PMAC, {args.against}", pmac, args.against))
        if shutil.which("rs274"):
            rows.append(("rs274 -g", ["rs274", "-g", str(prog)], ROOT))
        runs = timed([(cmd, cwd) for _, cmd, cwd in rows], args.runs)
        figures = [(name, *fig) for (name, _, _), fig in zip(rows, runs, strict=True)]
    if args.markdown:
        sys.path.insert(0, str(Path(__file__).parent))
        from mdsection import header

        print(header("Start-up"))
        print(
            f"Machine: {platform.platform()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}, "
            f"load average {os.getloadavg()[0]:.1f}; {args.runs} runs each\n"
        )
    print("| command | median wall s | least wall s | median CPU s |")
    print("|---|---:|---:|---:|")
    for name, med, least, cpu in figures:
        print(f"| {name} | {med:.3f} | {least:.3f} | {cpu:.3f} |")


if __name__ == "__main__":
    main()
