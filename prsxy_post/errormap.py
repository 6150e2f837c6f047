"""The virtual-axis error map E(x, y, z, A, B) of the paper's Eq. 4–5.

Structure (Eq. 5)::

    e_x = e_x'(x, y) + e_x''(z, A, B)
    e_y = e_y'(x, y) + e_y''(z, A, B)
    e_z = e_z(z)
    e_A = e_A(z, A, B)
    e_B = e_B(z, A, B)

Each function is a sum of products of Legendre polynomials of the coordinates
scaled to [−1, 1] over the fitted domain, total degree at most ``degree``.
Coordinates outside the domain are clamped to its edge: the map holds its
boundary value rather than extrapolate a polynomial.

The fit is ridge-regularised least squares on standardised columns; the degree
and the regularisation λ are chosen by K-fold cross-validation, so the map
averages measurement noise out instead of interpolating it (the paper's warning
about interpolating raw errors). The cross-validated RMS is kept as the map's
honest prediction error on points it was not fitted on.

The compensation is Q' = Q − e(Q) (Eq. 6), in :func:`chain.correct_virtual`.
"""

from __future__ import annotations

import functools
import itertools
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import kernel
from .errors import FitError, ProfileError
from .kernel.legendre import MapArrays
from .profile import Profile

COMPONENTS = ("x", "y", "z", "a", "b")
XY, ZAB = (0, 1), (2, 3, 4)
#: Variables each component depends on (indices into q = [x, y, z, A, B]).
#: "eq5" is the paper's Eq. 5 exactly. "eq5-coupled" adds what the additive form
#: misses on a real PRS-XY: the table moves by the tip position *plus* the head's
#: parasitic offset (a function of z, A, B), so table errors couple x, y with
#: z, A, B (bilinear terms), and guide errors move the tip height with the tilt
#: (e_z''(z, A, B)). Cross-validation chooses between the two per component.
STRUCTURES: dict[str, dict[str, tuple[tuple[tuple[int, ...], ...], ...]]] = {
    "eq5": {
        "x": ((XY,), (ZAB,)),
        "y": ((XY,), (ZAB,)),
        "z": (((2,),),),
        "a": ((ZAB,),),
        "b": ((ZAB,),),
    },
    "eq5-coupled": {
        "x": ((XY,), (ZAB,), (XY, ZAB)),
        "y": ((XY,), (ZAB,), (XY, ZAB)),
        "z": (((2,),), (ZAB,)),
        "a": ((ZAB,),),
        "b": ((ZAB,),),
    },
}
#: a Legendre product: the variables (0..4: x y z A B) and their degrees
Term = tuple[tuple[int, ...], tuple[int, ...]]
UNITS = {"x": "mm", "y": "mm", "z": "mm", "a": "deg", "b": "deg"}


def _exponents(nvar: int, degree: int) -> list[tuple[int, ...]]:
    """Multi-indices of total degree 1..degree (the constant is shared)."""
    out = [e for e in itertools.product(range(degree + 1), repeat=nvar) if 0 < sum(e) <= degree]
    return sorted(out, key=lambda e: (sum(e), e))


def _legendre_table(u: np.ndarray, degree: int) -> np.ndarray:
    """P_0..P_degree at u, shape (N, degree + 1)."""
    # here: numpy.polynomial costs 2 ms of start-up, and only fits need it
    from numpy.polynomial import legendre

    return legendre.legvander(u, degree)


def legendre_tables(
    q: np.ndarray, lo: np.ndarray, hi: np.ndarray, degree: int
) -> dict[int, np.ndarray]:
    """P_0..P_degree of every coordinate scaled to [−1, 1] (clamped outside)."""
    span = np.where(hi > lo, hi - lo, 1.0)
    u = np.clip(2.0 * (q - lo) / span - 1.0, -1.0, 1.0)
    return {v: _legendre_table(u[:, v], max(degree, 2)) for v in range(5)}


