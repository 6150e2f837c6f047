"""The corrected G-code writer's kernel calls (``kernel.gcode_ops``) of one
conversion: how many, their time, and the time a call costs besides its points.

Usage::

    python bench/gwrite_stops.py --program P.ngc --profile P.toml --runs 3

The writer calls the kernel once per chunk; trees before the kernel refitted arcs
itself (``gcode_ops``' ``fit``) called it again after each stop where the writer
refitted an arc (``gwrite.REQ_REARC``, ``REQ_ARC_TO``). Each call is timed (wall
clock, ``time.perf_counter``: run it side by side with another tree, e.g.
``PYTHONPATH=/other/tree python bench/gwrite_stops.py ...``, alternated) with the
points it decided (from where it started to where it stopped, or the chunk's
end); a least-squares line time = a + b * points gives the cost of a call (a)
and of a point (b). The last run's figures are printed.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

import prsxy_post.kernel as kernel
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.kernel import gwrite

STOP_AT = gwrite.I_NAMES.index("stop_at")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--program", type=Path, required=True)
    ap.add_argument("--profile", type=Path, required=True)
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    inner = kernel._gcode_ops
    rows: list[tuple[int, float]] = []

    def timed(st: gwrite.GState, *a: Any) -> Any:
        k0 = max(int(st.i[STOP_AT]), 0)
        t = time.perf_counter()
        out = inner(st, *a)
        took = time.perf_counter() - t
        k1 = int(st.i[STOP_AT])
        rows.append(((len(a[0]) if k1 < 0 else k1) - k0, took))
        return out

    kernel._gcode_ops = timed
    with tempfile.TemporaryDirectory() as tmp:
        job = ConvertJob(
            program=str(args.program),
            profile_path=str(args.profile),
            fmt="gcode",
            output=str(Path(tmp) / "out.ngc"),
            parallel=False,
        )
        for _ in range(args.runs):
            rows.clear()
            convert_file(job)
    r = np.array(rows, dtype=float)
    fit, *_ = np.linalg.lstsq(np.c_[np.ones(len(r)), r[:, 0]], r[:, 1], rcond=None)
    print(f"{kernel.__file__}: {len(r)} calls, {int(r[:, 0].sum())} points")
    print(f"calls total {r[:, 1].sum():.4f} s; per call {fit[0] * 1e6:.0f} us")
    print(f"per point {fit[1] * 1e9:.0f} ns")


if __name__ == "__main__":
    main()
