"""What a second fixed-point step of the virtual-axis map would change.

Usage::

    python bench/map_steps.py
    python bench/map_steps.py --amplitudes 1 10 50 --noise 1

The contract compensates with Q' = Q − e(Q) (``docs/machine-model.md``, the paper's
Eq. 6), one evaluation of the map. The machine, commanded Q', errs by e(Q'), so
Q' = Q − e(Q') solved by fixed-point steps would land the tip closer by
|∇e · e|. This script fits maps (``errormap.fit``, degree 3) to smooth errors of
each amplitude [µm] (``A · sin(q / 50)`` per axis, plus Gaussian measurement noise
of ``--noise`` µm) over the benchmark's work volume, and prints per map: the
largest |e| [µm], the largest change a second step makes [nm] (what one evaluation
leaves of the fixed point), and the map's cross-validated RMS [µm] (its own
prediction error on points it was not fitted on), at 50 000 random poses.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from prsxy_post import chain, errormap

LO = np.array([-150.0, -150.0, -60.0, -25.0, -25.0])
HI = np.array([150.0, 150.0, 40.0, 25.0, 25.0])


def poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 5) uniform poses over the benchmark's volume [mm, mm, mm, deg, deg]."""
    return rng.uniform(LO, HI, (n, 5))


def measure(amplitude_um: float, noise_um: float, seed: int = 1) -> dict[str, float]:
    rng = np.random.default_rng(seed)
    q = poses(rng, 300)
    err = 1e-3 * (amplitude_um * np.sin(q / 50.0) + rng.normal(0, noise_um, q.shape))
    emap = errormap.fit(q, err, rng=rng, degrees=(3,), lambdas=[1e-4])
    qs = poses(rng, 50_000)
    one = chain.correct_virtual(qs, emap, 1)
    two = chain.correct_virtual(qs, emap, 2)
    return {
        "e_max_um": float(np.abs(emap(qs)).max() * 1e3),
        "step_nm": float(np.abs(two - one).max() * 1e6),
        "cv_rms_um": float(max(emap.cv_rms.values()) * 1e3),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--amplitudes", type=float, nargs="+", default=[1.0, 10.0, 50.0])
    ap.add_argument("--noise", type=float, default=1.0, help="measurement noise [µm]")
    args = ap.parse_args()
    print(
        "| amplitude [µm] | max abs e [µm] | second step changes Q' by [nm] | map's CV RMS [µm] |"
    )
    print("|---:|---:|---:|---:|")
    for a in args.amplitudes:
        r = measure(a, args.noise)
        print(f"| {a:g} | {r['e_max_um']:.2f} | {r['step_nm']:.3g} | {r['cv_rms_um']:.2f} |")


if __name__ == "__main__":
    main()
