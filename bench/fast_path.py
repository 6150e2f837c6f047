"""The interpreter's fast path, compiled against its reference, beside ``rs274 -g``.

Usage::

    python bench/fast_path.py                    # 50 k and 200 k lines, best of 3
    python bench/fast_path.py --lines 50000 --repeat 5

On bench.py's generated five-axis program (G1 with X Y Z A B, small R arcs: the
fast path's), every motion taken from :func:`prsxy_post.program.motions_of_file`
with the fast path swapped (``gcode.fast.SELECTED``: ``pure`` is gcode/fast.py,
``compiled`` gcode/_fast.pyx), CPU seconds of this process and wall seconds, and
the whole ``rs274 -g`` command's wall seconds; runs alternated, so that a busy
moment of a shared machine falls on all three, each figure the best of
``--repeat``. It is a script, not a test: the figures depend on the machine.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

from bench import generate, time_rs274  # noqa: E402
from prsxy_post import program  # noqa: E402
from prsxy_post.gcode import fast  # noqa: E402


def time_ours(path: Path, path_impl: fast.FastPath) -> tuple[float, float, int]:
    """(CPU s, wall s, motions) of every motion of the program."""
    fast.SELECTED = path_impl
    c0, t0 = time.process_time(), time.perf_counter()
    n = sum(1 for _ in program.motions_of_file(path))
    return time.process_time() - c0, time.perf_counter() - t0, n


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lines", type=int, action="append", help="lines (repeatable)")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    args = ap.parse_args()
    if fast.COMPILED is None:
        sys.exit("the compiled fast path is not built (pip install -e . builds it)")
    impls = {"pure": fast.PURE, "compiled": fast.COMPILED}
    print("| lines | motions | pure CPU s | compiled CPU s | pure wall s | compiled wall s "
          "| rs274 -g wall s |")  # fmt: skip
    print("|---:|---:|---:|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as d:
        for lines in args.lines or [50_000, 200_000]:
            path = Path(d) / "cam.ngc"
            path.write_text(generate(lines))
            for impl in impls.values():  # imports and first calls out of the figures
                time_ours(path, impl)
            runs: dict[str, list[tuple[float, float, int]]] = {k: [] for k in impls}
            rs274: list[float] = []
            for _ in range(args.repeat):
                for name, impl in impls.items():
                    runs[name].append(time_ours(path, impl))
                r = time_rs274(path)
                if r is not None:
                    rs274.append(r)
            cpu = {k: min(r[0] for r in v) for k, v in runs.items()}
            wall = {k: min(r[1] for r in v) for k, v in runs.items()}
            theirs = f"{min(rs274):.3f}" if rs274 else "–"
            print(
                f"| {lines} | {runs['pure'][0][2]} | {cpu['pure']:.3f} | {cpu['compiled']:.3f} "
                f"| {wall['pure']:.3f} | {wall['compiled']:.3f} | {theirs} |"
            )


if __name__ == "__main__":
    main()
