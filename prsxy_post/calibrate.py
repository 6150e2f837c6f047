"""Calibration from measurements: real-axis tables, kinematic parameters, error map.

The stages, as in the paper (section 4), real axes first:

1. real-axis tables per motor from laser (axis) runs, with ISO 230-2 figures
   (the E_i(P_i) of Eq. 3);
2. the kinematic and table parameters of the contract (the g'_i of Eq. 3) from
   pose and ballbar measurements, by nonlinear least squares with an
   identifiability analysis;
3. the library's physical effects beyond the contract (:func:`stage_effects`):
   diagnose's selection over the whole library, the contract refitted with them;
   a member is written only when the data tell it from zero, from the contract's
   terms, from the laser tables' values within their standard errors and from a
   servo lag common to every motor (which position data cannot see);
4. the virtual-axis error map (Eq. 4–5) from what the calibrated model leaves.

Stage 2 in detail
-----------------
Unknowns θ: every contract term (36: per leg guide radius, angle, height, strut
length, platform radius, angle, z, guide tilts, hinge twist; tool length and
offsets; table scales and squareness), in profile units.

The data were taken with the machine commanded by a known profile, so the motor
commands are known; what the parts did follows from the real-axis tables (the
play model). The model of a measurement is then the forward kinematics of the
geometry θ:

    pose:    y = FK_θ(P_actual)                     (tip x, y, z and A, B)
    ballbar: y = |w_θ(P_actual) − pivot|            (ball-to-ball distance)

Residuals are whitened by the measurement noise (σ_tip, σ_angle, σ_ballbar). The
Jacobian ∂y/∂θ comes from the implicit function theorem on the FK constraints
F(x, θ) = 0 (x = platform pose): ∂x/∂θ = −F_x⁻¹ F_θ, so one FK solve per
iteration suffices.

Identifiability: with the parameters scaled by their prior size s (typical
manufacturing error), the whitened Jacobian J·diag(s) = U Σ Vᵀ. A combination
v_k is determined by the data to ±1/Σ_k of its prior size. Combinations with
1/Σ_k > ``max_rel_stderr`` cannot be told apart by these data (for example a
strut's length and its guide's height, which move the tip alike): they are left
at the starting profile's values (minimum-norm Gauss–Newton step in the
identified subspace) and reported as groups of parameters.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Collection, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import axiscomp, diagnose, errormap, kinematics, provenance, simulate
from . import effects as registry
from .errors import FitError
from .measure import AxisData, BallbarRun, PoseData
from .measurement_model import fk_with_jacobian
from .profile import (
    MOTORS,
    AxisComp,
    Effects,
    KinematicParams,
    Profile,
    TableParams,
    profile_from_dict,
)

LEG_KEYS = registry.LEG_KEYS


#: Profile paths of every contract parameter, in θ order (from the effects registry).
PARAMS = list(registry.CONTRACT)
#: Typical size of each (its prior): the registry's.
PRIOR = np.array([registry.prior(n) for n in PARAMS])


def units(name: str) -> str:
    return registry.unit(name)


def theta_of(profile: Profile) -> np.ndarray:
    return registry.theta_of(profile, PARAMS)


def params_of(theta: np.ndarray) -> tuple[KinematicParams, TableParams]:
    """KinematicParams and TableParams for θ (inverse of :func:`theta_of`)."""
    from .profile import Leg

    n = len(LEG_KEYS)
    legs = tuple(
        Leg(
            **dict(
                zip(LEG_KEYS, (float(x) for x in theta[3 + i * n : 3 + (i + 1) * n]), strict=True)
            )
        )
        for i in range(3)
    )
    kp = KinematicParams(float(theta[0]), legs, float(theta[1]), float(theta[2]))  # type: ignore[arg-type]
    tb = TableParams(float(theta[-3]), float(theta[-2]), float(theta[-1]))
    return kp, tb


def geometry_of(profile: Profile, theta: np.ndarray) -> kinematics.Geometry:
    return registry.geometry_at(profile, PARAMS, theta)


# ---------------------------------------------------------------- data


@dataclass
class Observations:
    """Measurements turned into model inputs and targets.

    P_pose : (Np, 5) motor positions the parts reached at each pose
    y_pose : (Np, 5) measured tip [mm] and A, B [deg] (NaN where not measured)
    P_bb : (Nb, 5) motor positions the parts reached along ballbar runs
    pivot_bb : (Nb, 3); dist_bb : (Nb,) measured ball-to-ball distance [mm]
    run_bb : (Nb,) index of the run each ballbar sample belongs to
    q_pose, q_bb : commanded poses (for guesses and the error map)
    """

    P_pose: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    y_pose: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    q_pose: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    P_bb: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    q_bb: np.ndarray = field(default_factory=lambda: np.zeros((0, 5)))
    pivot_bb: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    dist_bb: np.ndarray = field(default_factory=lambda: np.zeros(0))
    run_bb: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    run_names: list[str] = field(default_factory=list)
    sigma_tip_mm: float = 1e-3
    sigma_deg: float = 3e-4
    sigma_bb_mm: float = 0.5e-3


def reached_motors(
    real_axis: Sequence[AxisComp],
    P_cmd: np.ndarray,
    approach: int | None,
    effects: Effects | None = None,
) -> np.ndarray:
    """Where the parts end for commands, by the given real-axis tables (play model)."""
    tables = axiscomp.tables_by_motor(tuple(real_axis), effects)
    out = P_cmd.copy()
    for col, m in enumerate(MOTORS):
        t = tables.get(m)
        if t is None:
            continue
        out[:, col] = (
            axiscomp.play_model(t, P_cmd[:, col])
            if approach is None
            else axiscomp.approach(t, P_cmd[:, col], approach)
        )
    return out


def observations(
    commanded: Profile,
    real_axis: Sequence[AxisComp],
    poses: Sequence[PoseData],
    runs: Sequence[BallbarRun],
    ballbar_points: int = 720,
) -> Observations:
    """Model inputs for pose files (measure.PoseData) and ballbar runs (measure.BallbarRun).

    ``commanded``: the profile the machine was commanded with (its chain made the
    motor commands); ``real_axis``: the best knowledge of the real-axis tables
    (the truth's, as calibrated in stage 1, else the commanded profile's).
    ``ballbar_points``: each run is thinned to about this many samples (every
    half degree of a circle) after the whole run went through the play model;
    ten-millisecond neighbours carry the same information.
    """
    obs = Observations()
    if poses:
        q = np.vstack([p.commanded for p in poses])
        y = np.vstack([np.column_stack([p.tip, p.axis]) for p in poses])
        P_cmd = simulate.pose_commands(commanded, q)
        obs.P_pose = reached_motors(real_axis, P_cmd, +1)
        obs.y_pose, obs.q_pose = y, q
    P_all, q_all, piv, dist, run = [], [], [], [], []
    for k, r in enumerate(runs):
        stride = max(1, len(r.t) // ballbar_points)
        P_cmd = simulate.motion_commands(commanded, r.commanded, t=r.t)
        P = reached_motors(real_axis, P_cmd, None)[::stride]
        P_all.append(P)
        q_all.append(r.commanded[::stride])
        piv.append(np.broadcast_to(r.pivot, (len(P), 3)))
        dist.append(r.length + r.dev_um[::stride] * 1e-3)
        run.append(np.full(len(P), k))
        obs.run_names.append(getattr(r, "name", "") or getattr(r, "source", f"run {k + 1}"))
    if runs:
        obs.P_bb = np.vstack(P_all)
        obs.q_bb = np.vstack(q_all)
        obs.pivot_bb = np.vstack(piv)
        obs.dist_bb = np.concatenate(dist)
        obs.run_bb = np.concatenate(run)
    return obs


# ---------------------------------------------------------------- the model


@dataclass
class ModelEval:
    r: np.ndarray  # whitened residuals, measured − model
    J: np.ndarray | None  # whitened Jacobian of the model (∂ model / ∂θ)
    raw: dict[str, np.ndarray]  # unwhitened residuals per data type [mm, deg]


def evaluate(
    profile: Profile,
    theta: np.ndarray,
    obs: Observations,
    want_jac: bool = True,
    guesses: dict[str, np.ndarray] | None = None,
) -> ModelEval:
    """Whitened residuals (and Jacobian) of all observations under θ."""

    def make_geo(t: np.ndarray) -> kinematics.Geometry:
        return geometry_of(profile, t)

    rs, Js = [], []
    raw: dict[str, np.ndarray] = {}
    g = guesses if guesses is not None else {}
    if len(obs.P_pose):
        y, J, xv, _ = fk_with_jacobian(make_geo, theta, obs.P_pose, g.get("pose"), want_jac)
        g["pose"] = xv
        res = obs.y_pose - y
        ok = np.isfinite(res)
        w = np.array([1 / obs.sigma_tip_mm] * 3 + [1 / obs.sigma_deg] * 2)
        raw["pose_tip"] = res[:, :3]
        raw["pose_axis"] = res[:, 3:]
        rs.append((np.where(ok, res, 0.0) * w)[ok])
        if J is not None:
            Js.append((J * w[None, :, None])[ok])
    if len(obs.P_bb):
        y, J, xv, _ = fk_with_jacobian(make_geo, theta, obs.P_bb, g.get("bb"), want_jac)
        g["bb"] = xv
        vec = y[:, :3] - obs.pivot_bb
        d = np.linalg.norm(vec, axis=1)
        res = obs.dist_bb - d
        raw["ballbar"] = res
        rs.append(res / obs.sigma_bb_mm)
        if J is not None:
            Js.append(np.einsum("ni,nim->nm", vec / d[:, None], J[:, :3, :]) / obs.sigma_bb_mm)
    if not rs:
        raise FitError(
            "no pose or ballbar measurements to calibrate from", expected="pose or ballbar files"
        )
    r = np.concatenate(rs)
    Jall = np.vstack(Js) if want_jac else None
    return ModelEval(r, Jall, raw)


@dataclass
class KinematicFit:
    theta0: np.ndarray
    theta: np.ndarray
    stderr: np.ndarray  # NaN for parameters not identified
    identified: np.ndarray  # bool per parameter: determined on its own by these data
    singular_values: np.ndarray
    condition: float
    unidentified_groups: list[list[tuple[str, float]]]
    rms_before: dict[str, float]
    rms_after: dict[str, float]
    max_before: dict[str, float]
    max_after: dict[str, float]
    iterations: int
    noise_scale: float


def _stats(raw: dict[str, np.ndarray]) -> tuple[dict[str, float], dict[str, float]]:
    rms, mx = {}, {}
    for k, v in raw.items():
        a = v[np.isfinite(v)]
        if a.size:
            rms[k] = float(np.sqrt(np.mean(a**2)))
            mx[k] = float(np.max(np.abs(a)))
    return rms, mx


def fit_kinematics(
    profile: Profile,
    obs: Observations,
    *,
    max_rel_stderr: float = 0.25,
    max_iter: int = 12,
    only: Sequence[str] | None = None,
) -> KinematicFit:
    """Stage 2: Gauss–Newton in the identified subspace (see module docstring).

    Parameters
    ----------
    profile : the starting profile (θ0 and everything not fitted)
    obs : Observations
    max_rel_stderr : a combination whose standard error exceeds this fraction of
        its prior size is not identified and stays at θ0
    only : restrict the fit to these parameter names (others held)
    """
    theta0 = theta_of(profile)
    theta = theta0.copy()
    mask = (
        np.ones(len(PARAMS), dtype=bool)
        if only is None
        else np.array([n in set(only) for n in PARAMS])
    )
    guesses: dict[str, np.ndarray] = {}
    ev = evaluate(profile, theta, obs, True, guesses)
    rms_b, max_b = _stats(ev.raw)
    s = PRIOR * mask
    assert ev.J is not None
    Js = -ev.J * s[None, :]  # residual = measured − model: ∂r/∂θ = −J
    _, S, Vt = np.linalg.svd(Js, full_matrices=False)
    keep = (S > 0) & (1.0 / np.maximum(S, 1e-300) < max_rel_stderr)
    if not np.any(keep):
        raise FitError(
            "these measurements identify no kinematic parameter",
            expected="poses or ballbar runs that move the tip measurably",
        )
    V = Vt[keep].T  # (m, k) identified directions, scaled space
    cost = float(ev.r @ ev.r)
    iterations = 0
    for _ in range(max_iter):
        iterations += 1
        assert ev.J is not None
        A = (-ev.J * s[None, :]) @ V
        dz, *_ = np.linalg.lstsq(A, -ev.r, rcond=None)
        lam, trial, ev_t, cost_t = _line_search(profile, obs, guesses, theta, s * (V @ dz), cost)
        if ev_t is None or cost_t > cost:
            break
        theta, ev = trial, ev_t
        done = abs(cost - cost_t) <= 1e-10 * max(cost, 1e-30) or np.max(np.abs(dz * lam)) < 1e-9
        cost = cost_t
        if done:
            break
    rms_a, max_a = _stats(ev.raw)
    # report: covariance of the identified combinations at the solution
    assert ev.J is not None
    Js = -ev.J * s[None, :]
    _, S, Vt = np.linalg.svd(Js, full_matrices=False)
    keep = (S > 0) & (1.0 / np.maximum(S, 1e-300) < max_rel_stderr)
    dof = max(len(ev.r) - int(keep.sum()), 1)
    noise_scale = float(np.sqrt(float(ev.r @ ev.r) / dof))
    cov_scaled = (Vt[keep].T / S[keep] ** 2) @ Vt[keep]
    se = s * np.sqrt(np.maximum(np.diag(cov_scaled), 0.0)) * max(noise_scale, 1.0)
    se = np.where(mask, se, np.nan)
    # A parameter is identified on its own only if it has (almost) no part in the
    # combinations the data leave open: otherwise its estimate carries whatever
    # those combinations were left at, which no standard error describes.
    dropped = Vt[~keep]
    open_part = np.sqrt(np.sum(dropped**2, axis=0)) if len(dropped) else np.zeros(len(s))
    identified = mask & (se < max_rel_stderr * PRIOR) & (open_part < 0.1)
    groups = _open_groups(Vt[~keep], mask)
    smax = S[0] if S.size else 0.0
    smin = S[-1] if S.size else 0.0
    return KinematicFit(
        theta0,
        theta,
        se,
        identified,
        S,
        float(smax / smin) if smin > 0 else float("inf"),
        groups,
        rms_b,
        rms_a,
        max_b,
        max_a,
        iterations,
        noise_scale,
    )


def _line_search(
    profile: Profile,
    obs: Observations,
    guesses: dict[str, np.ndarray],
    theta: np.ndarray,
    step: np.ndarray,
    cost: float,
) -> tuple[float, np.ndarray, ModelEval | None, float]:
    """θ + λ·step for λ = 1, 1/4, 1/16, ... down to 1e-3 until the cost is no more
    than ``cost``: (λ, θ there, its evaluation or None where the model cannot be
    evaluated there, its cost)."""
    lam = 1.0
    while True:
        trial = theta + lam * step
        ev_t: ModelEval | None
        try:
            ev_t = evaluate(profile, trial, obs, True, dict(guesses))
            cost_t = float(ev_t.r @ ev_t.r)
        except FitError:
            ev_t, cost_t = None, np.inf
        if cost_t <= cost or lam < 1e-3:
            return lam, trial, ev_t, cost_t
        lam /= 4


def _open_groups(open_dirs: np.ndarray, mask: np.ndarray) -> list[list[tuple[str, float]]]:
    """The fitted parameters of each combination the data leave open (the rows of
    ``open_dirs``, scaled space) that take a part of at least 0.3 of its largest."""
    groups = []
    for v in open_dirs:
        big = np.nonzero(np.abs(v) >= 0.3 * np.max(np.abs(v)))[0]
        if big.size and np.any(mask[big]):
            groups.append([(PARAMS[j], float(v[j])) for j in big if mask[j]])
    return groups


def apply_theta(profile_doc: dict[str, Any], theta: np.ndarray) -> dict[str, Any]:
    """A profile document with the contract parameters set to θ."""
    from .profile import kinematics_to_dict

    kp, tb = params_of(theta)
    doc = dict(profile_doc)
    doc["kinematics"] = kinematics_to_dict(kp)
    doc["table"] = dataclasses.asdict(tb)
    return doc


# ---------------------------------------------------------------- the three stages


@dataclass
class StageReport:
    """What one stage changed and how the residuals moved."""

    name: str
    changed: list[dict[str, Any]]
    rms_before: dict[str, float]
    rms_after: dict[str, float]
    max_before: dict[str, float]
    max_after: dict[str, float]
    notes: list[str] = field(default_factory=list)
    details: dict[str, Any] = field(default_factory=dict)
    #: what the user should act on (the data could not support a result fully)
    warnings: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)


def _axis_residuals(tables: Sequence[AxisComp], axis: Sequence[AxisData]) -> dict[str, np.ndarray]:
    """measured − predicted position for laser runs under given tables [mm], per motor."""
    t = axiscomp.tables_by_motor(tuple(tables))
    out: dict[str, list[np.ndarray]] = {}
    for a in axis:
        for m in np.unique(a.motor):
            for d in (1, -1):
                sel = (a.motor == m) & (a.direction == d)
                pred = axiscomp.approach(t.get(int(m)), a.target[sel], d)
                out.setdefault(f"axis_{int(m)}", []).append(a.measured[sel] - pred)
    return {k: np.concatenate(v) for k, v in out.items()}


def stage_tables(start: Profile, axis: Sequence[AxisData]) -> tuple[list[AxisComp], StageReport]:
    """Stage 1: [[axis_comp]] tables and ISO 230-2 figures from laser runs."""
    from . import iso230_2

    motor = np.concatenate([a.motor for a in axis])
    target = np.concatenate([a.target for a in axis])
    measured = np.concatenate([a.measured for a in axis])
    direction = np.concatenate([a.direction for a in axis])
    run = np.concatenate([a.run for a in axis])
    new = [
        AxisComp(t.motor, t.positions, t.forward, t.reverse)
        for t in iso230_2.tables_from_axis(motor, target, measured, direction, run)
    ]
    figures = iso230_2.iso230_2(motor, target, measured, direction, run)
    merged = {c.motor: c for c in start.axis_comp}
    merged.update({c.motor: c for c in new})
    tabs = [merged[m] for m in sorted(merged)]
    before = _axis_residuals(start.axis_comp, axis)
    after = _axis_residuals(tabs, axis)
    rb, mb = _stats(before)
    ra, ma = _stats(after)
    changed = []
    for c in new:
        f = figures[c.motor]
        changed.append(
            {
                "name": f"axis_comp[motor={c.motor}]",
                "points": len(c.positions),
                "from": float(c.positions[0]),
                "to": float(c.positions[-1]),
                "iso230_2": {
                    k: _jsonable(getattr(f, k))
                    for k in ("systematic_E", "reversal_B", "repeatability_R", "accuracy_A")
                    if hasattr(f, k)
                },
            }
        )
    return tabs, StageReport("real-axis tables (ISO 230-2)", changed, rb, ra, mb, ma)


def _jsonable(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        return [float(v) for v in x.ravel()] if x.size > 1 else float(x)
    if isinstance(x, np.floating | np.integer):
        return float(x)
    return x


def stage_kinematics(
    start: Profile,
    commanded: Profile,
    real_axis: Sequence[AxisComp],
    poses: Sequence[PoseData],
    runs: Sequence[BallbarRun],
    **kw: Any,
) -> tuple[np.ndarray, KinematicFit, Observations, StageReport]:
    """Stage 2: contract parameters from poses and ballbar runs."""
    obs = observations(commanded, real_axis, poses, runs)
    fit = fit_kinematics(start, obs, **kw)
    changed = []
    for j, name in enumerate(PARAMS):
        d = fit.theta[j] - fit.theta0[j]
        if fit.identified[j] and abs(d) > 0:
            changed.append(
                {
                    "name": name,
                    "from": float(fit.theta0[j]),
                    "to": float(fit.theta[j]),
                    "change": float(d),
                    "stderr": float(fit.stderr[j]),
                    "unit": units(name),
                }
            )
    notes = [
        f"condition number of the scaled Jacobian: {fit.condition:.3g}",
        f"{int(fit.identified.sum())} of {len(PARAMS)} parameters identified to "
        f"{kw.get('max_rel_stderr', 0.25):.0%} of their prior size",
    ]
    for g in fit.unidentified_groups:
        txt = " ".join(f"{w:+.2f}·{n}" for n, w in g)
        notes.append(f"not separable by these data (left as they were): {txt}")
    rep = StageReport(
        "kinematic and table parameters",
        changed,
        fit.rms_before,
        fit.rms_after,
        fit.max_before,
        fit.max_after,
        notes,
        {"iterations": fit.iterations, "noise_scale": fit.noise_scale},
    )
    return fit.theta, fit, obs, rep


def stage_error_map(
    calibrated: Profile,
    theta: np.ndarray,
    obs: Observations,
    rng: np.random.Generator,
    provenance: dict[str, Any],
) -> tuple[Any, StageReport]:
    """Stage 3: the Eq. 5 error map from the pose residuals the calibrated model leaves."""
    if not len(obs.P_pose):
        raise FitError(
            "the error map needs pose measurements", expected="a pose file (kind: poses)"
        )
    ev = evaluate(calibrated, theta, obs, want_jac=False)
    resid = np.column_stack([ev.raw["pose_tip"], ev.raw["pose_axis"]])
    emap = errormap.fit(obs.q_pose, resid, rng=rng, provenance=provenance)
    after = resid - emap(obs.q_pose)
    rb, mb = _stats({"pose_tip": resid[:, :3], "pose_axis": resid[:, 3:]})
    ra, ma = _stats({"pose_tip": after[:, :3], "pose_axis": after[:, 3:]})
    return emap, _map_report(emap, rb, ra, mb, ma)


def _map_report(
    emap: errormap.ErrorMap,
    rms_before: dict[str, float],
    rms_after: dict[str, float],
    max_before: dict[str, float],
    max_after: dict[str, float],
) -> StageReport:
    """The error-map stage's report: each component's degree, ridge and errors."""
    changed = [
        {
            "name": f"error_map.{c}",
            "degree": emap.degree[c],
            "lambda": emap.lam[c],
            "cv_rms": emap.cv_rms[c],
            "fit_rms": emap.fit_rms[c],
            "unit": errormap.UNITS[c],
        }
        for c in emap.coef
    ]
    notes = [
        "cv_rms: cross-validated prediction error on poses left out of the fit; "
        "fit_rms below it by much would mean the map follows noise"
    ]
    return StageReport(
        "virtual-axis error map (Eq. 5)",
        changed,
        rms_before,
        rms_after,
        max_before,
        max_after,
        notes,
    )


# ---------------------------------------------------------------- the physical stage


def _axis_doc(tables: Sequence[AxisComp]) -> list[dict[str, Any]]:
    """``[[axis_comp]]`` entries of tables."""
    return [
        {
            "motor": int(c.motor),
            "positions": np.asarray(c.positions, dtype=float).tolist(),
            "forward": np.asarray(c.forward, dtype=float).tolist(),
            "reverse": np.asarray(c.reverse, dtype=float).tolist(),
        }
        for c in tables
    ]


def _kind_stats(
    resid: np.ndarray, segs: Sequence[Any]
) -> tuple[dict[str, float], dict[str, float]]:
    parts: dict[str, list[np.ndarray]] = {}
    for s in segs:
        parts.setdefault(s.kind, []).append(resid[s.start : s.stop])
    return _stats({k: np.concatenate(v) for k, v in parts.items()})


def stage_effects(
    now: Profile,
    commanded: Profile,
    poses: Sequence[PoseData],
    runs: Sequence[BallbarRun],
    *,
    alpha: float = 1e-3,
    max_rel_stderr: float = 0.25,
    tables_measured: Collection[int] = (),
    axis: Sequence[AxisData] = (),
) -> tuple[dict[str, Any], list[Any], StageReport]:
    """The physical stage: the library's effects outside the contract (bowed guides,
    curved table axes, backlash, cyclic error, servo lag), named, sized and written
    into the profile, with every contract parameter refitted jointly with them.

    The selection is diagnose's (:func:`prsxy_post.diagnose.find_effects`) with the
    contract parameters free, on the pose and ballbar data (the laser runs made
    the tables). ``tables_measured``: the motors whose tables in ``now`` the
    laser runs of the same machine made: they hold every static position error
    at their targets (a cyclic error among them, aliased when its pitch is under
    twice the spacing), so an effect is judged by what it adds beyond that and
    taken out of the table as it is written, as making the table again from the
    runs less the effect would. Returns the profile document, the effects and
    the report.
    """
    data = diagnose.Data.build(commanded, list(poses), list(runs), [])
    candidates = [n for n in registry.members() if n not in set(registry.CONTRACT)]
    measured, segs = data.measured()
    before = measured - diagnose.predict(now, data, []).pred
    found, fit, noise, _ = diagnose.find_effects(
        now,
        data,
        candidates=candidates,
        free=list(registry.CONTRACT),
        alpha=alpha,
        max_rel_stderr=max_rel_stderr,
        tables_measured=tables_measured,
        nuisance=diagnose.table_nuisance(now, axis, tables_measured, common_lag=True),
    )
    doc = registry.apply(now.raw, now, fit.changes(), fit.tables_measured)
    after = measured - diagnose.predict(fit.profile, data, []).pred
    rb, mb = _kind_stats(before, segs)
    ra, ma = _kind_stats(after, segs)
    changed = [
        {
            "name": e.name,
            "change": e.estimate,
            "stderr": e.stderr,
            "unit": e.unit,
            **({"period_mm": e.period, "phase_deg": e.phase_deg} if e.period else {}),
        }
        for e in found
    ]
    notes = effect_sentences(found) or ["no effect beyond the contract's terms found"]
    notes.append(tested_note(candidates, found, alpha, bool(tables_measured and axis)))
    notes.append(
        "contract parameters refitted with them: "
        + ", ".join(
            f"{n} {d:+.3g}"
            for n, d in zip(fit.free, fit.x[: len(fit.free)], strict=True)
            if abs(d) > 0
        )
        if any(abs(d) > 0 for d in fit.x[: len(fit.free)])
        else "contract parameters unchanged"
    )
    rep = StageReport(
        "physical effects (the library's, beyond the contract)",
        changed,
        rb,
        ra,
        mb,
        ma,
        notes,
        {"noise": noise},
    )
    return doc, found, rep


#: How each family is named in the report of what was tested.
_FAMILY_WORDS = {
    "guide_bow": "bowed guides",
    "table_straightness": "curved table axes",
    "backlash": "backlash beyond the tables",
    "cyclic": "cyclic errors",
    "servo_lag": "servo lag of one motor against the others",
}


def effect_sentences(found: Sequence[Any]) -> list[str]:
    """One sentence per effect, the servo lags in one: a lag common to every motor
    moves the tip along its own path, which position data cannot see (to first
    order), so only lags relative to the motors with none named are found and
    written; several motors "lagging more than the others" would contradict each
    other."""
    lags = [e for e in found if isinstance(registry.family(e.name), registry.ServoLag)]
    out = [e.sentence() for e in found if e not in lags]
    if lags:
        fam = registry.family(lags[0].name)
        assert isinstance(fam, registry.ServoLag)
        named = {fam.motor(e.name) for e in lags}
        ref = ", ".join(str(m) for m in MOTORS if m not in named)
        each = ", ".join(
            f"motor {fam.motor(e.name)} {e.estimate:+.3f} ms (± {e.stderr:.2g})"
            for e in sorted(lags, key=lambda e: fam.motor(e.name))
        )
        out.append(
            f"Servo lag against motors {ref} (position data cannot see a lag common to "
            f"every motor; none is written): {each}."
        )
    return out


def tested_note(candidates: Sequence[str], found: Sequence[Any], alpha: float, laser: bool) -> str:
    """What the physical stage tested and did not find, and the test."""
    named = {e.name for e in found}
    groups: dict[str, list[str]] = {}
    for n in candidates:
        groups.setdefault(registry.family(n).key, []).append(n)
    parts = []
    for key, names in groups.items():
        fam = registry.family(names[0])
        missing = [n for n in names if n not in named]
        if not missing:
            continue
        if isinstance(fam, registry.MotorFamily):
            which = "motors " + ", ".join(str(fam.motor(n)) for n in missing)
        else:
            which = ", ".join(str(fam.index(n) + 1) for n in missing)
        if isinstance(fam, registry.CyclicError):
            which += f" at pitches {min(fam.variants):g}-{max(fam.variants):g} mm"
        parts.append(f"{_FAMILY_WORDS.get(key, key)} ({which})")
    allowed = (
        "the laser tables' values within their standard error and a servo lag common to every motor"
        if laser
        else "a servo lag common to every motor"
    )
    return (
        f"tested {len(candidates)} library members, each by an F-test Bonferroni-corrected "
        f"for all of them at α = {alpha:g} and the BIC, with the contract's terms, "
        f"{allowed} free beside it; not found: " + ("; ".join(parts) or "none")
    )


def aliased_cyclic(
    found: Sequence[Any], axis: Sequence[AxisData], min_amplitude_mm: float = 0.00025
) -> list[str]:
    """Warnings for periodic errors found at pitches the laser runs cannot resolve.

    A real-axis table is made from laser targets spaced s apart and interpolated
    linearly between them; a periodic error of pitch p < 2 s (Nyquist: two
    samples a pitch at least) appears in it as a pattern of the alias frequency
    f_a = |1/p − k/s|, k the nearest integer. The physical stage models that (a
    cyclic member's signature is the error less what the table holds of it, and
    the table is made again without it), but the term is then sized from the
    ballbar and pose data alone and the laser runs cannot check it. A pitch that
    divides the spacing aliases to a constant (f_a = 0), which the kinematic
    parameters absorb, and a term smaller than ``min_amplitude_mm`` (default:
    half the default path tolerance) cannot move the path by much: neither is
    warned of. One sentence per motor.
    """
    by_motor: dict[int, list[tuple[float, float, float]]] = {}
    spacing_of: dict[int, float] = {}
    for e in found:
        fam = registry.family(e.name)
        if not isinstance(fam, registry.CyclicError) or not e.period:
            continue
        if abs(e.estimate) < min_amplitude_mm:
            continue
        motor = fam.motor(e.name)
        targets = np.unique(
            np.concatenate([a.target[a.motor == motor] for a in axis] or [np.zeros(0)])
        )
        if len(targets) < 2:
            continue
        spacing = float(np.max(np.diff(targets)))
        f, fs = 1.0 / e.period, 1.0 / spacing
        f_alias = abs(f - round(f / fs) * fs)
        if e.period < 2.0 * spacing and f_alias > 1e-9 * f:
            by_motor.setdefault(motor, []).append((e.period, abs(e.estimate), 1.0 / f_alias))
            spacing_of[motor] = spacing
    out = []
    for motor, terms in sorted(by_motor.items()):
        terms.sort(key=lambda t: -t[1])
        listed = ", ".join(
            f"{p:g} mm pitch ({a * 1000:.2f} µm, seen as a {al:.4g} mm pattern)"
            for p, a, al in terms
        )
        finest = min(p for p, _, _ in terms)
        out.append(
            f"motor {motor}: periodic errors at {listed}, but its laser targets are "
            f"up to {spacing_of[motor]:g} mm apart: its table holds them aliased (at "
            "least two targets a pitch are needed); they were sized from the ballbar "
            "and pose data and taken out of the table, which the laser runs cannot "
            f"check; measure the motor with targets at most {finest / 2:g} mm apart"
        )
    return out


def fit_error_map(profile: Profile, data: Any, seed: int, sources: Sequence[str]) -> Any:
    """Stage 3 on diagnose's model: the Eq. 5 map fitted on the pose residual
    [mm, deg] that ``profile`` (every effect it holds, no map) leaves."""
    measured, segs = data.measured()
    resid = measured - diagnose.predict(profile, data, []).pred
    q, e = [], []
    k = 0
    tip = np.zeros((0, 3))
    for s in segs:
        if s.kind == "pose_tip":
            tip = resid[s.start : s.stop].reshape(-1, 3)
        elif s.kind == "pose_axis":
            ax = resid[s.start : s.stop].reshape(-1, 2)
            q.append(data.poses[k].commanded)
            e.append(np.column_stack([tip, ax]))
            k += 1
    if not q:
        raise FitError(
            "the error map needs pose measurements", expected="a pose file (kind: poses)"
        )
    Q, E = np.vstack(q), np.vstack(e)
    ok = np.all(np.isfinite(E[:, :3]), axis=1)
    E = np.where(np.isfinite(E), E, 0.0)
    return errormap.fit(
        Q[ok], E[ok], rng=np.random.default_rng(seed), provenance={"from": list(sources)}
    )


#: The stages of :func:`calibrate`, in the paper's order: real axes first
#: (tables, kinematic parameters, the library's physical effects), the
#: virtual-axis map for what remains.
STAGES = ("tables", "kinematics", "effects", "map")


@dataclass
class Calibration:
    """The calibrated profile document (provenance recorded) and what each stage did."""

    doc: dict[str, Any]
    reports: list[StageReport]
    effects: list[Any]

    def to_json(self) -> dict[str, Any]:
        return {"stages": [r.to_dict() for r in self.reports]}


def stage_map(
    doc: dict[str, Any],
    source: str,
    commanded: Profile,
    poses: Sequence[PoseData],
    seed: int,
) -> tuple[dict[str, Any], StageReport]:
    """The virtual-axis error map (Eq. 4-5) fitted on what the profile ``doc`` leaves
    of the poses, written into it; the report holds the residuals before and after."""
    now = profile_from_dict(doc, source)
    data = diagnose.Data.build(commanded, list(poses), [], [])
    emap = fit_error_map(now, data, seed, [p.source for p in poses])
    measured, segs = data.measured()
    before = measured - diagnose.predict(now, data, []).pred
    doc = dict(doc, error_map=emap.to_dict())
    after = (
        measured - diagnose.predict(profile_from_dict(doc, source), data, [], with_map=True).pred
    )
    rb, mb = _kind_stats(before, segs)
    ra, ma = _kind_stats(after, segs)
    return doc, _map_report(emap, rb, ra, mb, ma)


def calibrate(
    start: Profile,
    commanded: Profile,
    poses: Sequence[PoseData],
    runs: Sequence[BallbarRun],
    axis: Sequence[AxisData],
    *,
    stages: Sequence[str] = STAGES,
    max_rel_stderr: float = 0.25,
    alpha: float = 1e-3,
    seed: int = 0,
    commanded_with: Any = None,
    sources: Sequence[str] | None = None,
    progress: Callable[[str, float], None] | None = None,
) -> Calibration:
    """Calibrate ``start`` from measurements taken while ``commanded`` commanded the
    machine: real-axis tables from laser runs, the contract's kinematic parameters,
    the library's physical effects (with the contract refitted jointly), then the
    virtual-axis error map on what remains.

    ``progress(stage, fraction of the stages done)`` hears of each as it begins.

    Example
    -------
    >>> cal = calibrate(nominal, nominal, poses, runs, axis)  # doctest: +SKIP
    >>> text = profile.dumps(cal.doc)  # doctest: +SKIP

    Raises
    ------
    FitError
        When no stage had data to work on, or a fit cannot identify anything.
    """
    from .errors import UsageError

    want = list(dict.fromkeys(stages))
    unknown = [s for s in want if s not in STAGES]
    if unknown:
        raise UsageError(f"unknown stage {unknown[0]!r}", expected=", ".join(STAGES))
    doc: dict[str, Any] = dict(start.raw)
    real_axis = list(start.axis_comp)
    reports: list[StageReport] = []
    found: list[Any] = []
    said = _stage_teller(want, poses, runs, axis, progress)
    if "tables" in want and axis:
        said("tables")
        real_axis, rep = stage_tables(start, axis)
        reports.append(rep)
        doc["axis_comp"] = _axis_doc(real_axis)
    if "kinematics" in want and (poses or runs):
        said("kinematics")
        theta, _, _, rep = stage_kinematics(
            start, commanded, real_axis, poses, runs, max_rel_stderr=max_rel_stderr
        )
        reports.append(rep)
        doc = apply_theta(doc, theta)
    if "effects" in want and (poses or runs):
        said("effects")
        now = profile_from_dict(doc, start.source)
        # the tables the laser runs just made hold the cyclic errors at their targets
        laser = {int(m) for a in axis for m in np.unique(a.motor)} if "tables" in want else set()
        doc, found, rep = stage_effects(
            now,
            commanded,
            poses,
            runs,
            alpha=alpha,
            max_rel_stderr=max_rel_stderr,
            tables_measured=laser,
            axis=axis,
        )
        tol = start.interpolation.path_tolerance_mm
        rep.warnings.extend(aliased_cyclic(found, axis, min_amplitude_mm=tol / 2))
        reports.append(rep)
    if "map" in want and poses:
        said("map")
        doc, rep = stage_map(doc, start.source, commanded, poses, seed)
        reports.append(rep)
    if not reports:
        raise FitError(
            "no stage had data to work on",
            expected="axis files for tables, pose or ballbar files for the "
            "kinematics and effects, pose files for the map",
        )
    note = {
        "start": start.source,
        "data": list(sources) if sources is not None else [],
        "stages": [r.name for r in reports],
        "effects": [f"{e.name} {e.estimate:+.6g} {e.unit} ± {e.stderr:.2g}" for e in found],
    }
    doc = provenance.record(doc, "calibrate", note, commanded_with=commanded_with)
    return Calibration(doc, reports, found)


def _stage_teller(
    want: Sequence[str],
    poses: Sequence[PoseData],
    runs: Sequence[BallbarRun],
    axis: Sequence[AxisData],
    progress: Callable[[str, float], None] | None,
) -> Callable[[str], None]:
    """``said(stage)`` tells ``progress`` that a stage of :func:`calibrate` begins."""
    n_poses = sum(len(p.commanded) for p in poses)
    motors = ", ".join(str(int(m)) for m in np.unique([m for a in axis for m in a.motor]))
    text = {
        "tables": f"real-axis tables from the laser runs of motors {motors}",
        "kinematics": f"kinematic parameters from {n_poses} poses and {len(runs)} ballbar runs",
        "effects": "physical effects beyond the kinematic parameters",
        "map": f"virtual-axis error map from {n_poses} poses",
    }
    has = {"tables": bool(axis), "kinematics": bool(poses or runs)}
    has.update(effects=has["kinematics"], map=bool(poses))
    runs_now = [s for s in STAGES if s in want and has[s]]

    def said(stage: str) -> None:
        if progress is not None:
            progress(text[stage], runs_now.index(stage) / len(runs_now))

    return said
