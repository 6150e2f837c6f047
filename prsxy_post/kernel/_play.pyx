# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The play model compiled: :mod:`prsxy_post.kernel.play` point by point, the same
operations in the same order (see that module), so the two agree to the bit.

numpy's ``interp`` is written out as numpy does it (the slope of the interval,
times the distance from its left end, plus its left value); numpy's ``maximum`` and
``minimum`` as numpy's (a NaN wins); the clamp scan runs as the sequential loop its
doubling steps compose to (every value is one of the inputs). The cubic's ``s**3``
at a turning point is numpy's power on the array the reference makes (it is not the
C library's pow on every processor); the periodic terms call the C library's sin
and cos, as the reference does through :mod:`math`. Compiled with -O2
-ffp-contract=off (no fused multiply-adds)."""

import numpy as np

from . import play as _pure

from cpython.mem cimport PyMem_Malloc, PyMem_Free
from libc.math cimport sin, cos, sqrt, fabs, copysign, INFINITY, NAN, M_PI
from libc.string cimport memcpy

cdef double TWO_PI = 2 * M_PI


cdef struct Tab:
    const double* breaks
    const double* lo_err
    const double* hi_err
    const double* lo_vals
    const double* hi_vals
    const double* s_lo
    const double* s_hi
    const double* amp
    const double* period
    const double* phase
    # the inverses' slopes, breaks over vals, interval by interval (b − 1,): the
    # division numpy's interp makes (beforehand, or at each point: the same)
    const double* si_lo
    const double* si_hi
    Py_ssize_t nb
    Py_ssize_t nc


cdef inline double _max(double a, double b) noexcept nogil:
    # numpy's maximum: the first when it is greater, or NaN; else the second (so
    # of −0.0 and 0.0 the second, as numpy gives: np.maximum(-0.0, 0.0) is 0.0)
    return a if (a > b or a != a) else b


cdef inline double _min(double a, double b) noexcept nogil:
    # numpy's minimum, the same way (np.minimum(0.0, -0.0) is -0.0)
    return a if (a < b or a != a) else b


cdef inline Py_ssize_t _find(double x, const double* xp, Py_ssize_t n, Py_ssize_t g) noexcept nogil:
    """numpy's binary_search_with_guess for x (not NaN) in xp (n >= 2, strictly
    increasing): −1 below, n above, n − 1 at its last value, else the j with
    xp[j] <= x < xp[j + 1] (unique, however found: the guess g first)."""
    cdef Py_ssize_t lo, hi, mid
    if x < xp[0]:
        return -1
    if x > xp[n - 1]:
        return n
    if x == xp[n - 1]:
        return n - 1
    if 0 <= g < n - 1 and xp[g] <= x:
        if x < xp[g + 1]:
            return g
        if g + 2 < n and x < xp[g + 2]:
            return g + 1
    elif 1 <= g < n and xp[g - 1] <= x:
        return g - 1  # x < xp[g] here
    lo = 0
    hi = n - 1  # xp[lo] <= x < xp[hi]
    while hi - lo > 1:
        mid = (lo + hi) >> 1
        if xp[mid] <= x:
            lo = mid
        else:
            hi = mid
    return lo


cdef inline double _at(double x, Py_ssize_t j, const double* xp, const double* fp,
                       Py_ssize_t n) noexcept nogil:
    """numpy's interp (compiled_base.c, arr_interp) at x (not NaN) in the interval
    j of :func:`_find`, end values held."""
    cdef double slope, r
    if j == -1:
        return fp[0]
    if j >= n - 1:
        return fp[n - 1]
    if xp[j] == x:
        return fp[j]
    slope = (fp[j + 1] - fp[j]) / (xp[j + 1] - xp[j])
    r = slope * (x - xp[j]) + fp[j]
    if r != r:
        r = slope * (x - xp[j + 1]) + fp[j + 1]
        if r != r and fp[j] == fp[j + 1]:
            r = fp[j]
    return r


cdef inline double _at_s(double x, Py_ssize_t j, const double* xp, const double* fp,
                         const double* slopes, Py_ssize_t n) noexcept nogil:
    """:func:`_at` with the intervals' slopes made beforehand (numpy makes them so
    when there are fewer table points than points asked for: the same division)."""
    cdef double r
    if j == -1:
        return fp[0]
    if j >= n - 1:
        return fp[n - 1]
    if xp[j] == x:
        return fp[j]
    r = slopes[j] * (x - xp[j]) + fp[j]
    if r != r:
        r = slopes[j] * (x - xp[j + 1]) + fp[j + 1]
        if r != r and fp[j] == fp[j + 1]:
            r = fp[j]
    return r


cdef inline double _interp(double x, const double* xp, const double* fp, Py_ssize_t n) noexcept nogil:
    """numpy's interp at one x."""
    if n == 1:
        return fp[0]
    if x != x:
        return x
    return _at(x, _find(x, xp, n, -1), xp, fp, n)


cdef inline double _cyc(const Tab* t, double p) noexcept nogil:
    cdef double out = 0.0
    cdef Py_ssize_t k
    for k in range(t.nc):
        out = out + t.amp[k] * sin(TWO_PI * p / t.period[k] + t.phase[k])
    return out


cdef inline double _lo(const Tab* t, double p) noexcept nogil:
    return p + _interp(p, t.breaks, t.lo_err, t.nb) + _cyc(t, p)


cdef inline double _hi(const Tab* t, double p) noexcept nogil:
    return p + _interp(p, t.breaks, t.hi_err, t.nb) + _cyc(t, p)


cdef inline Py_ssize_t _lo_hi(const Tab* t, double p, double* lo, double* hi,
                             Py_ssize_t g) noexcept nogil:
    """lo(p) and hi(p) (as :func:`_lo`, :func:`_hi`) on one search of the breaks,
    from the guess g; returns the interval found."""
    cdef double c = _cyc(t, p)
    cdef Py_ssize_t j = g
    if t.nb == 1:
        lo[0] = p + t.lo_err[0] + c
        hi[0] = p + t.hi_err[0] + c
    elif p != p:
        lo[0] = p + p + c
        hi[0] = lo[0]
    else:
        j = _find(p, t.breaks, t.nb, g)
        lo[0] = p + _at_s(p, j, t.breaks, t.lo_err, t.s_lo, t.nb) + c
        hi[0] = p + _at_s(p, j, t.breaks, t.hi_err, t.s_hi, t.nb) + c
    return j


cdef inline double _invert(double x, const double* vals, const double* breaks,
                           const double* err, Py_ssize_t n) noexcept nogil:
    cdef double out = _interp(x, vals, breaks, n)
    if x < vals[0]:
        out = x - err[0]
    elif x > vals[n - 1]:
        out = x - err[n - 1]
    return out


cdef inline double _invert_g(double x, const double* vals, const double* breaks,
                             const double* err, const double* si, Py_ssize_t n,
                             Py_ssize_t* g) noexcept nogil:
    """:func:`_invert`, its interval searched from the guess ``g`` (numpy's interp
    guesses the interval before; the interval found is the same, unique), the
    interval found left in ``g``; ``si`` the intervals' slopes (breaks over vals)."""
    cdef double out
    if n == 1:
        out = breaks[0]
    elif x != x:
        out = x
    else:
        g[0] = _find(x, vals, n, g[0])
        out = _at_s(x, g[0], vals, breaks, si, n)
    if x < vals[0]:
        out = x - err[0]
    elif x > vals[n - 1]:
        out = x - err[n - 1]
    return out


cdef void _solve(const Tab* t, const double* target, double* out, Py_ssize_t n,
                 bint up, double* scratch) noexcept nogil:
    """lo⁻¹ (``up``) or hi⁻¹ of ``target`` (n,) into ``out``; ``scratch`` (n,)."""
    cdef const double* vals = t.lo_vals if up else t.hi_vals
    cdef const double* err = t.lo_err if up else t.hi_err
    cdef const double* si = t.si_lo if up else t.si_hi
    cdef Py_ssize_t i, it, g = -1
    cdef double big, d
    cdef bint nan
    for i in range(n):
        out[i] = _invert_g(target[i], vals, t.breaks, err, si, t.nb, &g)
    if t.nc == 0:
        return
    for it in range(30):
        big = 0.0
        nan = False
        for i in range(n):
            scratch[i] = _invert(target[i] - _cyc(t, out[i]), vals, t.breaks, err, t.nb)
            d = fabs(scratch[i] - out[i])
            if d != d:
                nan = True
            elif d > big:
                big = d
        for i in range(n):
            out[i] = scratch[i]
        if not nan and big < 1e-13:
            break


cdef class _Table:
    """A PlayTable's arrays held as contiguous doubles, and the struct on them."""
    cdef Tab tab
    cdef object keep

    def __init__(self, t):
        cdef const double[::1] v
        cdef const double* ptr[10]
        cdef Py_ssize_t size[10]
        cdef int k
        cdef Py_ssize_t j
        cdef double[::1] si_lo
        cdef double[::1] si_hi
        self.keep = [np.ascontiguousarray(a, dtype=np.float64) for a in t]
        nb = len(self.keep[0])
        si = np.empty((2, nb))
        si_lo, si_hi = si[0], si[1]
        cdef const double[::1] br = self.keep[0]
        cdef const double[::1] lv = self.keep[3]
        cdef const double[::1] hv = self.keep[4]
        for j in range(nb - 1):
            si_lo[j] = (br[j + 1] - br[j]) / (lv[j + 1] - lv[j])
            si_hi[j] = (br[j + 1] - br[j]) / (hv[j + 1] - hv[j])
        self.keep.append(si)
        self.tab.si_lo = &si_lo[0] if nb else NULL
        self.tab.si_hi = &si_hi[0] if nb else NULL
        for k in range(10):
            v = self.keep[k]
            size[k] = v.shape[0]
            ptr[k] = &v[0] if v.shape[0] else NULL
        self.tab.breaks, self.tab.lo_err, self.tab.hi_err = ptr[0], ptr[1], ptr[2]
        self.tab.lo_vals, self.tab.hi_vals = ptr[3], ptr[4]
        self.tab.s_lo, self.tab.s_hi = ptr[5], ptr[6]
        self.tab.amp, self.tab.period, self.tab.phase = ptr[7], ptr[8], ptr[9]
        self.tab.nb = size[0]
        self.tab.nc = size[7]


