"""The compiled virtual-axis map against its numpy reference, and the reference
against the map as it was defined: the same bits.

Three references in a chain: numpy's ``legvander`` with the map's products made one
by one (:func:`_by_legvander`, the evaluation ``errormap.ErrorMap`` had before the
kernel), the kernel's numpy reference (``kernel/legendre.py``) and its compiled twin
(``_legendre.pyx``). Inputs: maps fitted to a simulated machine's errors (as
``calibrate`` makes them) and generated maps (hypothesis: every structure, degrees
0–8, domains flat in some coordinate, poses inside and outside the domain).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from numpy.polynomial import legendre as npleg

from prsxy_post import chain, errormap, kernel
from prsxy_post.kernel import legendre

from .kernel_cases import compiled, same_bits


def _by_legvander(em: errormap.ErrorMap, q: np.ndarray) -> np.ndarray:
    """e(q) as the map was evaluated before the kernel: numpy's legvander tables,
    each distinct product made once, summed per component in the products' order."""
    exps, C = em._plan
    span = np.where(em.hi > em.lo, em.hi - em.lo, 1.0)
    u = np.clip(2.0 * (q - em.lo) / span - 1.0, -1.0, 1.0)
    deg = max(max(em.degree.values(), default=2), 2)
    tables = [npleg.legvander(u[:, v], deg) for v in range(5)]
    out = np.zeros((len(q), 5))
    for k, e5 in enumerate(exps):
        col: np.ndarray | float = 1.0
        for v, d in enumerate(e5):
            if d:
                col = tables[v][:, d] * col
        for i in np.flatnonzero(C[k]).tolist():
            out[:, i] += C[k, i] * col
    return out


def _random_map(
    rng: np.random.Generator, degree: int, structure: str, flat: int
) -> errormap.ErrorMap:
    lo = np.array([-150.0, -150.0, -80.0, -40.0, -40.0])
    hi = np.array([150.0, 150.0, 20.0, 40.0, 40.0])
    if flat >= 0:
        hi[flat] = lo[flat]  # a coordinate the data never moved: span 1
    comps = {}
    for c in errormap.COMPONENTS:
        _, terms = errormap.design(np.zeros((1, 5)), c, degree, lo, hi, structure)
        coef = rng.normal(0, 1e-3, len(terms) + 1)
        coef[rng.random(len(coef)) < 0.2] = 0.0  # products a component does not use
        comps[c] = {
            "structure": structure,
            "degree": degree,
            "lambda": 0.0,
            "coef": coef.tolist(),
            "cv_rms": 0.0,
            "fit_rms": 0.0,
        }
    d = {"model": "legendre-eq5", "lo": lo.tolist(), "hi": hi.tolist(), "components": comps}
    return errormap.ErrorMap.from_dict(d)


def _poses(rng: np.random.Generator, n: int) -> np.ndarray:
    # beyond the domain too (clamped), and the domain's corners exactly
    q = rng.uniform([-200, -200, -100, -60, -60], [200, 200, 40, 60, 60], (n, 5))
    q[:2] = [[-150.0, -150.0, -80.0, -40.0, -40.0], [150.0, 150.0, 20.0, 40.0, 40.0]]
    return q


@pytest.mark.parametrize("structure", ["eq5", "eq5-coupled"])
@pytest.mark.parametrize("degree", [0, 1, 2, 3, 5, 8])
def test_reference_is_numpys_legvander(structure: str, degree: int) -> None:
    rng = np.random.default_rng(degree)
    em = _random_map(rng, degree, structure, flat=-1)
    q = _poses(rng, 500)
    assert same_bits(legendre.map_rows(em.arrays, q), _by_legvander(em, q))


@pytest.mark.parametrize("structure", ["eq5", "eq5-coupled"])
@pytest.mark.parametrize("degree", [0, 1, 2, 3, 5, 8])
def test_compiled_map_is_bit_identical(structure: str, degree: int) -> None:
    _legendre = compiled("_legendre")
    rng = np.random.default_rng(100 + degree)
    em = _random_map(rng, degree, structure, flat=-1)
    q = _poses(rng, 2000)
    want = legendre.map_rows(em.arrays, q)
    assert same_bits(_legendre.map_rows(em.arrays, q), want)
    assert same_bits(
        _legendre.correct_virtual(em.arrays, q), legendre.correct_virtual(em.arrays, q)
    )


@settings(max_examples=100, deadline=None)
@given(
    st.integers(0, 8),
    st.sampled_from(["eq5", "eq5-coupled"]),
    st.integers(-1, 4),
    st.integers(0, 2**32 - 1),
    hnp.arrays(
        np.float64,
        st.tuples(st.integers(1, 30), st.just(5)),
        elements=st.floats(-1e4, 1e4, allow_subnormal=True),
    ),
)
def test_generated_maps_are_bit_identical(
    degree: int, structure: str, flat: int, seed: int, q: np.ndarray
) -> None:
    _legendre = compiled("_legendre")
    em = _random_map(np.random.default_rng(seed), degree, structure, flat)
    want = legendre.map_rows(em.arrays, q)
    assert same_bits(want, _by_legvander(em, q))
    assert same_bits(_legendre.map_rows(em.arrays, q), want)
    for it in (1, 2, 3):
        assert same_bits(
            _legendre.correct_virtual(em.arrays, q, it), legendre.correct_virtual(em.arrays, q, it)
        )


