"""Calibration judged by execution, the figure in the README.

    python bench/calibration_accuracy.py [--seeds 7 8 9]

For each seed: a machine with random errors in every contract term, real-axis
errors with backlash, bowed guides and curved table axes is measured (0.5 µm
ballbar, 1 µm poses, 0.3 µm laser) while commanded with the nominal profile; the
three calibration stages build a profile; the samples converted with the nominal
and with the calibrated profile are executed on the machine. Prints the largest
distance of the executed points from the programmed path.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import profile, simulate  # noqa: E402
from tests.test_calibrate_e2e import _calibrate, _trace_error  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[7, 8, 9])
    args = ap.parse_args()
    nominal = profile.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    print(
        "| seed | program | nominal profile: max error µm | calibrated: max error µm | "
        "calibration s |"
    )
    print("|---:|---|---:|---:|---:|")
    for seed in args.seeds:
        truth = simulate.random_machine(
            nominal,
            np.random.default_rng(seed),
            axis_errors=True,
            effects=True,
            name=f"seeded {seed}",
        )
        t0 = time.perf_counter()
        cal = _calibrate(nominal, truth, seed)
        dt = time.perf_counter() - t0
        for program in ("pocket.ngc", "five-axis.ngc"):
            before = _trace_error(truth, nominal, program) * 1000
            after = _trace_error(truth, cal, program) * 1000
            print(f"| {seed} | {program} | {before:.1f} | {after:.2f} | {dt:.1f} |")


if __name__ == "__main__":
    main()
