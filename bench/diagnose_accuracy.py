"""How often diagnose is right on machines with several effects at once.

    python bench/diagnose_accuracy.py [--effects 3 5 8] [--seeds 0 1 2 ...] [--json out.json]
    python bench/diagnose_accuracy.py --summarise a.json b.json

For each number of effects and each seed: a random machine, the nominal design
with that many library members changed at realistic sizes (0.5 to 2 times each
member's prior, either sign; :func:`prsxy_post.simulate.random_effects`), at most
one member of each confounded group (members whose signatures correlate above
diagnose's alias threshold on these data: the data determine only their sum); the
contract's measurement files of a campaign on it (``simulate``'s: 16 ballbar runs
with 0.5 µm noise, 300 poses with 1 µm, laser runs with 0.3 µm), commanded with
the nominal profile and read back from their text; ``diagnose`` with the nominal
profile. Scored per hidden effect:

- named: the effect, or one that diagnose says it cannot tell apart from it (its
  group), is named (a periodic term with its period);
- sized: named itself and its estimate within 20 % of the truth;
- covered: named itself and the truth within 2 standard errors of the estimate;

and per diagnosis: nothing false (every named effect is a hidden one or has one
among its aliases). Plus machines with nothing hidden (nothing may be named).
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

import mdsection  # noqa: E402

from prsxy_post import diagnose, effects, experiments, measure, profile, simulate  # noqa: E402
from prsxy_post.diagnose import model, selection  # noqa: E402

NOMINAL = ROOT / "profiles" / "prsxy-nominal.toml"
#: The instruments' noise in the campaign [mm, deg] (experiments.measurement_files'
#: defaults; the pose axis noise is simulate.measure_poses').
NOISE = {"ballbar": 0.5e-3, "pose_tip": 1e-3, "pose_axis": 3e-4, "axis": 0.3e-3}


def campaign(truth: profile.Profile, nominal: profile.Profile, seed: int) -> diagnose.Data:
    """The contract's files of a campaign on ``truth``, read back from their text."""
    rng = np.random.default_rng(seed)
    files = experiments.measurement_files(truth, nominal, rng)
    data = [measure.read_measurement(text, name) for name, text in files.items()]
    return diagnose.Data.build(
        nominal,
        [d for d in data if isinstance(d, measure.PoseData)],
        [d for d in data if isinstance(d, measure.BallbarRun)],
        [d for d in data if isinstance(d, measure.AxisData)],
    )


def confounded(nominal: profile.Profile, seed: int = 12345) -> dict[str, set[str]]:
    """Each member's confounded group on a nominal campaign: members whose whitened
    signatures correlate above diagnose's alias threshold, and members taking part
    in a combination the data do not determine at all (diagnose's
    ``undetermined_with``: the platform frame's definition, a common servo lag)."""
    d = campaign(nominal, nominal, seed)
    names = effects.members()
    keys = model.column_keys(names)
    lin = model.predict(nominal, d, keys)
    meas, segs = d.measured()
    w = diagnose._whiten(segs, NOISE, len(meas))
    ok = np.isfinite(meas)
    single = [k for k in keys if lin.columns[k].shape[1] == 1]
    X = np.column_stack([lin.columns[k][:, 0] * w for k in single])[ok]
    nrm = np.linalg.norm(X, axis=0)
    visible = nrm > 0
    Xn = X[:, visible] / nrm[visible]
    C = np.abs(Xn.T @ Xn)
    vis = [k for k, v in zip(single, visible, strict=True) if v]
    groups: dict[str, set[str]] = {k: {k} for k in names}
    for i, a in enumerate(vis):
        for j, b in enumerate(vis):
            if i != j and C[i, j] > diagnose.ALIAS_CORR:
                groups[a].add(b)
    rows = diagnose._kind_rows(segs, len(meas))
    normal = selection.Normal.of(lin.columns, np.where(ok, 0.0, np.nan), rows)
    g = selection.Gram.build(normal, {k: NOISE[k] for k in rows}, keys)
    for i, tied in selection.undetermined(g).items():
        a = model.split_key(g.keys[i])[0]
        groups[a] |= {model.split_key(g.keys[j])[0] for j in tied}
    return groups


def draw(rng: np.random.Generator, n: int, groups: dict[str, set[str]]) -> list[effects.Change]:
    """n random library members at realistic sizes, no two in one confounded group."""
    while True:
        changes = simulate.random_effects(rng, n)
        names = [c.name for c in changes]
        if all(not (groups[a] & set(names) - {a}) for a in names):
            return changes


def score(truth: list[effects.Change], d: diagnose.Diagnosis) -> dict:
    def same(e: diagnose.Effect, t: effects.Change) -> bool:
        return e.name == t.name and (t.period is None or e.period == t.period)

    def names_it(e: diagnose.Effect, t: effects.Change) -> bool:
        return same(e, t) or (t.period is None and t.name in e.aliases)

    per = []
    for t in truth:
        own = next((e for e in d.effects if same(e, t)), None)
        named = own is not None or any(names_it(e, t) for e in d.effects)
        row = {
            "name": t.name,
            "period": t.period,
            "true": t.delta,
            "named": named,
            "estimate": own.estimate if own else None,
            "stderr": own.stderr if own else None,
            "sized": None,
            "covered": None,
        }
        if own is not None:
            row["sized"] = abs(own.estimate - t.delta) <= 0.2 * abs(t.delta)
            row["covered"] = abs(own.estimate - t.delta) <= 2 * own.stderr
        per.append(row)
    false = [
        f"{e.name}" + (f"@{e.period:g}" if e.period else "")
        for e in d.effects
        if not any(names_it(e, t) for t in truth)
    ]
    return {"hidden": per, "false": false}


