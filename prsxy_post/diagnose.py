"""Find where simulation and measurement disagree, name the missing effect, add it.

The loop an engineer runs with a ballbar plot, made a procedure:

1. **Simulate** every measurement with the current model (the profile), the
   machine commanded as the data say (the current profile unless another is
   named): pose files, ballbar runs, laser axis runs.
2. **Find** where they disagree: residual per run and per region (angle sectors
   and reversal points of circles, parts of the workspace, tilt levels), against
   the measurement noise estimated from the data itself (ballbar: the scatter of
   consecutive samples; laser: the spread of repeated runs; poses: the residual
   left by a fit of the whole library).
3. **Name** the effect: every member of a library of physical effects gives a
   column of the linearised model (its residual signature). Forward selection
   adds, one at a time, the effect that explains the whitened residual best, as
   long as its improvement passes both an F-test at level ``alpha`` (Bonferroni-
   corrected for the number of candidates the best was chosen from) and the BIC
   penalty (ΔSSE/σ̂² > dof · ln n). Effects whose signatures cannot be told
   apart from the chosen one (correlation of the whitened, already-explained-
   projected columns above ``alias_corr``) are reported as its aliases. Two
   effects together can resemble a third; when the best single effect leaves
   more than four times the noise, the step looks ahead over every pair
   (:func:`_best_pair`) and starts with the stronger member of a pair that
   explains clearly more than the greedy choice with its best partner.
4. **Add** it: the sizes are refined by Gauss–Newton through the full
   (nonlinear) model and written into the profile with a provenance note.
5. **Show** the gap shrink: residual RMS and max before and after, per run.

The library: every contract parameter (profile paths such as
``kinematics.legs[1].strut_length``, ``table.squareness``), the effects
``effects.guide_bow[i]`` and ``effects.table_straightness[i]``, and per motor m
``backlash[m]`` (full reversal value, mm: forward error − b/2, reverse + b/2),
``cyclic[m]`` (periodic error: amplitude mm, with period and phase found by a
scan over typical pitches) and ``servo_lag[m]`` (ms the motor follows behind its
command; profile ``effects.servo_lag_ms``).
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from . import axiscomp, calibrate, kinematics, simulate
from .errors import FitError, ProfileError
from .measure import AxisData, BallbarRun, PoseData
from .profile import MOTORS, Profile, profile_from_dict

EXTRA_PARAMS = [f"effects.guide_bow[{i}]" for i in (1, 2, 3)] + [
    "effects.table_straightness[1]",
    "effects.table_straightness[2]",
]
GEOM_PARAMS = calibrate.PARAMS + EXTRA_PARAMS
#: Typical size of each library member (its prior scale), for reporting and steps.
PRIOR = np.concatenate([calibrate.PRIOR, [0.01] * 3 + [0.05] * 2])
#: Pitches scanned for cyclic errors [mm]: ball screws, encoders, linear-motor poles.
CYCLIC_PERIODS = (1.0, 2.0, 2.5, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0)
MOTOR_INDEX = {m: i for i, m in enumerate(MOTORS)}


def unit_of(name: str) -> str:
    if name.startswith("backlash") or name.startswith("cyclic") or "guide_bow" in name:
        return "mm"
    if name.startswith("servo_lag"):
        return "ms"
    if "table_straightness" in name:
        return "mm/m^2"
    return calibrate.units(name)


# ---------------------------------------------------------------- model of the data


def _theta_ext(profile: Profile) -> np.ndarray:
    e = profile.effects
    return np.concatenate([calibrate.theta_of(profile), e.guide_bow, e.table_straightness])


def _geo_ext(profile: Profile, theta: np.ndarray) -> kinematics.Geometry:
    from .profile import Effects

    kp, tb = calibrate.params_of(theta[: len(calibrate.PARAMS)])
    ex = theta[len(calibrate.PARAMS) :]
    eff = Effects(
        (ex[0], ex[1], ex[2]), (ex[3], ex[4]), profile.effects.servo_lag_ms, profile.effects.cyclic
    )
    return kinematics.Geometry.from_params(kp, profile.origin, tb, eff)


@dataclass
class Segment:
    """One measurement file's rows in the stacked residual vector."""

    kind: str  # "pose_tip", "pose_axis", "ballbar", "axis"
    source: str
    name: str
    start: int
    stop: int
    unit: str


