"""What a model leaves: noise, regions of disagreement, and what stays unexplained.

Nothing stops silently: after a diagnosis every data kind (ballbar, pose tip,
pose axis, laser) is held against its noise, and a kind left above it is
reported with where (the regions), by how much, and how much of it the library
could take at all.

A kind is left unexplained when a statistical test rejects, at
:data:`CONFIDENCE` (99.9 %), the hypothesis that its residual is the
measurement noise; the item states the test, its statistic, its degrees of
freedom and its p-value:

- **ballbar** (the noise estimated from the same runs): the von Neumann ratio
  η = Σ (r_{k+1} − r_k)² / Σ r_k², pooled over the runs. Under the hypothesis
  (independent noise of one variance, zero mean) E[η] = 2 (ν − R)/ν and
  var η ≈ 4/ν with ν the samples and R the runs; anything smooth the model
  leaves lowers η (consecutive samples agree more than noise does), one-sided
  normal test. The noise it is held against is the one successive differences
  give, √(Σ Δr² / 2(ν − R)), which a smooth error does not reach;
- **pose tip, pose axis** (no noise estimate independent of the model): the
  F-test of a smooth function fitted to the residual (Legendre products of
  degree 2 in x, y, z, A, B) against what it leaves, F(p, ν − p);
- **laser**: the lack-of-fit F-test against the pure error of repeated runs,
  F = [Σ_g n_g r̄_g² / G] / [Σ (r − r̄_g)² / (ν − G)] over the G targets and
  directions, F(G, ν − G).

A residual a few per cent above the noise over tens of thousands of ballbar
samples is beyond the noise when its excess is structured (the test finds it);
a noise estimate off by as much is not (nothing is flagged: there is no ratio
threshold).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from scipy import stats

if TYPE_CHECKING:
    from .model import Data, Linearised, Segment

#: A kind is left unexplained when its test rejects "the residual is the noise"
#: at this confidence.
CONFIDENCE = 0.999
P_LEFT = 1.0 - CONFIDENCE
HARMONICS = 12

_LABEL = {
    "ballbar": ("ballbar", 1000.0, "µm"),
    "pose_tip": ("pose tip", 1000.0, "µm"),
    "pose_axis": ("pose axis", 3600.0, "arcsec"),
    "axis": ("laser", 1000.0, "µm"),
}


def _mad_diff(v: np.ndarray) -> float:
    d = np.diff(v)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2))


def independent_noise(data: Data, resid: np.ndarray, segs: list[Segment]) -> dict[str, float]:
    """Noise estimates that do not depend on any model [mm]: ballbar from the scatter
    of consecutive samples of the residual, laser from repeated runs."""
    out: dict[str, float] = {}
    diffs = [
        np.diff(resid[s.start : s.stop])
        for s in segs
        if s.kind == "ballbar" and s.stop - s.start > 10
    ]
    if diffs:
        d = np.concatenate(diffs)
        out["ballbar"] = float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2))
    dev, dof = 0.0, 0
    for a in data.axis:
        keys = np.stack([a.motor, a.target, a.direction], -1)
        _, inv = np.unique(keys, axis=0, return_inverse=True)
        inv = inv.ravel()
        for grp in np.unique(inv):
            x = a.measured[inv == grp]
            if len(x) > 1:
                dev += float(np.sum((x - x.mean()) ** 2))
                dof += len(x) - 1
    if dof:
        out["axis"] = math.sqrt(dev / dof)
    return out


def regions(
    data: Data, resid: np.ndarray, segs: list[Segment], noise: dict[str, float]
) -> list[dict[str, Any]]:
    """Residual per run and per region, largest against the noise first.

    Ballbar runs: the whole run, 45° sectors of the angle in the run's plane and
    the axis reversals; poses: all, tilt levels, halves of x, y, z; laser runs.
    """
    out: list[dict[str, Any]] = []

    def add(seg: Segment, region: str, v: np.ndarray, scale: float, unit: str) -> None:
        v = v[np.isfinite(v)]
        if not v.size:
            return
        rms = float(np.sqrt(np.mean(v**2))) * scale
        nz = noise.get(seg.kind, float("nan")) * scale
        out.append(
            {
                "source": seg.source,
                "kind": seg.kind,
                "region": region,
                "n": int(v.size),
                f"rms_{unit}": rms,
                f"max_{unit}": float(np.max(np.abs(v))) * scale,
                f"noise_{unit}": nz,
                "ratio": rms / nz if nz > 0 else float("inf"),
            }
        )

    ri = 0
    pi = 0
    for seg in segs:
        v = resid[seg.start : seg.stop]
        if seg.kind == "ballbar":
            r = data.runs[ri]
            ri += 1
            add(seg, "whole run", v, 1000.0, "um")
            ang = _run_angle(r.commanded, r.pivot)
            for lo in range(0, 360, 45):
                sel = (ang >= lo) & (ang < lo + 45)
                add(seg, f"angle {lo}-{lo + 45} deg", v[sel], 1000.0, "um")
            off = np.abs(((ang[:, None] - np.array([0, 90, 180, 270])) + 180) % 360 - 180)
            add(seg, "axis reversals (within 5 deg)", v[np.min(off, axis=1) < 5], 1000.0, "um")
        elif seg.kind == "pose_tip":
            p = data.poses[pi]
            v3 = v.reshape(-1, 3)
            q = p.commanded
            add(seg, "all poses", v, 1000.0, "um")
            tilt = np.degrees(np.arccos(np.cos(np.radians(q[:, 3])) * np.cos(np.radians(q[:, 4]))))
            for lo, hi in ((0, 5), (5, 15), (15, 90)):
                sel = (tilt >= lo) & (tilt < hi)
                add(seg, f"tilt {lo}-{hi} deg", v3[sel].ravel(), 1000.0, "um")
            for ax, nm in ((0, "x"), (1, "y"), (2, "z")):
                mid = np.median(q[:, ax])
                add(seg, f"{nm} < {mid:.0f}", v3[q[:, ax] < mid].ravel(), 1000.0, "um")
                add(seg, f"{nm} >= {mid:.0f}", v3[q[:, ax] >= mid].ravel(), 1000.0, "um")
        elif seg.kind == "pose_axis":
            add(seg, "all poses (axis)", v, 3600.0, "arcsec")
            pi += 1
        elif seg.kind == "axis":
            add(seg, "laser runs", v, 1000.0, "um")
    out.sort(key=lambda d: -d["ratio"])
    return out


def _run_angle(commanded: np.ndarray, pivot: np.ndarray) -> np.ndarray:
    """Angle [deg, 0-360) of the commanded tip about the pivot in the run's plane
    (the two axes it spans most)."""
    rel = commanded[:, :3] - pivot
    ext = np.ptp(rel, axis=0)
    a0, a1 = sorted(int(i) for i in np.argsort(ext)[::-1][:2])
    return np.degrees(np.arctan2(rel[:, a1], rel[:, a0])) % 360


def _legendre2(q: np.ndarray) -> np.ndarray:
    """1, each coordinate and every product of two, coordinates scaled to [-1, 1]."""
    lo, hi = q.min(axis=0), q.max(axis=0)
    u = (q - lo) / np.where(hi > lo, hi - lo, 1.0) * 2 - 1
    cols = [np.ones(len(q))]
    k = q.shape[1]
    cols += [u[:, i] for i in range(k)]
    cols += [u[:, i] * u[:, j] for i in range(k) for j in range(i, k)]
    return np.column_stack(cols)


def _structure(
    data: Data, resid: np.ndarray, segs: list[Segment], kind: str
) -> tuple[float, float, int, int, float]:
    """(RMS of the fitted smooth part, p-value of its F-test, rows, columns, F) for
    one kind."""
    ss_fit = ss_res = 0.0
    n = p = 0
    ri = pi = 0
    for seg in segs:
        v = resid[seg.start : seg.stop]
        X = None
        if seg.kind == "ballbar":
            r = data.runs[ri]
            ri += 1
            if kind == "ballbar":
                th = np.radians(_run_angle(r.commanded, r.pivot))
                X = np.column_stack(
                    [np.ones_like(th)]
                    + [f(k * th) for k in range(1, HARMONICS + 1) for f in (np.cos, np.sin)]
                )
        elif seg.kind in ("pose_tip", "pose_axis"):
            q = data.poses[pi].commanded
            if seg.kind == "pose_axis":
                pi += 1
            if seg.kind == kind:
                comps = 3 if kind == "pose_tip" else 2
                B = _legendre2(q)
                X = np.kron(B, np.eye(comps))  # rows ordered pose by pose, component inner
        elif seg.kind == "axis" and kind == "axis":
            a = data.axis[[s for s in segs if s.kind == "axis"].index(seg)]
            blocks = []
            for m in np.unique(a.motor):
                for d in (1, -1):
                    sel = (a.motor == m) & (a.direction == d)
                    if not sel.any():
                        continue
                    t = a.target
                    span = max(float(np.ptp(t[sel])), 1e-9)
                    u = (t - float(np.mean(t[sel]))) / span
                    blocks += [np.where(sel, u**j, 0.0) for j in range(4)]
            X = np.column_stack(blocks) if blocks else None
        if X is None:
            continue
        ok = np.isfinite(v)
        X, v = X[ok], v[ok]
        if len(v) <= X.shape[1] + 1:
            continue
        coef, *_ = np.linalg.lstsq(X, v, rcond=None)
        fitted = X @ coef
        ss_fit += float(fitted @ fitted)
        rr = v - fitted
        ss_res += float(rr @ rr)
        n += len(v)
        p += X.shape[1]
    if n == 0 or n <= p:
        return 0.0, 1.0, 0, 0, 0.0
    F = (ss_fit / p) / max(ss_res / (n - p), 1e-300)
    return math.sqrt(ss_fit / n), float(stats.f.sf(F, p, n - p)), n, p, F


def unexplained(
    data: Data,
    after: np.ndarray,
    segs: list[Segment],
    noise: dict[str, float],
    w: np.ndarray,
    library: Callable[[], Linearised] | None = None,
    table_errors: TableErrors | None = None,
) -> list[dict[str, Any]]:
    """Every data kind the model leaves above its noise (module docstring).

    library : the signatures of every member at the final model, asked for only
        when something is left, to say how much of it the library could take.
    table_errors : the signatures of errors of the model's table values and their
        standard errors (the laser runs' :class:`.nuisance.Nuisance`), asked for only
        when a kind is flagged: the test is then repeated on what is left after the
        errors of that size in the tables that explain most of the residual
        (:func:`allow_for_tables`), since the measurements are no better than the
        tables they were modelled with; a kind is left unexplained only if it is
        still not the noise.
    """
    out: list[dict[str, Any]] = []
    kinds = [
        k for k in ("ballbar", "pose_tip", "pose_axis", "axis") if any(s.kind == k for s in segs)
    ]
    lin: Linearised | None = None
    tables_left: np.ndarray | None = None
    for kind in kinds:
        label, scale, unit = _LABEL[kind]
        rows = np.zeros(len(after), dtype=bool)
        for s in segs:
            if s.kind == kind:
                rows[s.start : s.stop] = True
        v = after[rows]
        v = v[np.isfinite(v)]
        if not v.size:
            continue
        rms = float(np.sqrt(np.mean(v**2)))
        test = _test(data, after, segs, kind, noise)
        if test is None or test["p_value"] >= P_LEFT:
            continue
        if table_errors is not None and kind != "axis":
            if tables_left is None:
                tables_left = allow_for_tables(after, w, *table_errors())
            test = _test(data, tables_left, segs, kind, noise)
            if test is None or test["p_value"] >= P_LEFT:
                continue
            test["test"] += ", the tables' errors allowed for"
        s_rms, s_p, *_ = _structure(data, after, segs, kind)
        nz = test["noise"]
        ratio = rms / nz if nz > 0 else float("inf")
        regs = [r for r in regions(data, after, segs, {**noise, kind: nz}) if r["kind"] == kind]
        top = [r for r in regs if r["region"] not in ("whole run", "all poses")][:3] or regs[:3]
        item: dict[str, Any] = {
            "kind": kind,
            "unit": unit.replace("µ", "u"),
            "rms": rms * scale,
            "noise": nz * scale,
            "ratio": ratio,
            "test": test["test"],
            "statistic": test["statistic"],
            "dof": test["dof"],
            "confidence": CONFIDENCE,
            "p_value": test["p_value"],
            "structure_rms": s_rms * scale,
            "structure_p": s_p,
            "regions": top,
        }
        if library is not None:
            if lin is None:
                lin = library()
            item.update(_library_share(lin, after, rows, w))
        item["sentence"] = _sentence(label, item, unit)
        out.append(item)
    return out


#: The signatures (key -> (n, 1) columns) and standard errors [mm] of the table
#: values' errors (:func:`unexplained`).
TableErrors = Callable[[], tuple[Mapping[str, np.ndarray], Mapping[str, float]]]


def allow_for_tables(
    resid: np.ndarray,
    w: np.ndarray,
    columns: Mapping[str, np.ndarray],
    sd: Mapping[str, float],
) -> np.ndarray:
    """The residual less its best explanation by table-value errors within their
    standard errors: c = (NᵀW²N + Λ)⁻¹ NᵀW² r with Λ = diag(1/sd²) (the errors' prior;
    ridge regression, the best linear unbiased predictor of the errors), r − N c.
    Rows the columns do not move (laser readings: they made the prior) keep theirs."""
    keys = [k for k in sd if k in columns and np.any(columns[k])]
    if not keys:
        return resid
    ok = np.isfinite(resid)
    N = np.hstack([columns[k] for k in keys])
    Nw = (N * w[:, None])[ok]
    rw = (resid * w)[ok]
    A = Nw.T @ Nw + np.diag([1.0 / max(sd[k], 1e-300) ** 2 for k in keys])
    c = np.linalg.solve(A, Nw.T @ rw)
    out = resid.copy()
    out[ok] = resid[ok] - N[ok] @ c
    return out


def _test(
    data: Data, after: np.ndarray, segs: list[Segment], kind: str, noise: dict[str, float]
) -> dict[str, Any] | None:
    """The test of "the residual of ``kind`` is the noise" (module docstring): its
    name, statistic, degrees of freedom, p-value and the noise held against [mm or
    deg]; None when the kind has too few rows to test."""
    parts = [after[s.start : s.stop] for s in segs if s.kind == kind]
    parts = [v[np.isfinite(v)] for v in parts]
    parts = [v for v in parts if v.size]
    if kind == "ballbar":
        parts = [v for v in parts if v.size > 2]
        nu = sum(v.size for v in parts)
        runs = len(parts)
        if nu - runs < 10:
            return None
        dd = sum(float(np.sum(np.diff(v) ** 2)) for v in parts)
        ss = sum(float(v @ v) for v in parts)
        eta = dd / max(ss, 1e-300)
        z = (eta - 2.0 * (nu - runs) / nu) / math.sqrt(4.0 / nu)
        return {
            "test": "von Neumann ratio of successive samples",
            "statistic": eta,
            "dof": [nu],
            "p_value": float(stats.norm.cdf(z)),
            "noise": math.sqrt(dd / (2.0 * (nu - runs))),
        }
    if kind == "axis":
        return _lack_of_fit(data, after, segs)
    _, s_p, n, p, F = _structure(data, after, segs, kind)
    if not n:
        return None
    return {
        "test": "F-test of a smooth fit (Legendre, degree 2) to the residual",
        "statistic": float(F),
        "dof": [p, n - p],
        "p_value": s_p,
        "noise": noise.get(kind, float("nan")),
    }


def _lack_of_fit(data: Data, after: np.ndarray, segs: list[Segment]) -> dict[str, Any] | None:
    """The lack-of-fit F-test of laser residuals against repeated runs (module docstring)."""
    lof = pe = 0.0
    groups = nu = 0
    axis_segs = [s for s in segs if s.kind == "axis"]
    for seg, a in zip(axis_segs, data.axis, strict=True):
        r = after[seg.start : seg.stop]
        keys = np.stack([a.motor, a.target, a.direction], -1)
        _, inv = np.unique(keys, axis=0, return_inverse=True)
        inv = inv.ravel()
        for grp in np.unique(inv):
            x = r[(inv == grp) & np.isfinite(r)]
            if not x.size:
                continue
            lof += x.size * float(x.mean()) ** 2
            pe += float(np.sum((x - x.mean()) ** 2))
            groups += 1
            nu += x.size
    if not groups or nu - groups < 2:
        return None
    F = (lof / groups) / max(pe / (nu - groups), 1e-300)
    return {
        "test": "lack-of-fit F-test against repeated runs",
        "statistic": F,
        "dof": [groups, nu - groups],
        "p_value": float(stats.f.sf(F, groups, nu - groups)),
        "noise": math.sqrt(pe / (nu - groups)),
    }


def _library_share(
    lin: Linearised, after: np.ndarray, rows: np.ndarray, w: np.ndarray
) -> dict[str, Any]:
    """How much of a kind's residual the library could take: all members together
    and the closest three alone (shares of its sum of squares, on those rows)."""
    ok = rows & np.isfinite(after)
    r = (after * w)[ok]
    rr = float(r @ r)
    if rr <= 0 or not lin.columns:
        return {"library_share": 0.0, "closest": []}
    shares = []
    blocks = []
    for k, c in lin.columns.items():
        a = (c * w[:, None])[ok]
        if not np.any(a):
            continue
        coef, *_ = np.linalg.lstsq(a, r, rcond=None)
        f = a @ coef
        shares.append((float(f @ f) / rr, k))
        blocks.append(a)
    A = np.hstack(blocks) if blocks else np.zeros((len(r), 0))
    if A.shape[1]:
        nrm = np.linalg.norm(A, axis=0)
        nrm[nrm == 0] = 1.0
        coef, *_ = np.linalg.lstsq(A / nrm, r, rcond=1e-10)
        f = (A / nrm) @ coef
        total = float(f @ f) / rr
    else:
        total = 0.0
    shares.sort(reverse=True)
    closest = []
    for share, k in shares[:3]:
        name, _, per = k.partition("@")
        closest.append({"name": name, "period_mm": float(per) if per else None, "share": share})
    return {"library_share": total, "closest": closest}


def _sentence(label: str, item: dict[str, Any], unit: str) -> str:
    where = ""
    if item["regions"]:
        r = item["regions"][0]
        u = "arcsec" if item["kind"] == "pose_axis" else "um"
        where = (
            f", most in {r['source']} {r['region']} ({r[f'rms_{u}']:.2f} {unit})"
            if r.get(f"rms_{u}") is not None
            else ""
        )
    dof = ", ".join(f"{d:,}".replace(",", " ") for d in item["dof"])
    text = (
        f"Left unexplained: the {label} residual is {item['rms']:.2f} {unit} RMS against "
        f"{item['noise']:.2f} {unit} of noise{where}; it is not the noise at "
        f"{item['confidence']:.1%} confidence ({item['test']}: {item['statistic']:.4g} with "
        f"{dof} degrees of freedom, p = {item['p_value']:.2g})"
    )
    if "library_share" in item:
        share = item["library_share"]
        if item["closest"]:
            c = item["closest"][0]
            per = f" at {c['period_mm']:g} mm" if c["period_mm"] else ""
            closest = f"; the closest single effect, {c['name']}{per}, would take {c['share']:.0%}"
        else:
            closest = ""
        if share < 0.5:
            text += f"; no effect of the library explains it (all together {share:.0%}){closest}"
        else:
            text += (
                f"; library effects together would take {share:.0%}, none passes the tests "
                f"on its own{closest}"
            )
    return text + "."
