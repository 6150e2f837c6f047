# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The crossing windows compiled: :mod:`prsxy_post.kernel.windows` point by point,
the same operations in the same order (see that module), so the two agree to the
bit. numpy's ``maximum`` and ``minimum`` as numpy's (a NaN wins). Compiled with -O2
-ffp-contract=off (no fused multiply-adds)."""

import numpy as np

from . import windows as _pure
from ._play import creeps as _creeps

from libc.math cimport sqrt, fabs, copysign, signbit, INFINITY, NAN


cdef inline double _max(double a, double b) noexcept nogil:
    # numpy's maximum: the first when it is greater or NaN, else the second (so
    # maximum(-0.0, 0.0) is 0.0 and maximum(0.0, -0.0) is -0.0, as numpy's)
    return a if (a > b or a != a) else b


cdef inline double _min(double a, double b) noexcept nogil:
    return a if (a < b or a != a) else b


def _lengths(str what, Py_ssize_t n, **lengths):
    """Refuse arrays whose ``lengths`` (name: length) are not ``n`` before the
    loops run without bounds checks: a ValueError naming what was expected and
    what was got."""
    for name, got in lengths.items():
        if got != n:
            raise ValueError(f"{name} must have {what} ({n} values, as the first), got {got}")


cdef inline double _clip01(double x) noexcept nogil:
    # numpy's clip to [0, 1]: NaN stays, −0.0 stays
    if x != x:
        return x
    if x < 0.0:
        return 0.0
    if x > 1.0:
        return 1.0
    return x


cdef inline bint _isinf(double x) noexcept nogil:
    return x == INFINITY or x == -INFINITY


cdef inline double _vq(double P0, double V0, double P1, double V1, double h,
                       double* b) noexcept nogil:
    # play.velocity_quadratic: a returned, b set (c is V0)
    cdef double d = (P0 - P1) / h
    b[0] = -6.0 * d - 4.0 * V0 - 2.0 * V1
    return 6.0 * d + 3.0 * (V0 + V1)


def velocity_roots(P0, V0, P1, V1, h, new, bint has_new):
    """:func:`prsxy_post.kernel.windows.velocity_roots`, compiled."""
    cdef const double[::1] p0 = np.ascontiguousarray(P0, dtype=np.float64)
    cdef const double[::1] v0 = np.ascontiguousarray(V0, dtype=np.float64)
    cdef const double[::1] p1 = np.ascontiguousarray(P1, dtype=np.float64)
    cdef const double[::1] v1 = np.ascontiguousarray(V1, dtype=np.float64)
    cdef const double[::1] hh = np.ascontiguousarray(h, dtype=np.float64)
    cdef const double[::1] nw = np.ascontiguousarray(
        new if has_new else np.zeros(p0.shape[0]), dtype=np.float64
    )
    cdef Py_ssize_t n = p0.shape[0], i
    _lengths("one value a step", n, V0=len(v0), P1=len(p1), V1=len(v1), h=len(hh),
             new=len(nw))
    out_s = np.empty(n)
    out_a = np.empty(n)
    cdef double[::1] S = out_s
    cdef double[::1] AC = out_a
    cdef double a, b, s
    with nogil:
        for i in range(n):
            s = _root(p0[i], v0[i], p1[i], v1[i], hh[i], nw[i], has_new, &a, &b)
            S[i] = s
            AC[i] = (2.0 * a * s + b) / hh[i]
    return out_s, out_a


def turning_points(P0, V0, P1, V1, h):
    """:func:`prsxy_post.kernel.windows.turning_points`, compiled."""
    cdef const double[::1] p0 = np.ascontiguousarray(P0, dtype=np.float64)
    cdef const double[::1] v0 = np.ascontiguousarray(V0, dtype=np.float64)
    cdef const double[::1] p1 = np.ascontiguousarray(P1, dtype=np.float64)
    cdef const double[::1] v1 = np.ascontiguousarray(V1, dtype=np.float64)
    cdef const double[::1] hh = np.ascontiguousarray(h, dtype=np.float64)
    cdef Py_ssize_t n = p0.shape[0], i
    _lengths("one value a step", n, V0=len(v0), P1=len(p1), V1=len(v1), h=len(hh))
    out_lo = np.empty(n)
    out_hi = np.empty(n)
    cdef double[::1] LO = out_lo
    cdef double[::1] HI = out_hi
    cdef double a, b, c, disc, qq, r1, r2, lo, hi
    with nogil:
        for i in range(n):
            a = _vq(p0[i], v0[i], p1[i], v1[i], hh[i], &b)
            c = v0[i]
            disc = b * b - 4.0 * a * c
            qq = -0.5 * (b + copysign(sqrt(_max(disc, 0.0)), b))
            r1 = qq / a
            r2 = c / qq
            lo = _min(r1, r2)
            hi = _max(r1, r2)
            if (disc > 0) and (fabs(a) > 0) and (lo > 0) and (hi < 1) and (hi > lo):
                LO[i] = lo
                HI[i] = hi
            else:
                LO[i] = NAN
                HI[i] = NAN
    return out_lo, out_hi


cdef inline double _hermite(double s, double s3, double P0, double V0, double P1,
                            double V1, double h) noexcept nogil:
    # play.hermite at one fraction s (its cube s3 as numpy made it)
    cdef double s2 = s * s
    cdef double h00 = 2 * s3 - 3 * s2 + 1
    cdef double h10 = s3 - 2 * s2 + s
    cdef double h01 = -2 * s3 + 3 * s2
    cdef double h11 = s3 - s2
    return h00 * P0 + h10 * (h * V0) + h01 * P1 + h11 * (h * V1)


def dip_roots(P0, V0, P1, V1, h, sg, double tol, bint sets_off):
    """:func:`prsxy_post.kernel.windows.dip_roots`, compiled; the cubes of the
    turning points are numpy's power over the array the reference makes."""
    cdef const double[::1] p0 = np.ascontiguousarray(P0, dtype=np.float64)
    cdef const double[::1] v0 = np.ascontiguousarray(V0, dtype=np.float64)
    cdef const double[::1] p1 = np.ascontiguousarray(P1, dtype=np.float64)
    cdef const double[::1] v1 = np.ascontiguousarray(V1, dtype=np.float64)
    cdef const double[::1] hh = np.ascontiguousarray(h, dtype=np.float64)
    cdef Py_ssize_t n = p0.shape[0], i, j, m = 0
    _lengths("one value a step", n, V0=len(v0), P1=len(p1), V1=len(v1), h=len(hh),
             sg=len(sg))
    keep_a = np.zeros(n, dtype=bool)
    cdef unsigned char[::1] keep = keep_a.view(np.uint8)
    cdef const double[::1] r1
    cdef const double[::1] r2
    cdef const double[:, ::1] S3
    cdef const Py_ssize_t[::1] rows
    cdef double x1, x2
    if sets_off:
        s2_a, _ = velocity_roots(P0, V0, P1, V1, h, sg, True)
        r2 = s2_a
        S3 = np.ascontiguousarray(s2_a[:, None] ** 3)
        for i in range(n):
            x2 = _hermite(r2[i], S3[i, 0], p0[i], v0[i], p1[i], v1[i], hh[i])
            keep[i] = (fabs(x2 - p0[i]) > tol) and (r2[i] > 0)
        s1_k = np.zeros(n)[keep_a]
        s2_k = s2_a[keep_a]
    else:
        lo_a, hi_a = turning_points(P0, V0, P1, V1, h)
        turns = np.isfinite(lo_a)
        rows_a = np.flatnonzero(turns).astype(np.intp)
        rows = rows_a
        lo_t, hi_t = lo_a[turns], hi_a[turns]
        both = np.column_stack([lo_t, hi_t])
        r1, r2 = lo_t, hi_t
        S3 = np.ascontiguousarray(both ** 3)
        for j in range(rows.shape[0]):
            i = rows[j]
            x1 = _hermite(r1[j], S3[j, 0], p0[i], v0[i], p1[i], v1[i], hh[i])
            x2 = _hermite(r2[j], S3[j, 1], p0[i], v0[i], p1[i], v1[i], hh[i])
            keep[i] = fabs(x2 - x1) > tol
        deep = keep_a[rows_a]
        s1_k, s2_k = lo_t[deep], hi_t[deep]
    cdef const double[::1] k1 = s1_k
    cdef const double[::1] k2 = s2_k
    out_1 = np.empty(k1.shape[0])
    out_2 = np.empty(k1.shape[0])
    cdef double[::1] A1 = out_1
    cdef double[::1] A2 = out_2
    cdef double a, b
    for i in range(n):
        if keep[i]:
            a = _vq(p0[i], v0[i], p1[i], v1[i], hh[i], &b)
            A1[m] = (2 * a * k1[m] + b) / hh[i]
            A2[m] = (2 * a * k2[m] + b) / hh[i]
            m += 1
    return keep_a, s1_k, s2_k, out_1, out_2


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
    _lengths("one value a window", n, t1=len(T1), t_root=len(TR), accel=len(AC), rb=len(RB),
             ra=len(RA))
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