@dataclass
class Data:
    """Measurements and the motor commands the machine was given for them."""

    poses: list[PoseData]
    runs: list[BallbarRun]
    axis: list[AxisData]
    commanded: Profile
    P_pose: list[np.ndarray] = field(default_factory=list)
    P_run: list[np.ndarray] = field(default_factory=list)
    v_run: list[np.ndarray] = field(default_factory=list)  # command velocities [mm/s]
    dir_run: list[np.ndarray] = field(default_factory=list)  # last motion direction ±1

    @classmethod
    def build(
        cls,
        commanded: Profile,
        poses: Sequence[PoseData],
        runs: Sequence[BallbarRun],
        axis: Sequence[AxisData],
    ) -> Data:
        d = cls(list(poses), list(runs), list(axis), commanded)
        for p in poses:
            d.P_pose.append(simulate.pose_commands(commanded, p.commanded))
        for r in runs:
            P = simulate.motion_commands(commanded, r.commanded, t=r.t)
            d.P_run.append(P)
            v = simulate.servo_velocity(P, r.t)
            d.v_run.append(v)
            step = np.diff(P, axis=0, prepend=P[:1])
            sgn = np.sign(np.where(np.abs(step) > 1e-12, step, 0.0))
            # the direction the motor last moved in (the side of the play it sits on)
            idx = np.where(sgn != 0, np.arange(len(P))[:, None], -1)
            idx = np.maximum.accumulate(idx, axis=0)
            last = np.take_along_axis(sgn, np.maximum(idx, 0), axis=0)
            last[idx < 0] = 1.0
            d.dir_run.append(last)
        return d

    def measured(self) -> tuple[np.ndarray, list[Segment]]:
        """Stacked measured values and the segment of each file."""
        vals: list[np.ndarray] = []
        segs: list[Segment] = []
        n = 0

        def add(kind: str, src: str, name: str, v: np.ndarray, unit: str) -> None:
            nonlocal n
            vals.append(v)
            segs.append(Segment(kind, src, name, n, n + len(v), unit))
            n += len(v)

        for p in self.poses:
            add("pose_tip", p.source, "tip", p.tip.ravel(), "mm")
            add("pose_axis", p.source, "axis", p.axis.ravel(), "deg")
        for r in self.runs:
            add("ballbar", r.source, getattr(r, "name", "") or r.source, r.dev_um * 1e-3, "mm")
        for a in self.axis:
            add("axis", a.source, "laser", a.measured, "mm")
        return np.concatenate(vals) if vals else np.zeros(0), segs


@dataclass
class Linearised:
    """Model prediction and the residual signature of every library member."""

    pred: np.ndarray
    columns: dict[str, np.ndarray]  # name -> (n,) or (n, 2) for cyclic (sin, cos)
    cyclic_period: dict[str, float]
    segments: list[Segment]