#: the tables made, by the id of the PlayTable they hold (kept alive here, so the id
#: is theirs): a table (``MotorTable.flat``, made once) is made into its struct once
#: rather than at every call
_TABLES = {}


cdef _Table _table(t):
    # the settle hands its pieces the table it made once
    if type(t) is _Table:
        return <_Table>t
    hit = _TABLES.get(id(t))
    if hit is not None and hit[0] is t:
        return <_Table>hit[1]
    tb = _Table(t)
    if len(_TABLES) >= 64:
        _TABLES.clear()
    _TABLES[id(t)] = (t, tb)
    return tb


def _vec(p):
    return np.ascontiguousarray(p, dtype=np.float64)


def _lengths(str what, Py_ssize_t n, **lengths):
    """Refuse arrays whose ``lengths`` (name: length) are not ``n`` before the
    loops run without bounds checks: a ValueError naming what was expected and
    what was got."""
    for name, got in lengths.items():
        if got != n:
            raise ValueError(f"{name} must have {what} ({n} values), got {got}")


def _motion_lengths(mo, Py_ssize_t n):
    """A Motion's columns (and n) one value a point."""
    _lengths("one value a point", n, **{f: len(getattr(mo, f)) for f in mo._fields})


def lo(t, p):
    """lo(p) [mm]: :func:`play.lo`."""
    cdef _Table tb = _table(t)
    cdef const double[::1] x = _vec(p)
    out = np.empty(x.shape[0])
    cdef double[::1] o = out
    cdef Py_ssize_t i
    for i in range(x.shape[0]):
        o[i] = _lo(&tb.tab, x[i])
    return out


def hi(t, p):
    """hi(p) [mm]: :func:`play.hi`."""
    cdef _Table tb = _table(t)
    cdef const double[::1] x = _vec(p)
    out = np.empty(x.shape[0])
    cdef double[::1] o = out
    cdef Py_ssize_t i
    for i in range(x.shape[0]):
        o[i] = _hi(&tb.tab, x[i])
    return out


def _inv(t, target, bint up):
    cdef _Table tb = _table(t)
    cdef const double[::1] x = _vec(target)
    cdef Py_ssize_t n = x.shape[0]
    out = np.empty(n)
    scratch = np.empty(n)
    cdef double[::1] o = out
    cdef double[::1] s = scratch
    if n:
        _solve(&tb.tab, &x[0], &o[0], n, up, &s[0])
    return out


def lo_inv(t, target):
    """p [mm] with lo(p) = target: :func:`play.lo_inv`."""
    return _inv(t, target, True)


def hi_inv(t, target):
    """p [mm] with hi(p) = target: :func:`play.hi_inv`."""
    return _inv(t, target, False)


cdef inline double _slope1(const Tab* T, double pi_, double sdi,
                           Py_ssize_t* lo_i) noexcept nogil:
    """:func:`play.slope` at one position ``pi_`` on side ``sdi``, its interval
    searched from ``lo_i`` (the row before's) and left there."""
    cdef Py_ssize_t k
    cdef double v = 1.0, w
    if T.nb > 1:
        if pi_ >= T.breaks[0] and pi_ < T.breaks[T.nb - 1]:
            # breaks[lo_i] <= p < breaks[lo_i + 1], unique: searched from the
            # row before's
            lo_i[0] = _find(pi_, T.breaks, T.nb, lo_i[0])
            v = v + (T.s_lo[lo_i[0]] if sdi > 0 else T.s_hi[lo_i[0]])
        else:
            v = v + 0.0
    for k in range(T.nc):
        w = TWO_PI / T.period[k]
        v = v + T.amp[k] * w * cos(w * pi_ + T.phase[k])
    return v


cdef void _slope_core(const Tab* T, const double* x, const double* sd, Py_ssize_t n,
                      double* o) noexcept nogil:
    """:func:`play.slope` of ``x`` (n,) on sides ``sd`` (n,) into ``o``."""
    cdef Py_ssize_t i, lo_i = -1
    for i in range(n):
        o[i] = _slope1(T, x[i], sd[i], &lo_i)


def slope(t, p, side):
    """d lo/dp or d hi/dp: :func:`play.slope`."""
    cdef _Table tb = _table(t)
    cdef const double[::1] x = _vec(p)
    cdef const double[::1] sd = _vec(side)
    cdef Py_ssize_t n = x.shape[0]
    _lengths("one value a position", n, side=len(sd))
    out = np.empty(n)
    cdef double[::1] o = out
    if n:
        _slope_core(&tb.tab, &x[0], &sd[0], n, &o[0])
    return out


cdef int _sided_core(const Tab* T, const double* x, const double* sd, Py_ssize_t n,
                     double* o) except -1:
    """:func:`play.compensate_sided` of ``x`` (n,) on sides ``sd`` (n,) into ``o``:
    each side solved as one array (the periodic terms' iteration runs until the
    whole array has settled, as the reference's)."""
    cdef Py_ssize_t i, nu = 0, nd = 0, g_up = -1, g_dn = -1
    if n == 0:
        return 0
    if T.nc == 0:
        # no iteration: each value on its own (the guesses change the time only)
        for i in range(n):
            if sd[i] > 0:
                o[i] = _invert_g(x[i], T.lo_vals, T.breaks, T.lo_err, T.si_lo, T.nb, &g_up)
            else:
                o[i] = _invert_g(x[i], T.hi_vals, T.breaks, T.hi_err, T.si_hi, T.nb, &g_dn)
        return 0
    cdef double* g = <double*>PyMem_Malloc(3 * n * sizeof(double))
    if g == NULL:
        raise MemoryError()
    cdef double* r = g + n
    cdef double* sc = g + 2 * n
    for i in range(n):
        if sd[i] > 0:
            g[nu] = x[i]
            nu += 1
    if nu:
        _solve(T, g, r, nu, True, sc)
        nu = 0
        for i in range(n):
            if sd[i] > 0:
                o[i] = r[nu]
                nu += 1
    for i in range(n):
        if not sd[i] > 0:
            g[nd] = x[i]
            nd += 1
    if nd:
        _solve(T, g, r, nd, False, sc)
        nd = 0
        for i in range(n):
            if not sd[i] > 0:
                o[i] = r[nd]
                nd += 1
    PyMem_Free(g)
    return 0


def compensate_sided(t, target, side):
    """Commands pushed from ``side``: :func:`play.compensate_sided`."""
    cdef _Table tb = _table(t)
    cdef const double[::1] x = _vec(target)
    cdef const double[::1] sd = _vec(side)
    cdef Py_ssize_t n = x.shape[0]
    _lengths("one value a target", n, side=len(sd))
    out = np.empty(n)
    cdef double[::1] o = out
    if n:
        _sided_core(&tb.tab, &x[0], &sd[0], n, &o[0])
    return out


cdef int _commands_row(const Tab* T, const double* x, const double* vi, const double* sd,
                       Py_ssize_t n, double* Po, double* Vo) except -1:
    """:func:`play.table_commands` for one motor: ``Po`` = compensate_sided of ``x``
    (n,) on sides ``sd``, ``Vo`` = ``vi`` / the slope there. Without periodic terms
    in one pass (each value is its own); with them the inversion first, over the
    whole row (the reference's iteration runs over the array)."""
    cdef Py_ssize_t i, g_up = -1, g_dn = -1, lo_i = -1
    if T.nc == 0:
        for i in range(n):
            if sd[i] > 0:
                Po[i] = _invert_g(x[i], T.lo_vals, T.breaks, T.lo_err, T.si_lo, T.nb, &g_up)
            else:
                Po[i] = _invert_g(x[i], T.hi_vals, T.breaks, T.hi_err, T.si_hi, T.nb, &g_dn)
            Vo[i] = vi[i] / _slope1(T, Po[i], sd[i], &lo_i)
        return 0
    _sided_core(T, x, sd, n, Po)
    for i in range(n):
        Vo[i] = vi[i] / _slope1(T, Po[i], sd[i], &lo_i)
    return 0


def _in_place(a, str name):
    """Refuse an array the kernel cannot update in place as (motors, points)."""
    if not (isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 2
            and a.flags.c_contiguous and a.flags.writeable):
        raise ValueError(f"{name} must be a writeable C-ordered float array (motors, "
                         f"points), updated in place; got {type(a).__name__}")


def table_commands(tables, cols, P_ideal, V_ideal, side, P, V):
    """The commands of the motors ``cols`` through their tables:
    :func:`play.table_commands` (``P``, ``V`` C-ordered float arrays (R, n), their
    rows ``cols`` written in place)."""
    _in_place(P, "P")
    _in_place(V, "V")
    cdef double[:, ::1] Pm = P
    cdef double[:, ::1] Vm = V
    cdef Py_ssize_t R = Pm.shape[0], n = Pm.shape[1], i, nc
    _rows(V, "V", R, n)
    cdef const double[:, ::1] x = _rows(P_ideal, "P_ideal", R, n)
    cdef const double[:, ::1] vi = _rows(V_ideal, "V_ideal", R, n)
    cdef const double[:, ::1] sd = _rows(side, "side", R, n)
    cdef const long[::1] cv = np.ascontiguousarray(cols, dtype=np.int_)
    nc = cv.shape[0]
    _lengths("one value a motor, as cols", nc, tables=len(tables))
    for i in range(nc):
        if not 0 <= cv[i] < R:
            raise ValueError(f"cols must be rows of P (0 to {R - 1}), got {cv[i]}")
    cdef _Table tb
    if n == 0:
        return
    for i in range(nc):
        tb = _table(tables[i])
        _commands_row(&tb.tab, &x[cv[i], 0], &vi[cv[i], 0], &sd[cv[i], 0], n, &Pm[cv[i], 0],
                      &Vm[cv[i], 0])


