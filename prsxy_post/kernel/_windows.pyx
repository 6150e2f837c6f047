# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The crossing windows compiled: :mod:`prsxy_post.kernel.windows` point by point,
the same operations in the same order (see that module), so the two agree to the
bit. numpy's ``maximum`` and ``minimum`` as numpy's (a NaN wins). Compiled with -O2
-ffp-contract=off (no fused multiply-adds)."""

import numpy as np

from libc.math cimport sqrt, fabs, INFINITY


cdef inline double _max(double a, double b) noexcept nogil:
    # numpy's maximum: the first when it is not less, or NaN
    return a if (a >= b or a != a) else b


cdef inline double _min(double a, double b) noexcept nogil:
    return a if (a <= b or a != a) else b


cdef inline bint _isinf(double x) noexcept nogil:
    return x == INFINITY or x == -INFINITY


def crossing_windows(t0, t1, t_root, accel, rb, ra, double tol, double longest,
                     bint chords, double min_w):
    """:func:`prsxy_post.kernel.windows.crossing_windows`, compiled."""
    cdef const double[::1] T0 = np.ascontiguousarray(t0, dtype=np.float64)
    cdef const double[::1] T1 = np.ascontiguousarray(t1, dtype=np.float64)
    cdef const double[::1] TR = np.ascontiguousarray(t_root, dtype=np.float64)
    cdef const double[::1] AC = np.ascontiguousarray(accel, dtype=np.float64)
    cdef const double[::1] RB = np.ascontiguousarray(rb, dtype=np.float64)
    cdef const double[::1] RA = np.ascontiguousarray(ra, dtype=np.float64)
    cdef Py_ssize_t n = T0.shape[0], i
    out_a = np.empty(n)
    out_b = np.empty(n)
    cdef double[::1] A = out_a
    cdef double[::1] B = out_b
    cdef double half, db, da, extra, spare_b, spare_a, add_a, add_b, rest
    cdef double width, a, b, x0, x1, xr, r_b, r_a, acc
    cdef double half_longest = 0.5 * longest
    cdef double two_tol = 2.0 * tol
    cdef bint even, whole, short, grow_b, grow_a, before_ok
    with nogil:
        for i in range(n):
            x0, x1, xr, acc, r_b, r_a = T0[i], T1[i], TR[i], AC[i], RB[i], RA[i]
            half = half_longest if acc == 0 else sqrt(two_tol / fabs(acc))
            db = _min(half, r_b)
            da = _min(half, r_a)
            if chords:
                db = _min(db, da)
            db = _min(db, longest - _min(da, half_longest))
            da = _min(da, longest - db)
            extra = _max(min_w - (db + da), 0.0)
            spare_b = r_b - db
            spare_a = r_a - da
            even = (spare_b == spare_a) or (_isinf(spare_b) and _isinf(spare_a))
            if chords:
                add_a = 0.5 * extra if even else _min(extra, spare_a)
                rest = extra - add_a
                add_b = 0.5 * extra if even else _min(rest, da + add_a - db)
                rest = 0.0 if even else rest - add_b
                db, da = db + add_b + 0.5 * rest, da + add_a + 0.5 * rest
            else:
                if even:
                    add_b = 0.5 * extra
                elif spare_b > spare_a:
                    add_b = _min(extra, spare_b)
                else:
                    add_b = extra - _min(extra, spare_a)
                db, da = db + add_b, da + (extra - add_b)
            width = db + da
            whole = width >= x1 - x0
            a = _max(xr - db, x0)
            b = _min(xr + da, x1)
            short = b - a < min_w
            if short and a <= x0:
                b = _min(a + min_w, x1)
            if short and a > x0:
                a = _max(b - min_w, x0)
            grow_b = (x1 - b < 0.5 * width) and ((x1 - xr <= r_a) or (x1 - b < min_w))
            if grow_b:
                b = x1
            before_ok = xr - x0 <= r_b
            if chords:
                before_ok = before_ok and (xr - x0 <= b - xr)
            grow_a = (a - x0 < 0.5 * width) and (before_ok or (a - x0 < min_w))
            if grow_a:
                a = x0
            A[i] = x0 if whole else a
            B[i] = x1 if whole else b
    return out_a, out_b
