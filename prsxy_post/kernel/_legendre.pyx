# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The virtual-axis error map compiled: :mod:`prsxy_post.kernel.legendre` row by row,
the same operations in the same order (see that module), so the two agree to the bit.
Compiled with -O2 -ffp-contract=off (no fused multiply-adds)."""

import numpy as np


#: Highest Legendre degree a map may use (the profile allows 0..8).
DEGREE_MAX = 16


cdef struct _Map:
    # the map's domain and its products as lists: product k multiplies the tab
    # entries fac_at[5k : 5k + fac_n[k]] and adds term_cf[5k + j] × it to component
    # term_c[5k + j], j < term_n[k]; tab: 5 × (degree + 1) Legendre values of a row
    const double* lo
    const double* span
    int degree
    Py_ssize_t nk
    const int* fac_n
    const int* fac_at
    const int* term_n
    const int* term_c
    const double* term_cf
    double* tab


cdef inline void _row(const _Map* M, const double* q, double* out) noexcept nogil:
    """e(q) of one pose q[0..4] into out[0..4] (``legendre.map_rows``)."""
    cdef Py_ssize_t k, v, c, j
    cdef int d1 = M.degree + 1
    cdef double u, col
    cdef double acc[5]
    cdef double* tab = M.tab
    for v in range(5):
        u = 2.0 * (q[v] - M.lo[v]) / M.span[v] - 1.0
        # numpy's clip: minimum(maximum(u, −1), 1), NaN kept
        if u < -1.0:
            u = -1.0
        if u > 1.0:
            u = 1.0
        u = u + 0.0
        tab[v * d1] = u * 0 + 1
        if M.degree > 0:
            tab[v * d1 + 1] = u
            for j in range(2, M.degree + 1):
                tab[v * d1 + j] = (
                    tab[v * d1 + j - 1] * u * <double>(2 * j - 1)
                    - tab[v * d1 + j - 2] * <double>(j - 1)
                ) / <double>j
    for c in range(5):
        acc[c] = 0.0
    for k in range(M.nk):
        col = 1.0
        for j in range(M.fac_n[k]):
            col = tab[M.fac_at[5 * k + j]] * col
        for j in range(M.term_n[k]):
            c = M.term_c[5 * k + j]
            acc[c] = acc[c] + M.term_cf[5 * k + j] * col
    for c in range(5):
        out[c] = acc[c]


class _Plan:
    """A map's products as the C loop takes them (the arrays :class:`_Map` points
    into, kept alive while it runs)."""

    def __init__(self, m):
        cdef int degree = int(m.degree)
        if not 0 <= degree <= DEGREE_MAX:
            raise ValueError(f"degree must be 0..{DEGREE_MAX}")
        cdef const long long[:, :] exps = m.exps
        cdef const double[:, :] coef = m.coef
        cdef Py_ssize_t nk = exps.shape[0], k, v, c
        if coef.shape[0] != nk or coef.shape[1] != 5 or exps.shape[1] != 5:
            raise ValueError(f"exps and coef must be (K, 5) each, got {np.shape(m.exps)} "
                             f"and {np.shape(m.coef)}")
        # the products' factors and terms in the reference's order: variables x..B,
        # components x..B, zero coefficients skipped (the reference skips them too)
        self.fac_n = np.zeros(max(nk, 1), dtype=np.intc)
        self.fac_at = np.zeros(5 * max(nk, 1), dtype=np.intc)
        self.term_n = np.zeros(max(nk, 1), dtype=np.intc)
        self.term_c = np.zeros(5 * max(nk, 1), dtype=np.intc)
        self.term_cf = np.zeros(5 * max(nk, 1))
        self.lo = np.ascontiguousarray(m.lo, dtype=np.float64)
        self.span = np.ascontiguousarray(m.span, dtype=np.float64)
        if self.lo.shape != (5,) or self.span.shape != (5,):
            raise ValueError(f"lo and span must be (5,), got {self.lo.shape}, {self.span.shape}")
        self.tab = np.empty(5 * (degree + 1))
        self.degree = degree
        self.nk = nk
        cdef int[:] fn = self.fac_n, fa = self.fac_at, tn = self.term_n, tc = self.term_c
        cdef double[:] tf = self.term_cf
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


cdef _Map _map(plan):
    """The C view of a :class:`_Plan` (valid while ``plan`` lives)."""
    cdef _Map M
    cdef const double[::1] lo = plan.lo, span = plan.span, tf = plan.term_cf
    cdef const int[::1] fn = plan.fac_n, fa = plan.fac_at, tn = plan.term_n, tc = plan.term_c
    cdef double[::1] tab = plan.tab
    M.lo = &lo[0]
    M.span = &span[0]
    M.degree = plan.degree
    M.nk = plan.nk
    M.fac_n = &fn[0]
    M.fac_at = &fa[0]
    M.term_n = &tn[0]
    M.term_c = &tc[0]
    M.term_cf = &tf[0]
    M.tab = &tab[0]
    return M


def map_rows(m, q):
    """e(q) (N, 5); the compiled twin of ``legendre.map_rows``."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=np.float64)
    if qv.ndim != 2 or qv.shape[1] != 5:
        raise ValueError("q must be (N, 5)")
    plan = _Plan(m)
    cdef _Map M = _map(plan)
    cdef Py_ssize_t n = qv.shape[0], i
    out = np.empty((n, 5))
    cdef double[:, ::1] ov = out
    with nogil:
        for i in range(n):
            _row(&M, &qv[i, 0], &ov[i, 0])
    return out


def correct_virtual(m, q, int iterations=2):
    """Q' (N, 5) with Q' + e(Q') = Q; the compiled twin of
    ``legendre.correct_virtual``: every row's fixed-point steps in one pass."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=np.float64)
    if qv.ndim != 2 or qv.shape[1] != 5:
        raise ValueError("q must be (N, 5)")
    plan = _Plan(m)
    cdef _Map M = _map(plan)
    cdef Py_ssize_t n = qv.shape[0], i, c
    cdef int it
    out = np.empty((n, 5))
    cdef double[:, ::1] ov = out
    cdef double e[5]
    with nogil:
        for i in range(n):
            _row(&M, &qv[i, 0], e)
            for c in range(5):
                ov[i, c] = qv[i, c] - e[c]
            for it in range(iterations - 1):
                _row(&M, &ov[i, 0], e)
                for c in range(5):
                    ov[i, c] = qv[i, c] - e[c]
    return out