def _columns(comp: str, degree: int, structure: str = "eq5") -> Iterator[tuple[Term, Term | None]]:
    """Each column of a component's design after the constant: its Legendre
    product (variables, exponents), and the second one it is multiplied by for a
    coupling group (else None), in :func:`design`'s order."""
    for spec in STRUCTURES[structure][comp]:
        if len(spec) == 1:
            group = spec[0]
            for e in _exponents(len(group), degree):
                yield (group, e), None
        else:
            ga, gb = spec
            for ea in _exponents(len(ga), 1):
                for eb in _exponents(len(gb), min(degree, 2)):
                    yield (ga, ea), (gb, eb)


def design_terms(comp: str, degree: int, structure: str = "eq5") -> list[Term]:
    """(variables, exponents) of each column of :func:`design` after the first:
    what the columns are, without evaluating them."""
    return [
        a if b is None else (a[0] + b[0], a[1] + b[1]) for a, b in _columns(comp, degree, structure)
    ]


def design(
    q: np.ndarray,
    comp: str,
    degree: int,
    lo: np.ndarray,
    hi: np.ndarray,
    structure: str = "eq5",
    tables: dict[int, np.ndarray] | None = None,
) -> tuple[np.ndarray, list[Term]]:
    """Design matrix of one component: a constant, then every group's terms.

    A group of one variable set holds every Legendre product of total degree
    1..degree; a group of two sets (coupling) holds the products of a degree-1
    term of the first set with the terms of degree 1..2 of the second.

    Returns
    -------
    X : (N, m) ndarray
    terms : list of (variables, exponents) describing each column after the first
        (:func:`design_terms`)
    """
    if tables is None:
        tables = legendre_tables(q, lo, hi, degree)
    cols = [np.ones(len(q))]

    def product(group: tuple[int, ...], e: tuple[int, ...]) -> np.ndarray:
        col = np.ones(len(q))
        for v, k in zip(group, e, strict=True):
            if k:
                col = col * tables[v][:, k]
        return col

    for a, b in _columns(comp, degree, structure):
        cols.append(product(*a) if b is None else product(*a) * product(*b))
    return np.column_stack(cols), design_terms(comp, degree, structure)