def clamp_scan(lo, hi):
    """The play model's scan: :func:`play.clamp_scan`."""
    cdef const double[::1] a = _vec(lo)
    cdef const double[::1] b = _vec(hi)
    cdef Py_ssize_t n = a.shape[0], i
    _lengths("one value a row, as lo", n, hi=len(b))
    out = np.empty(n)
    cdef double[::1] o = out
    cdef double y
    if n == 0:
        return out
    y = a[0]
    o[0] = y
    for i in range(1, n):
        y = _min(_max(y, a[i]), b[i])
        o[i] = y
    return out


cdef inline bint _out01(double num, double den) noexcept nogil:
    """num / den rounded is surely not inside (0, 1), seen without dividing:
    rounding is monotone and keeps 0 and 1, so a quotient at or below 0 or at or
    above 1 stays there (NaN and the unsure: False, the division decides)."""
    if den > 0:
        return num <= 0 or num >= den
    if den < 0:
        return num >= 0 or num <= den
    return False


cdef Py_ssize_t _roots(const double* P0, const double* V0, const long* st, Py_ssize_t w,
                       const double* P, const double* V, const double* hv, Py_ssize_t n,
                       bint cubic, signed char* kind, double* S) noexcept nogil:
    """Each step's turning points inside it (0, 1 or 2 into ``kind``; their
    fractions into the rows of S (n, 2), NaN for a missing second), as
    :func:`play.follow_stretches` finds them, the command before each step taken
    where it is (a stretch's first from ``P0``, ``V0``); returns how many steps
    turn."""
    cdef Py_ssize_t i = 0, j, k, nt = 0
    cdef double h, hh, d, a, b, c, disc, sq, r1, r2, pa, va, den, n1, n2
    cdef bint ok1, ok2
    if not cubic:
        # straight lines: no step turns inside (ok1, ok2 below are false)
        for i in range(n):
            kind[i] = 0
        return 0
    for j in range(w):
        for k in range(st[j]):
            if k == 0:
                pa = P0[j]
                va = V0[j]
            else:
                pa = P[i - 1]
                va = V[i - 1]
            h = hv[i]
            hh = h if h > 0 else INFINITY
            d = (pa - P[i]) / hh
            a = 6.0 * d + 3.0 * (va + V[i])
            b = -6.0 * d - 4.0 * va - 2.0 * V[i]
            c = va
            disc = b * b - 4.0 * a * c
            kind[i] = 0
            if not (disc >= 0 and h > 0):
                # no root inside (ok1, ok2 below are false, NaN included): the
                # square root and the divisions are not needed
                i += 1
                continue
            if fabs(a) > 1e-300:
                sq = sqrt(_max(disc, 0.0))  # (the other branch takes no root)
                den = 2 * a
                n1 = -b - sq
                n2 = -b + sq
                if _out01(n1, den) and _out01(n2, den):
                    # neither root inside (ok1, ok2 below are false): no division
                    i += 1
                    continue
                r1 = n1 / den
                r2 = n2 / den
            else:
                r1 = -c / b if b != 0 else -1.0
                r2 = -1.0
            ok1 = disc >= 0 and r1 > 0 and r1 < 1 and h > 0 and cubic
            ok2 = disc >= 0 and r2 > 0 and r2 < 1 and h > 0 and fabs(r2 - r1) > 0 and cubic
            if ok1 and ok2:
                S[2 * nt] = _min(r1, r2)
                S[2 * nt + 1] = _max(r1, r2)
                kind[i] = 2
                nt += 1
            elif ok1 or ok2:
                S[2 * nt] = r1 if ok1 else r2
                S[2 * nt + 1] = NAN
                kind[i] = 1
                nt += 1
            i += 1
    return nt


cdef inline double _hermite(double s, double s3, double P0, double V0, double P1,
                            double V1, double h) noexcept nogil:
    """:func:`play.hermite` at one fraction s (its cube ``s3`` as numpy made it)."""
    cdef double s2 = s * s
    cdef double h00 = 2 * s3 - 3 * s2 + 1
    cdef double h10 = s3 - 2 * s2 + s
    cdef double h01 = -2 * s3 + 3 * s2
    cdef double h11 = s3 - s2
    return h00 * P0 + h10 * (h * V0) + h01 * P1 + h11 * (h * V1)


cdef int _follow_core(const Tab* T, const double* y0v, const double* P0v, const double* V0v,
                      const long* st, Py_ssize_t w, const double* Pv, const double* Vv,
                      const double* hv, Py_ssize_t n, bint cubic, double* ye, double* ymn,
                      double* ymx) except -1:
    """:func:`play.follow_stretches` over pointers: the stretches' starts (w,), their
    steps (n,) (``st`` (w,) of them each) into ``ye``, ``ymn``, ``ymx`` (n,)."""
    cdef Py_ssize_t i, j, k, m, nt, ti
    if n == 0:
        return 0
    # per step: its turning points (0, 1 or 2) and where they are
    cdef signed char* kind = <signed char*>PyMem_Malloc(n)
    cdef double* S = <double*>PyMem_Malloc(2 * n * sizeof(double))
    if kind == NULL or S == NULL:
        PyMem_Free(kind)
        PyMem_Free(S)
        raise MemoryError()
    nt = _roots(P0v, V0v, st, w, Pv, Vv, hv, n, cubic, kind, S)
    # s**3 as the reference takes it: numpy's power over the (turns, 2) array
    cdef double[:, ::1] Sv
    cdef const double[:, ::1] S3
    if nt:
        S_a = np.empty((nt, 2))
        Sv = S_a
        memcpy(&Sv[0, 0], S, 2 * nt * sizeof(double))
        S3 = S_a ** 3
    cdef double x, y = 0.0, lo_x, hi_x, mn, mx, pa = 0.0, va = 0.0
    cdef bint started = False
    cdef Py_ssize_t g = -1
    i = 0
    ti = 0
    for j in range(w):
        for k in range(st[j]):
            if k == 0:
                # the stretch opens where its part stands
                y = y0v[j] if not started else _min(_max(y, y0v[j]), y0v[j])
                started = True
            if kind[i]:
                # the command before the step, for its cubic
                pa = P0v[j] if k == 0 else Pv[i - 1]
                va = V0v[j] if k == 0 else Vv[i - 1]
                mn = INFINITY
                mx = -INFINITY
                for m in range(kind[i]):
                    x = _hermite(S[2 * ti + m], S3[ti, m], pa, va, Pv[i], Vv[i], hv[i])
                    g = _lo_hi(T, x, &lo_x, &hi_x, g)
                    y = _min(_max(y, lo_x), hi_x)
                    mn = _min(mn, y)  # numpy's reduce: a NaN wins
                    mx = _max(mx, y)
                ti += 1
                g = _lo_hi(T, Pv[i], &lo_x, &hi_x, g)
                y = _min(_max(y, lo_x), hi_x)
                mn = _min(mn, y)
                mx = _max(mx, y)
            else:
                g = _lo_hi(T, Pv[i], &lo_x, &hi_x, g)
                y = _min(_max(y, lo_x), hi_x)
                # one sample: numpy's reduce of one value is the value
                mn = y
                mx = y
            ye[i] = y
            ymn[i] = mn
            ymx[i] = mx
            i += 1
    PyMem_Free(kind)
    PyMem_Free(S)
    return 0


def follow_stretches(t, y0, P0, V0, P, V, dt, steps, bint cubic=True):
    """The part along the commands' cubics: :func:`play.follow_stretches`."""
    cdef _Table tb = _table(t)
    cdef const double[::1] y0v = _vec(y0)
    cdef const double[::1] P0v = _vec(P0)
    cdef const double[::1] V0v = _vec(V0)
    cdef const double[::1] Pv = _vec(P)
    cdef const double[::1] Vv = _vec(V)
    cdef const double[::1] hv = _vec(dt)
    cdef const long[::1] st = np.ascontiguousarray(steps, dtype=np.int_)
    cdef Py_ssize_t n = Pv.shape[0], w = st.shape[0], j, total = 0
    for j in range(w):
        total += st[j]
    if total != n or y0v.shape[0] != w or P0v.shape[0] != w or V0v.shape[0] != w:
        raise ValueError("steps must sum to len(P), and y0, P0, V0 have one value a stretch")
    if Vv.shape[0] != n or hv.shape[0] != n:
        raise ValueError("P, V and dt must have one value a step")
    y_end = np.empty(n)
    y_min = np.empty(n)
    y_max = np.empty(n)
    if n == 0:
        return y_end, y_min, y_max
    cdef double[::1] ye = y_end
    cdef double[::1] ymn = y_min
    cdef double[::1] ymx = y_max
    _follow_core(&tb.tab, &y0v[0], &P0v[0], &V0v[0], &st[0], w, &Pv[0], &Vv[0], &hv[0], n,
                 cubic, &ye[0], &ymn[0], &ymx[0])
    return y_end, y_min, y_max


