"""Where a conversion's points come from, on bench.py's program and profile.

Usage::

    python bench/points.py                  # the first 20 000 lines
    python bench/points.py --lines 200000

The work after the interpreter is proportional to the points, so this says what
makes them. Of the planned points (:mod:`prsxy_post.interpolate.sampling`):

- ``floor``: what one block would need with no point inside it but its steps,
  ``max(1, ceil(duration / step))``, the step being the period or shorter on a
  tight curve; every block's end is a point, because the path may turn there;
- ``phase boundaries``: the planned points less that floor, the points at the
  changes of acceleration inside a block (the controller's cubic is exact only
  while the acceleration is constant over a step);

and the points the real-axis stage adds for the motors with play, the chain's
points less the planned ones: where a motor reverses (its crossing of the play and
the standing that takes it up), and the two points that blend a corner taken at
speed where a motor stands on one side (``reversals.corners``,
``reversals.blend_shift``). Prints one Markdown table.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import mdsection  # noqa: E402

import bench  # noqa: E402
from prsxy_post import chain, gcode, profile, program  # noqa: E402
from prsxy_post.interpolate.sampling import longest_step, steps  # noqa: E402

CHUNK = 4096


def count(text: str, prof: profile.Profile) -> dict[str, float]:
    """Lines, blocks, planned points (floor, phase boundaries), chain points and the
    planned motion's duration [s] of a program."""
    pipe = chain.Pipeline(prof, chain.Stages())
    cfg = program.interpreter_config(prof, None)
    motions = list(gcode.iter_motions_batched(gcode.batches_of(gcode.split_lines(text)), cfg, "p"))
    out = dict.fromkeys(("blocks", "planned", "floor", "chain", "seconds"), 0.0)
    out["lines"] = float(len(text.splitlines()))
    lim = pipe.limits
    for k in range(0, len(motions) + 1, CHUNK):
        final = k + CHUNK > len(motions)
        prepared = chain.prepare(motions[k : k + CHUNK], prof, lim)
        planned = pipe.planning.plan(prepared, final)
        if planned.plan is not None:
            b, law = planned.plan.blocks, planned.plan.law
            moving = ~b.stops
            n = steps(b, law, lim).sum(axis=1)
            h = longest_step(b, law, lim)
            floor = np.where(moving, np.maximum(1, np.ceil(law.duration / h - 1e-9)), n)
            out["blocks"] += float(moving.sum())
            out["planned"] += float(n.sum())
            out["floor"] += float(floor.sum())
            out["seconds"] += float(law.duration[moving].sum())
        out["chain"] += float(sum(len(pc) for pc in pipe.feed_planned(planned)))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--lines", type=int, default=20000)
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    if args.markdown:
        print(mdsection.header("Where the points come from"))
    with tempfile.TemporaryDirectory() as tmp:
        prof = profile.loads(bench.bench_profile(Path(tmp) / "bench.toml").read_text(), "bench")
    c = count(bench.generate(args.lines), prof)
    per = c["lines"]
    rows = [
        ("floor: block ends and steps of at most the period", c["floor"]),
        ("phase boundaries", c["planned"] - c["floor"]),
        ("planned", c["planned"]),
        ("added for the motors with play (reversals, corners)", c["chain"] - c["planned"]),
        ("chain", c["chain"]),
    ]
    print(
        f"{int(c['lines'])} lines, {int(c['blocks'])} moving blocks, "
        f"{c['seconds']:.1f} s of motion ({c['seconds'] / 0.01:.0f} periods of 10 ms)\n"
    )
    print("| points | count | per line |")
    print("|---|---:|---:|")
    for name, v in rows:
        print(f"| {name} | {v:.0f} | {v / per:.2f} |")


if __name__ == "__main__":
    main()
