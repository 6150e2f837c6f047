"""Each stage's CPU seconds of one conversion in one process, side by side with
another tree of the package.

Usage::

    python bench/stages.py --program P.ngc --profile P.toml --format pmac --runs 3
    python bench/stages.py ... --against /path/to/other/checkout   # alternated

It converts ``--program`` with ``--profile`` (``parallel=False``: every stage in
this process) ``--runs`` times, each in a fresh interpreter, with the stage
timers reading CPU time (``time.process_time``) instead of the wall clock, and
prints every run's total and per-stage CPU [s] and the least of each. With
``--against``, the other tree's package (its directory holding ``prsxy_post``,
compiled in place) runs in turn with this one, run for run, so both meet the same
load on a shared machine, and the outputs are compared byte for byte.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: run in the child: one conversion, the stages' CPU as JSON on stdout
CHILD = """
import json, sys, time
time.perf_counter = time.process_time  # trees before 2026-11-27 timed stages by the wall clock
from prsxy_post.convert import ConvertJob, convert_file
program, prof, fmt, out = sys.argv[1:5]
job = ConvertJob(program=program, profile_path=prof, fmt=fmt, output=out, parallel=False)
t = time.process_time()
s = convert_file(job)
cpu = time.process_time() - t
print(json.dumps(dict(total=cpu, **{k: float(v) for k, v in s.timings.items()})))
"""


def run(tree: Path, program: str, prof: str, fmt: str, out: Path) -> dict[str, float]:
    """One conversion by the package under ``tree``: its stages' CPU seconds."""
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1")
    res = subprocess.run(
        [sys.executable, "-c", CHILD, program, prof, fmt, str(out)],
        env=env,
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
    )
    if res.returncode:
        sys.exit(f"{tree}: the conversion failed:\n{res.stderr}")
    figures: dict[str, float] = json.loads(res.stdout.strip().splitlines()[-1])
    return figures


def line(name: str, t: dict[str, float]) -> str:
    """A run's figures on one line."""
    return f"{name:11s} " + " ".join(f"{k}={v:.3f}" for k, v in t.items())


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--program", required=True)
    ap.add_argument("--profile", required=True)
    ap.add_argument("--format", default="pmac", choices=["pmac", "gcode"])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--against", type=Path, help="another tree: its package runs in turn")
    a = ap.parse_args()
    # the children run elsewhere (not to import this tree's package by its cwd)
    a.program, a.profile = str(Path(a.program).resolve()), str(Path(a.profile).resolve())
    trees = {"this": ROOT}
    if a.against is not None:
        trees["against"] = a.against.resolve()
    with tempfile.TemporaryDirectory() as tmp:
        outs = {name: Path(tmp) / f"{name}.out" for name in trees}
        best: dict[str, dict[str, float]] = {}
        for _ in range(a.runs):
            for name, tree in trees.items():
                t = run(tree, a.program, a.profile, a.format, outs[name])
                print(line(name, t), flush=True)
                best[name] = {k: min(v, best.get(name, t)[k]) for k, v in t.items()}
        for name, t in best.items():
            print(line(f"{name} min", t))
        if a.against is not None:
            same = filecmp.cmp(outs["this"], outs["against"], shallow=False)
            print("outputs identical" if same else "OUTPUTS DIFFER")


if __name__ == "__main__":
    main()
