"""Replay the paper's Table 2 experiment: an X-Y table calibrated from ballbar runs alone.

    python samples/table2/replay.py [--keep DIR]

1. ``simulate`` X-Y ballbar circles (radii 40, 50, 60, 80, 90 mm, ccw and cw) on the
   machine of ``truth.toml`` (the paper's table: 0.1349 mm/m out of square, 0.0256 mm
   scale mismatch at r = 40 mm), commanded with the nominal profile;
2. ``ballbar`` the runs (before);
3. ``calibrate`` from the ballbar files only (the table's squareness and scales are
   what X-Y circles can identify);
4. ``simulate`` the same circle programs commanded with the calibrated profile and
   ``ballbar`` them again (after);
5. print both beside the paper's figures.

Every step is the command a user would type; the script prints them.
"""

from __future__ import annotations

import argparse
import json
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
RADII = (40, 50, 60, 80, 90)
# the paper's Table 2: (squareness mm/m, scale mismatch mm) before and after
PAPER = {
    40: ((0.1349, 0.0256), (0.0099, 0.0032)),
    50: ((0.1295, 0.0320), (0.0099, 0.0028)),
    60: ((0.1323, 0.0414), (0.0100, 0.00334)),
    80: ((0.1334, 0.0630), (0.0102, 0.0038)),
    90: ((0.1342, 0.0773), (0.0097, 0.0024)),
}


def cli(*args: str) -> str:
    cmd = [sys.executable, "-m", "prsxy_post.cli", *args]
    print("$ prsxy-post " + " ".join(shlex.quote(a) for a in args), file=sys.stderr)
    return subprocess.run(cmd, check=True, capture_output=True, text=True, cwd=ROOT).stdout


def pairs(out_dir: Path) -> dict[int, dict]:
    files = sorted(str(p) for p in out_dir.glob("ballbar-*.csv"))
    j = json.loads(cli("ballbar", *files, "--json"))
    return {round(p["radius"]): p for p in j["pairs"]}


def main() -> dict[int, tuple[dict, dict]]:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--keep", help="keep the files in this directory")
    args = ap.parse_args()
    work = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="table2-"))
    work.mkdir(parents=True, exist_ok=True)
    radii = ",".join(str(r) for r in RADII)
    nominal = str(ROOT / "profiles" / "prsxy-nominal.toml")
    truth = str(HERE / "truth.toml")
    common = ["--radii", radii, "--only-xy", "--poses", "0", "--no-axis-runs"]
    cli(
        "simulate",
        "--truth",
        truth,
        "--profile",
        nominal,
        "-o",
        str(work / "before"),
        "--seed",
        "1",
        *common,
    )
    before = pairs(work / "before")
    cal = str(work / "calibrated.toml")
    cli(
        "calibrate",
        *sorted(str(p) for p in (work / "before").glob("*.csv")),
        "--profile",
        nominal,
        "-o",
        cal,
        "--stages",
        "kinematics",
    )
    cli(
        "simulate",
        "--truth",
        truth,
        "--profile",
        cal,
        "-o",
        str(work / "after"),
        "--seed",
        "2",
        *common,
    )
    after = pairs(work / "after")
    print(
        "| radius mm | squareness mm/m: paper before | ours before | paper after | ours after "
        "| scale mismatch mm: paper before | ours before | paper after | ours after |"
    )
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in RADII:
        (pb, pa) = PAPER[r]
        b, a = before[r], after[r]
        print(
            f"| {r} | {pb[0]:.4f} | {b['squareness_mm_per_m']:.4f} | {pa[0]:.4f} | "
            f"{a['squareness_mm_per_m']:.4f} | {pb[1]:.4f} | {b['scale_mismatch_mm']:.4f} | "
            f"{pa[1]:.4f} | {a['scale_mismatch_mm']:.5f} |"
        )
    print(f"\n(files in {work})", file=sys.stderr)
    return {r: (before[r], after[r]) for r in RADII}


if __name__ == "__main__":
    main()
