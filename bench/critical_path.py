"""The command's critical path: its start, its processes' CPU, and the floor two cores allow.

Usage::

    python bench/critical_path.py --lines 200000 --format gcode --runs 5
    python bench/critical_path.py --lines 2000000 --format pmac --runs 3

Runs the ``prsxy-post convert`` command as a user runs it (bench.py's
``convert_command``: Python's start included), wrapped so that it notes, by the
wall clock, when Python is up, when the imports are done, when ``convert_file``
starts and ends, and at its end the CPU [s] (user + system) of its own process (the
chain's; with G-code output the interpreter's too, ``Dialect.interpreter_apart``)
and of the processes it forked (the writer's; with PMAC output the interpreter's),
in turns with ``rs274 -g`` on the same program, ``--runs`` rounds. Then the same
conversion once in one process (``parallel=False``), its CPU.

It prints the medians, and the floor: the command's start (until ``convert_file``)
plus half the CPU of all its processes after it (their CPU less what this process
used before ``convert_file``, on one core during the start), what two cores would
take were that work shared evenly between them with nothing waiting (pipes, the
first chunk, the writer's last). Issue 31 asks the command at 2 x ``rs274 -g``
with G-code output: where the floor is above that, no layout of the same work
reaches it; only less CPU does; where the command is above the floor, a layout
that shares the work more evenly would gain up to the difference. The program and
profile are bench.py's unless given (``bench.program_parser``); the wall times
follow the machine's load, so compare runs made side by side.
"""

from __future__ import annotations

import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench

#: the command, noting its milestones (argv: the JSON file's path, then convert's)
WRAPPER = """
import json, os, resource, sys, time
def cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime
marks = {"python up": time.time()}
out, me = sys.argv.pop(1), os.getpid()
from prsxy_post import batch
from prsxy_post.cli import run
marks["imports done"] = time.time()
inner = batch.convert_file
def convert_file(*a, **k):
    marks["convert_file starts"], c0 = time.time(), time.process_time()
    try:
        return inner(*a, **k)
    finally:
        marks["convert_file ends"] = time.time()
        marks["chain CPU in convert_file"] = time.process_time() - c0
batch.convert_file = convert_file
end = os._exit
def _exit(code):
    if os.getpid() == me:  # not a forked child ending
        marks["command ends"] = time.time()
        marks["CPU here"] = cpu(resource.RUSAGE_SELF)
        marks["CPU forked"] = cpu(resource.RUSAGE_CHILDREN)
        with open(out, "w") as f:
            json.dump(marks, f)
    end(code)
os._exit = _exit
sys.argv[0] = "prsxy-post"
run()
"""

#: the conversion in one process (argv: program, profile, output, format)
ONE_PROCESS = """
import sys, time
from prsxy_post import allocator
from prsxy_post.convert import ConvertJob, convert_file
allocator.keep_freed_memory()
program, prof, out, fmt = sys.argv[1:]
c0 = time.process_time()
convert_file(ConvertJob(program, prof, fmt, out, options="bench", parallel=False))
print(time.process_time() - c0)
"""


def timed_command(program: str, prof: str, out: Path, fmt: str, marks: Path) -> dict[str, float]:
    """The command's milestones [s from its start] and CPU [s] (:data:`WRAPPER`)."""
    args = [sys.executable, "-c", WRAPPER, str(marks), *bench.convert_args(program, prof, out, fmt)]
    t0 = time.time()
    subprocess.run(args, check=True, cwd=bench.ROOT, env=bench.user_env())
    wall = time.time() - t0
    got = json.loads(marks.read_text())
    at = {k: v - t0 for k, v in got.items() if not k.startswith(("CPU", "chain CPU"))}
    cpu = {k: v for k, v in got.items() if k.startswith(("CPU", "chain CPU"))}
    return {**at, **cpu, "wall": wall}


def one_process_cpu(program: str, prof: str, out: Path, fmt: str) -> float:
    """CPU [s] of the conversion in one process (:data:`ONE_PROCESS`)."""
    args = [sys.executable, "-c", ONE_PROCESS, program, prof, str(out), fmt]
    done = subprocess.run(
        args, check=True, cwd=bench.ROOT, env=bench.user_env(), capture_output=True, text=True
    )
    return float(done.stdout.split()[-1])


def main() -> None:
    args = bench.program_parser(__doc__.split("\n")[0]).parse_args()
    runs: list[dict[str, float]] = []
    rs274: list[float] = []
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        program, prof = bench.program_and_profile(args, tmp)
        out = tmp / f"out.{args.format}"
        for _ in range(args.runs):
            runs.append(timed_command(program, prof, out, args.format, tmp / "marks.json"))
            t = bench.time_rs274(Path(program))
            if t is not None:
                rs274.append(t)
        one = one_process_cpu(program, prof, tmp / f"one.{args.format}", args.format)
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    every = statistics.median(r["CPU here"] + r["CPU forked"] for r in runs)
    # the start's CPU (before the fork) runs on one core, in the start's wall time
    start_cpu = statistics.median(r["CPU here"] - r["chain CPU in convert_file"] for r in runs)
    floor = med["convert_file starts"] + (every - start_cpu) / 2
    print(f"{args.format}, {program}: {args.runs} runs in turns with rs274 -g (medians, s)")
    print(
        "  from the command's start: Python up {python up:.3f}, imports done "
        "{imports done:.3f}, convert_file {convert_file starts:.3f} to "
        "{convert_file ends:.3f}, the command ends {command ends:.3f} "
        "(wall {wall:.3f})".format(**med)
    )
    print(
        f"  CPU: this process {med['CPU here']:.3f} ({med['chain CPU in convert_file']:.3f} "
        f"in convert_file), forked {med['CPU forked']:.3f}, all {every:.3f}; "
        f"the same conversion in one process {one:.3f}"
    )
    line = (
        f"  floor on two cores: {med['convert_file starts']:.3f} + ({every:.3f} - "
        f"{start_cpu:.3f}) / 2 = {floor:.3f}"
    )
    if rs274:
        r = statistics.median(rs274)
        line += (
            f"; rs274 -g {r:.3f}: the command {med['wall'] / r:.2f} x, the floor {floor / r:.2f} x"
        )
    print(line)


if __name__ == "__main__":
    main()
