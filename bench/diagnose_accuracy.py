"""How often diagnose is right: every library member hidden at several sizes and seeds.

    python bench/diagnose_accuracy.py [--seeds 5 | --seed 3 --seed 4] [--json out.json]
    python bench/diagnose_accuracy.py --summarise a.json b.json

For each effect of the library (at realistic sizes: tens of µm for lengths, a few
hundredths of a degree for angles, 0.1 mm/m squareness, a few µm of backlash or
cyclic error, a ms of servo lag), each size in (0.5, 1, 2) × the nominal size and
each seed: hide it in a nominal machine, measure (0.5 µm ballbar, 1 µm poses),
diagnose with the nominal profile, and score:

- named: the first effect is the hidden one or has it among its aliases;
- sized: that estimate is within 20 % (when the hidden one was named itself);
- clean: the residual after is within 20 % of the noise, and a second pass finds
  nothing more.

Plus no-effect runs (nothing may be named) and pairs of effects (both must be found).
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import diagnose, profile  # noqa: E402
from tests.synthetic import campaign  # noqa: E402

SIZES = {
    "kinematics.legs[1].strut_length": -0.03,
    "kinematics.legs[2].guide_height": 0.03,
    "kinematics.legs[3].guide_radius": 0.04,
    "kinematics.legs[1].guide_angle": 0.03,
    "kinematics.legs[2].platform_radius": 0.04,
    "kinematics.legs[3].platform_angle": 0.03,
    "kinematics.legs[1].guide_tilt_x": 0.02,
    "kinematics.legs[2].guide_tilt_y": 0.02,
    "kinematics.legs[3].hinge_twist": 0.03,
    "kinematics.legs[1].platform_z": 0.04,
    "kinematics.tool_length": 0.05,
    "kinematics.tool_offset_x": 0.03,
    "table.squareness": 1e-4,
    "table.scale_x": 5e-5,
    "table.scale_y": -5e-5,
    "backlash[5]": 0.004,
    "backlash[6]": 0.004,
    "backlash[1]": 0.004,
    "cyclic[5]": 0.003,
    "cyclic[2]": 0.003,
    "servo_lag[6]": 1.0,
    "effects.guide_bow[2]": 0.02,
}


def hide(nominal: profile.Profile, effects: dict[str, float]) -> profile.Profile:
    doc = copy.deepcopy(nominal.raw)
    es = [
        diagnose.Effect(
            n,
            v,
            0.0,
            diagnose.unit_of(n),
            period=10.0 if n.startswith("cyclic") else None,
            phase_deg=30.0 if n.startswith("cyclic") else None,
        )
        for n, v in effects.items()
    ]
    return profile.profile_from_dict(diagnose.apply_effects(doc, es, nominal))


def one(nominal: profile.Profile, effects: dict[str, float], seed: int) -> dict:
    truth = hide(nominal, effects)
    rng = np.random.default_rng(seed)
    poses, runs, axis = campaign(truth, nominal, rng)
    d = diagnose.diagnose(nominal, diagnose.Data.build(nominal, poses, runs, axis))
    found = {e.name for e in d.effects} | {a for e in d.effects for a in e.aliases}
    named = all(n in found for n in effects) if effects else not d.effects
    first_ok = (
        bool(effects)
        and bool(d.effects)
        and (d.effects[0].name in effects or any(n in d.effects[0].aliases for n in effects))
    )
    sized = None
    for e in d.effects:
        if e.name in effects:
            sized = abs(e.estimate - effects[e.name]) <= 0.2 * abs(effects[e.name])
    noise = d.noise.get("ballbar", 0.0) * 1000
    again = diagnose.diagnose(
        profile.profile_from_dict(d.updated), diagnose.Data.build(nominal, poses, runs, axis)
    )
    return {
        "effects": effects,
        "seed": seed,
        "named": named,
        "first": first_ok,
        "sized": sized,
        "rms_after_um": d.rms_after_um,
        "noise_um": noise,
        "clean": d.rms_after_um <= 1.2 * max(noise, 0.5) and not again.effects,
        "found": [e.name for e in d.effects],
    }


def scored(nominal: profile.Profile, effects: dict[str, float], seed: int) -> dict:
    """:func:`one`, with an exception counted as a miss (and its message kept)."""
    try:
        return one(nominal, effects, seed)
    except Exception as exc:  # a crash is a wrong answer, not the end of the sweep
        return {
            "effects": effects,
            "seed": seed,
            "named": False,
            "first": False,
            "sized": None,
            "rms_after_um": float("nan"),
            "noise_um": float("nan"),
            "clean": False,
            "found": [f"{type(exc).__name__}: {exc}"],
        }


def run_seed(nominal: profile.Profile, seed: int) -> list[dict]:
    """Every case of one seed; case i of seed s uses RNG seed s·1000 + i."""
    out = [scored(nominal, {}, 1000 + seed)]
    for name, size in SIZES.items():
        for k in (0.5, 1.0, 2.0):
            out.append(scored(nominal, {name: size * k}, seed * 1000 + len(out)))
    names = list(SIZES)
    rng = np.random.default_rng(seed)
    for _ in range(4):
        a, b = rng.choice(len(names), 2, replace=False)
        effects = {names[a]: SIZES[names[a]], names[b]: SIZES[names[b]]}
        out.append(scored(nominal, effects, 5000 + seed * 1000 + len(out)))
    return out


def summarise(out: list[dict]) -> str:
    single = [r for r in out if len(r["effects"]) == 1]
    none = [r for r in out if not r["effects"]]
    pairs = [r for r in out if len(r["effects"]) == 2]
    sized = [r for r in single if r["sized"] is not None]
    lines = [
        f"seeds {sorted({r['seed_group'] for r in out})}: {len(out)} diagnoses",
        f"single effects: named first {sum(r['first'] for r in single)}/{len(single)}, "
        f"sized within 20 % {sum(r['sized'] for r in sized)}/{len(sized)}, "
        f"residual to noise and nothing more on a second pass "
        f"{sum(r['clean'] for r in single)}/{len(single)}",
        f"no hidden effect: nothing named {sum(r['named'] for r in none)}/{len(none)}",
        f"two hidden effects: both found {sum(r['named'] for r in pairs)}/{len(pairs)}",
    ]
    for r in out:
        ok = r["named"] and (len(r["effects"]) != 1 or (r["first"] and r["clean"]))
        if not ok:
            lines.append(
                f"  missed: {r['effects']} found {r['found']} after {r['rms_after_um']:.2f} µm"
            )
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=3, help="seeds 0 .. N-1")
    ap.add_argument("--seed", type=int, action="append", help="these seeds instead")
    ap.add_argument("--json", help="write the cases here")
    ap.add_argument("--summarise", nargs="+", metavar="JSON", help="only summarise saved runs")
    args = ap.parse_args()
    if args.summarise:
        out = [r for f in args.summarise for r in json.loads(Path(f).read_text())]
        print(summarise(out))
        return
    nominal = profile.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    out = []
    for seed in args.seed or range(args.seeds):
        cases = run_seed(nominal, seed)
        for r in cases:
            r["seed_group"] = seed
        out += cases
        print(f"seed {seed}: {len(out)} diagnoses so far", file=sys.stderr)
    print(summarise(out))
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
