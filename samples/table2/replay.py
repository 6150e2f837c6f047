"""Replay the paper's Table 2 experiment: an X-Y table calibrated from ballbar runs alone.

    python samples/table2/replay.py [--keep DIR]

With the library, as a shop's script would (each step is also a command, named
beside it):

1. simulate X-Y ballbar circles (radii 40, 50, 60, 80, 90 mm, ccw and cw) on the
   machine of ``truth.toml`` (the paper's table: 0.1349 mm/m out of square, 0.0256 mm
   scale mismatch at r = 40 mm), commanded with the nominal profile
   (``prsxy-post simulate --only-xy``);
2. analyse the runs (``prsxy-post ballbar``), before;
3. calibrate from the ballbar files alone: the kinematic stage, since X-Y circles
   identify the table's squareness and scales (``prsxy-post calibrate --stages
   kinematics``);
4. simulate the same circles commanded with the calibrated profile and analyse
   them again, after;
5. print both beside the paper's figures.

With ``--keep DIR`` the measurement files and the calibrated profile are written
there, as the commands would write them.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import ballbar, calibrate, experiments, measure, profile  # noqa: E402
from prsxy_post.files import write_atomic  # noqa: E402

RADII = (40, 50, 60, 80, 90)
# the paper's Table 2: (squareness mm/m, scale mismatch mm) before and after
PAPER = {
    40: ((0.1349, 0.0256), (0.0099, 0.0032)),
    50: ((0.1295, 0.0320), (0.0099, 0.0028)),
    60: ((0.1323, 0.0414), (0.0100, 0.00334)),
    80: ((0.1334, 0.0630), (0.0102, 0.0038)),
    90: ((0.1342, 0.0773), (0.0097, 0.0024)),
}


def measure_circles(
    truth: profile.Profile, commanded: profile.Profile, seed: int
) -> tuple[dict[str, str], list[measure.BallbarRun]]:
    """The X-Y circles as files (contract form) and as read back from them."""
    files = experiments.measurement_files(
        truth,
        commanded,
        np.random.default_rng(seed),
        radii=[float(r) for r in RADII],
        tilts=[],
        planes=["XY"],
        n_poses=0,
        axis_runs=False,
        commanded_with=measure.CommandedWith.of(Path(commanded.source).name, commanded.text),
    )
    runs = [measure.read_ballbar(text, name) for name, text in sorted(files.items())]
    return files, runs


def pairs(runs: list[measure.BallbarRun]) -> dict[int, ballbar.BallbarPair]:
    return {round(p.radius): p for p in ballbar.analyse(runs).pairs}


def main() -> dict[int, tuple[ballbar.BallbarPair, ballbar.BallbarPair]]:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--keep", help="write the files into this directory")
    args = ap.parse_args()
    nominal = profile.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    truth = profile.loads((HERE / "truth.toml").read_text(), "truth.toml")
    files_before, runs_before = measure_circles(truth, nominal, seed=1)
    before = pairs(runs_before)
    cal = calibrate.calibrate(
        nominal, nominal, [], runs_before, [], stages=["kinematics"], sources=sorted(files_before)
    )
    cal_text = profile.dumps(cal.doc)
    calibrated = profile.loads(cal_text, "calibrated.toml")
    files_after, runs_after = measure_circles(truth, calibrated, seed=2)
    after = pairs(runs_after)
    if args.keep:
        keep = Path(args.keep)
        out: dict[Path, str | bytes] = {keep / "before" / n: t for n, t in files_before.items()}
        out.update({keep / "after" / n: t for n, t in files_after.items()})
        out[keep / "calibrated.toml"] = cal_text
        write_atomic(out)
    print(
        "| radius mm | squareness mm/m: paper before | ours before | paper after | ours after "
        "| scale mismatch mm: paper before | ours before | paper after | ours after |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in RADII:
        (pb, pa) = PAPER[r]
        b, a = before[r], after[r]
        print(
            f"| {r} | {pb[0]:.4f} | {b.squareness_mm_per_m:.4f} | {pa[0]:.4f} | "
            f"{a.squareness_mm_per_m:.4f} | {pb[1]:.4f} | {b.scale_mismatch_mm:.4f} | "
            f"{pa[1]:.4f} | {a.scale_mismatch_mm:.5f} |"
        )
    return {r: (before[r], after[r]) for r in RADII}


if __name__ == "__main__":
    main()
