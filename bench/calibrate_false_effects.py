"""Does calibrate write effects a machine does not have? (issue 32)

    python bench/calibrate_false_effects.py [--machines 20] [--seed 0] [--json out.json]
        [--truth profiles/some-machine.toml ...]

Each machine: the nominal design with a random error in every contract term,
smooth real-axis tables with backlash on every motor (``simulate.random_machine``
with ``axis_errors``), and no physical effect at all (no bow, straightness,
cyclic error or servo lag). It is measured as ``tests/loop.py`` measures (the
contract's files read back from their text: 16 ballbar runs with 0.5 µm noise,
400 poses with 1 µm, laser runs 20 mm apart with 0.3 µm) while the nominal profile
commands it, and ``calibrate`` runs all four stages from the nominal profile.
Every effect its physical stage writes is false. ``--truth`` adds machines given
as profiles (e.g. the contract's ``perturbed.toml``), measured the same way.

Prints one row per machine and the summary: machines with nothing false.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import calibrate, profile, simulate  # noqa: E402
from tests import loop  # noqa: E402


def one(nominal: profile.Profile, truth: profile.Profile, seed: int) -> dict:
    data = loop.measurements(truth, nominal, seed)
    t0 = time.process_time()
    cal = calibrate.calibrate(nominal, nominal, *data)
    cpu = time.process_time() - t0
    return {
        "seed": seed,
        "cpu_s": cpu,
        "false": [
            f"{e.name}" + (f"@{e.period:g}" if e.period else "") + f" {e.estimate:+.4g} {e.unit}"
            for e in cal.effects
        ],
    }


def summarise(out: list[dict]) -> str:
    lines = [
        "| machine | seed | effects written (all false) | calibrate CPU s |",
        "|---|---:|---|---:|",
    ]
    for r in out:
        lines.append(
            f"| {r['machine']} | {r['seed']} | {', '.join(r['false']) or 'none'} "
            f"| {r['cpu_s']:.0f} |"
        )
    clean = sum(not r["false"] for r in out)
    n = len(out)
    lines += [
        "",
        f"nothing false on {clean}/{n} machines ({100.0 * clean / max(n, 1):.1f} %); "
        f"{sum(len(r['false']) for r in out)} false effects written in all",
    ]
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--machines", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0, help="the first machine's seed")
    ap.add_argument("--truth", nargs="*", default=[], help="profiles of further machines")
    ap.add_argument("--json", help="write the cases here as they finish")
    args = ap.parse_args()
    nominal = profile.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    out: list[dict] = []
    cases: list[tuple[profile.Profile, int]] = []
    for k in range(args.machines):
        seed = args.seed + k
        rng = np.random.default_rng(seed)
        truth = simulate.random_machine(
            nominal, rng, axis_errors=True, effects=False, name=f"clean {seed}"
        )
        cases.append((truth, seed))
    for path in args.truth:
        cases.append((profile.loads(Path(path).read_text(), path), args.seed))
    for truth, seed in cases:
        r = one(nominal, truth, seed)
        if truth.source and not truth.source.startswith("<"):
            r["machine"] = Path(truth.source).name
        else:
            r["machine"] = f"random {seed}"
        out.append(r)
        print(
            f"{r['machine']}: false {r['false']}, {r['cpu_s']:.0f} s", file=sys.stderr, flush=True
        )
        if args.json:
            Path(args.json).write_text(json.dumps(out, indent=1))
    print(summarise(out))


if __name__ == "__main__":
    main()