def predict(
    model: Profile,
    data: Data,
    want_columns: bool = True,
    geo_guess: dict[str, list[np.ndarray | None]] | None = None,
) -> Linearised:
    """Simulate every measurement with ``model``; optionally each effect's signature."""
    tables = axiscomp.profile_tables(model)
    theta = _theta_ext(model)
    steps = np.concatenate(
        [
            calibrate.default_steps(calibrate.PARAMS, theta[: len(calibrate.PARAMS)]),
            [1e-6] * len(EXTRA_PARAMS),
        ]
    )

    def make_geo(t: np.ndarray) -> kinematics.Geometry:
        return _geo_ext(model, t)

    preds: list[np.ndarray] = []
    cols: dict[str, list[np.ndarray]] = {}
    cyc_period: dict[str, float] = {}
    names_geo = GEOM_PARAMS

    def push(name: str, v: np.ndarray) -> None:
        cols.setdefault(name, []).append(v)

    def motor_effects(
        JP: np.ndarray,
        Pm: np.ndarray,
        direction: np.ndarray | None,
        vel: np.ndarray | None,
        reduce: Any,
    ) -> None:
        """Columns of the motor-space effects through the motor sensitivities JP."""
        for m in MOTORS:
            i = MOTOR_INDEX[m]
            sens = JP[:, :, i]  # (N, 5): ∂y/∂P_m
            sign = direction[:, i] if direction is not None else np.ones(len(Pm))
            push(f"backlash[{m}]", reduce(sens * (-0.5 * sign)[:, None]))
            for per in CYCLIC_PERIODS:
                ph = 2 * np.pi * Pm[:, i] / per
                push(
                    f"cyclic[{m}]@{per:g}",
                    np.stack(
                        [reduce(sens * np.sin(ph)[:, None]), reduce(sens * np.cos(ph)[:, None])], -1
                    ),
                )
            lag = -(vel[:, i] * 1e-3) if vel is not None else np.zeros(len(Pm))
            push(f"servo_lag[{m}]", reduce(sens * lag[:, None]))

    guesses: dict[str, list[np.ndarray | None]] = dict(geo_guess or {})
    for k, P_cmd in enumerate(data.P_pose):
        Pm = simulate.actual_motors(model, P_cmd, approach=+1)
        g = guesses.get("pose", [None] * len(data.poses))[k]
        y, J, xv, JP = calibrate.fk_with_jacobian(
            make_geo, theta, Pm, g, want_columns, steps, motors=want_columns
        )
        guesses.setdefault("pose", [None] * len(data.poses))[k] = xv
        preds += [y[:, :3].ravel(), y[:, 3:].ravel()]
        if J is not None and JP is not None:
            for j, nm in enumerate(names_geo):
                push(nm, np.concatenate([J[:, :3, j].ravel(), J[:, 3:, j].ravel()]))

            def red_pose(a: np.ndarray) -> np.ndarray:
                return np.concatenate([a[:, :3].ravel(), a[:, 3:].ravel()])

            motor_effects(JP, Pm, None, None, red_pose)
    for k, (r, P_cmd) in enumerate(zip(data.runs, data.P_run, strict=True)):
        Pm = simulate.actual_motors(model, P_cmd, t=r.t)
        g = guesses.get("run", [None] * len(data.runs))[k]
        y, J, xv, JP = calibrate.fk_with_jacobian(
            make_geo, theta, Pm, g, want_columns, steps, motors=want_columns
        )
        guesses.setdefault("run", [None] * len(data.runs))[k] = xv
        vec = y[:, :3] - r.pivot
        dist = np.linalg.norm(vec, axis=1)
        unit = vec / dist[:, None]
        preds.append(dist - r.length)
        if J is not None and JP is not None:
            for j, nm in enumerate(names_geo):
                push(nm, np.einsum("ni,ni->n", unit, J[:, :3, j]))

            def red_bb(a: np.ndarray, unit: np.ndarray = unit) -> np.ndarray:
                return np.einsum("ni,ni->n", unit, a[:, :3])

            motor_effects(JP, Pm, data.dir_run[k], data.v_run[k], red_bb)
    for a in data.axis:
        pa = np.empty(len(a.target))
        for m in np.unique(a.motor):
            for d in (1, -1):
                sel = (a.motor == m) & (a.direction == d)
                pa[sel] = axiscomp.approach(tables.get(int(m)), a.target[sel], d)
        preds.append(pa)
        if want_columns:
            for nm in names_geo:
                push(nm, np.zeros(len(pa)))
            for m in MOTORS:
                sel = (a.motor == m).astype(float)
                push(f"backlash[{m}]", -0.5 * a.direction * sel)
                for per in CYCLIC_PERIODS:
                    ph = 2 * np.pi * a.target / per
                    push(f"cyclic[{m}]@{per:g}", np.stack([np.sin(ph) * sel, np.cos(ph) * sel], -1))
                push(f"servo_lag[{m}]", np.zeros(len(pa)))
    _, segs = data.measured()
    columns = {k: np.concatenate(v) for k, v in cols.items()} if want_columns else {}
    for key in columns:
        if key.startswith("cyclic"):
            cyc_period[key] = float(key.split("@")[1])
    return Linearised(np.concatenate(preds) if preds else np.zeros(0), columns, cyc_period, segs)


# ---------------------------------------------------------------- noise and regions


def estimate_noise(data: Data, resid: np.ndarray, segs: list[Segment]) -> dict[str, float]:
    """Measurement noise per kind, from the data's own scatter [mm or deg].

    ballbar: 1.4826 · MAD of consecutive differences / √2 (the signal is smooth on
    the 10 ms scale); laser: pooled spread of repeated runs at each target and
    direction; poses: residual RMS (the caller passes the residual of a fit of the
    whole library, so what remains is noise).
    """
    out: dict[str, float] = {}
    bb = [np.diff(r.dev_um * 1e-3) for r in data.runs if len(r.dev_um) > 10]
    if bb:
        d = np.concatenate(bb)
        out["ballbar"] = float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(2))
    if data.axis:
        dev, dof = 0.0, 0
        for a in data.axis:
            keys = np.stack([a.motor, a.target, a.direction], -1)
            _, inv = np.unique(keys, axis=0, return_inverse=True)
            for g in np.unique(inv):
                x = a.measured[inv.ravel() == g]
                if len(x) > 1:
                    dev += float(np.sum((x - x.mean()) ** 2))
                    dof += len(x) - 1
        if dof:
            out["axis"] = math.sqrt(dev / dof)
    for kind in ("pose_tip", "pose_axis"):
        v = np.concatenate(
            [resid[s.start : s.stop] for s in segs if s.kind == kind] or [np.zeros(0)]
        )
        v = v[np.isfinite(v)]
        if v.size:
            out[kind] = float(np.sqrt(np.mean(v**2)))
    return out