cdef inline bint _lt(double a, double b) noexcept nogil:
    # numpy's sort order (NaN last), as searchsorted compares
    return a < b or (b != b and a == a)


cdef inline double _sign(double x) noexcept nogil:
    if x > 0:
        return 1.0
    if x < 0:
        return -1.0
    if x == 0:
        return 0.0
    return x


cdef void _taken_up_ahead(const double* off, const double* wy, const signed char* ahead,
                          const double* rate, const long* length, Py_ssize_t m,
                          const long* idx, const double* s, const double* dP,
                          const double* Vm, const double* speed, double* mag,
                          double* steep_motor) noexcept nogil:
    """:func:`play._taken_up_ahead`: the take summed over every crossing's points in
    one running sum, each range's sum less the sum before it (as the reference)."""
    cdef Py_ssize_t i, j, k = 0
    cdef double cum = 0.0, before, ds, take, w, sv
    for i in range(m):
        if not ahead[i]:
            # takes of 0.0: the running sum (never −0.0) stays as it is
            k += length[i]
            continue
        before = cum
        w = wy[i]
        for j in range(length[i]):
            ds = s[idx[k]] - (s[idx[k] - 1] if idx[k] >= 1 else 0.0)
            take = _min(rate[i] * ds, _max(0.5 * w * dP[idx[k]], 0.0))
            cum = cum + take
            mag[k] = _max(fabs(off[i]) - (cum - before), 0.0)
            # the motor's limit only where an offset is left (_slopes reads no other)
            sv = speed[idx[k]] if mag[k] > 0 else 0.0
            if sv > 0:
                steep_motor[k] = _max(0.5 * w * Vm[idx[k]], 0.0) / sv
            k += 1


cdef void _left_at_last(const double* off, const long* st, const long* last,
                        const double* s0, const double* rate, const long* length,
                        const signed char* ahead, bint any_ahead, Py_ssize_t m,
                        const double* s, const double* mag, double* left) noexcept nogil:
    """:func:`play._left_at_last`."""
    cdef Py_ssize_t i, k = 0
    cdef double s_last, lm
    for i in range(m):
        s_last = s[last[i] if last[i] > 0 else 0] if last[i] > st[i] else s0[i]
        lm = _max(fabs(off[i]) - rate[i] * (s_last - s0[i]), 0.0)
        k += length[i]
        if any_ahead and ahead[i]:
            lm = mag[k - 1] if length[i] > 0 else fabs(off[i])
        left[i] = copysign(lm, off[i])


cdef Py_ssize_t _rates(const double* off, const signed char* ahead, const long* st,
                       const long* sp, Py_ssize_t m, const double* s, Py_ssize_t n,
                       double share, double hurry, double* s0, double* rate, long* last,
                       long* length) noexcept nogil:
    """Each crossing's path length at its start, the last point carrying its offset,
    its rate (:func:`play._catch_up_rates`) and how many points take it up (to
    where the path has run the offset off: numpy's searchsorted, left); returns
    the points of all."""
    cdef Py_ssize_t i, lo_, hi_, mid, K = 0
    cdef double room, need, key
    cdef long gone, end, first
    for i in range(m):
        s0[i] = s[st[i] if st[i] > 0 else 0] if st[i] >= 0 else 0.0
        last[i] = sp[i] if sp[i] < n else n - 1
        room = s[last[i]] - s0[i] if (sp[i] < n and last[i] > st[i]) else 0.0
        need = fabs(off[i]) / room if room > 0 else INFINITY
        rate[i] = _max(need, share) if need <= hurry * share else share
        key = s0[i] + fabs(off[i]) / rate[i]
        first = st[i] + 1
        if ahead[i]:
            end = last[i] + 1
        else:
            # searched between first and last + 1 only: s (sorted, NaN last) puts
            # a point found before first at first, and one after last + 1 at
            # last + 1, where end and length below clip it the same
            lo_ = first
            hi_ = last[i] + 1
            while lo_ < hi_:
                mid = (lo_ + hi_) >> 1
                if _lt(s[mid], key):
                    lo_ = mid + 1
                else:
                    hi_ = mid
            gone = lo_
            end = last[i] + 1 if last[i] + 1 < gone else gone
        length[i] = end - first if end - first > 0 else 0
        K += length[i]
    return K


cdef void _slopes(const double* off, const double* rate, const long* length, Py_ssize_t m,
                  const long* idx, const double* mag, const double* steep_motor,
                  const double* s, Py_ssize_t n, long* oidx, double* ooff,
                  double* oslope) noexcept nogil:
    """:func:`play._catch_up_slopes` at the points with an offset left, which go
    out with their offsets."""
    cdef Py_ssize_t i, jj, j = 0, k = 0
    cdef double ah, stp, offk
    for i in range(m):
        for jj in range(length[i]):
            if mag[k] > 0:
                offk = copysign(mag[k], off[i])
                ah = s[idx[k] + 1] - s[idx[k]] if idx[k] + 1 < n else INFINITY
                stp = _min(rate[i], mag[k] / ah if ah > 0 else INFINITY)
                stp = _min(stp, steep_motor[k])
                oidx[j] = idx[k]
                ooff[j] = offk
                oslope[j] = -_sign(offk) * stp
                j += 1
            k += 1


cdef Py_ssize_t _catch_up_core(const double* o0, const double* wy, const long* st,
                               const long* sp, Py_ssize_t m, const double* s, Py_ssize_t n,
                               double share, double hurry, bint has_motion,
                               const double* dP, const double* Vm, const double* speed,
                               long** oidx, double** ooff, double** oslope,
                               double* left) except -1:
    """:func:`play.catch_up` over pointers: the points with an offset left, their
    offsets and slopes into ``oidx``, ``ooff``, ``oslope`` (allocated here, the
    caller frees them; their count returned), the offsets left into ``left``
    (m,)."""
    cdef Py_ssize_t i, j, k, K, nk = 0
    cdef double x, mag0
    cdef bint any_ahead = False
    oidx[0] = NULL
    ooff[0] = NULL
    oslope[0] = NULL
    cdef char* mem = <char*>PyMem_Malloc(m * (3 * sizeof(double) + 2 * sizeof(long) + 1) + 1)
    if mem == NULL:
        raise MemoryError()
    cdef double* off = <double*>mem
    cdef double* s0 = off + m
    cdef double* rate = s0 + m
    cdef long* last = <long*>(rate + m)
    cdef long* length = last + m
    cdef signed char* ahead = <signed char*>(length + m)
    for i in range(m):
        x = o0[i] * wy[i]
        ahead[i] = x > 0 and has_motion
        any_ahead = any_ahead or ahead[i]
        off[i] = o0[i] if (x < 0 or ahead[i]) else 0.0
    if n == 0:
        for i in range(m):
            left[i] = off[i]
        PyMem_Free(mem)
        return 0
    K = _rates(off, ahead, st, sp, m, s, n, share, hurry, s0, rate, last, length)
    cdef char* kmem = <char*>PyMem_Malloc(K * (2 * sizeof(double) + sizeof(long)) + 1)
    if kmem == NULL:
        PyMem_Free(mem)
        raise MemoryError()
    cdef double* mag = <double*>kmem
    cdef double* steep_motor = mag + K
    cdef long* idx = <long*>(steep_motor + K)
    k = 0
    for i in range(m):
        mag0 = fabs(off[i])
        for j in range(length[i]):
            idx[k] = st[i] + 1 + j
            mag[k] = _max(mag0 - rate[i] * (s[idx[k]] - s0[i]), 0.0)
            steep_motor[k] = INFINITY
            k += 1
    if has_motion and any_ahead:
        _taken_up_ahead(off, wy, ahead, rate, length, m, idx, s, dP, Vm, speed, mag, steep_motor)
    _left_at_last(off, st, last, s0, rate, length, ahead, any_ahead, m, s, mag, left)
    # _catch_up_slopes, and only the points with an offset left
    for k in range(K):
        if mag[k] > 0:
            nk += 1
    oidx[0] = <long*>PyMem_Malloc(nk * sizeof(long) + 1)
    ooff[0] = <double*>PyMem_Malloc(nk * sizeof(double) + 1)
    oslope[0] = <double*>PyMem_Malloc(nk * sizeof(double) + 1)
    if oidx[0] == NULL or ooff[0] == NULL or oslope[0] == NULL:
        PyMem_Free(mem)
        PyMem_Free(kmem)
        raise MemoryError()
    if nk:
        _slopes(off, rate, length, m, idx, mag, steep_motor, s, n, oidx[0], ooff[0], oslope[0])
    PyMem_Free(mem)
    PyMem_Free(kmem)
    return nk


