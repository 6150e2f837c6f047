"""Find where simulation and measurement disagree, name the missing effects, add them.

The loop an engineer runs with a ballbar plot, made a procedure
(:func:`diagnose`):

1. **Simulate** every measurement with the current model (the profile), the
   machine commanded as the data say (:mod:`.model`).
2. **Noise.** Every library member's signature at the current model, fitted all
   together to the residual: what even the whole library leaves is the noise of
   each data kind (ballbar, pose tip, pose axis, laser), estimated from the data
   themselves. Residuals are whitened by it.
3. **Name** the effects (:mod:`.selection`): backward elimination from the full
   model, a forward check, and the sparsest explanation; each member judged by
   an F-test, Bonferroni-corrected for the number of candidates, and the BIC.
   Members the data cannot tell apart from a named one are reported as its
   aliases (its confounded group).
4. **Add** them: the sizes are refined by Gauss–Newton through the full
   (nonlinear) model; the model is linearised again at the result and the
   selection repeated on it until it no longer changes. Standard errors come
   from the joint fit at the end; an estimate that moves by more than two
   standard errors (and 2 %) when another named effect is left out says so
   (:attr:`Effect.depends_on`).
5. **Say what is left** (:mod:`.leftover`): every data kind whose residual a
   statistical test tells from its noise at 99.9 % confidence (the laser tables'
   own errors allowed for when laser runs are given), where, by how much, and how
   much of it any library member could take.
6. **Close the loop.** A profile with a virtual-axis error map: the map is part
   of the model, but when pose data are given the physical effects are judged
   on what the map took (real axes first, as in the paper) and the map is then
   refitted on what they leave (:attr:`Diagnosis.map_note`).

The library of effects is the registry in :mod:`prsxy_post.effects`; the
calibration's physical stage (:func:`prsxy_post.calibrate.calibrate`) runs the
same selection with the contract parameters free (``free=``) and, beside them,
what the data cannot tell a member from (``nuisance=``, :mod:`.nuisance`): the
laser tables' values within their standard errors and a servo lag common to
every motor.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy import stats

from .. import effects as registry
from .. import errormap, provenance
from ..errors import FitError, ProfileError
from ..measure import CommandedWith
from ..profile import Profile, profile_from_dict
from . import leftover, selection
from .model import Data, Linearised, Segment, column_keys, predict, split_key
from .nuisance import COMMON_LAG, Nuisance, table_nuisance

__all__ = [
    "COMMON_LAG",
    "Data",
    "Diagnosis",
    "Effect",
    "Linearised",
    "Nuisance",
    "Segment",
    "apply_effects",
    "diagnose",
    "estimate_noise",
    "predict",
    "regions",
    "table_nuisance",
]


#: Signatures more alike than this (|partial correlation|) cannot be told apart.
ALIAS_CORR = 0.98


@dataclass
class Effect:
    """A named effect: its estimate (the change to add to the profile's value, or
    the term's size), standard error and unit; for a periodic term its period [mm]
    and phase [deg]; members the data cannot tell apart from it; its evidence
    (``chi2``: the drop of the whitened SSE it gives, ``p_value`` of its F-test);
    the other named effects whose omission would move it by more than two standard
    errors and 2 % (``depends_on``: name, shift, shift in standard errors): the
    estimate is only as good as the model it was fitted in; the members with which
    it forms a combination these data do not determine at all
    (``undetermined_with``: the platform frame's definition, a common servo lag):
    of the equivalent explanations the one naming the fewest effects was taken,
    and the sizes are those of that explanation."""

    name: str
    estimate: float
    stderr: float
    unit: str
    aliases: list[str] = field(default_factory=list)
    period: float | None = None
    phase_deg: float | None = None
    p_value: float = 0.0
    chi2: float = 0.0
    depends_on: list[dict[str, Any]] = field(default_factory=list)
    undetermined_with: list[str] = field(default_factory=list)
    #: the 2-standard-error interval of the estimate, and how it was found:
    #: "linear" (estimate ± 2 stderr) or "profile" (the profile likelihood, where
    #: the model is not linear enough over the interval)
    interval: tuple[float, float] | None = None
    interval_method: str = "linear"
    #: how far the model moved from its linearisation at estimate + 2 stderr
    #: (relative), the test of whether the linear interval holds
    nonlinearity: float = 0.0

    @property
    def key(self) -> str:
        return self.name if self.period is None else f"{self.name}@{self.period:g}"

    def change(self) -> registry.Change:
        return registry.Change(self.name, self.estimate, self.period, self.phase_deg)

    def sentence(self) -> str:
        return registry.family(self.name).sentence(self.name, self.estimate, self.period)

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
        d["chi2"] = self.chi2
        if self.depends_on:
            d["depends_on"] = self.depends_on
        if self.undetermined_with:
            d["undetermined_with"] = self.undetermined_with
        if self.interval is not None:
            d["interval"] = list(self.interval)
            d["interval_method"] = self.interval_method
        d["nonlinearity"] = self.nonlinearity
        d["sentence"] = self.sentence()
        return d


def apply_effects(
    doc: dict[str, Any], effects: Sequence[Effect], profile: Profile
) -> dict[str, Any]:
    """A profile document with the effects added (estimates are changes to add)."""
    return registry.apply(doc, profile, [e.change() for e in effects])


# ---------------------------------------------------------------- noise and regions


def _kind_rows(segs: list[Segment], n: int) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for s in segs:
        m = out.setdefault(s.kind, np.zeros(n, dtype=bool))
        m[s.start : s.stop] = True
    return out


def _whiten(segs: list[Segment], noise: dict[str, float], n: int) -> np.ndarray:
    w = np.ones(n)
    for s in segs:
        w[s.start : s.stop] = 1.0 / max(noise.get(s.kind, 1e-3), 1e-12)
    return w


def estimate_noise(
    data: Data, resid: np.ndarray, segs: list[Segment], normal: selection.Normal
) -> dict[str, float]:
    """Measurement noise per data kind [mm or deg]: what a fit of every library
    member (and the free parameters) together leaves, with its degrees of freedom.

    Starting values: ballbar 1.4826 · MAD of consecutive differences / √2; laser
    the pooled spread of repeated runs; poses 1 µm and 1 arcsec. Each kind's
    degrees of freedom are its rows less its share of the fit (tr(G⁺ G_kind)): a
    few poses beside thousands of ballbar samples give most of their freedom to
    the fit. Two passes, the second whitened by the first. ``normal``: the
    cross-products of every signature and the residual (:class:`.selection.Normal`).
    """
    noise = {"pose_tip": 1e-3, "pose_axis": 3e-4, "ballbar": 0.5e-3, "axis": 0.3e-3}
    noise.update(leftover.independent_noise(data, resid, segs))
    noise = {k: v for k, v in noise.items() if k in normal.M}
    for _ in range(2):
        sse, used, _ = normal.full_fit(noise)
        for kind, v in sse.items():
            dof = normal.n[kind] - used[kind]
            if normal.n[kind] and dof > 0.05 * normal.n[kind]:
                noise[kind] = noise[kind] * math.sqrt(v / dof)
    return noise


def _rows(segs: list[Segment], n: int) -> dict[str, np.ndarray]:
    return _kind_rows(segs, n)


regions = leftover.regions


# ---------------------------------------------------------------- fitting


@dataclass
class _Fit:
    """Sizes of the free members and chosen terms, and where the model is then."""

    free: list[str]
    keys: list[str]  # column keys of the chosen terms
    x: np.ndarray  # free deltas then term values (d per term)
    dims: list[int]
    profile: Profile
    lin: Linearised
    cov: np.ndarray
    sigma2: float
    #: motors whose tables were measured with the effects present (:func:`refine`)
    tables_measured: tuple[int, ...] = ()

    def changes(self) -> list[registry.Change]:
        return _changes(self.free, self.keys, self.dims, self.x)


def _changes(
    free: Sequence[str], keys: Sequence[str], dims: Sequence[int], x: np.ndarray
) -> list[registry.Change]:
    out = [registry.Change(n, float(v)) for n, v in zip(free, x[: len(free)], strict=True)]
    j = len(free)
    for k, d in zip(keys, dims, strict=True):
        name, period = split_key(k)
        if d == 1:
            out.append(registry.Change(name, float(x[j])))
        else:
            a, b = float(x[j]), float(x[j + 1])
            out.append(
                registry.Change(name, math.hypot(a, b), period, math.degrees(math.atan2(b, a)))
            )
        j += d
    return out


def _priors(free: Sequence[str], keys: Sequence[str], dims: Sequence[int]) -> np.ndarray:
    s = [registry.prior(n) for n in free]
    for k, d in zip(keys, dims, strict=True):
        s += [registry.prior(split_key(k)[0])] * d
    return np.array(s)


def _design(lin: Linearised, keys: Sequence[str], w: np.ndarray, ok: np.ndarray) -> np.ndarray:
    if not keys:
        return np.zeros((int(ok.sum()), 0))
    return (np.hstack([lin.columns[k] for k in keys]) * w[:, None])[ok]


def refine(
    current: Profile,
    data: Data,
    measured: np.ndarray,
    w: np.ndarray,
    keys: Sequence[str],
    x0: np.ndarray,
    *,
    free: Sequence[str] = (),
    with_map: bool = False,
    iterations: int = 6,
    max_rel_stderr: float = 0.25,
    lower: Mapping[str, float] | None = None,
    tables_measured: Collection[int] = (),
) -> _Fit:
    """Gauss–Newton on the sizes through the full (nonlinear) model.

    keys : column keys of the chosen terms; x0 : starting sizes (free deltas,
    then each term's values). Directions of the free members the data cannot
    determine to ``max_rel_stderr`` of their prior stay where they are.
    lower : key -> the least size of a term's model
    (:func:`prsxy_post.effects.lower_bound`); steps stop there (projected
    Gauss–Newton).
    tables_measured : motors whose tables in ``current`` were measured on the
    machine as it is: what such a table holds of a term is taken out of it as the
    term is added (:func:`prsxy_post.effects.apply`).

    Raises
    ------
    ProfileError
        When a size runs beyond what a profile can hold.
    """
    free = list(free)
    keys = list(keys)
    dims = [2 if split_key(k)[1] is not None else 1 for k in keys]
    lo = _lower_bounds(free, keys, dims, lower or {})
    x = np.maximum(np.array(x0, dtype=float), lo)
    s = _priors(free, keys, dims)
    measured_motors = tuple(sorted(tables_measured))
    sizes = _Sizes(current, data, free, keys, dims, with_map, measured_motors, lo)

    def solve(X: np.ndarray, rw: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        return _svd_step(X, rw, s, len(free), max_rel_stderr)

    # Gauss-Newton with the Jacobian of the start (the model is close to linear in
    # sizes of micrometres), evaluated again where it converged for the covariance
    prof, lin = sizes.model_at(x, True)
    r = measured - lin.pred
    ok = np.isfinite(r)
    X = _design(lin, sizes.all_keys, w, ok)
    if not X.shape[1]:
        rw = (r * w)[ok]
        return _Fit(
            free,
            keys,
            x,
            dims,
            prof,
            lin,
            np.zeros((0, 0)),
            float(rw @ rw) / len(rw),
            measured_motors,
        )

    def cost(lin: Linearised) -> float:
        rw = ((measured - lin.pred) * w)[ok]
        return float(rw @ rw)

    for _ in range(iterations):
        dx, cov, sigma2 = solve(X, (r * w)[ok])
        dx = np.maximum(x + dx, lo) - x  # a size at its bound stays there
        moved = sizes.step(x, dx, cost, cost(lin), False)
        if moved is None:
            break
        x, prof, lin = moved
        r = measured - lin.pred
        se = np.sqrt(np.maximum(np.diag(cov), 1e-300))
        if np.max(np.abs(dx) / se, initial=0.0) < 0.01:
            break
    # linearised again where it converged, for the covariance; while the new
    # Jacobian still moves the sizes by more than a tenth of their standard error
    # (large or strongly coupled effects), more steps with it
    prof, lin = sizes.model_at(x, True)
    for _ in range(4):
        r = measured - lin.pred
        dx, cov, sigma2 = solve(_design(lin, sizes.all_keys, w, ok), (r * w)[ok])
        dx = np.maximum(x + dx, lo) - x
        if np.max(np.abs(dx) / np.sqrt(np.maximum(np.diag(cov), 1e-300)), initial=0.0) <= 0.1:
            break
        moved = sizes.step(x, dx, cost, cost(lin), True)
        if moved is None:
            break
        x, prof, lin = moved
    else:  # every pass moved x: the covariance where it ended
        r = measured - lin.pred
        _, cov, sigma2 = solve(_design(lin, sizes.all_keys, w, ok), (r * w)[ok])
    return _Fit(free, keys, x, dims, prof, lin, cov, sigma2, measured_motors)


def _lower_bounds(
    free: list[str], keys: list[str], dims: list[int], lower: Mapping[str, float]
) -> np.ndarray:
    """The least value of each size: free members and periodic parts unbounded, a
    term's model size at ``lower[key]``."""
    lo = np.full(len(free) + sum(dims), -np.inf)
    j = len(free)
    for k, d in zip(keys, dims, strict=True):
        if d == 1:
            lo[j] = lower.get(k, -np.inf)
        j += d
    return lo


def _svd_step(
    X: np.ndarray, rw: np.ndarray, s: np.ndarray, n_free: int, max_rel_stderr: float
) -> tuple[np.ndarray, np.ndarray, float]:
    """Step, covariance and σ̂² of the linear model X at the weighted residual rw,
    the sizes scaled by their priors ``s`` (the first ``n_free`` free members)."""
    Xs = X * s
    U, S, Vt = np.linalg.svd(Xs, full_matrices=False)
    # directions mostly of free members that the data determine worse than
    # max_rel_stderr of their prior stay put; the chosen terms passed their
    # tests, so every direction of theirs is kept
    free_part = np.sum(Vt[:, :n_free] ** 2, axis=1)
    weak = 1.0 / np.maximum(S, 1e-300) >= max_rel_stderr
    keep = (S > 1e-12 * (S[0] if S.size else 1.0)) & ~(weak & (free_part > 0.5))
    dx = s * (Vt[keep].T @ ((U[:, keep].T @ rw) / S[keep]))
    res = rw - X @ dx
    sigma2 = float(res @ res) / max(len(rw) - int(keep.sum()), 1)
    cov = (s[:, None] * ((Vt[keep].T / S[keep] ** 2) @ Vt[keep]) * s[None, :]) * sigma2
    return dx, cov, sigma2


class _Sizes:
    """The model of :func:`refine` at given sizes: the profile they make, its
    predictions, a step that lowers the cost of their residual."""

    def __init__(
        self,
        current: Profile,
        data: Data,
        free: list[str],
        keys: list[str],
        dims: list[int],
        with_map: bool,
        measured_motors: tuple[int, ...],
        lo: np.ndarray,
    ) -> None:
        self.current, self.data = current, data
        self.free, self.keys, self.dims = free, keys, dims
        self.all_keys = free + keys
        self.with_map, self.measured_motors, self.lo = with_map, measured_motors, lo

    def model_at(self, x: np.ndarray, columns: bool) -> tuple[Profile, Linearised]:
        current = self.current
        changes = _changes(self.free, self.keys, self.dims, x)
        doc = registry.apply(current.raw, current, changes, self.measured_motors)
        prof = profile_from_dict(doc, current.source)
        lin = predict(
            prof,
            self.data,
            self.all_keys if columns else [],
            with_map=self.with_map,
            tables_measured=self.measured_motors,
        )
        return prof, lin

    def step(
        self,
        x: np.ndarray,
        dx: np.ndarray,
        cost: Callable[[Linearised], float],
        c0: float,
        columns: bool,
    ) -> tuple[np.ndarray, Profile, Linearised] | None:
        """x + dx, halved while the model cannot be evaluated there (a geometry
        whose forward kinematics misses measured poses, a size a profile cannot
        hold) or ``cost`` grows beyond ``c0``; None when no share of the step helps."""
        for _ in range(8):
            x_new = np.maximum(x + dx, self.lo)  # halving a projected step stays inside
            try:
                prof, lin = self.model_at(x_new, columns)
            except (ProfileError, FitError):
                dx = dx / 2
                continue
            if cost(lin) <= c0 * (1 + 1e-9):
                return x_new, prof, lin
            dx = dx / 2
        return None


def _select(
    normal: selection.Normal,
    noise: dict[str, float],
    free: Sequence[str],
    candidates: Sequence[str],
    alpha: float,
    max_rel_stderr: float = selection.UNDETERMINED,
    lower: dict[str, float] | None = None,
    nuisance: Nuisance | None = None,
    columns: Mapping[str, np.ndarray] | None = None,
) -> tuple[selection.Gram, selection.Test, list[int]]:
    priors = {k: registry.prior(split_key(k)[0]) for k in candidates}
    extra = nuisance.keys(columns or {}) if nuisance is not None else []
    g = selection.Gram.build(
        normal,
        noise,
        candidates,
        [*free, *extra],
        priors=priors,
        max_rel_stderr=max_rel_stderr,
        lower=lower,
        known=nuisance.table_sd if nuisance is not None else None,
    )
    # the noise scale of the whole library's fit: 1 when the whitening is right
    sse, used, _ = normal.full_fit(noise)
    sigma2 = sum(sse.values()) / max(sum(normal.n.values()) - sum(used.values()), 1.0)
    test = selection.Test(alpha, max(len(g.keys), 1), sigma2, g.n)
    return g, test, selection.select(g, test)


# ---------------------------------------------------------------- the whole loop


@dataclass
class Diagnosis:
    """What :func:`diagnose` found; :meth:`to_json` is the contract's JSON."""

    effects: list[Effect]
    noise: dict[str, float]
    rms_before_um: float
    rms_after_um: float
    per_run: list[dict[str, Any]]
    regions: list[dict[str, Any]]
    unexplained: list[dict[str, Any]]
    updated: dict[str, Any]
    summary: str
    map_note: dict[str, Any] | None = None
    residual_before: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    residual_after: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)

    def to_json(self) -> dict[str, Any]:
        noise_um = (
            self.noise.get(
                "ballbar", self.noise.get("pose_tip", self.noise.get("axis", float("nan")))
            )
            * 1000.0
        )
        out = {
            "rms_before_um": self.rms_before_um,
            "rms_after_um": self.rms_after_um,
            "noise_um": noise_um,
            "noise": {
                k: v * (3600.0 if k == "pose_axis" else 1000.0) for k, v in self.noise.items()
            },
            "noise_units": {k: ("arcsec" if k == "pose_axis" else "um") for k in self.noise},
            "effects": [e.to_dict() for e in self.effects],
            "regions": self.regions,
            "unexplained": self.unexplained,
            "runs": self.per_run,
            "summary": self.summary,
        }
        if self.map_note is not None:
            out["error_map"] = self.map_note
        return out


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


#: The linear interval holds while the model at estimate + 2 stderr is within this
#: (relative) of its linearisation; beyond it the profile likelihood is used.
NONLINEAR = 0.1


def _intervals(
    found: list[Effect],
    fit: _Fit,
    current: Profile,
    data: Data,
    measured: np.ndarray,
    w: np.ndarray,
    with_map: bool,
) -> None:
    """The 2-standard-error interval of each effect, checked against the model.

    The model is evaluated at the estimate + 2 stderr (along the estimate's own
    direction for a periodic term); when the predictions moved differently from
    the linearisation by more than :data:`NONLINEAR`, the interval is the profile
    likelihood's: the sizes where the residual, with the other members refitted
    (linearly), has grown by 4 σ̂² (secant steps on each side)."""
    nf = len(fit.free)
    pos = np.concatenate([[nf], nf + np.cumsum(fit.dims)]).astype(int)
    ok = np.isfinite(measured - fit.lin.pred)
    keys = fit.free + fit.keys
    X = _design(fit.lin, keys, w, ok)

    def pred_at(x: np.ndarray) -> np.ndarray:
        doc = registry.apply(
            current.raw,
            current,
            _changes(fit.free, fit.keys, fit.dims, x),
            fit.tables_measured,
        )
        return predict(profile_from_dict(doc, current.source), data, [], with_map=with_map).pred

    by_key = {e.key: e for e in found}
    for t, k in enumerate(fit.keys):
        e = by_key.get(k)
        if e is None or not e.stderr > 0:
            continue
        a, b = int(pos[t]), int(pos[t + 1])
        v = fit.x[a:b]
        u = v / np.linalg.norm(v) if np.linalg.norm(v) > 0 else np.eye(b - a)[0]
        step = np.zeros_like(fit.x)
        step[a:b] = 2 * e.stderr * u
        try:
            moved = (pred_at(fit.x + step) - fit.lin.pred) * w
        except (ProfileError, FitError):
            moved = np.full_like(measured, np.nan)
        lin = X @ step
        dn = moved[ok]
        e.nonlinearity = (
            float(np.linalg.norm(dn - lin)) / max(float(np.linalg.norm(lin)), 1e-300)
            if np.all(np.isfinite(dn))
            else float("inf")
        )
        e.interval = (e.estimate - 2 * e.stderr, e.estimate + 2 * e.stderr)
        if e.nonlinearity <= NONLINEAR:
            continue
        # profile likelihood along u: the others refitted linearly at each size
        others = np.ones(X.shape[1], dtype=bool)
        others[a:b] = False
        Q, _ = np.linalg.qr(X[:, others]) if others.any() else (np.zeros((len(dn), 0)), None)
        r0 = ((measured - fit.lin.pred) * w)[ok]
        base = float(np.sum((r0 - Q @ (Q.T @ r0)) ** 2))

        def excess(
            s: float, unit_step: np.ndarray = step / 2, Q: np.ndarray = Q, base: float = base
        ) -> float:
            """Profiled SSE growth at estimate + s stderr, less 4 σ̂²."""
            try:
                r = ((measured - pred_at(fit.x + s * unit_step)) * w)[ok]
            except (ProfileError, FitError):
                return float("inf")
            return float(np.sum((r - Q @ (Q.T @ r)) ** 2)) - base - 4 * fit.sigma2

        ends = []
        for sign in (1.0, -1.0):
            s0, f0 = 0.0, -4 * fit.sigma2
            s1, f1 = 2.0 * sign, excess(2.0 * sign)
            for _ in range(8):
                if not np.isfinite(f1) or abs(f1 - f0) < 1e-12:
                    break
                s0, f0, s1 = s1, f1, s1 - f1 * (s1 - s0) / (f1 - f0)
                f1 = excess(s1)
                if abs(f1) < 0.01 * fit.sigma2:
                    break
            ends.append(e.estimate + s1 * e.stderr)
        e.interval = (min(ends), max(ends))
        e.interval_method = "profile"


def _effects_of(fit: _Fit, g: selection.Gram | None, sel: list[int], test: Any) -> list[Effect]:
    """Named effects with estimates, standard errors and dependencies from a fit."""
    nf = len(fit.free)
    out: list[Effect] = []
    pos = []
    j = nf
    for d in fit.dims:
        pos.append((j, j + d))
        j += d
    x, C = fit.x, fit.cov
    groups = selection.undetermined(g, test.sigma2) if g is not None else {}
    for t, (k, (a, b)) in enumerate(zip(fit.keys, pos, strict=True)):
        name, period = split_key(k)
        v = x[a:b]
        Ck = C[a:b, a:b]
        if b - a == 1:
            est = float(v[0])
            se = float(math.sqrt(max(Ck[0, 0], 0.0)))
            phase = None
            u = np.ones(1)
        else:
            est = float(math.hypot(v[0], v[1]))
            u = v / est if est > 0 else np.array([1.0, 0.0])
            se = float(math.sqrt(max(float(u @ Ck @ u), 0.0)))
            phase = float(math.degrees(math.atan2(v[1], v[0])))
        # the Wald statistic: the drop of the whitened SSE over σ̂²
        chi2 = float(v @ np.linalg.solve(Ck, v)) if se > 0 else 0.0
        p = float(stats.chi2.sf(chi2, b - a))
        depends = []
        for t2, (k2, (a2, b2)) in enumerate(zip(fit.keys, pos, strict=True)):
            if t2 == t:
                continue
            # β_t without k2: β_t − C_t,k2 C_k2,k2⁻¹ β_k2
            shift_v = -C[a:b, a2:b2] @ np.linalg.solve(C[a2:b2, a2:b2], x[a2:b2])
            shift = float(u @ shift_v)
            # worth saying: beyond two standard errors and 2 % of the estimate
            if se > 0 and abs(shift) > max(2 * se, 0.02 * abs(est)):
                depends.append(
                    {
                        "name": split_key(k2)[0],
                        "period_mm": split_key(k2)[1],
                        "shift": shift,
                        "in_stderr": shift / se,
                    }
                )
        aliases: list[str] = []
        if g is not None and k in g.keys:
            i = g.keys.index(k)
            if i in sel:
                aliases = [
                    split_key(g.keys[j])[0]
                    for j in selection.aliases(g, sel, sel.index(i), ALIAS_CORR)
                ]
        together: list[str] = []
        if g is not None and k in g.keys:
            i = g.keys.index(k)
            together = sorted({split_key(g.keys[j])[0] for j in groups.get(i, set())})
        out.append(
            Effect(
                name,
                est,
                se,
                registry.unit(name),
                aliases,
                period,
                phase,
                p,
                chi2,
                depends,
                together,
            )
        )
    out.sort(key=lambda e: -e.chi2)
    return out


def find_effects(
    current: Profile,
    data: Data,
    *,
    candidates: Sequence[str] | None = None,
    free: Sequence[str] = (),
    alpha: float = 1e-3,
    rounds: int = 3,
    with_map: bool = False,
    max_rel_stderr: float = 0.25,
    tables_measured: Collection[int] = (),
    nuisance: Nuisance | None = None,
) -> tuple[list[Effect], _Fit, dict[str, float], np.ndarray]:
    """Steps 2-4 of the module docstring: (effects, fit, noise, whitening weights).

    candidates : member names to choose from (default: every member not in ``free``)
    free : members always fitted, never reported as effects (calibration frees
        the contract parameters)
    max_rel_stderr : a combination the data determine worse than this fraction
        of its prior is undetermined: the free members stay put along it, and
        among the candidates the sparsest explanation of it is taken
        (:mod:`.selection`, step 1)
    tables_measured : motors whose tables in ``current`` were measured (laser runs)
        on the machine as it is, its effects present (calibration's physical
        stage): a member is judged by what it adds beyond what such a table holds,
        and taken out of the table as it is added (:func:`refine`)
    nuisance : what else may explain the data (:class:`Nuisance`): free in the
        selection (the table errors within their prior), never named or written;
        a member is named only if the data tell it apart from them
    """
    nuis = nuisance or Nuisance()
    measured, segs = data.measured()
    if not segs:
        raise FitError("no measurements to diagnose", expected="pose, ballbar or axis files")
    free = list(free)
    names = [n for n in (registry.members() if candidates is None else candidates) if n not in free]
    keys = column_keys(names)
    # the least change each member's model goes to (a motor's play stays >= 0)
    lower = {
        k: registry.lower_bound(split_key(k)[0], current) for k in keys if split_key(k)[1] is None
    }
    lower = {k: v for k, v in lower.items() if np.isfinite(v)}

    lin0 = predict(
        current,
        data,
        free + keys,
        with_map=with_map,
        tables_measured=tables_measured,
        table_knots=nuis.table_knots,
    )
    nuis.add_columns(lin0.columns)
    resid0 = measured - lin0.pred
    rows = _kind_rows(segs, len(resid0))
    normal = selection.Normal.of(lin0.columns, resid0, rows)
    noise = estimate_noise(data, resid0, segs, normal)
    w = _whiten(segs, noise, len(resid0))
    fit = _Fit(free, [], np.zeros(len(free)), [], current, lin0, np.zeros((0, 0)), 1.0)
    chosen: list[str] | None = None
    g: selection.Gram | None = None
    sel: list[int] = []
    test = None
    z = resid0
    for n_round in range(max(rounds, 1)):
        if n_round:
            # the noise again at the new linearisation: effects the first one saw
            # only roughly (the play after a reversal) no longer inflate it
            noise = estimate_noise(data, z, segs, normal)
            w = _whiten(segs, noise, len(resid0))
        g, test, sel = _select(
            normal, noise, free, keys, alpha, max_rel_stderr, lower, nuis, lin0.columns
        )
        same = chosen is not None and {g.keys[i] for i in sel} == set(chosen)
        fit_sizes = functools.partial(
            refine,
            current,
            data,
            measured,
            w,
            free=free,
            with_map=with_map,
            max_rel_stderr=max_rel_stderr,
            lower=lower,
            tables_measured=tables_measured,
        )
        fit = _refit(fit_sizes, g, sel, same, fit)
        if same:
            break
        chosen = [g.keys[i] for i in sel]
        lin, z = _working_response(
            fit, data, measured, free + keys, with_map, tables_measured, nuis
        )
        normal = selection.Normal.of(lin.columns, z, rows)
    assert test is not None and g is not None
    found = _effects_of(fit, g, sel, test)
    if nuisance is not None:
        _widen_by_nuisance(found, g, sel, test)
    _intervals(found, fit, current, data, measured, w, with_map)
    return found, fit, noise, w


def _refit(
    fit_sizes: Callable[[list[str], np.ndarray], _Fit],
    g: selection.Gram,
    sel: list[int],
    same: bool,
    fit: _Fit,
) -> _Fit:
    """The chosen members ``sel`` of ``g`` fitted through the full model
    (``fit_sizes``: :func:`refine` but for the keys and start): from where ``fit``
    left them when they are the same as last round, else from the selection's
    linear estimates. Where a size runs beyond anything a profile holds, its linear
    signature fitted something else: the weakest member leaves (``sel`` shrinks)."""
    n_free = len(fit.free)
    while True:
        picked = [g.keys[i] for i in sel]
        if same:
            picked = list(fit.keys)  # the same members: start where they are
            x0 = fit.x
        else:
            # starting sizes: the free ones where they are, the chosen at the
            # selection's linear estimates (relative to ``current``, as z is)
            beta, C, _ = g.fit(sel)
            b_u, _ = g.unscaled(sel, beta, C)
            x0 = np.concatenate([fit.x[:n_free], b_u])
        try:
            return fit_sizes(picked, x0)
        except ProfileError:
            if not sel or same:
                raise
            sel.pop(_weakest(g, sel))


def _working_response(
    fit: _Fit,
    data: Data,
    measured: np.ndarray,
    keys: list[str],
    with_map: bool,
    tables_measured: Collection[int],
    nuis: Nuisance,
) -> tuple[Linearised, np.ndarray]:
    """The model ``fit`` found linearised again (its columns added to the
    nuisance's), and the working response there: the data as that linearisation
    sees them, relative to the profile the fit started from (the sizes found
    are added back)."""
    lin = predict(
        fit.profile,
        data,
        keys,
        with_map=with_map,
        tables_measured=tables_measured,
        table_knots=nuis.table_knots,
    )
    nuis.add_columns(lin.columns)
    z = measured - lin.pred
    j = 0
    for k, d in zip(fit.free + fit.keys, [1] * len(fit.free) + fit.dims, strict=True):
        z = z + lin.columns[k] @ fit.x[j : j + d]
        j += d
    return lin, z


def _widen_by_nuisance(
    found: list[Effect], g: selection.Gram, sel: Sequence[int], test: selection.Test
) -> None:
    """Standard errors, χ² and p-values that allow for the nuisance (:class:`Nuisance`).

    The Gauss–Newton fit (:func:`refine`) holds the tables as the laser made them;
    the selection's Gram matrix has their errors in it (Henderson's equations), so
    its covariance of the chosen terms is the honest one where it is wider."""
    if not sel:
        return
    beta, C, _ = g.fit(list(sel))
    _, C_u = g.unscaled(list(sel), beta, C)
    C_u = C_u * test.sigma2
    pos = np.concatenate([[0], np.cumsum([g.dims[k] for k in sel])]).astype(int)
    by_key = {e.key: e for e in found}
    for t, k in enumerate(sel):
        e = by_key.get(g.keys[k])
        if e is None:
            continue
        a, b = int(pos[t]), int(pos[t + 1])
        Ck = C_u[a:b, a:b]
        if b - a == 1:
            se = math.sqrt(max(float(Ck[0, 0]), 0.0))
            v = np.array([e.estimate])
        else:
            phase = math.radians(e.phase_deg or 0.0)
            u = np.array([math.cos(phase), math.sin(phase)])
            se = math.sqrt(max(float(u @ Ck @ u), 0.0))
            v = e.estimate * u
        if se <= e.stderr:
            continue
        e.stderr = se
        e.chi2 = float(v @ np.linalg.solve(Ck, v))
        e.p_value = float(stats.chi2.sf(e.chi2, b - a))


def _weakest(g: selection.Gram, sel: Sequence[int]) -> int:
    """Position in ``sel`` of the member with the least evidence in the joint fit."""
    beta, C, _ = g.fit(sel)
    pos = np.concatenate([[0], np.cumsum([g.dims[k] for k in sel])])
    ev = [
        float(beta[a:b] @ np.linalg.solve(C[a:b, a:b], beta[a:b]))
        for a, b in itertools.pairwise(pos)
    ]
    return int(np.argmin(ev))


def _left_unexplained(
    updated: Profile,
    data: Data,
    after: np.ndarray,
    segs: list[Any],
    noise: dict[str, float],
    w: np.ndarray,
    has_map: bool,
) -> list[dict[str, Any]]:
    """What the updated model leaves above the noise (:func:`leftover.unexplained`),
    the whole library's signatures and, with laser runs, the tables' values within
    their standard errors allowed for."""
    all_keys = column_keys()

    def library() -> Linearised:
        return predict(updated, data, all_keys, with_map=has_map)

    laser = {int(m) for a in data.axis for m in np.unique(a.motor)}
    nuis = table_nuisance(updated, data.axis, laser) if laser else None

    def table_errors() -> tuple[dict[str, np.ndarray], dict[str, float]]:
        assert nuis is not None
        lin = predict(updated, data, [], with_map=has_map, table_knots=nuis.table_knots)
        return lin.columns, dict(nuis.table_sd)

    return leftover.unexplained(
        data, after, segs, noise, w, library, table_errors if nuis is not None else None
    )


def diagnose(
    current: Profile,
    data: Data,
    *,
    alpha: float = 1e-3,
    rounds: int = 3,
    commanded_with: CommandedWith | None = None,
    rng_seed: int = 0,
    progress: Callable[[str, float], None] | None = None,
) -> Diagnosis:
    """The whole loop (module docstring); ``data`` was commanded by ``data.commanded``.

    ``progress(stage, fraction)`` is told each stage as it begins: what it does,
    and the fraction of the stages that are done."""
    measured, segs = data.measured()
    if not segs:
        raise FitError("no measurements to diagnose", expected="pose, ballbar or axis files")
    has_map = errormap.from_profile(current) is not None
    refit_map = has_map and bool(data.poses)
    sel_map = has_map and not refit_map
    stages = ["effects", *(["map"] if refit_map else []), "left"]

    def said(stage: str, text: str) -> None:
        if progress is not None:
            progress(text, stages.index(stage) / len(stages))

    said("effects", f"looking for the effects the model misses (up to {max(rounds, 1)} rounds)")
    before = measured - predict(current, data, [], with_map=has_map).pred
    effects, _, noise, w = find_effects(current, data, alpha=alpha, rounds=rounds, with_map=sel_map)
    updated_doc = apply_effects(current.raw, effects, current) if effects else dict(current.raw)
    map_note: dict[str, Any] | None = None
    if has_map:
        map_note = {
            "action": "kept",
            "reason": "no effect was added" if not effects else "no pose data to refit it",
        }
        if refit_map and effects:
            said("map", "fitting the virtual-axis error map again on what the effects leave")
            prof_new = profile_from_dict(updated_doc, current.source)
            resid = measured - predict(prof_new, data, [], with_map=False).pred
            emap = _refit_map(data, resid, segs, rng_seed, [p.source for p in data.poses])
            updated_doc["error_map"] = emap.to_dict()
            map_note = {
                "action": "refitted",
                "reason": "the effects added explain part of what the old map held; "
                "it was fitted again on the pose residual they leave",
                "cv_rms": {c: float(v) for c, v in emap.cv_rms.items()},
            }
        elif sel_map and effects:
            map_note["reason"] = (
                "no pose data to refit it: the effects were judged on what the map leaves"
            )
    updated = profile_from_dict(updated_doc, current.source)
    after = measured - predict(updated, data, [], with_map=has_map).pred
    rms_b, rms_a = _rms_um(before, segs), _rms_um(after, segs)
    said("left", "testing what is left against the noise")
    left = _left_unexplained(updated, data, after, segs, noise, w, has_map)
    note: dict[str, Any] = {
        "data": sorted({s.source for s in segs}),
        "effects": [f"{e.name} {e.estimate:+.6g} {e.unit} ± {e.stderr:.2g}" for e in effects],
        "rms_before_um": rms_b,
        "rms_after_um": rms_a,
    }
    if map_note is not None:
        note["error_map"] = map_note["action"]
    udoc = provenance.record(updated_doc, "diagnose", note, commanded_with=commanded_with)
    summary = (
        " ".join(e.sentence() for e in effects)
        if effects
        else "The model explains the measurements to their noise: no effect is missing."
    )
    if left:
        summary += " " + " ".join(item["sentence"] for item in left)
    return Diagnosis(
        effects,
        noise,
        rms_b,
        rms_a,
        _per_run(before, after, segs),
        leftover.regions(data, before, segs, noise),
        left,
        udoc,
        summary,
        map_note,
        before,
        after,
    )


def _refit_map(
    data: Data, resid: np.ndarray, segs: list[Segment], seed: int, sources: list[str]
) -> errormap.ErrorMap:
    """The virtual-axis map fitted on the pose residual [mm, deg] a model leaves."""
    q, e = [], []
    k = 0
    for s in segs:
        if s.kind == "pose_tip":
            p = data.poses[k]
            tip = resid[s.start : s.stop].reshape(-1, 3)
        elif s.kind == "pose_axis":
            ax = resid[s.start : s.stop].reshape(-1, 2)
            q.append(p.commanded)
            e.append(np.column_stack([tip, ax]))
            k += 1
    Q = np.vstack(q)
    E = np.vstack(e)
    okr = np.all(np.isfinite(E[:, :3]), axis=1)
    E = np.where(np.isfinite(E), E, 0.0)
    return errormap.fit(
        Q[okr], E[okr], rng=np.random.default_rng(seed), provenance={"from": sources}
    )