def regions(
    data: Data, resid: np.ndarray, segs: list[Segment], noise: dict[str, float]
) -> list[dict[str, Any]]:
    """Residual per run and per region, largest against the noise first."""
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
            rel = r.commanded[:, :3] - r.pivot
            # angle in the plane the run spans (largest two extents)
            ext = np.ptp(rel, axis=0)
            a0, a1 = np.argsort(ext)[::-1][:2]
            a0, a1 = min(a0, a1), max(a0, a1)
            ang = np.degrees(np.arctan2(rel[:, a1], rel[:, a0])) % 360
            for lo in range(0, 360, 45):
                add(
                    seg, f"angle {lo}-{lo + 45} deg", v[(ang >= lo) & (ang < lo + 45)], 1000.0, "um"
                )
            near = (
                np.min(
                    np.abs(((ang[:, None] - np.array([0, 90, 180, 270])) + 180) % 360 - 180), axis=1
                )
                < 5
            )
            add(seg, "axis reversals (within 5 deg)", v[near], 1000.0, "um")
        elif seg.kind == "pose_tip":
            p = data.poses[pi]
            v3 = v.reshape(-1, 3)
            e = np.linalg.norm(v3, axis=1)
            q = p.commanded
            add(seg, "all poses", v, 1000.0, "um")
            tilt = np.degrees(np.arccos(np.cos(np.radians(q[:, 3])) * np.cos(np.radians(q[:, 4]))))
            for lo, hi in ((0, 5), (5, 15), (15, 90)):
                add(
                    seg, f"tilt {lo}-{hi} deg", v3[(tilt >= lo) & (tilt < hi)].ravel(), 1000.0, "um"
                )
            for ax, nm in ((0, "x"), (1, "y"), (2, "z")):
                mid = np.median(q[:, ax])
                add(seg, f"{nm} < {mid:.0f}", v3[q[:, ax] < mid].ravel(), 1000.0, "um")
                add(seg, f"{nm} >= {mid:.0f}", v3[q[:, ax] >= mid].ravel(), 1000.0, "um")
            del e
        elif seg.kind == "pose_axis":
            add(seg, "all poses (axis)", v, 3600.0, "arcsec")
            pi += 1
        elif seg.kind == "axis":
            add(seg, "laser runs", v, 1000.0, "um")
    out.sort(key=lambda d: -d["ratio"])
    return out


# ---------------------------------------------------------------- selection


@dataclass
class Effect:
    name: str
    estimate: float
    stderr: float
    unit: str
    aliases: list[str] = field(default_factory=list)
    period: float | None = None
    phase_deg: float | None = None
    delta_sse: float = 0.0
    p_value: float = 0.0

    def to_dict(self) -> dict[str, Any]:
        d: dict[str, Any] = {
            "name": self.name,
            "estimate": self.estimate,
            "stderr": self.stderr,
            "unit": self.unit,
        }
        if self.aliases:
            d["aliases"] = self.aliases
        if self.period is not None:
            d["period_mm"] = self.period
            d["phase_deg"] = self.phase_deg
        d["p_value"] = self.p_value
        return d


def _whiten(segs: list[Segment], noise: dict[str, float], n: int) -> np.ndarray:
    w = np.ones(n)
    for s in segs:
        w[s.start : s.stop] = 1.0 / max(noise.get(s.kind, 1e-3), 1e-12)
    return w


def _family(name: str) -> str:
    return name.split("@")[0]


def _best_pair(
    cols: dict[str, np.ndarray],
    X: np.ndarray,
    r: np.ndarray,
    skip_families: set[str],
    alias_corr: float,
    must: str | None = None,
) -> tuple[float, str, str] | None:
    """The pair of members that together explain most of ``r`` beyond ``X``.

    Every pair of the library, from one Gram matrix of the columns projected off
    ``X``: SSE(k1, k2) = r'r - b' G^-1 b over the pair's columns. Pairs whose
    signatures are aliases of each other (|correlation| > ``alias_corr``) are not
    separable and are skipped. With ``must``, only pairs that contain it.
    Returns (SSE, k1, k2) or None.
    """
    keys = [k for k in cols if _family(k) not in skip_families]
    if len(keys) < 2:
        return None
    A = np.hstack([cols[k] for k in keys])
    rr = r
    if X.shape[1]:
        q, _ = np.linalg.qr(X)
        A = A - q @ (q.T @ A)
        rr = r - q @ (q.T @ r)
    G = A.T @ A
    bvec = A.T @ rr
    r2 = float(rr @ rr)
    start = np.cumsum([0] + [cols[k].shape[1] for k in keys])
    idx = [np.arange(start[i], start[i + 1]) for i in range(len(keys))]
    diag = np.sqrt(np.maximum(np.diag(G), 1e-300))
    best: tuple[float, str, str] | None = None
    for i in range(len(keys)):
        for j in range(i + 1, len(keys)):
            if _family(keys[i]) == _family(keys[j]) or (
                must is not None and must not in (keys[i], keys[j])
            ):
                continue
            ii, jj = idx[i], idx[j]
            if (
                ii.size == 1
                and jj.size == 1
                and abs(G[ii[0], jj[0]]) / (diag[ii[0]] * diag[jj[0]]) > alias_corr
            ):
                continue
            sel = np.concatenate([ii, jj])
            g = G[np.ix_(sel, sel)]
            bb = bvec[sel]
            sol = np.linalg.lstsq(g, bb, rcond=1e-12)[0]
            s = r2 - float(bb @ sol)
            if best is None or s < best[0]:
                best = (s, keys[i], keys[j])
    return best


