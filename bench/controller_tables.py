"""Largest residual of the exported controller tables, as the controllers apply them.

For random machines (nominal design, random tables with backlash, constant and
varying along the travel), every motor is commanded to targets over its travel,
approached from below and from above. The tables are loaded and applied by the
controller models of the tests (LinuxCNC's loader and screw compensation from its
source; a Turbo PMAC download and servo loop from its manuals). The play model says
where the part ends. The script prints the largest |end − target|.

    python bench/controller_tables.py [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import mdsection

from tests import test_controller_tables_linuxcnc as lc
from tests import test_controller_tables_pmac as pm


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    seeds = tuple(args.seeds)
    rows = {**lc.measured_residuals(seeds), **pm.measured_residuals(seeds)}
    if args.markdown:
        print(mdsection.header("Real-axis tables as the controllers apply them"))
        print(f"| table | largest abs(end − target) over seeds {', '.join(map(str, seeds))} µm |")
        print("|---|---:|")
        for name, worst in rows.items():
            print(f"| {name} | {worst * 1e3:.4f} |")
        return
    print(f"largest |end - target| over seeds {', '.join(map(str, seeds))}:")
    for name, worst in rows.items():
        print(f"  {name:28s} {worst * 1e3:.4f} um")


if __name__ == "__main__":
    main()