@dataclass(frozen=True)
class ErrorMap:
    """A fitted map: per component, degree and coefficients over a domain.

    lo, hi : (5,) domain of q [mm, mm, mm, deg, deg]
    degree : dict component → total degree
    coef : dict component → (m,) coefficients [mm or deg]
    cv_rms : dict component → cross-validated RMS prediction error
    fit_rms : dict component → RMS residual on the fitted points
    provenance : free-form notes (data files, date, counts)
    """

    lo: np.ndarray
    hi: np.ndarray
    degree: dict[str, int]
    structure: dict[str, str]
    coef: dict[str, np.ndarray]
    cv_rms: dict[str, float]
    fit_rms: dict[str, float]
    lam: dict[str, float]
    provenance: dict[str, Any]

    def __call__(self, q: np.ndarray) -> np.ndarray:
        """e(q), shape (N, 5) [mm, mm, mm, deg, deg]: Σ_u M_u(q) C_u over the
        distinct Legendre products M_u the components use (each made once), in
        the kernel (:func:`prsxy_post.kernel.legendre.map_rows`)."""
        q = np.atleast_2d(np.asarray(q, dtype=float))
        return kernel.map_rows(self.arrays, q)

    @functools.cached_property
    def arrays(self) -> MapArrays:
        """The map flattened for the kernel: domain, distinct products and their
        coefficients per component."""
        exps, C = self._plan
        return MapArrays(
            lo=np.asarray(self.lo, dtype=float),
            span=np.where(self.hi > self.lo, self.hi - self.lo, 1.0),
            degree=max(max(self.degree.values(), default=2), 2),
            exps=np.array(exps, dtype=np.int64).reshape(-1, 5),
            coef=C,
        )

    @functools.cached_property
    def _plan(self) -> tuple[list[tuple[int, ...]], np.ndarray]:
        """The distinct products (exponents of x, y, z, A, B; the constant first)
        and their coefficients per component, (U, 5)."""
        index: dict[tuple[int, ...], int] = {(0, 0, 0, 0, 0): 0}
        entries: list[tuple[int, int, float]] = []
        for i, c in enumerate(COMPONENTS):
            if c not in self.coef:
                continue
            terms = design_terms(c, self.degree[c], self.structure[c])
            coef = self.coef[c]
            entries.append((0, i, float(coef[0])))
            for j, (group, e) in enumerate(terms, 1):
                e5 = [0] * 5
                for v, k in zip(group, e, strict=True):
                    e5[v] += k
                u = index.setdefault(tuple(e5), len(index))
                entries.append((u, i, float(coef[j])))
        C = np.zeros((len(index), 5))
        for u, i, cf in entries:
            C[u, i] += cf
        return list(index), C

    def to_dict(self) -> dict[str, Any]:
        """The profile's ``[error_map]`` section."""
        return {
            "model": "legendre-eq5",
            "lo": [float(x) for x in self.lo],
            "hi": [float(x) for x in self.hi],
            "components": {
                c: {
                    "structure": self.structure[c],
                    "degree": int(self.degree[c]),
                    "lambda": float(self.lam[c]),
                    "coef": [float(x) for x in self.coef[c]],
                    "cv_rms": float(self.cv_rms[c]),
                    "fit_rms": float(self.fit_rms[c]),
                    "unit": UNITS[c],
                }
                for c in self.coef
            },
            "provenance": dict(self.provenance),
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any], source: str = "<profile>") -> ErrorMap:
        def bad(key: str, msg: str, exp: str) -> ProfileError:
            return ProfileError(msg, source=source, key=f"error_map.{key}", expected=exp)

        if d.get("model") != "legendre-eq5":
            raise bad("model", f"is {d.get('model')!r}", "'legendre-eq5'")
        lo = np.asarray(d.get("lo", []), dtype=float)
        hi = np.asarray(d.get("hi", []), dtype=float)
        if lo.shape != (5,) or hi.shape != (5,) or not np.all(hi >= lo):
            raise bad("lo", "domain is not two arrays of 5 with hi >= lo", "lo, hi of x,y,z,a,b")
        comps = d.get("components", {})
        if not isinstance(comps, dict):
            raise bad("components", "is not a table", "a table per component x y z a b")
        degree, coef, cv, fit, lam, struct = {}, {}, {}, {}, {}, {}
        for c, v in comps.items():
            if c not in COMPONENTS or not isinstance(v, dict):
                raise bad(f"components.{c}", "unknown component", "x, y, z, a or b")
            deg = v.get("degree")
            if not isinstance(deg, int) or not 0 <= deg <= 8:
                raise bad(f"components.{c}.degree", f"is {deg!r}", "an integer 0..8")
            st = v.get("structure", "eq5")
            if st not in STRUCTURES:
                raise bad(
                    f"components.{c}.structure",
                    f"is {st!r}",
                    " or ".join(repr(k) for k in STRUCTURES),
                )
            co = np.asarray(v.get("coef", []), dtype=float)
            n = 1 + len(design_terms(c, deg, st))
            if co.shape != (n,) or not np.all(np.isfinite(co)):
                raise bad(
                    f"components.{c}.coef",
                    f"has {co.size} values",
                    f"{n} finite coefficients for degree {deg}",
                )
            degree[c], coef[c], struct[c] = deg, co, st
            cv[c] = float(v.get("cv_rms", np.nan))
            fit[c] = float(v.get("fit_rms", np.nan))
            lam[c] = float(v.get("lambda", 0.0))
        return cls(lo, hi, degree, struct, coef, cv, fit, lam, dict(d.get("provenance", {})))


def from_profile(profile: Profile) -> ErrorMap | None:
    """The profile's error map, or None when it has none."""
    d = profile.raw.get("error_map")
    if not d:
        return None
    return ErrorMap.from_dict(d, profile.source)