def select_effects(
    lin: Linearised,
    resid: np.ndarray,
    w: np.ndarray,
    *,
    alpha: float = 1e-3,
    alias_corr: float = 0.98,
    max_effects: int = 6,
    exclude: Sequence[str] = (),
    given: Sequence[str] = (),
) -> list[Effect]:
    """Forward selection over the library (module docstring, step 3).

    ``given``: column keys already in the model (their signatures are part of the
    fit, so a new effect must explain what they cannot).
    """
    ok = np.isfinite(resid)
    r = (resid * w)[ok]
    n = r.size
    cols: dict[str, np.ndarray] = {}
    for k, c in lin.columns.items():
        if _family(k) in exclude or k in exclude:
            continue
        c2 = (c * (w[:, None] if c.ndim == 2 else w))[ok]
        if c2.ndim == 1:
            c2 = c2[:, None]
        if np.max(np.abs(c2)) < 1e-12:
            continue  # the data do not see this effect at all
        cols[k] = c2
    chosen: list[str] = [k for k in given if k in cols]
    X = np.hstack([cols[k] for k in chosen]) if chosen else np.zeros((n, 0))
    if chosen:
        c0, *_ = np.linalg.lstsq(X, r, rcond=None)
        sse = float(np.sum((r - X @ c0) ** 2))
    else:
        sse = float(r @ r)
    n_given = len(chosen)
    out: list[Effect] = []
    while len(out) < max_effects:
        best: tuple[float, str] | None = None
        results: dict[str, float] = {}
        for k, c in cols.items():
            if _family(k) in {_family(x) for x in chosen}:
                continue
            Xk = np.hstack([X, c])
            coef, *_ = np.linalg.lstsq(Xk, r, rcond=None)
            res = r - Xk @ coef
            s = float(res @ res)
            results[k] = s
            if best is None or s < best[0]:
                best = (s, k)
        if best is None:
            break
        s_new, k = best
        if s_new / max(n - X.shape[1] - 1, 1) > 4.0:
            # the best single member leaves far more than noise: two effects acting
            # together can look like a third (strut 1 short and guide 2 high tilt the
            # platform much as guide 3 high does). Look one step ahead over every
            # pair; when a pair explains clearly more than the greedy first choice
            # with its best partner, start with that pair's stronger member.
            fams = {_family(x) for x in chosen}
            pair = _best_pair(cols, X, r, fams, alias_corr)
            greedy = _best_pair(cols, X, r, fams, alias_corr, must=k) if pair else None
            if pair and greedy and k not in pair[1:] and pair[0] < 0.5 * greedy[0]:
                k = min(pair[1:], key=results.__getitem__)
                s_new = results[k]
        dof = cols[k].shape[1]
        p = X.shape[1] + dof
        dof_res = max(n - p, 1)
        sigma2 = s_new / dof_res
        F = (sse - s_new) / dof / max(sigma2, 1e-300)
        pval = float(stats.f.sf(F, dof, dof_res))
        # sigma2 ≈ 1 when the noise estimate is right; the BIC term guards against
        # an effect that is significant only because the noise was underestimated
        # the best of m candidates is tested, not one chosen beforehand: Bonferroni
        # (without it, noise alone passes alpha = 1e-3 at some step of some runs)
        if pval * len(results) > alpha or (sse - s_new) / max(sigma2, 1e-300) < dof * math.log(n):
            break
        # aliases: other members whose signature, after what is already explained,
        # is nearly the same as the chosen one's
        base = cols[k] - X @ np.linalg.lstsq(X, cols[k], rcond=None)[0] if X.shape[1] else cols[k]
        aliases = []
        for k2, c2 in cols.items():
            if k2 == k or _family(k2) == _family(k) or c2.shape[1] != 1 or base.shape[1] != 1:
                continue
            b2 = c2 - X @ np.linalg.lstsq(X, c2, rcond=None)[0] if X.shape[1] else c2
            den = np.linalg.norm(base) * np.linalg.norm(b2)
            if den > 0 and abs(float(base[:, 0] @ b2[:, 0])) / den > alias_corr:
                aliases.append(k2)
        chosen.append(k)
        X = np.hstack([X, cols[k]])
        out.append(
            Effect(
                _family(k),
                0.0,
                0.0,
                unit_of(k),
                aliases,
                lin.cyclic_period.get(k),
                None,
                sse - s_new,
                pval,
            )
        )
        sse = s_new
    # sizes and standard errors from the joint fit of everything chosen
    if out:
        coef, *_ = np.linalg.lstsq(X, r, rcond=None)
        res = r - X @ coef
        sigma2 = float(res @ res) / max(n - X.shape[1], 1)
        cov = np.linalg.pinv(X.T @ X) * max(sigma2, 1.0)
        j = sum(cols[k].shape[1] for k in chosen[:n_given])
        for e, k in zip(out, chosen[n_given:], strict=True):
            d = cols[k].shape[1]
            if d == 1:
                e.estimate = float(coef[j])
                e.stderr = float(math.sqrt(max(cov[j, j], 0.0)))
            else:
                a, b = coef[j], coef[j + 1]
                amp = math.hypot(a, b)
                e.estimate = float(amp)
                e.phase_deg = float(math.degrees(math.atan2(b, a)))
                # amplitude standard error: the larger of the two directions
                e.stderr = float(math.sqrt(max(cov[j, j], cov[j + 1, j + 1], 0.0)))
            j += d
    return out


