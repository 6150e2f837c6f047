"""What ending the command's process costs: Python's shutdown against ``cli.run``.

Usage::

    python bench/ending.py                     # 200 000 lines, 3 rounds
    python bench/ending.py --lines 20000 --runs 5

Converts a generated program (``bench.py``'s ``generate`` and ``bench_profile``) with
the command in a process of its own, two ways in alternating rounds: through
``cli.run`` (the ``prsxy-post`` executable: ``os._exit`` once the command returns)
and through ``cli.main`` as click runs it alone (``SystemExit``: Python's shutdown
frees every object before the process ends). The child writes the wall clock
(``time.time``) when ``convert_file`` returns; the figure is the time from then to
the moment its parent sees the process gone [s].
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))

import bench  # noqa: E402

#: the child: the command, with the moment convert_file returned written to stderr
CHILD = """
import sys, time
from prsxy_post import cli, convert
real = convert.convert_file
def timed(*args, **kwargs):
    try:
        return real(*args, **kwargs)
    finally:
        sys.stderr.write(f"RETURNED {time.time()!r}\\n")
        sys.stderr.flush()
convert.convert_file = timed
ending = sys.argv[1]
args = sys.argv[2:]
if ending == "run":
    sys.argv = ["prsxy-post", *args]
    cli.run()
else:
    cli.main(args, prog_name="prsxy-post")
"""


def ending_seconds(ending: str, args: list[str]) -> float:
    """From ``convert_file``'s return to the process's end [s], one conversion."""
    r = subprocess.run(
        [sys.executable, "-c", CHILD, ending, *args], capture_output=True, text=True, cwd=ROOT
    )
    done = time.time()
    if r.returncode != 0:
        raise SystemExit(f"the conversion failed ({ending}):\n{r.stderr}")
    returned = [float(x.split()[1]) for x in r.stderr.splitlines() if x.startswith("RETURNED ")]
    return done - returned[-1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lines", type=int, default=200_000, help="generated program's size")
    ap.add_argument("--runs", type=int, default=3, help="rounds of the two ways")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        program = Path(d) / "finish.ngc"
        program.write_text(bench.generate(a.lines))
        profile = bench.bench_profile(Path(d) / "bench.toml")
        args = ["convert", str(program), "--profile", str(profile), "-o", f"{d}/out.pmc", "-q"]
        ways = {"run": "cli.run (os._exit)", "main": "cli.main (Python's shutdown)"}
        seconds: dict[str, list[float]] = {w: [] for w in ways}
        for _ in range(a.runs):
            for w in ways:
                seconds[w].append(ending_seconds(w, args))
    print(f"| {a.lines:,} lines, {a.runs} runs each | median s | least s |")
    print("|---|---:|---:|")
    for w, name in ways.items():
        print(f"| {name} | {statistics.median(seconds[w]):.3f} | {min(seconds[w]):.3f} |")


if __name__ == "__main__":
    main()
