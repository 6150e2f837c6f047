"""CPython 3.11's ``math.hypot`` and ``math.dist`` in Python floats, on every Python.

CPython computes ``hypot`` and ``dist`` with its own ``vector_norm``, not the C
library's ``hypot``, and 3.12 changed it (python/cpython#101383: the squares are
summed with fused multiply-adds). The corrected G-code writer's decisions
(:mod:`prsxy_post.kernel.gwrite`) compare lengths against tolerances, so a length
one ulp off can move a line's end, and its compiled twin (``_gwrite.pyx``) writes
3.11's algorithm out in C. This module is that algorithm in Python's IEEE doubles
(no contraction into fused operations), so the reference and the twin make the
same bits whatever the interpreter's version; ``tests/test_kernel_vnorm.py``
checks it against ``math.hypot`` on 3.11 and against the twin everywhere.

The norm of values |x_i| ≤ m is computed as m' · sqrt(Σ (x_i / m')²) with m' = 2^e
the power of two at m's exponent (exact scaling), each square split exactly
(Dekker: x = hi + lo, x² = hi² + 2 hi lo + lo²), the sum compensated (Neumaier),
and the root h corrected by one Newton step on the residual: h + (s − h²) / (2 h).
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence

#: 2**27 + 1: Dekker's split of a double into two 26-bit halves
_SPLIT = 134217729.0


def _split(x: float) -> tuple[float, float]:
    """x = hi + lo exactly, hi with at most 26 significant bits."""
    t = x * _SPLIT
    hi = t - (t - x)
    return hi, x - hi


def _vector_norm(vec: Sequence[float], mx: float, found_nan: bool) -> float:
    """CPython 3.11's ``vector_norm`` of values >= 0 whose largest is ``mx``."""
    if mx == math.inf:
        return mx
    if found_nan:
        return math.nan
    if mx == 0.0 or len(vec) <= 1:
        return mx
    max_e = math.frexp(mx)[1]
    if max_e < -1023:
        # ldexp(1.0, -max_e) would overflow: divide by the largest instead
        csum, frac1 = 1.0, 0.0
        for v in vec:
            x = v / mx
            x = x * x
            old = csum
            csum += x
            frac1 += (old - csum) + x
        return mx * math.sqrt(csum - 1.0 + frac1)
    scale = math.ldexp(1.0, -max_e)
    csum, frac1, frac2, frac3 = 1.0, 0.0, 0.0, 0.0
    for v in vec:
        hi, lo = _split(v * scale)
        x = hi * hi
        old = csum
        csum += x
        frac1 += (old - csum) + x
        x = 2.0 * hi * lo
        old = csum
        csum += x
        frac2 += (old - csum) + x
        frac3 += lo * lo
    h = math.sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
    # the residual s - h^2, its square split exactly as the terms were
    hi, lo = _split(h)
    x = -hi * hi
    old = csum
    csum += x
    frac1 += (old - csum) + x
    x = -2.0 * hi * lo
    old = csum
    csum += x
    frac2 += (old - csum) + x
    x = -lo * lo
    old = csum
    csum += x
    frac3 += (old - csum) + x
    x = csum - 1.0 + (frac1 + frac2 + frac3)
    return (h + x / (2.0 * h)) / scale


def _norm_of(values: list[float]) -> float:
    """The norm of ``values``; the largest found as CPython does (NaN never is)."""
    absolute = [abs(v) for v in values]
    mx, found_nan = 0.0, False
    for a in absolute:
        found_nan = found_nan or a != a
        if a > mx:
            mx = a
    return _vector_norm(absolute, mx, found_nan)


def hypot_311(*x: float) -> float:
    """``math.hypot(*x)`` as CPython 3.11 computes it: sqrt(Σ x_i²), from the
    largest |x_i| down, within one rounding of the exact value."""
    return _norm_of([float(v) for v in x])


def dist_311(p: Sequence[float], q: Sequence[float]) -> float:
    """``math.dist(p, q)`` as CPython 3.11 computes it: hypot of p − q."""
    if len(p) != len(q):
        raise ValueError(
            f"both points need the same number of coordinates, got {len(p)} and {len(q)}"
        )
    return _norm_of([float(a) - float(b) for a, b in zip(p, q, strict=True)])


#: ``math.hypot`` and ``math.dist`` themselves on 3.11 (the same bits, checked by
#: tests/test_kernel_vnorm.py; 35 times faster by timeit), the port on any other Python
hypot: Callable[..., float] = math.hypot if sys.version_info[:2] == (3, 11) else hypot_311
dist: Callable[[Sequence[float], Sequence[float]], float] = (
    math.dist if sys.version_info[:2] == (3, 11) else dist_311
)