# ---------------------------------------------------------------- applying effects


def apply_effects(
    doc: dict[str, Any], effects: Sequence[Effect], profile: Profile
) -> dict[str, Any]:
    """A profile document with the effects added (estimates are changes to add)."""
    doc = copy.deepcopy(doc)
    theta_names = calibrate.PARAMS
    theta = calibrate.theta_of(profile)
    changed = False
    for e in effects:
        if e.name in theta_names:
            theta[theta_names.index(e.name)] += e.estimate
            changed = True
    if changed:
        doc = calibrate.apply_theta(doc, theta)
    eff = doc.setdefault("effects", {})
    for e in effects:
        if e.name.startswith("effects.guide_bow["):
            i = int(e.name[-2]) - 1
            v = list(eff.get("guide_bow", [0.0, 0.0, 0.0]))
            v[i] += e.estimate
            eff["guide_bow"] = v
        elif e.name.startswith("effects.table_straightness["):
            i = int(e.name[-2]) - 1
            v = list(eff.get("table_straightness", [0.0, 0.0]))
            v[i] += e.estimate
            eff["table_straightness"] = v
        elif e.name.startswith("servo_lag["):
            m = int(e.name[10:-1])
            v = list(eff.get("servo_lag_ms", [0.0] * 5))
            v[MOTOR_INDEX[m]] += e.estimate
            eff["servo_lag_ms"] = v
        elif e.name.startswith("cyclic["):
            m = int(e.name[7:-1])
            eff.setdefault("cyclic", []).append(
                {
                    "motor": m,
                    "amplitude": e.estimate,
                    "period": e.period,
                    "phase": e.phase_deg or 0.0,
                }
            )
        elif e.name.startswith("backlash["):
            m = int(e.name[9:-1])
            comps = doc.setdefault("axis_comp", [])
            entry = next((c for c in comps if c["motor"] == m), None)
            if entry is None:
                mc = profile.motor(m)
                entry = {
                    "motor": m,
                    "positions": [mc.min, mc.max],
                    "forward": [0.0, 0.0],
                    "reverse": [0.0, 0.0],
                }
                comps.append(entry)
                comps.sort(key=lambda c: c["motor"])
            entry["forward"] = [float(x) - e.estimate / 2 for x in entry["forward"]]
            entry["reverse"] = [float(x) + e.estimate / 2 for x in entry["reverse"]]
    if not eff:
        doc.pop("effects", None)
    return doc


# ---------------------------------------------------------------- the whole loop


@dataclass
class Diagnosis:
    effects: list[Effect]
    noise: dict[str, float]
    rms_before_um: float
    rms_after_um: float
    per_run: list[dict[str, Any]]
    regions: list[dict[str, Any]]
    updated: dict[str, Any]
    summary: str

    def to_json(self) -> dict[str, Any]:
        noise_um = (
            self.noise.get(
                "ballbar", self.noise.get("pose_tip", self.noise.get("axis", float("nan")))
            )
            * 1000.0
        )
        return {
            "rms_before_um": self.rms_before_um,
            "rms_after_um": self.rms_after_um,
            "noise_um": noise_um,
            "noise": {
                k: v * (3600.0 if k == "pose_axis" else 1000.0) for k, v in self.noise.items()
            },
            "noise_units": {k: ("arcsec" if k == "pose_axis" else "um") for k in self.noise},
            "effects": [e.to_dict() for e in self.effects],
            "regions": self.regions,
            "runs": self.per_run,
            "summary": self.summary,
        }