def one(nominal: profile.Profile, n: int, seed: int, groups: dict[str, set[str]]) -> dict:
    rng = np.random.default_rng(seed)
    truth_changes = draw(rng, n, groups) if n else []
    truth = simulate.plant(nominal, truth_changes, f"random {n} seed {seed}")
    data = campaign(truth, nominal, seed + 100_000)
    t0 = time.process_time()
    try:
        d = diagnose.diagnose(nominal, data)
    except Exception as exc:  # a crash is a wrong answer, not the end of the sweep
        return {
            "n": n,
            "seed": seed,
            "hidden": [
                {"name": c.name, "period": c.period, "true": c.delta, "named": False}
                for c in truth_changes
            ],
            "false": [f"{type(exc).__name__}: {exc}"],
            "cpu_s": time.process_time() - t0,
        }
    out = score(truth_changes, d)
    out.update(
        n=n,
        seed=seed,
        cpu_s=time.process_time() - t0,
        rms_before_um=d.rms_before_um,
        rms_after_um=d.rms_after_um,
        found=[(e.name, e.period, e.estimate, e.stderr) for e in d.effects],
        unexplained=[u["kind"] for u in d.unexplained],
    )
    return out


def _pct(k: int, n: int) -> str:
    return f"{k}/{n} ({100.0 * k / n:.1f} %)" if n else "-"


def summarise(out: list[dict]) -> str:
    lines = [
        "| effects | machines | named | sized within 20 % | nothing false "
        "| covered by 2 SE | CPU s per diagnosis |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for n in sorted({r["n"] for r in out}):
        rs = [r for r in out if r["n"] == n]
        hidden = [h for r in rs for h in r["hidden"]]
        sized = [h for h in hidden if h.get("sized") is not None]
        cov = [h for h in hidden if h.get("covered") is not None]
        cpu = np.mean([r["cpu_s"] for r in rs])
        lines.append(
            f"| {n} | {len(rs)} | {_pct(sum(h['named'] for h in hidden), len(hidden))} | "
            f"{_pct(sum(h['sized'] for h in sized), len(sized))} | "
            f"{_pct(sum(not r['false'] for r in rs), len(rs))} | "
            f"{_pct(sum(h['covered'] for h in cov), len(cov))} | {cpu:.0f} |"
        )
    # z = (estimate - truth) / SE over every estimate with a standard error
    z = np.array(
        [
            (h["estimate"] - h["true"]) / h["stderr"]
            for r in out
            for h in r["hidden"]
            if h.get("covered") is not None and h.get("stderr")
        ]
    )
    if z.size:
        rms, within = np.sqrt(np.mean(z**2)), 100.0 * np.mean(np.abs(z) <= 2)
        lines += [
            "",
            f"z = (estimate - truth) / SE over {z.size} estimates: "
            f"rms {rms:.2f}, |z| <= 2 for {within:.1f} %",
        ]
    misses = []
    for r in out:
        for h in r["hidden"]:
            if not h["named"] or h.get("sized") is False or h.get("covered") is False:
                what = (
                    "not named"
                    if not h["named"]
                    else "size"
                    if h.get("sized") is False
                    else "not covered"
                )
                est = f" est {h['estimate']:.4g} ± {h['stderr']:.2g}" if h.get("estimate") else ""
                if h.get("estimate") and h.get("stderr"):
                    est += f" (z {(h['estimate'] - h['true']) / h['stderr']:+.2f})"
                misses.append(
                    f"  n={r['n']} seed {r['seed']}: {h['name']}"
                    + (f"@{h['period']:g}" if h.get("period") else "")
                    + f" true {h['true']:.4g}{est}: {what}"
                )
        if r["false"]:
            misses.append(f"  n={r['n']} seed {r['seed']}: false {r['false']}")
    return "\n".join(lines + (["", "misses:", *misses] if misses else []))


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--effects", type=int, nargs="+", default=[3, 5, 8])
    ap.add_argument("--seeds", type=int, nargs="+", default=list(range(10)))
    ap.add_argument("--json", help="write the cases here")
    ap.add_argument("--summarise", nargs="+", metavar="JSON", help="only summarise saved runs")
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    head = mdsection.header("Diagnosis on random machines") + "\n" if args.markdown else ""
    if args.summarise:
        out = [r for f in args.summarise for r in json.loads(Path(f).read_text())]
        print(head + summarise(out))
        return
    nominal = profile.loads(NOMINAL.read_text(), "prsxy-nominal.toml")
    groups = confounded(nominal)
    out = []
    for n in args.effects:
        for seed in args.seeds:
            r = one(nominal, n, 1000 * n + seed, groups)
            out.append(r)
            print(
                f"n={n} seed {seed}: {sum(h['named'] for h in r['hidden'])}/{n} named, "
                f"false {r['false']}, {r['cpu_s']:.0f} s",
                file=sys.stderr,
            )
            if args.json:
                Path(args.json).write_text(json.dumps(out, indent=1, default=float))
    print(head + summarise(out))


if __name__ == "__main__":
    main()