def catch_up(off0, way, start, stop, s_path, double share, double hurry, motion=None):
    """The offsets taken up after crossings: :func:`play.catch_up`."""
    cdef const double[::1] o0 = _vec(off0)
    cdef const double[::1] wy = _vec(way)
    cdef const long[::1] st = np.ascontiguousarray(start, dtype=np.int_)
    cdef const long[::1] sp = np.ascontiguousarray(stop, dtype=np.int_)
    cdef const double[::1] s = _vec(s_path)
    cdef Py_ssize_t m = o0.shape[0], n = s.shape[0], nk
    cdef bint has_motion = motion is not None
    _lengths("one value a crossing, as off0", m, way=len(wy), start=len(st), stop=len(sp))
    if has_motion:
        _lengths("one value a point, as s_path", n, dP=len(motion[0]), V=len(motion[1]),
                 speed=len(motion[2]))
    cdef const double[::1] dP
    cdef const double[::1] Vm
    cdef const double[::1] speed
    cdef const double* p_dP = NULL
    cdef const double* p_Vm = NULL
    cdef const double* p_sp = NULL
    if has_motion and n:
        dP = _vec(motion[0])
        Vm = _vec(motion[1])
        speed = _vec(motion[2])
        p_dP, p_Vm, p_sp = &dP[0], &Vm[0], &speed[0]
    left_a = np.empty(m)
    if m == 0:
        none = np.zeros(0)
        return none.astype(int), none, none.copy(), left_a
    cdef double[::1] left = left_a
    cdef long* oidx
    cdef double* ooff
    cdef double* oslope
    nk = _catch_up_core(&o0[0], &wy[0], &st[0], &sp[0], m, &s[0] if n else NULL, n, share,
                        hurry, has_motion, p_dP, p_Vm, p_sp, &oidx, &ooff, &oslope, &left[0])
    idx_a = np.empty(nk, dtype=np.int_)
    off_a = np.empty(nk)
    slope_a = np.empty(nk)
    cdef long[::1] iv = idx_a
    cdef double[::1] ov = off_a
    cdef double[::1] sv = slope_a
    if nk:
        memcpy(&iv[0], oidx, nk * sizeof(long))
        memcpy(&ov[0], ooff, nk * sizeof(double))
        memcpy(&sv[0], oslope, nk * sizeof(double))
    PyMem_Free(oidx)
    PyMem_Free(ooff)
    PyMem_Free(oslope)
    return idx_a, off_a, slope_a, left_a


cdef struct Mo:
    # one motor's columns over a chunk (play.Motion), n values each
    const double* P_ideal
    const double* V_ideal
    const double* dP
    const double* speed
    const double* dt
    const double* s_path
    const double* side
    Py_ssize_t n


cdef class _Motion:
    """A Motion's columns held as contiguous doubles, and the struct on them."""
    cdef Mo mo
    cdef object keep

    def __init__(self, mo):
        cdef const double[::1] v
        cdef const double* ptr[7]
        cdef int k
        self.keep = [np.ascontiguousarray(a, dtype=np.float64) for a in mo]
        for k in range(7):
            v = self.keep[k]
            ptr[k] = &v[0] if v.shape[0] else NULL
        self.mo.P_ideal, self.mo.V_ideal, self.mo.dP, self.mo.speed = ptr[0], ptr[1], ptr[2], ptr[3]
        self.mo.dt, self.mo.s_path, self.mo.side = ptr[4], ptr[5], ptr[6]
        self.mo.n = len(self.keep[0])


cdef int _commands_core(const Tab* T, const Mo* mo, const double* off0, const long* st,
                        const long* sp, Py_ssize_t m, double* Pv, double* Vv, double share,
                        double hurry, double* left, double* carry) except -1:
    """:func:`play.catch_up_commands` over pointers: ``Pv``, ``Vv`` (n,) updated in
    place, the offsets left into ``left`` (m,), the offset carried into ``carry``."""
    cdef Py_ssize_t n = mo.n, i, k, K
    cdef long* idx
    cdef double* off
    cdef double* slp
    cdef double* way = <double*>PyMem_Malloc(m * sizeof(double) + 1)
    if way == NULL:
        raise MemoryError()
    for i in range(m):
        way[i] = mo.side[st[i] if st[i] > 0 else 0]
    K = _catch_up_core(off0, way, st, sp, m, mo.s_path, n, share, hurry, True, mo.dP,
                       mo.V_ideal, mo.speed, &idx, &off, &slp, left)
    PyMem_Free(way)
    carry[0] = NAN
    if m and sp[m - 1] >= n and left[m - 1] != 0.0:
        carry[0] = left[m - 1]
    cdef double* buf = <double*>PyMem_Malloc(4 * K * sizeof(double) + 1)
    if buf == NULL:
        PyMem_Free(idx)
        PyMem_Free(off)
        PyMem_Free(slp)
        raise MemoryError()
    cdef double* tg = buf
    cdef double* sd = buf + K
    cdef double* pk = buf + 2 * K
    cdef double* sl = buf + 3 * K
    if K:
        for k in range(K):
            tg[k] = mo.P_ideal[idx[k]] + off[k]
            sd[k] = mo.side[idx[k]]
        _sided_core(T, tg, sd, K, pk)
        _slope_core(T, pk, sd, K, sl)
        for k in range(K):
            Pv[idx[k]] = pk[k]
            Vv[idx[k]] = (mo.V_ideal[idx[k]] + slp[k] * mo.speed[idx[k]]) / sl[k]
    for i in range(m):
        if not sp[i] < n:
            left[i] = 0.0
    PyMem_Free(buf)
    PyMem_Free(idx)
    PyMem_Free(off)
    PyMem_Free(slp)
    return 0


def catch_up_commands(t, mo, off0, start, stop, P, V, double share, double hurry):
    """The take-up's commands: :func:`play.catch_up_commands` (``P``, ``V``
    contiguous float arrays, updated in place)."""
    cdef _Table tb = _table(t)
    cdef double[::1] Pv = P
    cdef double[::1] Vv = V
    _lengths("one value a point, as P", Pv.shape[0], V=len(Vv))
    _motion_lengths(mo, Pv.shape[0])
    cdef _Motion mv = _Motion(mo)
    cdef const long[::1] st = np.ascontiguousarray(start, dtype=np.int_)
    cdef const long[::1] sp = np.ascontiguousarray(stop, dtype=np.int_)
    cdef const double[::1] o0 = _vec(off0)
    cdef Py_ssize_t m = st.shape[0]
    _lengths("one value a crossing, as start", m, stop=len(sp), off0=len(o0))
    left_a = np.empty(m)
    cdef double[::1] left = left_a
    cdef double carry = NAN
    if m:
        _commands_core(&tb.tab, &mv.mo, &o0[0], &st[0], &sp[0], m,
                       &Pv[0] if Pv.shape[0] else NULL, &Vv[0] if Vv.shape[0] else NULL,
                       share, hurry, &left[0], &carry)
    return left_a, carry


cdef void _extreme(const double* lo, const double* hi, Py_ssize_t n, const long* cuts,
                   const double* beg, const signed char* up, double* out,
                   Py_ssize_t c) noexcept nogil:
    """:func:`play._extreme`: numpy's reduceat over [cuts[2i], cuts[2i + 1]) (the
    value at cuts[2i] where that is empty; ±inf past the end)."""
    cdef Py_ssize_t i, j, a, z
    cdef double x
    for i in range(c):
        a = cuts[2 * i]
        z = cuts[2 * i + 1]
        if up[i]:
            x = lo[a] if a < n else INFINITY
            for j in range(a + 1, z):
                x = _min(x, lo[j] if j < n else INFINITY)
            out[i] = _min(x, beg[i])
        else:
            x = hi[a] if a < n else -INFINITY
            for j in range(a + 1, z):
                x = _max(x, hi[j] if j < n else -INFINITY)
            out[i] = _max(x, beg[i])


cdef int _contact_core(const Tab* T, const double* y, const signed char* u, const double* sh,
                       Py_ssize_t c, double* out) except -1:
    """:func:`play._contact` of ``y`` (c,) into ``out`` (lo⁻¹ and hi⁻¹ each over the
    whole array, as the reference's np.where takes them)."""
    cdef Py_ssize_t i
    if c == 0:
        return 0
    cdef double* buf = <double*>PyMem_Malloc(3 * c * sizeof(double))
    if buf == NULL:
        raise MemoryError()
    cdef double* a = buf
    cdef double* b = buf + c
    _solve(T, y, a, c, True, buf + 2 * c)
    _solve(T, y, b, c, False, buf + 2 * c)
    for i in range(c):
        out[i] = a[i] - sh[i] if u[i] else b[i] + sh[i]
    PyMem_Free(buf)
    return 0


def _contact(t, y, up, shortfall):
    """:func:`play._contact`."""
    cdef _Table tb = _table(t)
    cdef const double[::1] yv = _vec(y)
    cdef const signed char[::1] u = np.ascontiguousarray(up, dtype=np.int8)
    cdef const double[::1] s = _vec(shortfall)
    cdef Py_ssize_t c = yv.shape[0]
    _lengths("one value a crossing, as y", c, up=len(u), shortfall=len(s))
    out = np.empty(c)
    cdef double[::1] o = out
    if c:
        _contact_core(&tb.tab, &yv[0], &u[0], &s[0], c, &o[0])
    return out


cdef struct Crossings:
    # a motor's c crossings as settle_crossings holds them
    const long* e
    const long* b
    const signed char* u
    const double* shortfall
    const long* stops
    const double* made
    const double* P_made
    const double* V_made
    Py_ssize_t c