def _rms_um(resid: np.ndarray, segs: list[Segment]) -> float:
    v = np.concatenate([resid[s.start : s.stop] for s in segs if s.unit == "mm"] or [np.zeros(0)])
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2)) * 1000.0) if v.size else float("nan")


def _per_run(before: np.ndarray, after: np.ndarray, segs: list[Segment]) -> list[dict[str, Any]]:
    out = []
    for s in segs:
        scale, unit = (3600.0, "arcsec") if s.unit == "deg" else (1000.0, "um")
        b, a = before[s.start : s.stop], after[s.start : s.stop]
        b, a = b[np.isfinite(b)], a[np.isfinite(a)]
        if not b.size:
            continue
        out.append(
            {
                "source": s.source,
                "kind": s.kind,
                "name": s.name,
                "unit": unit,
                "rms_before": float(np.sqrt(np.mean(b**2)) * scale),
                "rms_after": float(np.sqrt(np.mean(a**2)) * scale),
                "max_before": float(np.max(np.abs(b)) * scale),
                "max_after": float(np.max(np.abs(a)) * scale),
            }
        )
    return out


def sentence(e: Effect) -> str:
    """One sentence a machine-tool engineer would write about an effect."""
    n = e.name
    size = e.estimate
    if n.startswith("kinematics.legs["):
        leg = n[16]
        key = n.split(".")[-1].replace("_", " ")
        u = unit_of(n)
        if key == "strut length":
            return (
                f"Strut {leg} is {abs(size) * 1000:.1f} µm "
                f"{'longer' if size > 0 else 'shorter'} than the profile says."
            )
        return f"Leg {leg}: the {key} is off by {size:+.4g} {u} from the profile."
    if n == "table.squareness":
        return (
            f"The X-Y table is out of square by {size * 1000:+.4f} mm/m "
            "(positive: the Y motion leans towards +X)."
        )
    if n in ("table.scale_x", "table.scale_y"):
        return f"The table's {n[-1].upper()} axis scale is off by {size * 1e6:+.2f} µm/m."
    if n.startswith("backlash["):
        return f"Motor {n[9:-1]} has {size * 1000:.2f} µm more backlash than its table holds."
    if n.startswith("cyclic["):
        return (
            f"Motor {n[7:-1]} has a periodic error of {size * 1000:.2f} µm amplitude with "
            f"a {e.period:g} mm pitch."
        )
    if n.startswith("servo_lag["):
        return (
            f"Motor {n[10:-1]} lags its command by {size:+.3f} ms more than the others "
            "(servo mismatch)."
        )
    if "guide_bow" in n:
        return f"Guide {n[-2]} is bowed by {size * 1000:+.2f} µm at 100 mm of travel."
    if "table_straightness" in n:
        ax = "X" if n[-2] == "1" else "Y"
        return f"The table's {ax} motion is curved by {size:+.4f} mm/m²."
    if n.startswith("kinematics.tool"):
        return f"The tool's {n.split('.')[-1].replace('_', ' ')} is off by {size:+.4f} mm."
    return f"{n} differs from the profile by {size:+.4g} {e.unit}."


def _refine(
    current: Profile,
    data: Data,
    measured: np.ndarray,
    w: np.ndarray,
    total: list[Effect],
    iterations: int,
) -> tuple[Profile, np.ndarray, Linearised]:
    """Gauss–Newton on the sizes of the chosen effects through the nonlinear model.

    Updates the estimates and standard errors in place; returns the updated
    profile, its residual and its linearisation.
    """
    updated = profile_from_dict(apply_effects(current.raw, total, current), current.source)
    lin = predict(updated, data)
    for it in range(iterations + 1):
        r2 = measured - lin.pred
        ok = np.isfinite(r2)
        cols = []
        for e in total:
            key = e.name if e.period is None else f"{e.name}@{e.period:g}"
            c = lin.columns[key]
            cols.append(c if c.ndim == 2 else c[:, None])
        X = (np.hstack(cols) * w[:, None])[ok]
        rw = (r2 * w)[ok]
        d, *_ = np.linalg.lstsq(X, rw, rcond=None)
        res = rw - X @ d
        sigma2 = max(float(res @ res) / max(len(rw) - X.shape[1], 1), 1.0)
        cov = np.linalg.pinv(X.T @ X) * sigma2
        j = 0
        biggest = 0.0
        for e in total:
            if e.period is None:
                if it < iterations:
                    e.estimate += float(d[j])
                    biggest = max(biggest, abs(float(d[j])) / max(e.stderr, 1e-12))
                e.stderr = float(math.sqrt(max(cov[j, j], 0.0)))
                j += 1
            else:
                a = e.estimate * math.cos(math.radians(e.phase_deg or 0.0)) + d[j]
                b = e.estimate * math.sin(math.radians(e.phase_deg or 0.0)) + d[j + 1]
                if it < iterations:
                    biggest = max(biggest, float(math.hypot(d[j], d[j + 1])) / max(e.stderr, 1e-12))
                    e.estimate = float(math.hypot(a, b))
                    e.phase_deg = float(math.degrees(math.atan2(b, a)))
                e.stderr = float(math.sqrt(max(cov[j, j], cov[j + 1, j + 1], 0.0)))
                j += 2
        if it == iterations or biggest < 0.01:
            break
        updated = profile_from_dict(apply_effects(current.raw, total, current), current.source)
        lin = predict(updated, data)
    return updated, measured - lin.pred, lin