def chord_windows(t0, t1, t_root, accel, rb, ra, double tol, double longest, t_before,
                  t_after, double min_w, double snap):
    """:func:`prsxy_post.kernel.windows.chord_windows`, compiled."""
    cdef const double[::1] T0 = np.ascontiguousarray(t0, dtype=np.float64)
    cdef const double[::1] T1 = np.ascontiguousarray(t1, dtype=np.float64)
    cdef const double[::1] TR = np.ascontiguousarray(t_root, dtype=np.float64)
    cdef const double[::1] AC = np.ascontiguousarray(accel, dtype=np.float64)
    cdef const double[::1] RB = np.ascontiguousarray(rb, dtype=np.float64)
    cdef const double[::1] RA = np.ascontiguousarray(ra, dtype=np.float64)
    cdef const double[::1] TB = np.ascontiguousarray(t_before, dtype=np.float64)
    cdef const double[::1] TA = np.ascontiguousarray(t_after, dtype=np.float64)
    cdef Py_ssize_t n = T0.shape[0], i
    cdef int j
    _lengths("one value a window", n, t1=len(T1), t_root=len(TR), accel=len(AC), rb=len(RB),
             ra=len(RA), t_before=len(TB), t_after=len(TA))
    out_a = np.empty(n)
    out_b = np.empty(n)
    cdef double[::1] A = out_a
    cdef double[::1] B = out_b
    cdef double x0, x1, xr, acc, half, d, lim_b, lim_a, a, b, grow
    cdef double half_longest = 0.5 * longest
    cdef double half_min = 0.5 * min_w
    cdef double two_tol = 2.0 * tol
    cdef bint short, sl_b, sl_a, even
    with nogil:
        for i in range(n):
            x0, x1, xr, acc = T0[i], T1[i], TR[i], AC[i]
            half = half_longest if acc == 0 else sqrt(two_tol / fabs(acc))
            d = _min(_min(half, half_longest), _min(RB[i], RA[i]))
            d = _max(d, half_min)
            lim_b = _min(TB[i], x0)
            lim_a = _max(TA[i], x1)
            if (xr - d < x0 - snap) or (xr + d > x1 + snap):
                d = _max(_min(d, 0.5 * (x1 - x0)), half_min)
            a = _max(xr - d, lim_b)
            b = _min(xr + d, lim_a)
            short = b - a < min_w
            if short and a <= lim_b:
                b = _min(a + min_w, lim_a)
            if short and a > lim_b:
                a = _max(b - min_w, lim_b)
            for j in range(2):
                sl_b = (a > x0) and (a - x0 < min_w)
                sl_a = (b < x1) and (x1 - b < min_w)
                grow = _max(xr - x0 if sl_b else 0.0, x1 - xr if sl_a else 0.0)
                even = (sl_b or sl_a) and (xr - grow >= lim_b) and (xr + grow <= lim_a)
                if even:
                    a = _min(a, xr - grow)
                    b = _max(b, xr + grow)
            if (a > x0) and (a - x0 < min_w):
                a = x0
            if (b < x1) and (x1 - b < min_w):
                b = x1
            A[i] = a
            B[i] = b
    return out_a, out_b


