"""Micro-benchmarks of the kernels, compiled against the numpy reference, per row.

Usage::

    python bench/kernel_speed.py            # IK rows and PMAC row text, 4096 rows a call
    python bench/kernel_speed.py --rows 512 --repeat 7

It times (timeit, best of ``--repeat``) one call of each kernel on a chunk of
``--rows`` rows of the shop profile's geometry: ``inverse_rows`` (the closed-form
IK, what ``kinematics.inverse`` runs) and ``format_fixed_rows`` on a PMAC row
(five motors, a position with 7 decimals and a velocity with 4 each), and prints
ns a row. It also counts, on 10^6 random arguments, where numpy's float64 math
functions differ from the C library's on this machine (why the reference calls
acos and atan2 through ``math``: prsxy_post/kernel/libm.py). A loaded machine
lengthens every figure; best-of-N keeps the least disturbed.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import timeit
from pathlib import Path

import numpy as np

from prsxy_post import kinematics, profile
from prsxy_post.kernel import ik, text

ROOT = Path(__file__).resolve().parent.parent


def per_row(fn: object, rows: int, repeat: int) -> float:
    """Best time of one call over ``repeat`` runs, in ns a row."""
    t = timeit.Timer(fn)  # type: ignore[arg-type]
    number, _ = t.autorange()
    return min(t.repeat(repeat, number)) / number / rows * 1e9


def libm_differences(n: int = 10**6) -> dict[str, float]:
    """Share of arguments where numpy's function and the C library's (through
    math) give different doubles."""
    rng = np.random.default_rng(0)
    a, b = rng.uniform(-1, 1, n), rng.uniform(-1, 1, n)
    t = rng.uniform(-1.6, 1.6, n)
    al, bl, tl = a.tolist(), b.tolist(), t.tolist()
    pairs = {
        "sin": (np.sin(t), np.fromiter(map(math.sin, tl), float, n)),
        "cos": (np.cos(t), np.fromiter(map(math.cos, tl), float, n)),
        "arccos": (np.arccos(a), np.fromiter(map(math.acos, al), float, n)),
        "arctan2": (np.arctan2(a, b), np.fromiter(map(math.atan2, al, bl), float, n)),
        # not a C library function: the C kernel's x * (pi / 180)
        "radians": (np.radians(t * 100), t * 100 * (math.pi / 180.0)),
    }
    return {k: float(np.mean(x != y)) for k, (x, y) in pairs.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=4096, help="rows a call (a chunk)")
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    n = args.rows
    try:
        from prsxy_post.kernel import _ik, _text  # type: ignore[attr-defined]
    except ImportError as e:
        raise SystemExit(f"the compiled kernel is not built ({e}): pip install -e .") from None

    path = ROOT / "profiles" / "prsxy-shop.toml"
    prof = profile.loads(path.read_text(), path.name)
    geo = kinematics.Geometry.from_params(prof.kinematics, prof.origin, prof.table, prof.effects)
    m = geo.ik_arrays
    rng = np.random.default_rng(1)
    q = np.column_stack(
        [rng.uniform(-100, 100, (n, 2)), rng.uniform(-60, 0, n), rng.uniform(-30, 30, (n, 2))]
    )
    tz = ik.tool_z(m, n, 10.0)
    P = ik.inverse_rows(m, q, tz)
    V = rng.uniform(-50, 50, (n, 5))
    cols = [
        col
        for i, a in enumerate("ABCXY")
        for col in (
            (f"{' ' if i else ''}{a}", np.round(P[:, i], 7) + 0.0, 7),
            (":", np.round(V[:, i], 4) + 0.0, 4),
        )
    ]
    print(f"Machine: {platform.platform()}, Python {platform.python_version()}")
    print(f"Load average: {' '.join(f'{x:.1f}' for x in os.getloadavg())} (2 cores)")
    print(f"{n} rows a call, best of {args.repeat}\n")
    print("| kernel | numpy reference ns/row | compiled ns/row | ratio |")
    print("|---|---:|---:|---:|")
    for name, pure, comp in [
        (
            "IK rows (inverse_rows)",
            lambda: ik.inverse_rows(m, q, tz),
            lambda: _ik.inverse_rows(m, q, tz),
        ),
        (
            "PMAC row text (format_fixed_rows)",
            lambda: text.format_fixed_rows(cols),
            lambda: _text.format_fixed_rows(cols),
        ),
    ]:
        a, b = per_row(pure, n, args.repeat), per_row(comp, n, args.repeat)
        print(f"| {name} | {a:.0f} | {b:.0f} | {a / b:.1f} x |")
    print("\nnumpy float64 against the C library (share of 10^6 arguments that differ):")
    for k, v in libm_differences().items():
        print(f"  np.{k}: {100 * v:.2f} %")


if __name__ == "__main__":
    main()