def diagnose(
    current: Profile, data: Data, *, alpha: float = 1e-3, refine: int = 3, max_effects: int = 6
) -> Diagnosis:
    """The whole loop (module docstring); ``data`` was commanded by ``data.commanded``."""
    measured, segs = data.measured()
    if not segs:
        raise FitError("no measurements to diagnose", expected="pose, ballbar or axis files")
    lin = predict(current, data)
    resid = measured - lin.pred
    # noise: ballbar and laser from their own scatter; poses from what a fit of
    # the whole library leaves
    noise = estimate_noise(data, resid, segs)
    w0 = _whiten(segs, {**noise, "pose_tip": 1e-3, "pose_axis": 3e-4}, len(resid))
    if any(s.kind.startswith("pose") for s in segs):
        ok = np.isfinite(resid)
        X = np.column_stack([c if c.ndim == 1 else c[:, 0] for c in lin.columns.values()])
        Xw = (X * w0[:, None])[ok]
        coef, *_ = np.linalg.lstsq(Xw, (resid * w0)[ok], rcond=1e-10)
        full = np.full_like(resid, np.nan)
        full[ok] = resid[ok] - X[ok] @ coef
        rank = np.linalg.matrix_rank(Xw, tol=1e-8 * np.linalg.norm(Xw, 2))
        for kind in ("pose_tip", "pose_axis"):
            v = np.concatenate([full[s.start : s.stop] for s in segs if s.kind == kind])
            v = v[np.isfinite(v)]
            n_all = int(np.sum([np.isfinite(resid[s.start : s.stop]).sum() for s in segs]))
            if v.size:
                noise[kind] = float(np.sqrt(np.sum(v**2) / max(v.size * (1 - rank / n_all), 1.0)))
    w = _whiten(segs, noise, len(resid))
    regs = regions(data, resid, segs, noise)
    # one effect at a time: select on the true (nonlinear) residual of the model
    # as it stands, refine every chosen size through the full model, repeat
    total: list[Effect] = []
    updated = current
    after = resid
    lin_now = lin
    for _ in range(max_effects):
        keys = [e.name if e.period is None else f"{e.name}@{e.period:g}" for e in total]
        new = select_effects(
            lin_now,
            after,
            w,
            alpha=alpha,
            max_effects=1,
            exclude=[e.name for e in total],
            given=keys,
        )
        if not new:
            break
        saved = [(e.estimate, e.stderr, e.phase_deg) for e in total]
        total.append(new[0])
        try:
            updated, after, lin_now = _refine(current, data, measured, w, total, refine)
        except ProfileError:
            # through the full model its size ran beyond anything a machine (or a
            # profile) holds: the linear signature fitted noise, not this effect
            total.pop()
            for e, (est, se, ph) in zip(total, saved, strict=True):
                e.estimate, e.stderr, e.phase_deg = est, se, ph
            break
    # a final joint test: an effect whose size is within 3 standard errors of
    # zero once the others are in is not kept
    kept = [e for e in total if abs(e.estimate) > 3 * e.stderr]
    if len(kept) != len(total):
        total = kept
        if total:
            updated, after, lin_now = _refine(current, data, measured, w, total, refine)
        else:
            updated, after = current, resid
    effects = total
    rms_b, rms_a = _rms_um(resid, segs), _rms_um(after, segs)
    note = {
        "by": "prsxy-post diagnose",
        "sources": sorted({s.source for s in segs}),
        "effects": [f"{e.name} {e.estimate:+.6g} {e.unit} ± {e.stderr:.2g}" for e in effects],
        "rms_before_um": rms_b,
        "rms_after_um": rms_a,
    }
    udoc = copy.deepcopy(updated.raw)
    udoc.setdefault("provenance", {})
    prov = udoc["provenance"]
    prov.setdefault("diagnose", [])
    prov["diagnose"] = [*list(prov["diagnose"]), note]
    summary = (
        " ".join(sentence(e) for e in effects)
        if effects
        else "The model explains the measurements to their noise: no effect is missing."
    )
    return Diagnosis(
        effects, noise, rms_b, rms_a, _per_run(resid, after, segs), regs, udoc, summary
    )