cdef inline bint _in(long x, const long* pool, Py_ssize_t m) noexcept nogil:
    """x is one of pool[0..m−1] (sorted): :func:`windows.in_sorted`'s answer."""
    cdef Py_ssize_t lo = 0, hi = m, mid
    while lo < hi:  # the first not below x (numpy's searchsorted, side left)
        mid = (lo + hi) // 2
        if pool[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo < m and pool[lo] == x


def chord_room(km, t0, t1, dt, resting, busy, bent, double min_w):
    """:func:`prsxy_post.kernel.windows.chord_room`, compiled."""
    cdef const long[::1] K = np.ascontiguousarray(km, dtype=np.int_)
    cdef const double[::1] T0 = np.ascontiguousarray(t0, dtype=np.float64)
    cdef const double[::1] T1 = np.ascontiguousarray(t1, dtype=np.float64)
    cdef const double[::1] DT = np.ascontiguousarray(dt, dtype=np.float64)
    cdef const unsigned char[::1] RS = np.ascontiguousarray(resting, dtype=bool).view(np.uint8)
    busy_a = np.ascontiguousarray(busy, dtype=np.int_)
    bent_a = np.ascontiguousarray(bent, dtype=np.int_)
    cdef const long[::1] BU = busy_a
    cdef const long[::1] BE = bent_a
    cdef Py_ssize_t m = K.shape[0], n = DT.shape[0], nb = BU.shape[0], ne = BE.shape[0], i
    _lengths("one value a window", m, t0=len(T0), t1=len(T1))
    _lengths("one value a step", n, resting=len(RS))
    for i in range(m):
        if not 0 <= K[i] < n:
            raise ValueError(f"km must be steps of dt (0 to {n - 1}), got {K[i]}")
    cdef const long* pb = &BU[0] if nb else NULL
    cdef const long* pe = &BE[0] if ne else NULL
    out_b = np.empty(m)
    out_a = np.empty(m)
    cdef double[::1] TB = out_b
    cdef double[::1] TA = out_a
    cdef long k, prv, nxt
    cdef bint free
    with nogil:
        for i in range(m):
            k = K[i]
            prv = k - 1 if k >= 1 else 0
            nxt = k + 1 if k + 1 <= n - 1 else n - 1
            free = (k >= 2 and not RS[prv] and not RS[k - 2]
                    and DT[prv] > 0 and not _in(k - 1, pb, nb) and not _in(k - 1, pe, ne))
            TB[i] = T0[i] - (_max(DT[prv] - min_w, 0.0) if free else 0.0)
            free = (k + 1 < n and not RS[k] and not RS[nxt] and DT[nxt] > 0
                    and not _in(k + 1, pb, nb) and not _in(k, pe, ne))
            TA[i] = T1[i] + (_max(DT[nxt] - min_w, 0.0) if free else 0.0)
    return out_b, out_a


# the kinds of :func:`prsxy_post.kernel.windows.motor_turns` (windows.MID, AT_REST,
# CREPT, STOOD)
cdef signed char MID = 0, AT_REST = 1, CREPT = 2, STOOD = 3


cdef signed char _turn_kind(const double* p, const unsigned char* rs, const long* sg,
                            const long* cr, Py_ssize_t i, Py_ssize_t off) noexcept nogil:
    """The kind of the reversal at row i (its direction ``sg[i]`` new, the rows
    before final): from rest, a creep's end, after standing, or in mid motion
    (:func:`prsxy_post.kernel.windows.motor_turns`)."""
    cdef long nw = sg[i]
    cdef Py_ssize_t b1 = i - 1 if i >= 1 else 0, b2 = i - 2 if i >= 2 else 0
    cdef bint old_way = nw * (p[i] - p[b1]) < 0.0
    cdef bint at_rest = i == 0 or (rs[b1] and not old_way)
    cdef bint crept_f = cr[i] != 0 and not at_rest and sg[b1] != -nw
    cdef bint stood = (
        not at_rest and not crept_f and i - off >= 1 and i >= 2 and sg[b1] == 0
        and sg[b2] == 0 and fabs(p[b1] - p[b2]) < 1e-9 and not old_way
    )
    return AT_REST if at_rest else (CREPT if crept_f else (STOOD if stood else MID))


cdef inline bint _turns_twice(double P0, double V0, double P1, double V1, double h,
                              double* lo, double* hi) noexcept nogil:
    # turning_points' test for one step, its operations as there; the roots (in
    # time order) set where it holds
    cdef double a, b, c, disc, qq, r1, r2
    a = _vq(P0, V0, P1, V1, h, &b)
    c = V0
    disc = b * b - 4.0 * a * c
    if not (disc > 0 and fabs(a) > 0):
        return False  # most steps: the roots need not be made
    # both roots positive needs qq's sign (that of −b's sign bit: disc > 0, so
    # b and the root's term it adds share theirs) to be a's and c's, c ≠ 0: the
    # sign rules of IEEE division, exact, so the test below would fail anyway
    if c == 0 or (a > 0) != (c > 0) or (signbit(b) != 0) != (c > 0):
        return False
    qq = -0.5 * (b + copysign(sqrt(_max(disc, 0.0)), b))
    r1 = qq / a
    r2 = c / qq
    lo[0] = _min(r1, r2)
    hi[0] = _max(r1, r2)
    return (lo[0] > 0) and (hi[0] < 1) and (hi[0] > lo[0])


cdef inline double _root(double P0, double V0, double P1, double V1, double h, double nw,
                         bint has_new, double* a_out, double* b_out) noexcept nogil:
    # one step of velocity_roots: its s returned, the quadratic's a and b set
    cdef double a, b, c, disc, qq, r1, r2, best, linear
    cdef bint lin, ok1, ok2, turn1, turn2
    a = _vq(P0, V0, P1, V1, h, &b)
    a_out[0] = a
    b_out[0] = b
    c = V0
    disc = b * b - 4.0 * a * c
    lin = fabs(a) < 1e-12 * (fabs(b) + fabs(c) + 1e-300)
    qq = -0.5 * (b + copysign(sqrt(_max(disc, 0.0)), b))
    if lin:
        r1 = -c / b if b != 0 else NAN
        r2 = NAN
    else:
        r1 = qq / a
        r2 = c / qq if qq != 0 else -b / (2 * a)
    if not disc >= 0:
        r1 = NAN
        r2 = NAN
    ok1 = (r1 >= -1e-9) and (r1 <= 1 + 1e-9)
    ok2 = (r2 >= -1e-9) and (r2 <= 1 + 1e-9)
    if has_new:
        turn1 = ok1 and (nw * (2.0 * a * r1 + b) >= 0)
        turn2 = ok2 and (nw * (2.0 * a * r2 + b) >= 0)
        if turn1 or turn2:
            ok1, ok2 = turn1, turn2
    if ok1 and ok2:
        best = _min(r1, r2)
    elif ok1:
        best = r1
    elif ok2:
        best = r2
    else:
        best = NAN
    linear = V0 / (V0 - V1) if V0 != V1 else 0.5
    return _clip01(linear if best != best else best)


cdef inline double _velocity_root(double P0, double V0, double P1, double V1, double h,
                                  double nw) noexcept nogil:
    # velocity_roots' s for one step with has_new
    cdef double a, b
    return _root(P0, V0, P1, V1, h, nw, True, &a, &b)


def _dips_of(const double[::1] p, const double[::1] v, const double[::1] hh, Py_ssize_t off,
             j_a, r_a, Py_ssize_t m, double tol, bint sets_off):
    """:func:`prsxy_post.kernel.windows.motor_dips` past its candidates (for
    :func:`motor_reversals`, which finds them, :func:`dip_roots` fused in: a
    dip's only where the step's cubic turns twice inside it,
    :func:`turning_points`' test; a setting-off's root by :func:`velocity_roots`):
    of the m candidate rows ``j_a`` and
    their roots ``r_a`` (rows of (cap, 2) turning points, or (cap, 1) velocity
    roots setting off), the roots' cubes by numpy's power over the array the
    reference makes, the depths, and the steps that dip with their roots and
    accelerations."""
    cdef const Py_ssize_t[::1] jj = j_a
    cdef const double[:, ::1] rr = r_a
    cdef Py_ssize_t i, j, k = 0
    cdef const double[:, ::1] S3 = np.ascontiguousarray(r_a[:m] ** 3)
    keep_a = np.empty(m, dtype=np.intp)
    cdef Py_ssize_t[::1] kp = keep_a
    cdef double x1, x2, a, b
    with nogil:
        for i in range(m):
            j = jj[i]
            if sets_off:
                x2 = _hermite(rr[i, 0], S3[i, 0], p[j - 1], v[j - 1], p[j], v[j], hh[j - off])
                if (fabs(x2 - p[j - 1]) > tol) and (rr[i, 0] > 0):
                    kp[k] = i
                    k += 1
            else:
                x1 = _hermite(rr[i, 0], S3[i, 0], p[j - 1], v[j - 1], p[j], v[j], hh[j - off])
                x2 = _hermite(rr[i, 1], S3[i, 1], p[j - 1], v[j - 1], p[j], v[j], hh[j - off])
                if fabs(x2 - x1) > tol:
                    kp[k] = i
                    k += 1
    out_j = np.empty(k, dtype=np.intp)
    out_s1, out_s2, out_1, out_2 = np.empty(k), np.empty(k), np.empty(k), np.empty(k)
    cdef Py_ssize_t[::1] oj = out_j
    cdef double[::1] S1 = out_s1
    cdef double[::1] S2 = out_s2
    cdef double[::1] A1 = out_1
    cdef double[::1] A2 = out_2
    cdef double k1, k2
    with nogil:
        for m in range(k):
            i = kp[m]
            j = jj[i]
            if sets_off:
                k1 = 0.0
                k2 = rr[i, 0]
            else:
                k1 = rr[i, 0]
                k2 = rr[i, 1]
            a = _vq(p[j - 1], v[j - 1], p[j], v[j], hh[j - off], &b)
            oj[m] = j
            S1[m] = k1
            S2[m] = k2
            A1[m] = (2 * a * k1 + b) / hh[j - off]
            A2[m] = (2 * a * k2 + b) / hh[j - off]
    return out_j, out_s1, out_s2, out_1, out_2


cdef Py_ssize_t _turn_pass(const double* p, const double* v, const unsigned char* rs,
                           const double* hh, long* sg, long* came, const long* cr, long side,
                           Py_ssize_t N, Py_ssize_t off, Py_ssize_t n_h, Py_ssize_t* r,
                           signed char* kind, Py_ssize_t* j0, double* r0, Py_ssize_t* m0,
                           Py_ssize_t* j1, double* r1, Py_ssize_t* m1) noexcept nogil:
    """One pass over a motor's rows, its creeps ``cr`` known: the creeps made its
    directions in ``sg``, the way each row comes from into ``came``, its reversals
    and their kinds (the reference's :func:`~prsxy_post.kernel.windows.motor_turns`:
    their count returned), and the candidates of the reference's
    :func:`~prsxy_post.kernel.windows.motor_dips` (rows and roots: its dips into
    ``j0``, ``r0`` (cap, 2), ``m0`` of them, its settings-off back into ``j1``,
    ``r1``, ``m1``). Every test
    at row i reads rows up to i, final by then: the separate passes' answers."""
    cdef Py_ssize_t i, m = 0, a0 = 0, a1 = 0
    cdef Py_ssize_t lo_j = off if off > 1 else 1
    cdef Py_ssize_t hi_j = off + n_h if off + n_h < N else N
    cdef long cur = side
    cdef double lo, hi
    for i in range(N):
        if cr[i] != 0:
            sg[i] = cr[i]
        came[i] = cur
        if sg[i] != 0:
            cur = sg[i]
        if i >= off and sg[i] != 0 and sg[i] != came[i]:
            r[m] = i
            kind[m] = _turn_kind(p, rs, sg, cr, i, off)
            m += 1
        if i < lo_j or i >= hi_j:
            continue
        if sg[i] == sg[i - 1] and sg[i] != 0:
            if _turns_twice(p[i - 1], v[i - 1], p[i], v[i], hh[i - off], &lo, &hi):
                j0[a0] = i
                r0[2 * a0] = lo
                r0[2 * a0 + 1] = hi
                a0 += 1
        if (sg[i] != 0 and sg[i - 1] == 0 and came[i] == sg[i]
                and sg[i] * (p[i] - p[i - 1]) < 0.0):
            j1[a1] = i
            r1[a1] = _velocity_root(p[i - 1], v[i - 1], p[i], v[i], hh[i - off], <double>sg[i])
            a1 += 1
    m0[0] = a0
    m1[0] = a1
    return m


def _row_major(a, str name, Py_ssize_t r, Py_ssize_t n):
    """``a`` as a C-ordered (r, n) float array (refused otherwise)."""
    out = np.ascontiguousarray(a, dtype=np.float64)
    if out.shape != (r, n):
        raise ValueError(f"{name} must have one row a motor of one value a row, as P "
                         f"({r}, {n}), got {out.shape}")
    return out


def motor_reversals(V, P, rest, cols, side, ref, double drift, Py_ssize_t off, double eps, h,
                    double tol):
    """:func:`prsxy_post.kernel.windows.motor_reversals`, compiled: for each motor,
    its directions (one pass), its creeps (:func:`.play.creeps`, compiled), then one
    pass (:func:`_turn_pass`) for its reversals, their kinds and the candidates of
    its dips and settings-off back, then those (:func:`_dips_of`), as
    the reference's :func:`~prsxy_post.kernel.windows.motor_turns` and
    :func:`~prsxy_post.kernel.windows.motor_dips` make them."""
    P_a = np.ascontiguousarray(P, dtype=np.float64)
    if P_a.ndim != 2:
        raise ValueError(f"P must have one row a motor, got {P_a.ndim} dimensions")
    cdef Py_ssize_t R = P_a.shape[0], N = P_a.shape[1], c, i, k, m, M = 0, m0, m1, cap
    cdef const double[:, ::1] Pv = P_a
    cdef const double[:, ::1] Vv = _row_major(V, "V", R, N)
    cdef const unsigned char[::1] rs = np.ascontiguousarray(rest, dtype=np.bool_).view(np.uint8)
    cdef const double[::1] hh = np.ascontiguousarray(h, dtype=np.float64)
    cdef const long[::1] cv = np.ascontiguousarray(cols, dtype=np.int_)
    cdef const long[::1] sd = np.ascontiguousarray(side, dtype=np.int_)
    cdef const double[::1] rf = np.ascontiguousarray(ref, dtype=np.float64)
    c = cv.shape[0]
    _lengths("one value a row, as P", N, rest=len(rs))
    _lengths("one value a motor, as P's rows", R, side=len(sd), ref=len(rf))
    if hh.shape[0] > N - off:
        raise ValueError(f"h must have at most {N - off} values (one a step), got {hh.shape[0]}")
    for i in range(c):
        if not 0 <= cv[i] < R:
            raise ValueError(f"cols must be rows of P (0 to {R - 1}), got {cv[i]}")
    sg_a = np.empty((c, N), dtype=np.int_)
    came_a = np.empty((c, N), dtype=np.int_)
    r_a = np.empty(c * N, dtype=np.intp)
    kind_a = np.empty(c * N, dtype=np.int8)
    turns_a = np.zeros(c + 1, dtype=np.intp)
    reach_a = np.empty(c)
    cdef long[:, ::1] sg = sg_a
    cdef long[:, ::1] came = came_a
    cdef Py_ssize_t[::1] r = r_a
    cdef signed char[::1] kind = kind_a
    cdef const long[::1] cr
    cdef Py_ssize_t[::1] j0
    cdef Py_ssize_t[::1] j1
    cdef double[:, ::1] r0
    cdef double[:, ::1] r1
    cdef Py_ssize_t lo_j = off if off > 1 else 1
    cdef Py_ssize_t hi_j = off + hh.shape[0] if off + hh.shape[0] < N else N
    cap = hi_j - lo_j if hi_j > lo_j else 0
    parts = []
    for i in range(c):
        col = cv[i]
        for k in range(N):
            sg[i, k] = 0 if rs[k] else (1 if Vv[col, k] > eps else (-1 if Vv[col, k] < -eps else 0))
        crept_a, reach_a[i] = _creeps(sg_a[i], P_a[col], sd[col], rf[col], drift)
        cr = crept_a
        # the candidates' roots: (m, 2) turning points as turning_points' rows, or
        # (m, 1) velocity_roots' s setting off (motor_dips' arrays)
        j0_a, j1_a = np.empty(cap, dtype=np.intp), np.empty(cap, dtype=np.intp)
        r0_a, r1_a = np.empty((cap, 2)), np.empty((cap, 1))
        j0, j1, r0, r1 = j0_a, j1_a, r0_a, r1_a
        if N:
            m = _turn_pass(&Pv[col, 0], &Vv[col, 0], &rs[0], &hh[0] if hh.shape[0] else NULL,
                           &sg[i, 0], &came[i, 0], &cr[0], sd[col], N, off, hh.shape[0],
                           &r[M], &kind[M], &j0[0] if cap else NULL,
                           &r0[0, 0] if cap else NULL, &m0, &j1[0] if cap else NULL,
                           &r1[0, 0] if cap else NULL, &m1)
        else:
            m = m0 = m1 = 0
        M += m
        turns_a[i + 1] = M
        parts.append(_dips_of(P_a[col], Vv[col], hh, off, j0_a, r0_a, m0, tol, False))
        parts.append(_dips_of(P_a[col], Vv[col], hh, off, j1_a, r1_a, m1, tol, True))
    dips_a = np.cumsum([0] + [len(x[0]) for x in parts])
    none = (np.zeros(0, dtype=np.intp),) + (np.zeros(0),) * 4
    flat = [np.concatenate([none[f]] + [x[f] for x in parts]) for f in range(5)]
    return _pure.Reversals(sg_a, came_a, r_a[:M], kind_a[:M], turns_a, reach_a, *flat, dips_a)


def corner_blends(V_in, V_out, cols, h, double accel, double v_eps, double turn_mm,
                  double blend_min):
    """:func:`prsxy_post.kernel.windows.corner_blends`, compiled: a corner at a
    time, the motors with play's (1 − 6 v / |ΔV|) in a (k, c) array as the
    reference's, raised to 1.5 by numpy there (numpy's power, not the C library's
    pow)."""
    cdef const double[:, ::1] vin = np.ascontiguousarray(V_in, dtype=np.float64)
    cdef const double[:, ::1] vout = np.ascontiguousarray(V_out, dtype=np.float64)
    cdef const Py_ssize_t[::1] cv = np.ascontiguousarray(cols, dtype=np.intp)
    cdef const double[::1] hh = np.ascontiguousarray(h, dtype=np.float64)
    cdef Py_ssize_t k = vin.shape[0], c = cv.shape[0], i, j, col
    if vin.shape[1] != 5 or vout.shape[1] != 5:
        raise ValueError(
            f"V_in and V_out must be (k, 5), got {tuple(np.shape(V_in))} and "
            f"{tuple(np.shape(V_out))}"
        )
    _lengths("one row a corner, as V_in", k, V_out=vout.shape[0], h=len(hh))
    for j in range(c):
        if not 0 <= cv[j] < 5:
            raise ValueError(f"cols must be motor columns 0 to 4, got {cv[j]}")
    left_a = np.empty((k, c))
    moves_a = np.empty((k, c), dtype=np.uint8)
    cdef double[:, ::1] left = left_a
    cdef unsigned char[:, ::1] moves = moves_a
    cdef double vi, vo, fast, slow, d, x
    for i in range(k):
        for j in range(c):
            col = cv[j]
            vi = vin[i, col]
            vo = vout[i, col]
            if fabs(vo) >= fabs(vi):
                fast = vo
                slow = vi
            else:
                fast = vi
                slow = vo
            slow = slow * (-1.0 if fast < 0 else 1.0)
            moves[i, j] = (fabs(fast) >= v_eps) and (slow > -v_eps)
            d = fabs(vo - vi)
            x = 1.0 - 6.0 * slow / d if d > 0 else 0.0
            left[i, j] = _clip01(x)
    cdef const double[:, ::1] p15 = np.ascontiguousarray(left_a ** 1.5)
    blend_a = np.zeros(k, dtype=bool)
    tau_a = np.empty(k)
    cdef unsigned char[::1] blend = blend_a.view(np.uint8)
    cdef double[::1] tau = tau_a
    cdef double m, turn
    cdef bint any_turn
    for i in range(k):
        m = 0.0
        for j in range(5):
            m = _max(m, fabs(vout[i, j] - vin[i, j]))
        tau[i] = _max(blend_min, m / (2.0 * accel))
        any_turn = False
        for j in range(c):
            col = cv[j]
            d = fabs(vout[i, col] - vin[i, col])
            turn = (4.0 / 27.0) * hh[i] * d / 2.0 * p15[i, j]
            if moves[i, j] and turn > turn_mm:
                any_turn = True
        blend[i] = any_turn and (tau[i] <= 0.5 * hh[i])
    return blend_a, tau_a
