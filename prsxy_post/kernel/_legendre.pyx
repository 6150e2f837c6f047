# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The virtual-axis error map compiled: :mod:`prsxy_post.kernel.legendre` row by row,
the same operations in the same order (see that module), so the two agree to the bit.
Compiled with -O2 -ffp-contract=off (no fused multiply-adds)."""

import numpy as np


#: Highest Legendre degree a map may use (the profile allows 0..8).
DEGREE_MAX = 16


cdef struct _Map:
    # the map's domain and its products: col[0] is 1.0 (the reference's start of
    # every product), then each product is made as the reference makes it, its
    # factors in order, col[dst] = tab[fac] × col[src] for each op (dst, fac, src)
    # in turn: a product one factor longer than another the map has (or makes for
    # it) takes that one's value, the same bits, instead of its factors again.
    # Component c is the sum of term_cf[L c + i] × col[term_k[L c + i]], i < L,
    # its terms in the reference's order after 0 · col[0] (+0.0, the sum's own
    # start: a component with fewer terms is padded in front without a change of
    # bit). Each component's sum is the reference's, term for term; the five run
    # side by side (five chains of additions, not one in turn).
    # Where no coordinate is NaN, the same sums run product by product instead:
    # dense_cf[5 i + c] × col[dense_k[i]] for the products i with a term, 0.0 where
    # the reference has none. A product of Legendre values of u in [−1, 1] is
    # finite, so 0 · it is ±0.0, and a sum from +0.0 is never −0.0 (x + y is −0.0
    # only when both are): adding ±0.0 leaves it as it is, bit for bit.
    # tab: 5 × (degree + 1) Legendre values of a row, then 1.0
    const double* lo
    const double* span
    int degree
    Py_ssize_t n_ops
    int L
    const int* ops
    const int* term_k
    const double* term_cf
    Py_ssize_t nd
    const int* dense_k
    const double* dense_cf
    double* tab
    double* col


cdef inline void _row(const _Map* M, const double* q, double* out) noexcept nogil:
    """e(q) of one pose q[0..4] into out[0..4] (``legendre.map_rows``)."""
    cdef Py_ssize_t k, v, j, i
    cdef int d1 = M.degree + 1
    cdef int L = M.L
    cdef double u, acc0, acc1, acc2, acc3, acc4
    cdef double* tab = M.tab
    cdef double* col = M.col
    cdef const int* op = M.ops
    cdef const int* tk = M.term_k
    cdef const double* tf = M.term_cf
    cdef const double* df = M.dense_cf
    cdef double c_i
    cdef bint nan = False
    for v in range(5):
        u = 2.0 * (q[v] - M.lo[v]) / M.span[v] - 1.0
        nan = nan or u != u
        # numpy's clip: minimum(maximum(u, −1), 1), NaN kept
        if u < -1.0:
            u = -1.0
        if u > 1.0:
            u = 1.0
        u = u + 0.0
        tab[v * d1] = u * 0 + 1
        if M.degree > 0:
            tab[v * d1 + 1] = u
            # x / 2 is x · 0.5 to the bit (both the exact half, rounded once)
            if M.degree >= 2:
                tab[v * d1 + 2] = (tab[v * d1 + 1] * u * 3.0 - tab[v * d1] * 1.0) * 0.5
            for j in range(3, M.degree + 1):
                tab[v * d1 + j] = (
                    tab[v * d1 + j - 1] * u * <double>(2 * j - 1)
                    - tab[v * d1 + j - 2] * <double>(j - 1)
                ) / <double>j
    for k in range(M.n_ops):
        col[op[3 * k]] = tab[op[3 * k + 1]] * col[op[3 * k + 2]]
    acc0 = 0.0
    acc1 = 0.0
    acc2 = 0.0
    acc3 = 0.0
    acc4 = 0.0
    if not nan:
        for i in range(M.nd):
            c_i = col[M.dense_k[i]]
            acc0 = acc0 + df[5 * i] * c_i
            acc1 = acc1 + df[5 * i + 1] * c_i
            acc2 = acc2 + df[5 * i + 2] * c_i
            acc3 = acc3 + df[5 * i + 3] * c_i
            acc4 = acc4 + df[5 * i + 4] * c_i
        out[0] = acc0
        out[1] = acc1
        out[2] = acc2
        out[3] = acc3
        out[4] = acc4
        return
    for i in range(L):
        acc0 = acc0 + tf[i] * col[tk[i]]
        acc1 = acc1 + tf[L + i] * col[tk[L + i]]
        acc2 = acc2 + tf[2 * L + i] * col[tk[2 * L + i]]
        acc3 = acc3 + tf[3 * L + i] * col[tk[3 * L + i]]
        acc4 = acc4 + tf[4 * L + i] * col[tk[4 * L + i]]
    out[0] = acc0
    out[1] = acc1
    out[2] = acc2
    out[3] = acc3
    out[4] = acc4


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
        self.lo = np.ascontiguousarray(m.lo, dtype=np.float64)
        self.span = np.ascontiguousarray(m.span, dtype=np.float64)
        if self.lo.shape != (5,) or self.span.shape != (5,):
            raise ValueError(f"lo and span must be (5,), got {self.lo.shape}, {self.span.shape}")
        one = 5 * (degree + 1)  # tab's entry 1.0
        self.n_tab = one + 1
        self.degree = degree
        # what the plan was made from (:meth:`made_from`)
        self.made = (np.array(m.lo, dtype=np.float64), np.array(m.span, dtype=np.float64),
                     np.array(m.exps), np.array(m.coef))
        # each product's factors (variables x..B, as the reference multiplies them)
        facs = []
        for k in range(nk):
            f = []
            for v in range(5):
                if exps[k, v]:
                    if not 0 < exps[k, v] <= degree:
                        raise ValueError("a product's degree is beyond the map's degree")
                    f.append(v * (degree + 1) + <int>exps[k, v])
            facs.append(tuple(f))
        # col's slots: 0 the start (1.0), the products, then the partial products
        # the map lacks; ops make each from the one a factor shorter
        slot = {(): 0}
        for k, f in enumerate(facs):
            slot.setdefault(f, 1 + k)
        ops = []
        made = {()}
        for f in facs:
            for n_f in range(1, len(f) + 1):  # its partial products first
                part = f[:n_f]
                if part not in made:
                    if part not in slot:
                        slot[part] = len(slot)
                    # (no negative index here: the module runs without wraparound)
                    ops.append((slot[part], f[n_f - 1], slot[f[: n_f - 1]]))
                    made.add(part)
        # a constant product (no factor) is the start itself
        self.ops = np.array(ops if ops else [(0, one, 0)], dtype=np.intc).reshape(-1)
        self.n_ops = len(ops)
        self.n_col = max(len(slot), 1 + nk)
        # each component's terms: products in order, zero coefficients skipped as
        # the reference skips them
        terms = [
            [(slot[facs[k]], coef[k, c]) for k in range(nk) if coef[k, c] != 0.0]
            for c in range(5)
        ]
        self.L = max(len(t) for t in terms)
        self.term_k = np.zeros(max(5 * self.L, 1), dtype=np.intc)
        self.term_cf = np.zeros(max(5 * self.L, 1))
        for c, t in enumerate(terms):
            pad = self.L - len(t)
            for i, (k, cf) in enumerate(t):
                self.term_k[c * self.L + pad + i] = k
                self.term_cf[c * self.L + pad + i] = cf
        # the same terms product by product (rows without NaN)
        used = []
        for k in range(nk):
            for c in range(5):
                if coef[k, c] != 0.0:
                    used.append(k)
                    break
        self.nd = len(used)
        self.dense_k = np.zeros(max(len(used), 1), dtype=np.intc)
        self.dense_cf = np.zeros(5 * max(len(used), 1))
        for i, k in enumerate(used):
            self.dense_k[i] = slot[facs[k]]
            for c in range(5):
                if coef[k, c] != 0.0:
                    self.dense_cf[5 * i + c] = coef[k, c]


    def made_from(self, m):
        """True when map ``m`` holds what this plan was made from."""
        lo, span, exps, coef = self.made
        return (
            int(m.degree) == self.degree
            and np.array_equal(m.lo, lo) and np.array_equal(m.span, span)
            and np.array_equal(m.exps, exps) and np.array_equal(m.coef, coef)
        )

    def scratch(self):
        """A call's own rows of Legendre values (tab, its last entry 1.0) and of
        products (col, its first 1.0)."""
        tab = np.empty(self.n_tab)
        tab[self.n_tab - 1] = 1.0
        col = np.empty(self.n_col)
        col[0] = 1.0
        return tab, col


#: the last map's plan (a conversion evaluates one map, chunk after chunk)
_last = [None, None]


def _plan_of(m):
    """The :class:`_Plan` of map ``m``: the last one made, when made from ``m``
    and ``m`` still holds what it held then (a plan costs more than the map on a
    few hundred rows)."""
    last_m, plan = _last
    if last_m is m and plan.made_from(m):
        return plan
    plan = _Plan(m)
    _last[:] = [m, plan]
    return plan


cdef _Map _map(plan, tab_a, col_a):
    """The C view of a :class:`_Plan` and a call's scratch rows (valid while they
    live)."""
    cdef _Map M
    cdef const double[::1] lo = plan.lo, span = plan.span, tf = plan.term_cf
    cdef const int[::1] ops = plan.ops, tk = plan.term_k, dk = plan.dense_k
    cdef const double[::1] dcf = plan.dense_cf
    cdef double[::1] tab = tab_a, col = col_a
    M.lo = &lo[0]
    M.span = &span[0]
    M.degree = plan.degree
    M.n_ops = plan.n_ops
    M.L = plan.L
    M.ops = &ops[0]
    M.nd = plan.nd
    M.dense_k = &dk[0]
    M.dense_cf = &dcf[0]
    M.term_k = &tk[0]
    M.term_cf = &tf[0]
    M.tab = &tab[0]
    M.col = &col[0]
    return M


def map_rows(m, q):
    """e(q) (N, 5); the compiled twin of ``legendre.map_rows``."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=np.float64)
    if qv.ndim != 2 or qv.shape[1] != 5:
        raise ValueError("q must be (N, 5)")
    plan = _plan_of(m)
    tab, col = plan.scratch()
    cdef _Map M = _map(plan, tab, col)
    cdef Py_ssize_t n = qv.shape[0], i
    out = np.empty((n, 5))
    cdef double[:, ::1] ov = out
    with nogil:
        for i in range(n):
            _row(&M, &qv[i, 0], &ov[i, 0])
    return out


def correct_virtual(m, q, int iterations=1):
    """Q' (N, 5) = Q − e(Q), then Q − e(Q') ``iterations`` − 1 times; the compiled
    twin of ``legendre.correct_virtual``: every row's steps in one pass."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=np.float64)
    if qv.ndim != 2 or qv.shape[1] != 5:
        raise ValueError("q must be (N, 5)")
    plan = _plan_of(m)
    tab, col = plan.scratch()
    cdef _Map M = _map(plan, tab, col)
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