cdef int _settle_core(const Tab* T, const Mo* mo, double y0, double P0, double V0,
                      const long* ev, const long* bv, const double* shv, Py_ssize_t c,
                      double* Pv, double* Vv, bint cubic, double share, double hurry,
                      double* res) except -1:
    """:func:`play.settle_crossings` for c >= 1 crossings, the commands ``Pv``, ``Vv``
    (mo.n,) updated in place: ``res`` the part, the command's position and
    velocity at the last contact and the offset carried (NaN: none)."""
    cdef Py_ssize_t n = mo.n, i, k, upto = 0, w
    cdef double carry = NAN, cr
    for i in range(c):
        if ev[i] + 1 > upto:
            upto = ev[i] + 1
    # the work arrays: n values (the follow's three, the commands as made) and c
    cdef double* buf = <double*>PyMem_Malloc((5 * n + 6 * c + 1) * sizeof(double))
    cdef long* ibuf = <long*>PyMem_Malloc((5 * c + 1) * sizeof(long))
    cdef signed char* u = <signed char*>PyMem_Malloc(c + 1)
    if buf == NULL or ibuf == NULL or u == NULL:
        PyMem_Free(buf)
        PyMem_Free(ibuf)
        PyMem_Free(u)
        raise MemoryError()
    cdef double* y_pt = buf
    cdef double* lo_ = buf + n
    cdef double* hi_ = buf + 2 * n
    cdef double* P_made = buf + 3 * n
    cdef double* V_made = buf + 4 * n
    cdef double* at_beg = buf + 5 * n
    cdef double* made = at_beg + c
    cdef double* y_s = made + c
    cdef double* off = y_s + c
    cdef double* left = off + c
    cdef double* ct = left + c
    cdef long* cuts = ibuf
    cdef long* stops = ibuf + 2 * c
    cdef long* todo = ibuf + 3 * c
    cdef long* nxt = ibuf + 4 * c
    cdef long one_step = upto
    cdef Crossings X
    try:
        _follow_core(T, &y0, &P0, &V0, &one_step, 1, Pv, Vv, mo.dt, upto, cubic, y_pt, lo_,
                     hi_)
        for i in range(c):
            at_beg[i] = y_pt[bv[i] if bv[i] > 0 else 0] if bv[i] >= 0 else y0
            cuts[2 * i] = bv[i] + 1 if bv[i] + 1 > 0 else 0
            cuts[2 * i + 1] = ev[i] + 1
            u[i] = mo.side[ev[i]] > 0
            stops[i] = bv[i + 1] if i + 1 < c else n
            made[i] = Pv[ev[i]]
        _extreme(lo_, hi_, upto, cuts, at_beg, u, y_s, c)
        _contact_core(T, y_s, u, shv, c, ct)
        for i in range(c):
            Pv[ev[i]] = ct[i]
            off[i] = y_s[i] - mo.P_ideal[ev[i]]
        memcpy(P_made, Pv, n * sizeof(double))
        memcpy(V_made, Vv, n * sizeof(double))
        _commands_core(T, mo, off, ev, stops, c, Pv, Vv, share, hurry, left, &cr)
        if cr == cr:
            carry = cr
        # a part still off where the next crossing begins takes that offset into it
        w = 0
        for i in range(1, c):
            if left[i - 1] != 0.0:
                todo[w] = i
                w += 1
        X.e, X.b, X.u, X.shortfall, X.stops = ev, bv, u, shv, stops
        X.made, X.P_made, X.V_made, X.c = made, P_made, V_made, c
        while w:
            w = _reckon_again(T, mo, &X, todo, w, y_s, left, Pv, Vv, cubic, share, hurry, &cr,
                              nxt)
            if cr == cr:
                carry = cr
            todo, nxt = nxt, todo
        k = 0
        for i in range(c):
            if ev[i] > ev[k]:
                k = i
        res[0] = y_s[k]
        res[1] = Pv[upto - 1]
        res[2] = Vv[upto - 1]
        res[3] = carry
        return 0
    finally:
        PyMem_Free(buf)
        PyMem_Free(ibuf)
        PyMem_Free(u)


def settle_crossings(t, mo, before, e, b, shortfall, P, V, bint cubic, double share,
                     double hurry):
    """The crossings ended where the parts stand: :func:`play.settle_crossings`."""
    cdef _Table tb = _table(t)
    cdef _Motion mv = _Motion(mo)
    cdef const double[::1] shv = _vec(shortfall)
    P_a = np.array(P, dtype=np.float64)
    V_a = np.array(V, dtype=np.float64)
    cdef double[::1] Pv = P_a
    cdef double[::1] Vv = V_a
    cdef const long[::1] ev = np.ascontiguousarray(e, dtype=np.int_)
    cdef const long[::1] bv = np.ascontiguousarray(b, dtype=np.int_)
    cdef Py_ssize_t n = Pv.shape[0], c = ev.shape[0]
    cdef double res[4]
    _motion_lengths(mo, n)
    _lengths("one value a point, as P", n, V=len(Vv))
    _lengths("one value a crossing, as e", c, b=len(bv), shortfall=len(shv))
    if c == 0:
        raise ValueError("e must have a crossing at least (the reference's e.max()), got none")
    _settle_core(&tb.tab, &mv.mo, before[0], before[1], before[2], &ev[0], &bv[0], &shv[0], c,
                 &Pv[0], &Vv[0], cubic, share, hurry, res)
    return _pure.Settled(P_a, V_a, res[0], res[1], res[2], res[3])


cdef void _stretches(const Mo* mo, const Crossings* X, const long* todo, Py_ssize_t w,
                     const long* span, Py_ssize_t K, const double* y_s, const double* Pv,
                     const double* Vv, double* y0, double* P0, double* V0, double* Pw,
                     double* Vw, double* dtw) noexcept nogil:
    """:func:`_reckon_again`'s stretches, from each crossing before to each
    crossing's end (K points in all), their starts, and the crossings' ends as
    made (numpy's order: the last write wins, index −1 the last element)."""
    cdef Py_ssize_t i, j, k = 0, ti, ep
    for i in range(w):
        ti = todo[i]
        ep = X.e[ti - 1]
        y0[i] = y_s[ti - 1]
        P0[i] = Pv[ep]
        V0[i] = Vv[ep]
        for j in range(span[i]):
            Pw[k] = Pv[ep + 1 + j]
            Vw[k] = Vv[ep + 1 + j]
            dtw[k] = mo.dt[ep + 1 + j]
            k += 1
    k = 0
    for i in range(w):
        k += span[i]
        if K:
            Pw[k - 1 if k >= 1 else K - 1] = X.made[todo[i]]


cdef Py_ssize_t _reckon_again(const Tab* T, const Mo* mo, const Crossings* X, const long* todo,
                              Py_ssize_t w, double* y_s, double* left, double* Pv, double* Vv,
                              bint cubic, double share, double hurry, double* carry,
                              long* moved) except -1:
    """One round: :func:`play._reckon_again` for the crossings ``todo`` (w,); the
    crossings the next round reckons again into ``moved``, their count returned."""
    cdef Py_ssize_t n = mo.n, c = X.c, i, j, k, K = 0, ti, ep, ej, into, base, hi_end, nm
    cdef long* span = <long*>PyMem_Malloc((4 * w + 1) * sizeof(long))
    if span == NULL:
        raise MemoryError()
    cdef long* cuts = span + w
    cdef long* ejv = span + 3 * w
    for i in range(w):
        span[i] = X.e[todo[i]] - X.e[todo[i] - 1]
        K += span[i]
    cdef double* buf = <double*>PyMem_Malloc((6 * K + 12 * w + 1) * sizeof(double))
    cdef signed char* uu = <signed char*>PyMem_Malloc(w + 1)
    if buf == NULL or uu == NULL:
        PyMem_Free(span)
        PyMem_Free(buf)
        PyMem_Free(uu)
        raise MemoryError()
    cdef double* Pw = buf
    cdef double* Vw = buf + K
    cdef double* dtw = buf + 2 * K
    cdef double* y_w = buf + 3 * K
    cdef double* lo_w = buf + 4 * K
    cdef double* hi_w = buf + 5 * K
    cdef double* y0 = buf + 6 * K
    cdef double* P0 = y0 + w
    cdef double* V0 = P0 + w
    cdef double* beg = V0 + w
    cdef double* ys = beg + w
    cdef double* sh = ys + w
    cdef double* ct = sh + w
    cdef double* off = ct + w
    cdef double* new_left = off + w
    try:
        _stretches(mo, X, todo, w, span, K, y_s, Pv, Vv, y0, P0, V0, Pw, Vw, dtw)
        _follow_core(T, y0, P0, V0, span, w, Pw, Vw, dtw, K, cubic, y_w, lo_w, hi_w)
        base = 0
        for i in range(w):
            ti = todo[i]
            ep = X.e[ti - 1]
            into = X.b[ti] - ep if X.b[ti] - ep > 0 else 0
            beg[i] = y_w[base + into - 1] if into > 0 else y_s[ti - 1]
            cuts[2 * i] = base + into
            cuts[2 * i + 1] = base + span[i]
            uu[i] = X.u[ti]
            sh[i] = X.shortfall[ti]
            base += span[i]
        _extreme(lo_w, hi_w, K, cuts, beg, uu, ys, w)
        _contact_core(T, ys, uu, sh, w, ct)
        # ended where their parts stand, the take-up after each back to the
        # commands as made
        for i in range(w):
            y_s[todo[i]] = ys[i]
        for i in range(w):
            Pv[X.e[todo[i]]] = ct[i]
        for i in range(w):
            ti = todo[i]
            ej = X.e[ti]
            hi_end = X.stops[ti] + 1 if X.stops[ti] + 1 < n else n
            for j in range(ej + 1, hi_end):
                Pv[j] = X.P_made[j]
                Vv[j] = X.V_made[j]
            off[i] = y_s[ti] - mo.P_ideal[ej]
            ejv[i] = ej
            cuts[i] = X.stops[ti]  # the round's stops (cuts no longer needed)
        _commands_core(T, mo, off, ejv, cuts, w, Pv, Vv, share, hurry, new_left, carry)
        nm = 0
        for i in range(w):
            ti = todo[i]
            if new_left[i] != left[ti] and ti + 1 < c:
                moved[nm] = ti + 1
                nm += 1
            left[ti] = new_left[i]
        return nm
    finally:
        PyMem_Free(span)
        PyMem_Free(buf)
        PyMem_Free(uu)