def _ridge(X: np.ndarray, y: np.ndarray, lam: float) -> np.ndarray:
    """Ridge solution on standardised columns (the constant is not penalised)."""
    scale = np.sqrt(np.mean(X**2, axis=0))
    scale[scale == 0] = 1.0
    Xs = X / scale
    m = X.shape[1]
    pen = np.sqrt(lam) * np.eye(m)
    pen[0, 0] = 0.0
    A = np.vstack([Xs, pen])
    b = np.concatenate([y, np.zeros(m)])
    from scipy import linalg  # here: converting evaluates maps, only fitting needs scipy

    sol, *_ = linalg.lstsq(A, b, lapack_driver="gelsy")
    return sol / scale


def fit(
    q: np.ndarray,
    err: np.ndarray,
    *,
    rng: np.random.Generator,
    degrees: Sequence[int] = (1, 2, 3, 4),
    lambdas: Sequence[float] | None = None,
    structures: Sequence[str] = ("eq5", "eq5-coupled"),
    folds: int = 5,
    provenance: dict[str, Any] | None = None,
) -> ErrorMap:
    """Fit the Eq. 5 map to errors measured at commanded poses.

    Parameters
    ----------
    q : (N, 5) commanded poses [mm, mm, mm, deg, deg]
    err : (N, 5) measured − commanded (NaN where a component was not measured)
    rng : random generator for the fold split
    degrees, lambdas, structures : the cross-validation grid
    folds : K of K-fold cross-validation

    Returns
    -------
    ErrorMap with the (structure, degree, λ) of least cross-validated RMS per
    component; a richer structure must lower the CV error by 2 % to be chosen.
    """
    q = np.asarray(q, dtype=float)
    err = np.asarray(err, dtype=float)
    if q.ndim != 2 or q.shape[1] != 5 or err.shape != q.shape:
        raise FitError("error map data must be (N, 5) poses and errors", expected="matching arrays")
    lam_grid = list(lambdas) if lambdas is not None else list(np.logspace(-8, 2, 11))
    lo, hi = q.min(axis=0), q.max(axis=0)
    degree, coef, cv_rms, fit_rms, lam_best, struct = {}, {}, {}, {}, {}, {}
    for i, c in enumerate(COMPONENTS):
        ok = np.isfinite(err[:, i])
        n = int(ok.sum())
        if n < 2 * folds:
            continue
        qi, yi = q[ok], err[ok, i]
        fold = rng.permutation(n) % folds
        best: tuple[float, int, float, str] = (np.inf, 0, 0.0, "eq5")
        for si, st in enumerate(structures):
            # prefer the simpler structure unless the richer one predicts better
            margin = 1.0 if si == 0 else 0.98
            for deg in degrees:
                X, _ = design(qi, c, deg, lo, hi, st)
                if X.shape[1] >= n * (folds - 1) / folds:
                    continue  # more terms than the training folds can determine
                for lam in lam_grid:
                    sse = 0.0
                    for f in range(folds):
                        tr, te = fold != f, fold == f
                        w = _ridge(X[tr], yi[tr], lam)
                        sse += float(np.sum((X[te] @ w - yi[te]) ** 2))
                    rms = np.sqrt(sse / n)
                    if rms < best[0] * margin * (1 - 1e-9):
                        best = (rms, deg, lam, st)
        if not np.isfinite(best[0]):
            continue
        _, deg, lam, st = best
        X, _ = design(qi, c, deg, lo, hi, st)
        w = _ridge(X, yi, lam)
        degree[c], coef[c], lam_best[c], struct[c] = deg, w, lam, st
        cv_rms[c] = float(best[0])
        fit_rms[c] = float(np.sqrt(np.mean((X @ w - yi) ** 2)))
    if not coef:
        raise FitError(
            f"too few points for an error map ({len(q)})",
            expected=f"at least {2 * folds} measured poses",
        )
    return ErrorMap(lo, hi, degree, struct, coef, cv_rms, fit_rms, lam_best, dict(provenance or {}))
