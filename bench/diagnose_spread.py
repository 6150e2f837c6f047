"""How far diagnose's estimates stray, in its own standard errors, over noise draws.

    python bench/diagnose_spread.py --effects 5 --machine 5009 --draws 11 12 13
    python bench/diagnose_spread.py --plant table.scale_x=-5e-5 --draws 1 2 3 4
    python bench/diagnose_spread.py --effects 5 --machine 5009 --draws 7 --noise-scale 0.01
    python bench/diagnose_spread.py --effects 5 --machine 5000 ... 5009 --draws 1 ... 8 --known

One machine or several (``--effects n --machine s ...``: ``diagnose_accuracy.py``'s
draw of n library members for seed s; or ``--plant name=delta ...``), the
contract's measurement campaign on each once per draw (a new noise seed each),
``diagnose`` with the nominal profile. Prints z = (estimate − truth) / standard
error for every planted effect and draw, the rms of z per effect over the draws
(1 where the standard errors are honest) and, pooled over everything, the rms of
z and the share within 2 (95.4 % for a normal z). ``--known``: no selection, the
planted members alone refined jointly (``diagnose.refine``, weighted by the
instruments' noise), z per fitted column (a periodic term's cosine and sine
parts): the standard errors of the joint fit on their own. ``--noise-scale``
scales every instrument's noise.
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


def known(
    changes: list[effects.Change], nominal: profile.Profile, data: diagnose.Data, scale: float
) -> dict[str, float]:
    """z per column of the planted members refined alone, from the truth."""
    keys, truth = [], []
    for c in changes:
        if c.period is None:
            keys.append(c.name)
            truth.append(c.delta)
        else:
            key = f"{c.name}@{c.period:g}"
            ph = np.radians(c.phase or 0.0)
            keys.append(key)
            truth += [c.delta * np.cos(ph), c.delta * np.sin(ph)]
    x_true = np.array(truth)
    measured, segs = data.measured()
    w = diagnose._whiten(segs, {k: v * scale for k, v in da.NOISE.items()}, len(measured))
    fit = diagnose.refine(nominal, data, measured, w, keys, x_true)
    z = (fit.x - x_true) / np.sqrt(np.diag(fit.cov))
    names = []
    for k, d in zip(keys, fit.dims, strict=True):
        names += [k] if d == 1 else [f"{k} cos", f"{k} sin"]
    return dict(zip(names, z.tolist(), strict=True))


def selected(changes: list[effects.Change], d: diagnose.Diagnosis) -> tuple[dict, list[str]]:
    """z per planted effect diagnose named itself; the rest said in words."""
    sc = da.score(changes, d)
    z, words = {}, []
    for h in sc["hidden"]:
        key = h["name"] + (f"@{h['period']:g}" if h["period"] else "")
        if h["estimate"] is None:
            words.append(f"{key}: not named")
        else:
            z[key] = (h["estimate"] - h["true"]) / h["stderr"]
    if sc["false"]:
        words.append(f"false {sc['false']}")
    return z, words


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--effects", type=int, help="draw this many library members")
    ap.add_argument(
        "--machine", type=int, nargs="+", help="the draws' seeds (diagnose_accuracy's n*1000+seed)"
    )
    ap.add_argument("--plant", nargs="+", metavar="NAME=DELTA", help="plant these instead")
    ap.add_argument("--draws", type=int, nargs="+", required=True, help="noise seeds")
    ap.add_argument("--noise-scale", type=float, default=1.0)
    ap.add_argument("--known", action="store_true", help="refine the planted members alone")
    args = ap.parse_args()
    nominal = profile.loads(da.NOMINAL.read_text(), "prsxy-nominal.toml")
    if args.plant:
        machines = {
            "planted": [
                effects.Change(name, float(delta))
                for name, delta in (p.split("=", 1) for p in args.plant)
            ]
        }
    elif args.effects is not None and args.machine:
        groups = da.confounded(nominal)
        machines = {
            str(s): da.draw(np.random.default_rng(s), args.effects, groups) for s in args.machine
        }
    else:
        ap.error("give --plant, or --effects and --machine")
    pooled: list[float] = []
    table = []
    for label, changes in machines.items():
        truth = simulate.plant(nominal, changes, "spread")
        z: dict[str, list[float]] = {}
        for seed in args.draws:
            data = campaign(truth, nominal, seed, args.noise_scale)
            if args.known:
                row, words = known(changes, nominal, data, args.noise_scale), []
            else:
                row, words = selected(changes, diagnose.diagnose(nominal, data))
            for k, v in row.items():
                z.setdefault(k, []).append(v)
            pooled += row.values()
            shown = [f"{k}: z {v:+.2f}" for k, v in row.items()] + words
            print(f"machine {label} draw {seed}: " + "; ".join(shown), flush=True)
        for key, vals in z.items():
            table.append((label, key, len(vals), float(np.sqrt(np.mean(np.square(vals))))))
    print("\n| machine | effect | draws | rms z |\n|---|---|---:|---:|")
    for label, key, n, rms in table:
        print(f"| {label} | {key} | {n} | {rms:.2f} |")
    zz = np.array(pooled)
    if zz.size:
        print(
            f"\npooled: {zz.size} z values, rms {float(np.sqrt(np.mean(zz**2))):.3f}, "
            f"within 2: {int(np.sum(np.abs(zz) <= 2))}/{zz.size} "
            f"({100.0 * float(np.mean(np.abs(zz) <= 2)):.1f} %)"
        )


if __name__ == "__main__":
    main()
