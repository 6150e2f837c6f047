"""CPU of one conversion, per stage, for two or more checkouts side by side.

The machine is shared, so figures from different minutes do not compare: this runs
the same conversion (one process, ``parallel=False``, stage timings in CPU seconds
as ``time.process_time``) for each checkout in turn, ``--runs`` times, alternating,
each in a fresh interpreter with ``PYTHONPATH`` set to the checkout (its own build
of the compiled kernel), and prints each run and the medians.

    python bench/side_by_side.py /work/main /work/wt/arcsk \\
        --program /tmp/p/50k.ngc --profile /tmp/p/bench.toml --format gcode
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

#: the conversion one child runs: COMMON.md's per-stage CPU command
CHILD = """
import json, sys, time
time.perf_counter = time.process_time  # stage timings in CPU seconds
import prsxy_post.kernel as k
from prsxy_post.convert import ConvertJob, convert_file
job = ConvertJob(program=sys.argv[1], profile_path=sys.argv[2], fmt=sys.argv[3],
                 output=sys.argv[4], parallel=False)
t = time.process_time()
s = convert_file(job)
print(json.dumps({"total": time.process_time() - t, "kernel": k.NAME, **s.timings}))
"""


def run_once(root: Path, program: str, profile: str, fmt: str, out: Path) -> dict[str, float]:
    """One conversion with ``root`` first on the path, from a directory outside it."""
    env = dict(os.environ, PYTHONPATH=str(root))
    got = subprocess.run(
        [sys.executable, "-c", CHILD, program, profile, fmt, str(out)],
        env=env,
        cwd=tempfile.gettempdir(),
        capture_output=True,
        text=True,
        check=True,
    )
    result: dict[str, float] = json.loads(got.stdout.strip().splitlines()[-1])
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("roots", type=Path, nargs="+", help="checkouts (each with its build)")
    ap.add_argument("--program", required=True)
    ap.add_argument("--profile", required=True)
    ap.add_argument("--format", default="gcode", choices=["gcode", "pmac"])
    ap.add_argument("--runs", type=int, default=5)
    args = ap.parse_args()
    totals: dict[Path, list[float]] = {r: [] for r in args.roots}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.runs):
            for j, root in enumerate(args.roots):
                out = Path(tmp) / f"{j}.out"
                t = run_once(root.resolve(), args.program, args.profile, args.format, out)
                totals[root].append(float(t["total"]))
                stages = " ".join(
                    f"{k} {float(v):.3f}" for k, v in t.items() if k not in ("total", "kernel")
                )
                print(f"run {i + 1} {root}: total {t['total']:.3f} ({stages}) [{t['kernel']}]")
    first = statistics.median(totals[args.roots[0]])
    for root in args.roots:
        med = statistics.median(totals[root])
        print(f"median {root}: {med:.3f} s CPU = {med / first:.3f} x {args.roots[0]}")


if __name__ == "__main__":
    main()
