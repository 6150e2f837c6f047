"""CPython 3.11's hypot and dist in Python floats (prsxy_post.kernel.vnorm).

The oracle is CPython 3.11's own ``math.hypot`` / ``math.dist`` (Modules/mathmodule.c,
``vector_norm``), on 3.11 only: 3.12 changed the algorithm (python/cpython#101383),
which is why the module exists. On every Python the compiled writer kernel's norm
(``_gwrite.hypot``) must give the module's bits, and both must be within one
rounding of the exact norm (a closed form in rationals)."""

from __future__ import annotations

import math
import sys
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post.kernel import vnorm

from .kernel_cases import compiled, same_bits

ON_311 = sys.version_info[:2] == (3, 11)

_float = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e150, max_value=1e150),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e-300, max_value=1e-300),
    st.sampled_from([0.0, -0.0, 1e-320, 5e-324, 1.0, 0.1, 3.0, 2.0**-1022]),
)
_values = st.lists(_float, min_size=0, max_size=5)


@pytest.mark.skipif(not ON_311, reason="math.hypot is CPython 3.11's only on 3.11")
@settings(max_examples=3000, deadline=None)
@given(x=_values)
def test_hypot_is_cpython_311s(x: list[float]) -> None:
    assert same_bits(np.array(vnorm.hypot_311(*x)), np.array(math.hypot(*x)))


@pytest.mark.skipif(not ON_311, reason="math.dist is CPython 3.11's only on 3.11")
@settings(max_examples=1000, deadline=None)
@given(pq=st.integers(0, 5).flatmap(lambda n: st.tuples(*[st.tuples(_float, _float)] * n)))
def test_dist_is_cpython_311s(pq: tuple[tuple[float, float], ...]) -> None:
    p, q = [a for a, _ in pq], [b for _, b in pq]
    want = math.dist(p, q) if all(math.isfinite(a - b) for a, b in pq) else None
    if want is not None:
        assert same_bits(np.array(vnorm.dist_311(p, q)), np.array(want))


@settings(max_examples=2000, deadline=None)
@given(x=st.lists(st.floats(min_value=-1e100, max_value=1e100), min_size=2, max_size=5))
def test_hypot_is_within_an_ulp_of_the_exact_norm(x: list[float]) -> None:
    got = vnorm.hypot_311(*x)
    exact_sq = sum(Fraction(v) ** 2 for v in x)
    # |got - sqrt(s)| <= ulp(got)  <=>  (got - ulp)^2 <= s <= (got + ulp)^2
    ulp = Fraction(math.ulp(got))
    assert max(Fraction(got) - ulp, Fraction(0)) ** 2 <= exact_sq <= (Fraction(got) + ulp) ** 2


@settings(max_examples=2000, deadline=None)
@given(x=_values)
def test_the_compiled_writer_kernel_norm_is_the_modules(x: list[float]) -> None:
    _gwrite = compiled("_gwrite")
    got = _gwrite.hypot(np.array(x, dtype=float))
    assert same_bits(np.array(got), np.array(vnorm.hypot_311(*x)))


def test_the_writer_kernel_uses_311s_norm_on_every_python() -> None:
    if ON_311:
        assert vnorm.hypot is math.hypot and vnorm.dist is math.dist
    else:
        assert vnorm.hypot is vnorm.hypot_311 and vnorm.dist is vnorm.dist_311


def test_special_values_are_cpythons() -> None:
    assert vnorm.hypot_311() == 0.0
    assert vnorm.hypot_311(-3.0) == 3.0
    assert vnorm.hypot_311(3.0, 4.0) == 5.0
    assert vnorm.hypot_311(math.inf, math.nan) == math.inf  # an infinity wins over NaN
    assert math.isnan(vnorm.hypot_311(1.0, math.nan))
    assert vnorm.dist_311((1.0, 2.0, 3.0), (4.0, 6.0, 3.0)) == 5.0
    with pytest.raises(ValueError, match="same number of coordinates, got 2 and 3"):
        vnorm.dist_311((1.0, 2.0), (1.0, 2.0, 3.0))