cdef int _across(const double* t, const long* e, const long* b, Py_ssize_t c, double P0,
                 double* P, double* V) except -1:
    """:func:`play.across` on :func:`play.across_rows`' rows of the crossings (c,):
    every window's first and last command taken before any point inside is moved
    (numpy's gather, then its scatter, in the rows' order)."""
    cdef Py_ssize_t i, j, b0
    cdef double* buf = <double*>PyMem_Malloc((3 * c + 1) * sizeof(double))
    if buf == NULL:
        raise MemoryError()
    cdef double* P_b = buf
    cdef double* rate = buf + c
    cdef double* t_b = buf + 2 * c
    for i in range(c):
        if e[i] - b[i] - 1 > 0:
            b0 = b[i] if b[i] > 0 else 0
            t_b[i] = t[b0] if b[i] >= 0 else 0.0
            P_b[i] = P[b0] if b[i] >= 0 else P0
            rate[i] = (P[e[i]] - P_b[i]) / (t[e[i]] - t_b[i])
    for i in range(c):
        if e[i] - b[i] - 1 > 0:
            for j in range(b[i] + 1, e[i]):
                P[j] = P_b[i] + rate[i] * (t[j] - t_b[i])
                V[j] = rate[i]
    PyMem_Free(buf)
    return 0


cdef struct Chunk:
    # a chunk's columns (play.Chunk), the motors' as rows of n
    const double* P_ideal
    const double* V_ideal
    const double* side
    const double* speed
    const double* dt
    const double* s_path
    const double* t
    const double* P_before
    Py_ssize_t n


cdef int _settle_one(const Tab* T, const Chunk* ch, long col, const double* before,
                     double carried_off, const long* e, const long* b, const double* sh,
                     Py_ssize_t c, double* Pv, double* Vv, bint cubic, double share,
                     double hurry, double* dP, double* out) except -1:
    """:func:`play._settle_motor` for motor ``col`` (its c crossings ``e``, ``b``,
    ``sh``; its commands ``Pv``, ``Vv`` (n,) in place; ``dP`` (n,) work space):
    ``out`` the part at the chunk's end and the offset carried (NaN: none)."""
    cdef Py_ssize_t n = ch.n, j, start = 0
    cdef Mo mo
    cdef double carry = NAN, cr, off0 = carried_off, left, y0, P0, V0
    cdef long st = -1, sp, length
    cdef double res[4]
    mo.P_ideal = ch.P_ideal + col * n
    mo.V_ideal = ch.V_ideal + col * n
    mo.side = ch.side + col * n
    mo.speed, mo.dt, mo.s_path, mo.dP, mo.n = ch.speed, ch.dt, ch.s_path, dP, n
    if n:
        dP[0] = mo.P_ideal[0] - ch.P_before[col]
    for j in range(1, n):
        dP[j] = mo.P_ideal[j] - mo.P_ideal[j - 1]
    if off0 != 0.0:
        # what it leaves where the first crossing begins, the follow below sees
        sp = b[0] if c else n
        _commands_core(T, &mo, &off0, &st, &sp, 1, Pv, Vv, share, hurry, &left, &cr)
        carry = cr
    y0, P0, V0 = before[0], before[1], before[2]
    if c:
        if not cubic:
            _across(ch.t, e, b, c, P0, Pv, Vv)
        _settle_core(T, &mo, y0, P0, V0, e, b, sh, c, Pv, Vv, cubic, share, hurry, res)
        if res[3] == res[3]:
            carry = res[3]
        if not cubic:
            _across(ch.t, e, b, c, P0, Pv, Vv)
        y0, P0, V0 = res[0], res[1], res[2]
        # from the last contact on, the corrected commands carry the part
        for j in range(c):
            if e[j] + 1 > start:
                start = e[j] + 1
    if start < n:
        length = n - start
        buf = <double*>PyMem_Malloc((3 * length + 1) * sizeof(double))
        if buf == NULL:
            raise MemoryError()
        try:
            _follow_core(T, &y0, &P0, &V0, &length, 1, Pv + start, Vv + start, ch.dt + start,
                         length, cubic, buf, buf + length, buf + 2 * length)
            y0 = buf[length - 1]
        finally:
            PyMem_Free(buf)
    out[0] = y0
    out[1] = carry
    return 0


def _rows(a, str name, Py_ssize_t r, Py_ssize_t n):
    """``a`` as a C-ordered (r, n) float array (refused otherwise)."""
    out = np.ascontiguousarray(a, dtype=np.float64)
    if out.shape != (r, n):
        raise ValueError(f"{name} must have one row a motor of one value a point ({r}, {n}), "
                         f"got {out.shape}")
    return out


def settle_motors(tables, cols, ch, before, carried_off, x, P, V, bint cubic, double share,
                  double hurry):
    """Every motor with play through a chunk: :func:`play.settle_motors` (``P``,
    ``V`` C-ordered float arrays (R, n), updated in place)."""
    _in_place(P, "P")
    _in_place(V, "V")
    cdef double[:, ::1] Pm = P
    cdef double[:, ::1] Vm = V
    cdef Py_ssize_t R = Pm.shape[0], n = Pm.shape[1], nc, m, i, k, c
    _rows(V, "V", R, n)
    keep = [_rows(a, f, R, n) for f, a in zip(("P_ideal", "V_ideal", "side"), ch[:3])]
    keep += [_vec(a) for a in ch[3:]]
    for f, a in zip(ch._fields[3:7], keep[3:7]):
        _lengths("one value a point, as P", n, **{f: len(a)})
    _lengths("one value a motor, as P's rows", R, P_before=len(keep[7]))
    cdef const long[::1] cv = np.ascontiguousarray(cols, dtype=np.int_)
    nc = cv.shape[0]
    cdef const double[:, ::1] bf = np.ascontiguousarray(before, dtype=np.float64).reshape(-1, 3)
    cdef const double[::1] co = _vec(carried_off)
    _lengths("one value a motor, as cols", nc, tables=len(tables), before=bf.shape[0],
             carried_off=len(co))
    for i in range(nc):
        if not 0 <= cv[i] < R:
            raise ValueError(f"cols must be rows of P (0 to {R - 1}), got {cv[i]}")
    cdef const long[::1] ev = np.ascontiguousarray(x.e, dtype=np.int_)
    cdef const long[::1] bv = np.ascontiguousarray(x.b, dtype=np.int_)
    cdef const long[::1] xc = np.ascontiguousarray(x.col, dtype=np.int_)
    cdef const double[::1] sh = _vec(x.short)
    m = ev.shape[0]
    _lengths("one value a crossing, as e", m, b=len(bv), col=len(xc), short=len(sh))
    cdef Chunk C
    cdef const double* ptr[8]
    cdef const double[::1] flat
    for k in range(8):
        flat = keep[k].reshape(-1)
        ptr[k] = &flat[0] if flat.shape[0] else NULL
    C.P_ideal, C.V_ideal, C.side, C.speed = ptr[0], ptr[1], ptr[2], ptr[3]
    C.dt, C.s_path, C.t, C.P_before, C.n = ptr[4], ptr[5], ptr[6], ptr[7], n
    y_a, carry_a = np.empty(nc), np.empty(nc)
    cdef double[::1] ya = y_a
    cdef double[::1] ca = carry_a
    cdef double out[2]
    cdef _Table tb
    cdef char* mem = <char*>PyMem_Malloc((n + m + 1) * sizeof(double) + (2 * m + 1) * sizeof(long))
    if mem == NULL:
        raise MemoryError()
    cdef double* dP = <double*>mem
    cdef double* ms = dP + n
    cdef long* me = <long*>(ms + m + 1)
    cdef long* mb = me + m
    try:
        for i in range(nc):
            tb = _table(tables[i])
            c = 0
            for k in range(m):  # the motor's own crossings, in their order
                if xc[k] == cv[i]:
                    me[c], mb[c], ms[c] = ev[k], bv[k], sh[k]
                    c += 1
            _settle_one(&tb.tab, &C, cv[i], &bf[i, 0], co[i], me, mb, ms, c,
                        &Pm[cv[i], 0] if n else NULL, &Vm[cv[i], 0] if n else NULL, cubic,
                        share, hurry, dP, out)
            ya[i], ca[i] = out[0], out[1]
    finally:
        PyMem_Free(mem)
    return y_a, carry_a


def carried(sg, side):
    """The side carried through the rows without a direction: :func:`play.carried`
    (the result's type as numpy's where gives it)."""
    a = np.asarray(sg)
    dtype = np.result_type(a, side)
    cdef Py_ssize_t n = a.shape[0], k, i, j
    if n == 0:
        return np.empty(np.broadcast_shapes(a.shape, np.shape(side)), dtype=dtype)
    a2 = np.ascontiguousarray(a, dtype=np.float64).reshape(n, -1)
    k = a2.shape[1]
    cdef const double[:, ::1] x = a2
    cdef const double[::1] s0 = np.ascontiguousarray(
        np.broadcast_to(np.asarray(side, dtype=np.float64), (k,)))
    out = np.empty((n, k))
    cdef double[:, ::1] o = out
    cdef double cur
    for j in range(k):
        cur = s0[j]
        for i in range(n):
            if x[i, j] != 0:
                cur = x[i, j]
            o[i, j] = cur
    return out.reshape(a.shape).astype(dtype, copy=False)


cdef Py_ssize_t _first_creep(const long* sg, const double* P, Py_ssize_t n, long side,
                             double ref, double drift, long* came_out,
                             double* far_out) noexcept nogil:
    """:func:`play._farthest` over rows 0..n−1, then the first row that has drifted
    back (``play.creeps``' hit), or −1; the last row's came and far go out."""
    cdef Py_ssize_t i, last = -1, stretch = 0
    cdef long came = side
    cdef double v, vmax = -INFINITY, vmin = INFINITY, span, lift, acc = -INFINITY, far
    cdef bint nan = False
    # the lift needs the slice's span of came·P first (numpy's max, min: a NaN wins)
    for i in range(n):
        if sg[i] != 0:
            came = sg[i]
        v = came * P[i]
        if v != v:
            nan = True
        else:
            if v > vmax:
                vmax = v
            if v < vmin:
                vmin = v
    span = (NAN if nan else vmax - vmin) + 1.0
    came = side
    for i in range(n):
        if sg[i] != 0:
            if i >= 1 and last != i:
                stretch += 1
            last = i
            came = sg[i]
        v = came * P[i]
        lift = stretch * span
        acc = _max(acc, v + lift) if i else v + lift
        far = acc - lift
        if last < 0:
            far = -INFINITY if ref != ref else _max(far, side * ref)
        came_out[0] = came
        far_out[0] = far
        if sg[i] == 0 and came * P[i] - far < -drift:
            return i
    return -1


