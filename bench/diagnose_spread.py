"""How far diagnose's estimates stray, in its own standard errors, over noise draws.

    python bench/diagnose_spread.py --effects 5 --machine 5009 --draws 11 12 13
    python bench/diagnose_spread.py --plant table.scale_x=-5e-5 --draws 1 2 3 4
    python bench/diagnose_spread.py --effects 5 --machine 5009 --draws 7 --noise-scale 0.01

One machine (``--effects n --machine s``: ``diagnose_accuracy.py``'s draw of n
library members for seed s; or ``--plant name=delta ...``), the contract's
measurement campaign on it once per draw (a new noise seed each), ``diagnose`` with
the nominal profile. Prints z = (estimate − truth) / standard error for every
planted effect and draw, and the rms of z per effect over the draws: 1 where the
standard errors are honest. ``--noise-scale`` scales every instrument's noise:
where the estimates' errors shrink with it, the model holds no bias.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import diagnose_accuracy as da  # noqa: E402

from prsxy_post import diagnose, effects, experiments, measure, profile, simulate  # noqa: E402


def campaign(truth: profile.Profile, nominal: profile.Profile, seed: int, scale: float):
    """The campaign of ``diagnose_accuracy.campaign`` with every noise scaled."""
    if scale == 1.0:
        return da.campaign(truth, nominal, seed)
    files = experiments.measurement_files(
        truth,
        nominal,
        np.random.default_rng(seed),
        noise_um=0.5 * scale,
        pose_noise_um=1.0 * scale,
        laser_noise_um=0.3 * scale,
    )
    data = [measure.read_measurement(text, name) for name, text in files.items()]
    return diagnose.Data.build(
        nominal,
        [d for d in data if isinstance(d, measure.PoseData)],
        [d for d in data if isinstance(d, measure.BallbarRun)],
        [d for d in data if isinstance(d, measure.AxisData)],
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--effects", type=int, help="draw this many library members")
    ap.add_argument("--machine", type=int, help="the draw's seed (diagnose_accuracy's n*1000+seed)")
    ap.add_argument("--plant", nargs="+", metavar="NAME=DELTA", help="plant these instead")
    ap.add_argument("--draws", type=int, nargs="+", required=True, help="noise seeds")
    ap.add_argument("--noise-scale", type=float, default=1.0)
    args = ap.parse_args()
    nominal = profile.loads(da.NOMINAL.read_text(), "prsxy-nominal.toml")
    if args.plant:
        changes = [
            effects.Change(name, float(delta))
            for name, delta in (p.split("=", 1) for p in args.plant)
        ]
    elif args.effects is not None and args.machine is not None:
        changes = da.draw(np.random.default_rng(args.machine), args.effects, da.confounded(nominal))
    else:
        ap.error("give --plant, or --effects and --machine")
    truth = simulate.plant(nominal, changes, "spread")
    z: dict[str, list[float]] = {}
    for seed in args.draws:
        d = diagnose.diagnose(nominal, campaign(truth, nominal, seed, args.noise_scale))
        sc = da.score(changes, d)
        row = []
        for h in sc["hidden"]:
            key = h["name"] + (f"@{h['period']:g}" if h["period"] else "")
            if h["estimate"] is None:
                row.append(f"{key}: not named")
                continue
            zz = (h["estimate"] - h["true"]) / h["stderr"]
            z.setdefault(key, []).append(zz)
            row.append(f"{key}: z {zz:+.2f} (se {h['stderr']:.2g})")
        print(f"draw {seed}: " + "; ".join(row) + (f"; false {sc['false']}" if sc["false"] else ""))
    print("\n| effect | draws | rms z |\n|---|---:|---:|")
    for key, vals in z.items():
        print(f"| {key} | {len(vals)} | {float(np.sqrt(np.mean(np.square(vals)))):.2f} |")


if __name__ == "__main__":
    main()
