"""Which library members the data need: selection on the linearised model.

Inputs are whitened (divided by the noise of their kind): the residual r (n,)
and each candidate's signature block A_k (n, d_k), with the always-free columns
(calibration's contract parameters) projected out. Everything after works on
the Gram matrix of the unit-normalised columns, G = AᵀA, b = Aᵀr:

    SSE(S) = rᵀr − b_Sᵀ G_S⁻¹ b_S

1. **Undetermined combinations.** With each column scaled to its member's prior
   (z = size / prior), a combination v of members is determined by the data to
   ± σ/√λ of its prior, λ its eigenvalue of the prior-scaled Gram matrix (as
   calibration's identifiability). Combinations determined worse than
   ``max_rel_stderr`` of their prior (λ < σ² / max_rel_stderr²) are not told
   apart by the data: exact ones (the tool length and the three ball-joint
   heights; the platform frame's definition) and nearly exact ones (a servo lag
   common to every motor, which moves a circle only as far as the path departs
   from one). Along them the sparsest explanation is taken, and the data's
   estimate there, which is mostly the linearisation's error, is not used.
2. **Backward elimination from the full model.** With every candidate in,
   β = G_S⁻¹ b_S and C = G_S⁻¹; the member with the largest p-value of its partial
   F-test F_k = β_kᵀ (C_kk)⁻¹ β_k / (d_k σ²) leaves while it fails the test:
   Bonferroni-corrected for the m candidates (p_k · m > α) or below the BIC
   penalty (F_k d_k < d_k ln n), or moves no data kind by :data:`NEGLIGIBLE` of
   its noise (thousands of samples make a 0.05 µm term significant; it is not
   worth naming). Starting from the full model, every effect that is present is
   in the model while the others are judged, so two effects that together
   resemble a third do not pull the selection towards the third. A member whose
   estimate lies where its model does not go (a motor's play below zero: the
   model folds back there, :func:`prsxy_post.effects.lower_bound`) explains
   nothing and leaves first (the active-set step of bounded least squares).
3. **Forward check.** A member outside whose addition passes the same test (at a
   size its model goes to) is added and the elimination rerun (stepwise in both
   directions).
4. **Sparsest explanation.** A member outside that, added, lets the elimination
   end with fewer members (or the same number and a better fit) without a
   significantly worse fit replaces them (three ball-joint heights that are one
   tool length).

σ² is the noise scale of the full model's residual: 1 when the whitening is right.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

#: An effect moving no data kind by this fraction of its noise (RMS) is not named.
NEGLIGIBLE = 0.1
#: A combination of members the data determine worse than this fraction of its
#: prior is undetermined (module docstring, step 1); calibration's identifiability
#: threshold (``max_rel_stderr``).
UNDETERMINED = 0.25


@dataclass
class Normal:
    """Cross-products ZᵀZ of Z = [columns, residual] per data kind, unwhitened.

    Whitening divides a kind's rows by its noise σ, so the whitened normal
    equations for any noise estimate are Σ_kind M_kind / σ_kind²: the expensive
    products are made once per linearisation.
    """

    keys: list[str]
    dims: list[int]
    M: dict[str, np.ndarray]  # kind -> (p + 1, p + 1), residual last
    n: dict[str, int]

    @classmethod
    def of(
        cls, columns: Mapping[str, np.ndarray], r: np.ndarray, rows: Mapping[str, np.ndarray]
    ) -> Normal:
        """columns : key -> (n, d); r : (n,) residual; rows : kind -> (n,) bool."""
        keys = list(columns)
        dims = [columns[k].shape[1] for k in keys]
        M, n = {}, {}
        for kind, sel in rows.items():
            sel = sel & np.isfinite(r)
            Z = np.hstack([*(columns[k][sel] for k in keys), r[sel][:, None]])
            M[kind] = Z.T @ Z
            n[kind] = int(sel.sum())
        return cls(keys, dims, M, n)

    def whitened(self, noise: Mapping[str, float]) -> np.ndarray:
        return sum(m / max(noise[k], 1e-300) ** 2 for k, m in self.M.items())  # type: ignore[return-value]

    def columns(self, keys: Sequence[str]) -> np.ndarray:
        start = np.concatenate([[0], np.cumsum(self.dims)]).astype(int)
        pos = {k: i for i, k in enumerate(self.keys)}
        parts = [np.arange(start[pos[k]], start[pos[k] + 1]) for k in keys]
        return np.concatenate(parts) if parts else np.zeros(0, dtype=int)

    def full_fit(
        self, noise: Mapping[str, float]
    ) -> tuple[dict[str, float], dict[str, float], int]:
        """Every column fitted together: the whitened SSE of each kind, the degrees
        of freedom the fit took from each kind's rows (its share of the hat matrix's
        trace, tr(G⁺ G_kind)), and the rank."""
        Mw = self.whitened(noise)
        p = Mw.shape[0] - 1
        Gp, rank = _pinv(Mw[:p, :p])
        coef = Gp @ Mw[:p, p]
        sse, used = {}, {}
        for kind, m in self.M.items():
            s2 = max(noise[kind], 1e-300) ** 2
            s = m[p, p] - 2 * coef @ m[:p, p] + coef @ m[:p, :p] @ coef
            sse[kind] = float(max(s, 0.0)) / s2
            used[kind] = float(np.sum(Gp * m[:p, :p])) / s2  # tr(G⁺ G_kind), both symmetric
        return sse, used, rank


def _pinv(G: np.ndarray) -> tuple[np.ndarray, int]:
    """Pseudo-inverse of a symmetric, possibly singular G (its columns scaled to
    unit diagonal first, eigenvalues below 1e-10 of the largest dropped) and its
    numerical rank."""
    d = np.sqrt(np.maximum(np.diag(G), 1e-300))
    w, V = np.linalg.eigh(G / np.outer(d, d))
    keep = w > 1e-10 * max(float(w[-1]), 1e-300) if w.size else np.zeros(0, dtype=bool)
    P = (V[:, keep] / w[keep]) @ V[:, keep].T
    return P / np.outer(d, d), int(keep.sum())


@dataclass
class Gram:
    """The normal equations of the whitened candidates (module docstring).

    keys : candidate column keys; dims : columns of each; G : (p, p) Gram matrix
    of the unit-normalised columns; b : (p,) their products with r; norm : (p,)
    the columns' norms before normalising; rr : rᵀr; n : rows; n_free : rank of
    the free columns projected out.
    """

    keys: list[str]
    dims: list[int]
    start: np.ndarray
    G: np.ndarray
    b: np.ndarray
    norm: np.ndarray
    rr: float
    n: int
    n_free: int
    prior: np.ndarray  # (p,) typical size of each column's member
    #: (p,) RMS of each whitened column over the rows of the data kind it moves
    #: most: a size β moves that kind by |β| · reach noise standard deviations
    reach: np.ndarray
    #: (k,) the least size of each member (its own units) the model goes on to
    #: (``effects.lower_bound``: a motor's play cannot go below zero); -inf if none
    lower: np.ndarray
    #: combinations determined worse than this fraction of their prior are
    #: undetermined (:data:`UNDETERMINED`)
    max_rel_stderr: float = UNDETERMINED

    @classmethod
    def build(
        cls,
        normal: Normal,
        noise: Mapping[str, float],
        candidates: Sequence[str],
        free: Sequence[str] = (),
        *,
        priors: Mapping[str, float] | None = None,
        invisible: float = 1e-9,
        max_rel_stderr: float = UNDETERMINED,
        lower: Mapping[str, float] | None = None,
        known: Mapping[str, float] | None = None,
    ) -> Gram:
        """Whitened normal equations of ``candidates`` with the ``free`` columns
        projected out (Schur complement). A candidate whose whitened columns are all
        shorter than ``invisible`` (a unit size moves the data by a billionth of
        their noise), or lie in the span of the free columns, is left out: the data
        do not see it. ``lower``: the least size of single-column members (none
        where not given).

        ``known``: free single-column members known beforehand to ± the given
        standard deviation (their own units; a table value the laser measured):
        a prior N(0, s²) on each, i.e. the pseudo-observation 0 = c / s added to the
        normal equations (1/s² on its diagonal). The Schur complement is then
        Henderson's mixed-model equations: a candidate's estimate and covariance are
        the generalised least squares ones under the noise plus what those errors
        can do, so nothing they could explain is credited to a candidate."""
        Mw = normal.whitened(noise)
        p = Mw.shape[0] - 1
        cand = [k for k in candidates if k in set(normal.keys)]
        ia = normal.columns(cand)
        known_at = {
            int(normal.columns([key])[0]): sd for key, sd in (known or {}).items() if key in free
        }
        G, b, rr, n_free, G_before = _schur(Mw, ia, normal.columns(list(free)), known_at)
        diag = np.maximum(np.diag(G), 0.0)
        start_all = np.concatenate(
            [[0], np.cumsum([normal.dims[normal.keys.index(k)] for k in cand])]
        )
        keys, dims, cols = [], [], []
        for i, k in enumerate(cand):
            c = np.arange(start_all[i], start_all[i + 1])
            if np.max(np.sqrt(G_before[c])) < invisible:
                continue
            if np.max(diag[c] / np.maximum(G_before[c], 1e-300)) < 1e-12:
                continue  # inside the span of the free columns
            keys.append(k)
            dims.append(len(c))
            cols.append(c)
        sel = np.concatenate(cols) if cols else np.zeros(0, dtype=int)
        G = G[np.ix_(sel, sel)]
        b = b[sel]
        norm = np.sqrt(np.maximum(np.diag(G), 1e-300))
        start = np.concatenate([[0], np.cumsum(dims)]).astype(int)
        n = sum(normal.n.values())
        prior = (
            np.concatenate(
                [np.full(d, (priors or {}).get(k, 1.0)) for k, d in zip(keys, dims, strict=True)]
            )
            if keys
            else np.zeros(0)
        )
        reach_all = np.max(
            [
                np.sqrt(np.diag(m[:p, :p])[ia] / max(noise[k], 1e-300) ** 2 / max(normal.n[k], 1))
                for k, m in normal.M.items()
            ],
            axis=0,
        )
        return cls(
            keys,
            dims,
            start,
            G / np.outer(norm, norm),
            b / norm,
            norm,
            rr,
            n,
            n_free,
            prior,
            reach_all[sel],
            np.array([(lower or {}).get(k, -np.inf) for k in keys], dtype=float),
            max_rel_stderr,
        )

    def effect(self, S: Sequence[int], beta: np.ndarray) -> np.ndarray:
        """How far each block of S at sizes β (normalised) moves the data kind it
        moves most, in noise standard deviations (RMS over that kind's rows)."""
        c = self.columns(S)
        moved = beta / self.norm[c] * self.reach[c]
        out = np.empty(len(S))
        pos = 0
        for i, k in enumerate(S):
            out[i] = float(np.sqrt(np.sum(moved[pos : pos + self.dims[k]] ** 2)))
            pos += self.dims[k]
        return out

    def feasible(self, S: Sequence[int], beta: np.ndarray) -> np.ndarray:
        """(len(S),) bool: each block of S at sizes β (normalised) at or above its
        member's least size."""
        out = np.ones(len(S), dtype=bool)
        pos = 0
        for i, k in enumerate(S):
            if self.dims[k] == 1 and np.isfinite(self.lower[k]):
                out[i] = beta[pos] / self.norm[self.start[k]] >= self.lower[k]
            pos += self.dims[k]
        return out

    def columns(self, S: Sequence[int]) -> np.ndarray:
        if not S:
            return np.zeros(0, dtype=int)
        return np.concatenate([np.arange(self.start[k], self.start[k + 1]) for k in S])

    def fit(self, S: Sequence[int]) -> tuple[np.ndarray, np.ndarray, float]:
        """β (normalised), C = G_S⁻¹ and SSE of the model with blocks S."""
        c = self.columns(S)
        if not c.size:
            return np.zeros(0), np.zeros((0, 0)), self.rr
        Gs = self.G[np.ix_(c, c)]
        C = np.linalg.inv(Gs)
        beta = C @ self.b[c]
        return beta, C, max(self.rr - float(self.b[c] @ beta), 0.0)

    def dof(self, S: Sequence[int]) -> int:
        return max(self.n - self.n_free - sum(self.dims[k] for k in S), 1)

    def unscaled(self, S: Sequence[int], beta: np.ndarray, C: np.ndarray) -> tuple:
        """β and C in the members' own units (per unit of whitened column)."""
        nrm = self.norm[self.columns(S)]
        return beta / nrm, C / np.outer(nrm, nrm)


@dataclass(frozen=True)
class Test:
    """The significance test of members (module docstring), and what is worth
    naming: a member that moves no data kind by :data:`NEGLIGIBLE` of its noise
    (RMS) is not named however significant thousands of samples make it (a
    0.05 µm cyclic term that only a table's interpolation error resembles)."""

    alpha: float
    m: int  # candidates the best was chosen from (Bonferroni)
    sigma2: float
    n: int

    def passes(
        self, delta_sse: np.ndarray, d: np.ndarray, dof: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """(significant, p-value) of blocks of d columns that explain delta_sse."""
        delta_sse = np.asarray(delta_sse, dtype=float)
        d = np.asarray(d, dtype=float)
        chi = delta_sse / max(self.sigma2, 1e-300)
        p = stats.f.sf(chi / d, d, dof)
        ok = (p * self.m <= self.alpha) & (chi >= d * math.log(self.n))
        return ok, p


def _block_dsse(beta: np.ndarray, C: np.ndarray, dims: Sequence[int]) -> np.ndarray:
    """SSE increase when each block leaves: β_kᵀ (C_kk)⁻¹ β_k."""
    out = np.empty(len(dims))
    pos = 0
    for i, d in enumerate(dims):
        bk = beta[pos : pos + d]
        if d == 1:
            out[i] = bk[0] ** 2 / max(C[pos, pos], 1e-300)
        else:
            out[i] = float(bk @ np.linalg.solve(C[pos : pos + d, pos : pos + d], bk))
        pos += d
    return out


def weak_directions(
    g: Gram, c: np.ndarray, sigma2: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Combinations of the columns c that the data do not determine (module
    docstring, step 1), in prior units z = β / (norm · prior).

    Returns sc (the columns' norm · prior: β_normalised = sc · z), the eigenvalues
    w and eigenvectors V of the prior-scaled Gram matrix diag(sc) G diag(sc), and
    the mask of those below σ² / max_rel_stderr² (standard error above
    max_rel_stderr of the prior)."""
    sc = g.norm[c] * g.prior[c]
    w, V = np.linalg.eigh(g.G[np.ix_(c, c)] * np.outer(sc, sc))
    return sc, w, V, w < sigma2 / g.max_rel_stderr**2


def _drop_dependent(g: Gram, S: list[int], sigma2: float = 1.0) -> list[int]:
    """The members of S less those the data cannot tell from combinations of others.

    Combinations of members that the data do not determine (:func:`weak_directions`:
    the platform frame's definition, a common servo lag, a strut's length against
    its guide's height) are resolved towards the sparsest explanation
    (:func:`_sparsest`): along those directions the sizes are chosen so that the
    fewest members keep a size worth naming, and the members set to zero leave.
    """
    S = list(S)
    for _ in range(len(S)):
        if not S:
            return S
        c = g.columns(S)
        sc, w, V, null = weak_directions(g, c, sigma2)
        if not null.any():
            return S
        N = V[:, null]
        keep = ~null
        # the estimate with the undetermined part set to zero, in prior units
        z0 = V[:, keep] @ ((V[:, keep].T @ (g.b[c] * sc)) / w[keep])
        zero = _sparsest(z0, N, np.ones(len(c)))
        owner = np.repeat(np.arange(len(S)), [g.dims[k] for k in S])
        gone = {int(owner[j]) for j in zero}
        S = [k for i, k in enumerate(S) if i not in gone]
    return S


#: Among equivalent explanations, a size below this fraction of a member's prior
#: does not count as a member named.
NEGLIGIBLE_SIZE = 0.05


def _sparsest(beta0: np.ndarray, N: np.ndarray, u: np.ndarray) -> list[int]:
    """Columns to set to zero along the undetermined directions N (p, k).

    β = β0 + N c; choosing k columns Z to be zero fixes c. Of every such choice
    (the columns involved taken k at a time, up to 20 000 choices) the one with
    the fewest sizes above :data:`NEGLIGIBLE_SIZE` of their prior wins, ties going to
    the least Σ |β_j| u_j. Beyond that many choices: the weighted-L1 minimum
    (a linear program), its k smallest columns."""
    from itertools import combinations
    from math import comb

    k = N.shape[1]
    J = np.nonzero(np.linalg.norm(N, axis=1) > 1e-6)[0]
    if len(J) <= k:
        return [int(j) for j in J[:k]]
    if comb(len(J), k) <= 20_000:
        Z = np.array(list(combinations(J.tolist(), k)))  # (C, k)
        A = N[Z]  # (C, k, k)
        good = np.abs(np.linalg.det(A)) > 1e-6 * np.prod(np.linalg.norm(A, axis=2), axis=1)
        Z, A = Z[good], A[good]
        if len(Z):
            cvec = np.linalg.solve(A, -beta0[Z][..., None])[..., 0]  # (C, k)
            bJ = beta0[J][None, :] + cvec @ N[J].T  # (C, |J|)
            size = np.abs(bJ) * u[J][None, :]
            count = np.sum(size > NEGLIGIBLE_SIZE, axis=1)
            l1 = np.sum(size, axis=1)
            best = int(np.lexsort((l1, count))[0])
            return [int(j) for j in Z[best]]
    beta = _min_weighted_l1(beta0, N, u)
    order = J[np.argsort(np.abs(beta[J]) * u[J])]
    return [int(j) for j in order[:k]]


def _min_weighted_l1(beta0: np.ndarray, N: np.ndarray, u: np.ndarray) -> np.ndarray:
    """β = β0 + N c minimising Σ u_j |β_j| (a linear program in c and t ≥ |β|)."""
    from scipy.optimize import linprog

    _, k = N.shape
    rows = np.nonzero(np.linalg.norm(N, axis=1) > 1e-9)[0]
    if not rows.size:
        return beta0
    m = len(rows)
    cost = np.concatenate([np.zeros(k), u[rows]])
    A = np.block([[N[rows], -np.eye(m)], [-N[rows], -np.eye(m)]])
    rhs = np.concatenate([-beta0[rows], beta0[rows]])
    bounds = [(None, None)] * k + [(0, None)] * m
    res = linprog(cost, A_ub=A, b_ub=rhs, bounds=bounds, method="highs")
    if not res.success:
        return beta0
    return beta0 + N @ res.x[:k]


def backward(g: Gram, S: Sequence[int], test: Test) -> list[int]:
    """Backward elimination from ``S`` (module docstring, steps 1-2).

    The inverse C = G_S⁻¹ is downdated as members leave (C ← C_rr − C_rk C_kk⁻¹ C_kr),
    and recomputed every 16 removals against drift."""
    S = _drop_dependent(g, list(S), test.sigma2)
    removed = 0
    C = beta = np.zeros(0)
    while S:
        if removed % 16 == 0:
            beta, C, _ = g.fit(S)
        dims = [g.dims[k] for k in S]
        dsse = _block_dsse(beta, C, dims)
        ok, p = test.passes(dsse, np.array(dims), g.dof(S))
        ok &= g.effect(S, beta) >= NEGLIGIBLE
        # a size the model does not go to (negative play) explains nothing: such
        # members leave first, as if their p-value were 1
        feasible = g.feasible(S, beta)
        ok &= feasible
        p = np.where(feasible, p, 1.0)
        if np.all(ok):
            break
        bad = np.nonzero(~ok)[0]
        i = int(bad[np.lexsort((dsse[bad], -p[bad]))[0]])  # largest p, then least dsse
        a = sum(dims[:i])
        b = a + dims[i]
        rest = np.r_[0:a, b : len(beta)]
        X = np.linalg.solve(C[a:b, a:b], C[a:b, rest])
        beta = beta[rest] - C[rest, a:b] @ np.linalg.solve(C[a:b, a:b], beta[a:b])
        C = C[np.ix_(rest, rest)] - C[rest, a:b] @ X
        S.pop(i)
        removed += 1
    return S


def forward_candidate(g: Gram, S: Sequence[int], test: Test) -> int | None:
    """The member outside S whose addition explains most, if it passes the test.

    For every block K outside at once, by the Schur complement:
    ΔSSE_K = q_Kᵀ (G_KK − G_KS C G_SK)⁻¹ q_K, q_K = b_K − G_KS β."""
    c = g.columns(S)
    beta, C, _ = g.fit(S)
    if c.size:
        M = C @ g.G[c, :]  # (p_S, p)
        q = g.b - g.G[:, c] @ beta
    else:
        M = np.zeros((0, len(g.b)))
        q = g.b.copy()
    inside = set(S)
    best, best_d = None, 0.0
    for k in range(len(g.keys)):
        if k in inside:
            continue
        a, b = g.start[k], g.start[k + 1]
        sch = g.G[a:b, a:b] - (g.G[a:b, c] @ M[:, a:b] if c.size else 0.0)
        try:
            step = np.linalg.solve(sch, q[a:b])
        except np.linalg.LinAlgError:
            continue
        d = float(q[a:b] @ step)
        if not g.feasible([k], step)[0]:
            continue
        if d > best_d and g.effect([k], step)[0] >= NEGLIGIBLE:
            best, best_d = k, d
    if best is None:
        return None
    ok, _ = test.passes(np.array([best_d]), np.array([g.dims[best]]), g.dof([*S, best]))
    return best if bool(ok[0]) else None


def select(g: Gram, test: Test, start: Sequence[int] | None = None) -> list[int]:
    """Members the data need (module docstring, steps 1-4), as indices into g.keys."""
    S = backward(g, list(range(len(g.keys))) if start is None else list(start), test)
    seen = {frozenset(S)}
    for _ in range(4 * len(g.keys) + 10):
        k = forward_candidate(g, S, test)
        T = backward(g, [*S, k], test) if k is not None else _sparser(g, S, test)
        if T is None or frozenset(T) in seen:
            break  # nothing better, or back where it was (no cycles)
        S = T
        seen.add(frozenset(S))
    return S


def _sparser(g: Gram, S: list[int], test: Test) -> list[int] | None:
    """A selection with fewer members (or as many and a better fit) that one
    outside member makes possible without a significantly worse fit."""
    _, _, sse = g.fit(S)
    d_S = sum(g.dims[k] for k in S)
    best: tuple[int, float, list[int]] | None = None
    for k in range(len(g.keys)):
        if k in S:
            continue
        try:
            T = backward(g, [*S, k], test)
        except np.linalg.LinAlgError:
            continue
        if k not in T:
            continue
        _, _, s = g.fit(T)
        d_T = sum(g.dims[j] for j in T)
        if len(T) < len(S):
            # fewer members, and the fit not significantly worse
            extra = max(d_S - d_T, 1)
            limit = test.sigma2 * float(stats.chi2.isf(test.alpha, extra))
            if s - sse > limit:
                continue
        elif len(T) == len(S):
            if s >= sse - 1e-9 * max(sse, 1.0):
                continue
        else:
            continue
        key = (len(T), s)
        if best is None or key < (len(best[2]), best[1]):
            best = (k, s, T)
    return best[2] if best is not None else None


def aliases(g: Gram, S: Sequence[int], i: int, corr: float) -> list[int]:
    """Members outside S that, given the rest of S, the data cannot tell apart from
    S[i]: |partial correlation| of their signatures above ``corr`` (single
    columns only)."""
    k = S[i]
    if g.dims[k] != 1:
        return []
    R = [j for j in S if j != k]
    cR = g.columns(R)
    ck = g.columns([k])[0]
    out = np.array([j for j in range(len(g.keys)) if j not in S and g.dims[j] == 1], dtype=int)
    if not out.size:
        return []
    cj = g.start[out]
    if cR.size:
        GRR = g.G[np.ix_(cR, cR)]
        X = np.linalg.solve(GRR, g.G[np.ix_(cR, np.append(cj, ck))])
        red = (
            g.G[np.ix_(np.append(cj, ck), np.append(cj, ck))]
            - g.G[np.ix_(np.append(cj, ck), cR)] @ X
        )
    else:
        idx = np.append(cj, ck)
        red = g.G[np.ix_(idx, idx)]
    var = np.maximum(np.diag(red), 1e-300)
    c = red[-1, :-1] / np.sqrt(var[-1] * var[:-1])
    return [int(j) for j, cc in zip(out, c, strict=True) if abs(cc) > corr]


def undetermined(g: Gram, sigma2: float = 1.0) -> dict[int, set[int]]:
    """For each candidate taking part in a combination the data do not determine
    (:func:`weak_directions` over every candidate: the space N they span), the
    candidates it is tied to there.

    With P = N Nᵀ the projector onto that space (in prior units), candidates i and
    j are tied when both lie in it by more than 1 % (P_ii, P_jj > 0.01) and |P_ij|
    exceeds a tenth of √(P_ii P_jj). P does not depend on how the space's basis
    happens to be chosen, so nearly degenerate combinations of different legs stay
    apart."""
    if not g.keys:
        return {}
    _, _, V, null = weak_directions(g, np.arange(len(g.b)), sigma2)
    N = V[:, null]
    if not N.shape[1]:
        return {}
    P = N @ N.T
    owner = np.repeat(np.arange(len(g.keys)), g.dims)
    k = len(g.keys)
    Pb = np.zeros((k, k))
    np.maximum.at(Pb, (owner[:, None], owner[None, :]), np.abs(P))
    d = np.diag(Pb)
    inside = d > 0.01
    out: dict[int, set[int]] = {}
    for i in np.nonzero(inside)[0]:
        tied = {
            int(j)
            for j in np.nonzero(inside & (Pb[i] > 0.1 * np.sqrt(d[i] * np.maximum(d, 1e-300))))[0]
            if j != i
        }
        if tied:
            out[int(i)] = tied
    return out


def _schur(
    Mw: np.ndarray, ia: np.ndarray, iF: np.ndarray, known_at: Mapping[int, float]
) -> tuple[np.ndarray, np.ndarray, float, int, np.ndarray]:
    """The whitened normal equations ``Mw`` (last row and column the residual) of
    the columns ``ia`` with the columns ``iF`` projected out: (G, b, r·r, how many
    free directions the data identify, G's diagonal before). ``known_at``: free
    column -> the standard deviation of its prior (1/s² added on its diagonal)."""
    p = Mw.shape[0] - 1
    G = Mw[np.ix_(ia, ia)]
    b = Mw[ia, p]
    rr = float(Mw[p, p])
    G_before = np.diag(G).copy()
    if not iF.size:
        return G, b, rr, 0, G_before
    GFF = Mw[np.ix_(iF, iF)].copy()
    for j, sd in known_at.items():
        pos = int(np.nonzero(iF == j)[0][0])
        GFF[pos, pos] += 1.0 / max(sd, 1e-300) ** 2
    GFA = Mw[np.ix_(iF, ia)]
    bF = Mw[iF, p]
    d = np.sqrt(np.maximum(np.diag(GFF), 1e-300))
    w, V = np.linalg.eigh(GFF / np.outer(d, d))
    keep = w > 1e-10 * max(float(w[-1]), 1e-300)
    # pseudo-inverse of GFF on its identified subspace
    P = (V[:, keep] / w[keep]) @ V[:, keep].T / np.outer(d, d)
    G = G - GFA.T @ P @ GFA
    b = b - GFA.T @ P @ bF
    rr = rr - float(bF @ P @ bF)
    return G, b, rr, int(keep.sum()), G_before