@pytest.mark.parametrize("degree", [0, 1, 3, 8])
def test_poses_with_nan_are_bit_identical(degree: int) -> None:
    """A NaN coordinate makes NaN only the products that take it, and the
    components whose terms use them (the compiled kernel sums such rows term by
    term, the others product by product)."""
    _legendre = compiled("_legendre")
    rng = np.random.default_rng(200 + degree)
    em = _random_map(rng, degree, "eq5-coupled", flat=-1)
    q = _poses(rng, 400)
    q[rng.random(q.shape) < 0.1] = np.nan
    q[5] = np.nan
    q[6] = [np.inf, -np.inf, 1e308, -1e308, np.nan]
    q[7] = [np.inf, -np.inf, 1e308, -1e308, 0.0]  # clamped to the domain's edges
    with np.errstate(over="ignore", invalid="ignore"):  # the reference's scaling
        want = legendre.map_rows(em.arrays, q)
        assert same_bits(want, _by_legvander(em, q))
        assert same_bits(_legendre.map_rows(em.arrays, q), want)
        assert same_bits(
            _legendre.correct_virtual(em.arrays, q), legendre.correct_virtual(em.arrays, q)
        )
    assert np.isfinite(want[7]).all()


def test_the_chain_corrects_through_the_kernel_as_through_the_map() -> None:
    """chain.correct_virtual hands a fitted map to the kernel's one-pass correction:
    the same bits as the fixed-point steps through the map's own evaluation (any
    error function's way: Q' = Q − e(Q), then Q' = Q − e(Q'))."""
    em = _random_map(np.random.default_rng(11), 3, "eq5", flat=-1)
    q = _poses(np.random.default_rng(12), 3000)
    for it in (1, 2, 3):
        got = chain.correct_virtual(q, em, it)
        assert same_bits(got, chain.correct_virtual(q, lambda x: em(x), it))
        assert same_bits(got, legendre.correct_virtual(em.arrays, q, it))
    assert chain.correct_virtual(q[:0], em).shape == (0, 5)


def test_compiled_correction_refuses_other_shapes() -> None:
    _legendre = compiled("_legendre")
    em = _random_map(np.random.default_rng(7), 2, "eq5", flat=-1)
    with pytest.raises(ValueError, match="q must be"):
        _legendre.correct_virtual(em.arrays, np.zeros((3, 4)))
    with pytest.raises(ValueError, match="exps and coef"):
        _legendre.correct_virtual(em.arrays._replace(coef=em.arrays.coef[:-1]), np.zeros((3, 5)))


def test_the_selected_kernel_evaluates_the_map() -> None:
    em = _random_map(np.random.default_rng(7), 3, "eq5", flat=-1)
    q = _poses(np.random.default_rng(8), 100)
    assert same_bits(em(q), _by_legvander(em, q))
    assert em(q).shape == (100, 5)
    assert kernel.map_rows(em.arrays, q[:0]).shape == (0, 5)


def test_a_fitted_map_is_bit_identical() -> None:
    """A map fitted as calibrate fits one, on a smooth error with noise."""
    _legendre = compiled("_legendre")
    rng = np.random.default_rng(3)
    q = rng.uniform([-100, -100, -60, -30, -30], [100, 100, 0, 30, 30], (400, 5))
    err = 1e-3 * np.column_stack(
        [np.sin(q[:, 0] / 50), q[:, 1] / 100, q[:, 2] / 60, q[:, 3] / 30, q[:, 4] / 30]
    ) + rng.normal(0, 1e-5, (400, 5))
    em = errormap.fit(q, err, rng=rng)
    q2 = _poses(rng, 1000)
    want = legendre.map_rows(em.arrays, q2)
    assert same_bits(want, _by_legvander(em, q2))
    assert same_bits(_legendre.map_rows(em.arrays, q2), want)


def test_compiled_map_keeps_its_plan_only_for_the_map_it_was_made_from() -> None:
    """The compiled map keeps the last map's plan of products from call to call (a
    conversion's chunks): a map changed in place, another map, or a map of other
    products after it, each evaluates as the reference does."""
    _legendre = compiled("_legendre")
    rng = np.random.default_rng(9)
    q = _poses(rng, 50)
    em2, em3 = _random_map(rng, 2, "eq5", flat=-1), _random_map(rng, 3, "eq5-coupled", flat=1)
    m = em2.arrays._replace(coef=em2.arrays.coef.copy(), lo=em2.arrays.lo.copy())
    for change in ("", "coef", "lo", "", "other map", "back"):
        if change == "coef":
            m.coef[1, 0] += 1e-3
        elif change == "lo":
            m.lo[2] -= 5.0
        arrays = em3.arrays if change == "other map" else m
        for it in (1, 2):
            want = legendre.correct_virtual(arrays, q, it)
            assert same_bits(_legendre.correct_virtual(arrays, q, it), want), change
        assert same_bits(_legendre.map_rows(arrays, q), legendre.map_rows(arrays, q)), change
