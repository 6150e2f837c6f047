"""Selection on the linearised model, held against linear problems with a known truth."""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post.diagnose import selection


def _problem(
    rng: np.random.Generator, n: int, p: int, truth: dict[int, float], *, corr: float = 0.6
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Columns sharing a common part (pairwise correlation ``corr``), unit noise."""
    common = rng.normal(size=(n, 1))
    X = np.sqrt(corr) * common + np.sqrt(1 - corr) * rng.normal(size=(n, p))
    beta = np.zeros(p)
    for j, b in truth.items():
        beta[j] = b
    r = X @ beta + rng.normal(size=n)
    return {f"m{j}": X[:, j : j + 1] for j in range(p)}, r


def _select(cols: dict[str, np.ndarray], r: np.ndarray, alpha: float = 1e-3) -> list[str]:
    rows = {"k": np.ones(len(r), dtype=bool)}
    normal = selection.Normal.of(cols, r, rows)
    g = selection.Gram.build(normal, {"k": 1.0}, list(cols))
    sse, used, _ = normal.full_fit({"k": 1.0})
    test = selection.Test(alpha, len(g.keys), sse["k"] / (len(r) - used["k"]), g.n)
    return sorted(g.keys[i] for i in selection.select(g, test))


def test_the_support_of_a_sparse_truth_is_found() -> None:
    """40 correlated candidates, 6 of them present at 5 to 40 standard errors:
    the exact support in at least 19 of 20 draws, and never anything outside it
    in more than one."""
    exact = extra = 0
    for seed in range(20):
        rng = np.random.default_rng(seed)
        support = rng.choice(40, 6, replace=False)
        truth = {int(j): float(rng.choice([-1, 1]) * rng.uniform(0.15, 1.0)) for j in support}
        cols, r = _problem(rng, 3000, 40, truth)
        got = _select(cols, r)
        exact += got == sorted(f"m{j}" for j in truth)
        extra += bool(set(got) - {f"m{j}" for j in truth})
    assert exact >= 19 and extra <= 1, (exact, extra)


def test_nothing_present_selects_nothing() -> None:
    false = 0
    for seed in range(30):
        rng = np.random.default_rng(100 + seed)
        cols, r = _problem(rng, 2000, 60, {})
        false += bool(_select(cols, r))
    assert false <= 1  # alpha = 1e-3 over 60 candidates, Bonferroni: ≤ 0.1 % per draw


@pytest.mark.parametrize("present", [0, 1])
def test_an_exact_dependency_resolves_to_the_sparsest(present: int) -> None:
    """m0 = m1 + m2 + m3 exactly (the tool length and the three ball-joint heights):
    a truth in m0 is m0, not three; a truth in m1 is m1, not m0 less two."""
    rng = np.random.default_rng(7)
    n = 2000
    X = rng.normal(size=(n, 8))
    X[:, 0] = X[:, 1] + X[:, 2] + X[:, 3]
    r = X[:, present] * 0.3 + rng.normal(size=n)
    cols = {f"m{j}": X[:, j : j + 1] for j in range(8)}
    assert _select(cols, r) == [f"m{present}"]


def test_linear_standard_errors_cover_the_truth_95_percent() -> None:
    """Repeated noise on one design: the truth lies within 2 standard errors of the
    estimate (from the Gram inverse and σ̂²) in 93-97 % of 600 intervals."""
    rng = np.random.default_rng(3)
    n, p = 1500, 12
    common = rng.normal(size=(n, 1))
    X = 0.7 * common + 0.7 * rng.normal(size=(n, p))
    beta = np.zeros(p)
    beta[[1, 4, 7]] = [0.5, -0.3, 0.2]
    hits = total = 0
    for _ in range(200):
        r = X @ beta + rng.normal(size=n) * 2.0
        cols = {f"m{j}": X[:, j : j + 1] for j in range(p)}
        normal = selection.Normal.of(cols, r, {"k": np.ones(n, dtype=bool)})
        g = selection.Gram.build(normal, {"k": 2.0}, list(cols))
        S = [g.keys.index(f"m{j}") for j in (1, 4, 7)]
        b, C, sse = g.fit(S)
        bu, Cu = g.unscaled(S, b, C)
        sigma2 = sse / g.dof(S)
        # whitening divides data and columns alike: the sizes are in the members' units
        se = np.sqrt(np.diag(Cu) * sigma2)
        est = bu
        hits += int(np.sum(np.abs(est - beta[[1, 4, 7]]) <= 2 * se))
        total += 3
    assert 0.93 <= hits / total <= 0.97, hits / total


def test_a_nearly_undetermined_combination_takes_the_sparsest_explanation() -> None:
    """Five members whose sum the data barely see (a servo lag common to every
    motor: it moves a circle only where the path leaves one), determined to 0.7 of
    its prior where calibration's identifiability asks for 0.25. The truth is m3
    alone; the data's estimate along the sum is off by a whole prior (what a
    linearisation far from the truth gives there). The explanation naming one
    member is taken, not the four others at minus that size."""
    rng = np.random.default_rng(11)
    n = 3000
    B = rng.normal(size=(n, 5))
    e = rng.normal(size=n)
    e *= np.sqrt(0.4) / np.linalg.norm(e)  # |Σ columns|² = 5 · 0.4: λ = 2, SE 0.71
    X = B - B.mean(axis=1, keepdims=True) + e[:, None]
    X = np.hstack([X, rng.normal(size=(n, 6))])  # unrelated members m5..m10
    # truth m3 = 1; along the sum the data say −1 instead of 0
    r = X[:, 3] - X[:, :5].sum(axis=1) + rng.normal(size=n)
    cols = {f"m{j}": X[:, j : j + 1] for j in range(X.shape[1])}
    assert _select(cols, r) == ["m3"]
    # and the undetermined combination is reported as one
    rows = {"k": np.ones(n, dtype=bool)}
    g = selection.Gram.build(selection.Normal.of(cols, r, rows), {"k": 1.0}, list(cols))
    tied = selection.undetermined(g)
    assert {g.keys[j] for j in tied[g.keys.index("m3")]} == {"m0", "m1", "m2", "m4"}


def test_a_size_the_model_does_not_go_to_is_not_named() -> None:
    """A member bounded below at 0 (a motor's play) that the data would fit at
    −0.3 is not named, by elimination or by the forward check; a member present
    beside it still is. Without the bound it would be (the check that the case
    bites)."""
    rng = np.random.default_rng(5)
    n = 2000
    X = rng.normal(size=(n, 6))
    r = -0.3 * X[:, 0] + 0.4 * X[:, 1] + rng.normal(size=n)
    cols = {f"m{j}": X[:, j : j + 1] for j in range(6)}
    rows = {"k": np.ones(n, dtype=bool)}
    normal = selection.Normal.of(cols, r, rows)
    for lower, want in (({"m0": 0.0}, ["m1"]), (None, ["m0", "m1"])):
        g = selection.Gram.build(normal, {"k": 1.0}, list(cols), lower=lower)
        test = selection.Test(1e-3, len(g.keys), 1.0, g.n)
        assert sorted(g.keys[i] for i in selection.select(g, test)) == want
        # nor is it the forward check's candidate beside the member present
        k = selection.forward_candidate(g, [g.keys.index("m1")], test)
        assert (k is not None and g.keys[k] == "m0") == (lower is None)