def creeps(sg, P, side, double ref, double drift):
    """Rows where a creeping motor drifted back: :func:`play.creeps`."""
    cdef const long[::1] s = np.ascontiguousarray(sg, dtype=np.int_)
    cdef const double[::1] p = _vec(P)
    cdef Py_ssize_t n = s.shape[0], start = 0, r
    _lengths("one value a row, as sg", n, P=len(p))
    out_a = np.zeros(n, dtype=int)
    cdef long[::1] out = out_a
    cdef long cur_side = int(side), came = 0
    cdef double cur_ref = ref, far = 0.0
    while start < n:
        r = _first_creep(&s[start], &p[start], n - start, cur_side, cur_ref, drift, &came, &far)
        if r < 0:
            return out_a, (came * far if (far == far and far != INFINITY and far != -INFINITY) else NAN)
        r += start
        out[r] = -came
        cur_side = out[r]
        cur_ref = p[r]
        start = r + 1
    return out_a, cur_ref


cdef void _sides_core(const double* v, const unsigned char* rest, Py_ssize_t m,
                      const long* fv, const long* ev, const long* nv, const long* lv,
                      Py_ssize_t w, const long* sf, const long* sn, Py_ssize_t ns, long side,
                      double eps, long* sg) noexcept nogil:
    """:func:`play.motor_sides` of one motor into ``sg`` (m,), over pointers: its w
    windows and its ns standing crossings."""
    cdef Py_ssize_t i, j, k
    cdef long lo_f, cur = side
    for i in range(m):
        sg[i] = 0 if rest[i] else (1 if v[i] > eps else (-1 if v[i] < -eps else 0))
    for i in range(w):
        for j in range(lv[i] - ev[i] - 1):
            sg[ev[i] + 1 + j] = nv[i]
    for i in range(w):
        lo_f = 0 if i == 0 else ev[i - 1] + 1
        lo_f = fv[i] if fv[i] > lo_f else lo_f
        for j in range(ev[i] - lo_f):
            sg[lo_f + j] = -nv[i]
    for i in range(w):
        k = ev[i] if ev[i] >= 0 else ev[i] + m
        sg[k] = nv[i]
    for i in range(ns):
        k = sf[i] if sf[i] >= 0 else sf[i] + m
        sg[k] = sn[i]
    # carried(out, side) in place: the last direction at or before each row
    for i in range(m):
        if sg[i] != 0:
            cur = sg[i]
        sg[i] = cur


def _longs(a):
    return np.ascontiguousarray(a, dtype=np.int_)


cdef Py_ssize_t _outside(const long* fv, const long* ev, const long* lv, Py_ssize_t w,
                         const long* sf, Py_ssize_t ns, Py_ssize_t m) noexcept nogil:
    """The first window (or w + the first standing crossing) for which
    :func:`_sides_core` would write outside its m points, −1 if none: where the
    reference's indexing raises IndexError, the core, without bounds checks,
    would write past the array."""
    cdef Py_ssize_t i
    cdef long lo_f
    for i in range(w):
        if not -m <= ev[i] < m:
            return i
        if lv[i] - ev[i] - 1 > 0 and (ev[i] + 1 < 0 or lv[i] > m):
            return i
        lo_f = 0 if i == 0 else ev[i - 1] + 1
        lo_f = fv[i] if fv[i] > lo_f else lo_f
        if ev[i] - lo_f > 0 and lo_f < 0:
            return i
    for i in range(ns):
        if not -m <= sf[i] < m:
            return w + i
    return -1


def _refuse_outside(Py_ssize_t bad, Py_ssize_t w, Py_ssize_t m):
    if bad >= w:
        raise ValueError(f"s_first must be points of the chunk (-{m} to {m - 1}), "
                         f"got standing crossing {bad - w} outside")
    if bad >= 0:
        raise ValueError(f"f, e, last_row must be points of the chunk (-{m} to {m - 1}), "
                         f"got window {bad} outside")


def motor_sides(V, resting, f, e, new, last_row, s_first, s_new, long side, double eps):
    """A motor's side at each point: :func:`play.motor_sides` (a window ending at
    −1 sets the last point, as numpy's index −1 does)."""
    cdef const double[::1] v = _vec(V)
    cdef const unsigned char[::1] rest = np.ascontiguousarray(resting, dtype=np.uint8)
    cdef const long[::1] fv = _longs(f)
    cdef const long[::1] ev = _longs(e)
    cdef const long[::1] nv = _longs(new)
    cdef const long[::1] lv = _longs(last_row)
    cdef const long[::1] sf = _longs(s_first)
    cdef const long[::1] sn = _longs(s_new)
    cdef Py_ssize_t m = v.shape[0], w = ev.shape[0]
    _lengths("one value a point, as V", m, resting=len(rest))
    _lengths("one value a window, as e", w, f=len(fv), new=len(nv), last_row=len(lv))
    _lengths("one value a standing crossing, as s_first", sf.shape[0], s_new=len(sn))
    _refuse_outside(_outside(&fv[0] if w else NULL, &ev[0] if w else NULL,
                             &lv[0] if w else NULL, w, &sf[0] if sf.shape[0] else NULL,
                             sf.shape[0], m), w, m)
    out = np.empty(m, dtype=int)
    cdef long[::1] sg = out
    if m:
        _sides_core(&v[0], &rest[0], m, &fv[0] if w else NULL, &ev[0] if w else NULL,
                    &nv[0] if w else NULL, &lv[0] if w else NULL, w,
                    &sf[0] if sf.shape[0] else NULL, &sn[0] if sf.shape[0] else NULL,
                    sf.shape[0], side, eps, &sg[0])
    return out


def motors_sides(V, resting, cols, side, f, e, new, last_row, lo, hi, s_first, s_new, s_col,
                 double eps, out):
    """Every motor's side at each point, into the rows ``cols`` of ``out``:
    :func:`play.motors_sides`."""
    _in_place(out, "out")
    cdef double[:, ::1] o = out
    cdef Py_ssize_t R = o.shape[0], m = o.shape[1], nc, w, ns, i, k, a, c
    cdef const double[:, ::1] v = _rows(V, "V", R, m)
    cdef const unsigned char[::1] rest = np.ascontiguousarray(resting, dtype=np.uint8)
    cdef const long[::1] cv = _longs(cols)
    cdef const long[::1] sd = _longs(side)
    cdef const long[::1] fv = _longs(f)
    cdef const long[::1] ev = _longs(e)
    cdef const long[::1] nv = _longs(new)
    cdef const long[::1] lv = _longs(last_row)
    cdef const long[::1] lo_v = _longs(lo)
    cdef const long[::1] hi_v = _longs(hi)
    cdef const long[::1] sf = _longs(s_first)
    cdef const long[::1] sn = _longs(s_new)
    cdef const long[::1] sc = _longs(s_col)
    nc, w, ns = cv.shape[0], ev.shape[0], sf.shape[0]
    _lengths("one value a point, as out's rows", m, resting=len(rest))
    _lengths("one value a motor, as out's rows", R, side=len(sd))
    _lengths("one value a motor, as cols", nc, lo=len(lo_v), hi=len(hi_v))
    _lengths("one value a window, as e", w, f=len(fv), new=len(nv), last_row=len(lv))
    _lengths("one value a standing crossing, as s_first", ns, s_new=len(sn), s_col=len(sc))
    for i in range(nc):
        if not 0 <= cv[i] < R:
            raise ValueError(f"cols must be rows of out (0 to {R - 1}), got {cv[i]}")
        if not 0 <= lo_v[i] <= hi_v[i] <= w:
            raise ValueError(f"lo, hi must cut the windows (0 to {w}), got {lo_v[i]}, {hi_v[i]}")
    cdef char* mem = <char*>PyMem_Malloc((m + 2 * ns + 1) * sizeof(long))
    if mem == NULL:
        raise MemoryError()
    cdef long* sg = <long*>mem
    cdef long* mf = sg + m
    cdef long* mn = mf + ns
    try:
        for i in range(nc):  # refuse indexes outside the chunk before writing a row
            c = 0
            for k in range(ns):
                if sc[k] == cv[i]:
                    mf[c] = sf[k]
                    c += 1
            a = lo_v[i]
            _refuse_outside(_outside(&fv[a] if w else NULL, &ev[a] if w else NULL,
                                     &lv[a] if w else NULL, hi_v[i] - a, mf, c, m),
                            hi_v[i] - a, m)
        for i in range(nc):
            c = 0
            for k in range(ns):  # its standing crossings, in their order
                if sc[k] == cv[i]:
                    mf[c], mn[c] = sf[k], sn[k]
                    c += 1
            a = lo_v[i]
            if m:
                _sides_core(&v[cv[i], 0], &rest[0], m, &fv[a] if w else NULL,
                            &ev[a] if w else NULL, &nv[a] if w else NULL,
                            &lv[a] if w else NULL, hi_v[i] - a, mf, mn, c, sd[cv[i]], eps, sg)
            for k in range(m):
                o[cv[i], k] = sg[k]
    finally:
        PyMem_Free(mem)
