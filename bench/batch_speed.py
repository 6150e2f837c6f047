"""Batch conversion: many small programs in one ``convert`` command, with --jobs.

Usage::

    python bench/batch_speed.py                     # 80 programs, 5 rounds
    python bench/batch_speed.py --copies 40 --runs 9 --markdown
    python bench/batch_speed.py --against DIR       # DIR's prsxy_post too

The shop-floor batch: ``--copies`` copies of each sample program (pocket.ngc,
five-axis.ngc: 16-26 lines, a few seconds of motion each) converted by one command
with the shop profile, ``--jobs 1`` (one after another, in the command's process)
and ``--jobs 2``, as whole commands in rounds of one run of each (``startup.timed``:
the median and least wall time, the median CPU of the command's processes). With
``--against`` the same two commands of another checkout (run from DIR) join each
round. The outputs of every command are compared with those of ``--jobs 1``: the
script stops if any differs.
"""

from __future__ import annotations

import argparse
import filecmp
import os
import platform
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).parent))

from startup import timed  # noqa: E402

SAMPLES = ("pocket.ngc", "five-axis.ngc")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--copies", type=int, default=40, help="copies of each sample")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--markdown", action="store_true", help="docs/measurements.md's section")
    ap.add_argument("--against", type=Path, metavar="DIR", help="another checkout, beside")
    args = ap.parse_args()
    py = sys.executable
    with tempfile.TemporaryDirectory() as d:
        src = Path(d) / "src"
        src.mkdir()
        for name in SAMPLES:
            text = (ROOT / "samples" / name).read_text()
            for i in range(args.copies):
                (src / f"{i:03d}-{name}").write_text(text)
        programs = sorted(str(p) for p in src.iterdir())
        prof = str(ROOT / "profiles" / "prsxy-shop.toml")
        rows = []
        trees = [("", ROOT)] + ([(f", {args.against}", args.against)] if args.against else [])
        for label, tree in trees:
            for jobs in (1, 2):
                out = Path(d) / f"out{len(rows)}"
                cmd = [py, "-m", "prsxy_post.cli", "convert", *programs, "--profile", prof]
                cmd += ["--out-dir", str(out), "--jobs", str(jobs), "-q"]
                rows.append((f"--jobs {jobs}{label}", cmd, tree, out))
        figures = timed([(cmd, tree) for _, cmd, tree, _ in rows], args.runs)
        first = rows[0][3]
        for name, _, _, out in rows[1:]:
            _, diff, errs = filecmp.cmpfiles(first, out, os.listdir(first), shallow=False)
            if diff or errs or len(os.listdir(out)) != len(programs):
                raise SystemExit(f"{name}: outputs differ from --jobs 1's: {diff + errs}")
    n = len(programs)
    if args.markdown:
        from mdsection import header

        print(header("Batch conversion"))
        print(
            f"Machine: {platform.platform()}, {os.cpu_count()} cores, "
            f"Python {platform.python_version()}, load average {os.getloadavg()[0]:.1f}; "
            f"{n} programs, {args.runs} runs each\n"
        )
    print("| command | median wall s | least wall s | median CPU s | ms a program |")
    print("|---|---:|---:|---:|---:|")
    for (name, _, _, _), (med, least, cpu) in zip(rows, figures, strict=True):
        print(f"| {name} | {med:.3f} | {least:.3f} | {cpu:.3f} | {1000 * med / n:.1f} |")


if __name__ == "__main__":
    main()
