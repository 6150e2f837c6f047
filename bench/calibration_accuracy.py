"""Calibration and diagnosis judged by execution, the figures of docs/measurements.md.

    python bench/calibration_accuracy.py [--seeds 7 8 9]

For each seed a machine with random errors in every contract term, real-axis
tables with backlash, bowed guides, curved table axes and cyclic errors on two
motors (``tests/loop.py``) is measured (0.5 µm ballbar, 1 µm poses, 0.3 µm laser)
while commanded with the nominal profile. From the contract's files:

- "map only": tables, kinematic parameters and the virtual-axis map (the stages
  without the library's physical effects, as before issue 13);
- "calibrate": the four stages, the physical effects before the map;
- "+ diagnose -o": diagnose on the calibrated profile with the same data.

Each profile converts the samples; the written PMAC program is executed on the
machine at its points. Prints the largest distance of an executed point from the
point meant on the path, and the CPU time of calibrate and diagnose.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mdsection  # noqa: E402

from prsxy_post import profile  # noqa: E402
from tests import loop  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[7, 8, 9])
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    if args.markdown:
        print(mdsection.header("Calibration closes the loop"))
    nominal = profile.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    print(
        "| seed | program | nominal µm | map only µm | calibrate µm | + diagnose -o µm "
        "| calibrate CPU s | diagnose CPU s |"
    )
    print("|---:|---|---:|---:|---:|---:|---:|---:|")
    for seed in args.seeds:
        truth = loop.unmodelled_machine(nominal, seed)
        data = loop.measurements(truth, nominal, seed)
        old = loop.calibrated(nominal, data, ("tables", "kinematics", "map"))
        t0 = time.process_time()
        cal = loop.calibrated(nominal, data)
        t_cal = time.process_time() - t0
        t0 = time.process_time()
        diag, _ = loop.diagnosed(cal, nominal, data)
        t_diag = time.process_time() - t0
        for program in loop.PROGRAMS:
            e = [loop.trace_error(truth, p, program) * 1000 for p in (nominal, old, cal, diag)]
            print(
                f"| {seed} | {program} | {e[0]:.1f} | {e[1]:.2f} | {e[2]:.2f} | {e[3]:.2f} "
                f"| {t_cal:.0f} | {t_diag:.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
