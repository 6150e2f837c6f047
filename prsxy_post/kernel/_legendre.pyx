# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The virtual-axis error map compiled: :mod:`prsxy_post.kernel.legendre` row by row,
the same operations in the same order (see that module), so the two agree to the bit.
Compiled with -O2 -ffp-contract=off (no fused multiply-adds)."""

import numpy as np

from libc.stdlib cimport malloc, free

#: Highest Legendre degree a map may use (the profile allows 0..8).
DEGREE_MAX = 16


cdef void _rows(
    const double[:] lo,
    const double[:] span,
    int degree,
    Py_ssize_t nk,
    const int* fac_n,
    const int* fac_at,
    const int* term_n,
    const int* term_c,
    const double* term_cf,
    const double[:, :] q,
    double[:, :] out,
    double* tab,
) noexcept nogil:
    # tab: 5 × (degree + 1) Legendre values of one row; the products as lists:
    # product k multiplies the tab entries fac_at[5k : 5k + fac_n[k]] and adds
    # term_cf[5k + j] × it to component term_c[5k + j], j < term_n[k]
    cdef Py_ssize_t n = q.shape[0], i, k, v, c, j
    cdef int d1 = degree + 1
    cdef double u, col
    cdef double acc[5]
    for i in range(n):
        for v in range(5):
            u = 2.0 * (q[i, v] - lo[v]) / span[v] - 1.0
            # numpy's clip: minimum(maximum(u, −1), 1), NaN kept
            if u < -1.0:
                u = -1.0
            if u > 1.0:
                u = 1.0
            u = u + 0.0
            tab[v * d1] = u * 0 + 1
            if degree > 0:
                tab[v * d1 + 1] = u
                for j in range(2, degree + 1):
                    tab[v * d1 + j] = (
                        tab[v * d1 + j - 1] * u * <double>(2 * j - 1)
                        - tab[v * d1 + j - 2] * <double>(j - 1)
                    ) / <double>j
        for c in range(5):
            acc[c] = 0.0
        for k in range(nk):
            col = 1.0
            for j in range(fac_n[k]):
                col = tab[fac_at[5 * k + j]] * col
            for j in range(term_n[k]):
                c = term_c[5 * k + j]
                acc[c] = acc[c] + term_cf[5 * k + j] * col
        for c in range(5):
            out[i, c] = acc[c]


def map_rows(m, q):
    """e(q) (N, 5); the compiled twin of ``legendre.map_rows``."""
    cdef const double[:, :] qv = np.ascontiguousarray(q, dtype=np.float64)
    if qv.ndim != 2 or qv.shape[1] != 5:
        raise ValueError("q must be (N, 5)")
    cdef int degree = int(m.degree)
    if not 0 <= degree <= DEGREE_MAX:
        raise ValueError(f"degree must be 0..{DEGREE_MAX}")
    cdef const long long[:, :] exps = m.exps
    cdef const double[:, :] coef = m.coef
    cdef Py_ssize_t nk = exps.shape[0], k, v, c
    out = np.empty((qv.shape[0], 5))
    cdef double[:, :] ov = out
    # the products' factors and terms in the reference's order: variables x..B,
    # components x..B, zero coefficients skipped (the reference skips them too)
    fac_n = np.zeros(nk, dtype=np.intc)
    fac_at = np.zeros(5 * nk, dtype=np.intc)
    term_n = np.zeros(nk, dtype=np.intc)
    term_c = np.zeros(5 * nk, dtype=np.intc)
    term_cf = np.zeros(5 * nk)
    cdef int[:] fn = fac_n, fa = fac_at, tn = term_n, tc = term_c
    cdef double[:] tf = term_cf
    for k in range(nk):
        for v in range(5):
            if exps[k, v]:
                if not 0 < exps[k, v] <= degree:
                    raise ValueError("a product's degree is beyond the map's degree")
                fa[5 * k + fn[k]] = v * (degree + 1) + <int>exps[k, v]
                fn[k] += 1
        for c in range(5):
            if coef[k, c] != 0.0:
                tc[5 * k + tn[k]] = c
                tf[5 * k + tn[k]] = coef[k, c]
                tn[k] += 1
    cdef double* tab = <double*>malloc(5 * (degree + 1) * sizeof(double))
    if tab == NULL:
        raise MemoryError()
    try:
        _rows(m.lo, m.span, degree, nk, &fn[0] if nk else NULL, &fa[0] if nk else NULL,
              &tn[0] if nk else NULL, &tc[0] if nk else NULL, &tf[0] if nk else NULL,
              qv, ov, tab)
    finally:
        free(tab)
    return out


def correct_virtual(m, q, int iterations=2):
    """Q' (N, 5) with Q' + e(Q') = Q; the compiled twin of
    ``legendre.correct_virtual``."""
    q = np.ascontiguousarray(q, dtype=np.float64)
    qp = q - map_rows(m, q)
    for _ in range(iterations - 1):
        qp = q - map_rows(m, qp)
    return qp
