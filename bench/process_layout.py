"""Where a large program's interpreter runs: in a process of its own or in the chain's.

Usage::

    python bench/process_layout.py --lines 200000 --format gcode --runs 5
    python bench/process_layout.py --lines 2000000 --format pmac --runs 3
    python bench/process_layout.py --program x.ngc --profile p.toml --format gcode

The ``prsxy-post convert`` command as a user runs it (bench.py's
``convert_command``: Python's start included), with the output's dialect set to
keep its interpreter apart (three processes: the interpreter's, the chain's, the
writer's) and not (two: the chain's, with the interpreter in it, and the writer's),
``Dialect.interpreter_apart``, in turns, ``--runs`` rounds, so that a machine
getting slower or faster over the runs weighs on both alike. It prints each run's
wall time [s] and the medians, and the median CPU of the command's processes
[s] (their user and system time, ``RUSAGE_CHILDREN``). The outputs must be the
same bytes (checked). The program and profile are bench.py's unless given
(``bench.program_parser``).
"""

from __future__ import annotations

import filecmp
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench

#: the command, with the dialect's layout set first (argv: layout, then convert's)
WRAPPER = """
import sys
from prsxy_post import writers
from prsxy_post.cli import run
fmt = sys.argv[sys.argv.index("--format") + 1]
d = writers.DIALECTS[fmt]
writers.DIALECTS[fmt] = d._replace(interpreter_apart=sys.argv.pop(1) == "apart")
sys.argv[0] = "prsxy-post"
run()
"""


def timed(layout: str, program: str, prof: str, out: Path, fmt: str) -> tuple[float, float]:
    """Wall time and CPU of the command with the dialect's interpreter ``layout``."""
    args = [sys.executable, "-c", WRAPPER, layout, *bench.convert_args(program, prof, out, fmt)]
    c0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(args, check=True, cwd=bench.ROOT, env=bench.user_env())
    wall = time.perf_counter() - t0
    c1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (c1.ru_utime - c0.ru_utime) + (c1.ru_stime - c0.ru_stime)


def main() -> None:
    args = bench.program_parser(__doc__.split("\n")[0]).parse_args()
    layouts = ("apart", "here")
    times: dict[str, list[float]] = {k: [] for k in layouts}
    cpus: dict[str, list[float]] = {k: [] for k in layouts}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        program, prof = bench.program_and_profile(args, tmp)
        outs = {k: tmp / k / f"out.{args.format}" for k in layouts}
        for out in outs.values():
            out.parent.mkdir()
        for _ in range(args.runs):
            for k in layouts:
                outs[k].unlink(missing_ok=True)
                wall, cpu = timed(k, program, prof, outs[k], args.format)
                times[k].append(wall)
                cpus[k].append(cpu)
        if not filecmp.cmp(outs["apart"], outs["here"], shallow=False):
            raise SystemExit("the two layouts wrote different outputs")
    print(f"{args.format}, {program}: the command's wall time [s], {args.runs} runs in turns")
    for k in layouts:
        runs = " ".join(f"{t:.3f}" for t in times[k])
        print(
            f"  interpreter {k:5s}: median {statistics.median(times[k]):.3f} ({runs}); "
            f"CPU median {statistics.median(cpus[k]):.3f}"
        )


if __name__ == "__main__":
    main()
