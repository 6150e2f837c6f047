# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The corrected G-code writer's decisions compiled: :mod:`prsxy_post.kernel.gwrite`
point by point, the same operations in the same order (see that module), so the
two agree to the bit. Python's ``min`` and ``max`` as Python's (the first of
equals), ``math.fsum`` exactly rounded as CPython sums it, ``math.hypot`` and
``math.dist`` as CPython 3.11's ``vector_norm`` (not libm's ``hypot``; a later
CPython that computes it otherwise fails tests/test_kernel_gwrite.py's
``test_fsum_and_hypot_are_cpythons``). Compiled with -O2 -ffp-contract=off (no
fused multiply-adds)."""

import numpy as np

from libc.math cimport sqrt, fabs, frexp, ldexp, rint, INFINITY, NAN
from libc.string cimport memmove

from . import _arcs, gwrite

#: the reference's names of the state's scalars, in this module's order
F_NAMES = (
    "tol", "blend", "tilt_cut", "tilt_hold", "tilt_chord", "accel", "accel_deg",
    "prev_accel", "t_total", "last_speed", "peak", "trough", "plan_peak", "stretch",
    "len_sum", "dt_sum", "corner_t", "prev_len", "prev_t", "patch_f",
    "smooth", "arc_hold", "speed0", "ca_len", "ca_dt", "tilt_fit", "ca_radius",
    "prev_radius",
)
I_NAMES = (
    "all_exact", "n", "has_line", "last_line", "run_n", "run_src", "corner_src",
    "held_src", "exact", "after_settle", "prev_idx", "prev_turns", "prev_blend",
    "has_prev", "patch", "keep",
    "plane", "stop_at", "req_kind", "req_arc", "req_answer", "corner_arc", "ca_plane",
    "ca_from", "decimals", "corner_fit",
)

cdef enum:
    OP_G0, OP_G93, OP_LINE, OP_G61, OP_G64, OP_G1, OP_G4P0, OP_G94, OP_FN, OP_DWELL, OP_ARC,
    OP_PLANE

DEF NONE = -9
DEF CARRIED = -1
DEF PATCH_F = 1
DEF PATCH_STOP = 2
DEF CORNER_SRC = -2
DEF REQ_REARC = 1
DEF REQ_ARC_TO = 2
DEF CHORD_NO = 0
DEF CHORD_OK = 1
DEF CHORD_FIT = 2
DEF SERVO_PERIOD_S = 1e-3
DEF BLEND_STEPS = 64  # gwrite.BLEND_STEPS
DEF DIP_SHARE = 1e-3
DEF T27 = 134217729.0  # 2**27 + 1: Dekker's split


cdef struct W:
    double tol, blend, tilt_cut, tilt_hold, tilt_chord, accel, accel_deg
    double prev_accel, t_total, last_speed, peak, trough, plan_peak, stretch
    double len_sum, dt_sum, corner_t, prev_len, prev_t, patch_f
    long long all_exact, n, has_line, last_line, run_n, run_src, corner_src
    long long held_src, exact, after_settle, prev_idx, prev_turns, prev_blend
    long long has_prev, patch, keep
    double smooth, arc_hold, speed0, ca_len, ca_dt
    long long plane, stop_at, req_kind, req_arc, req_answer, corner_arc, ca_plane
    long long ca_from, decimals
    double tilt_fit
    long long corner_fit
    double ca_radius, prev_radius
    double last_q[5]
    double last_ab[2]
    double held_ab[2]
    double lead0[5]
    double corner_q[5]
    double corner_in[5]
    double* run
    long long* code
    long long* arg
    long long* ab
    long long* aux
    double* val
    Py_ssize_t m
    # the chunk's points (n of them, rows of 5), their times, and its arcs
    const double* q
    const double* dt
    Py_ssize_t npts
    const long long* arc_of
    const long long* arc_i
    const double* arc_f
    bint has_arcs
    # the tilts centered before runs of arcs (rows of 2), nt of them
    double* tilts
    Py_ssize_t nt


# Python's max(a, b) and min(a, b): the first unless the second compares past it
cdef inline double _pmax(double a, double b) noexcept nogil:
    return b if b > a else a


cdef inline double _pmin(double a, double b) noexcept nogil:
    return b if b < a else a


# numpy's maximum and minimum of two values that are no NaN
cdef inline double _npmax(double a, double b) noexcept nogil:
    return a if a >= b else b


cdef inline double _npmin(double a, double b) noexcept nogil:
    return a if a <= b else b


cdef double _fsum(const double* x, int n) noexcept nogil:
    """math.fsum of n finite values: Shewchuk's partials (each sum's rounding
    error kept as a partial, none overlapping), then the partials added from the
    largest down while exact, the last rounding made half-even across partials."""
    cdef double p[32]
    cdef int np_ = 0, i, j
    cdef double v, y, t, hi, lo = 0.0, yr
    for j in range(n):
        v = x[j]
        i = 0
        for jj in range(np_):
            y = p[jj]
            if fabs(v) < fabs(y):
                t = v
                v = y
                y = t
            hi = v + y
            yr = hi - v
            lo = y - yr
            if lo != 0.0:
                p[i] = lo
                i += 1
            v = hi
        np_ = i
        if v != 0.0:
            p[np_] = v
            np_ += 1
    hi = 0.0
    if np_ > 0:
        np_ -= 1
        hi = p[np_]
        lo = 0.0
        while np_ > 0:
            v = hi
            np_ -= 1
            y = p[np_]
            hi = v + y
            yr = hi - v
            lo = y - yr
            if lo != 0.0:
                break
        if np_ > 0 and ((lo < 0.0 and p[np_ - 1] < 0.0) or (lo > 0.0 and p[np_ - 1] > 0.0)):
            y = lo * 2.0
            v = hi + y
            yr = v - hi
            if y == yr:
                hi = v
    return hi


cdef double _vnorm(double* vec, int n, double mx, bint found_nan) noexcept nogil:
    """CPython 3.11's vector_norm (math.hypot, math.dist) of n values >= 0 whose
    largest is mx: scaled by a power of two, squares split exactly (Dekker), the
    sum compensated, the root corrected by one differential step."""
    cdef double x, scale, oldcsum, csum = 1.0, frac1 = 0.0, frac2 = 0.0, frac3 = 0.0
    cdef double t, hi, lo, h
    cdef int max_e, i
    if mx == INFINITY:
        return mx
    if found_nan:
        return NAN
    if mx == 0.0 or n <= 1:
        return mx
    frexp(mx, &max_e)
    if max_e >= -1023:
        scale = ldexp(1.0, -max_e)
        for i in range(n):
            x = vec[i] * scale
            t = x * T27
            hi = t - (t - x)
            lo = x - hi
            x = hi * hi
            oldcsum = csum
            csum += x
            frac1 += (oldcsum - csum) + x
            x = 2.0 * hi * lo
            oldcsum = csum
            csum += x
            frac2 += (oldcsum - csum) + x
            frac3 += lo * lo
        h = sqrt(csum - 1.0 + (frac1 + frac2 + frac3))
        x = h
        t = x * T27
        hi = t - (t - x)
        lo = x - hi
        x = -hi * hi
        oldcsum = csum
        csum += x
        frac1 += (oldcsum - csum) + x
        x = -2.0 * hi * lo
        oldcsum = csum
        csum += x
        frac2 += (oldcsum - csum) + x
        x = -lo * lo
        oldcsum = csum
        csum += x
        frac3 += (oldcsum - csum) + x
        x = csum - 1.0 + (frac1 + frac2 + frac3)
        return (h + x / (2.0 * h)) / scale
    # ldexp(1.0, -max_e) would overflow: divide by the largest instead
    for i in range(n):
        x = vec[i] / mx
        x = x * x
        oldcsum = csum
        csum += x
        frac1 += (oldcsum - csum) + x
    return mx * sqrt(csum - 1.0 + frac1)


cdef double _hypot(const double* v, int n) noexcept nogil:
    """math.hypot(*v[:n])."""
    cdef double a[5]
    cdef double mx = 0.0, x
    cdef bint nan = False
    cdef int i
    for i in range(n):
        x = fabs(v[i])
        a[i] = x
        nan = nan or x != x
        if x > mx:
            mx = x
    return _vnorm(a, n, mx, nan)


cdef double _dist(const double* p, const double* q, int n) noexcept nogil:
    """math.dist(p[:n], q[:n])."""
    cdef double a[5]
    cdef double mx = 0.0, x
    cdef bint nan = False
    cdef int i
    for i in range(n):
        x = fabs(p[i] - q[i])
        a[i] = x
        nan = nan or x != x
        if x > mx:
            mx = x
    return _vnorm(a, n, mx, nan)


def fsum(x):
    """math.fsum of finite values, compiled (for the differential tests)."""
    cdef const double[::1] v = np.ascontiguousarray(x, dtype=np.float64)
    if len(v) > 30:
        raise ValueError(f"at most 30 values, got {len(v)}")
    return _fsum(&v[0], <int>len(v)) if len(v) else 0.0


def hypot(x):
    """math.hypot(*x) of up to 5 values, compiled (for the differential tests)."""
    cdef const double[::1] v = np.ascontiguousarray(x, dtype=np.float64)
    if len(v) > 5:
        raise ValueError(f"at most 5 values, got {len(v)}")
    return _hypot(&v[0], <int>len(v)) if len(v) else 0.0


cdef void _corner_cut(const double* q_in, const double* q_at, const double* q_out, double t_in,
                      double t_out, double accel, double* mm, double* deg) noexcept nogil:
    # gwrite.corner_cut
    cdef double r_in[5]
    cdef double r_out[5]
    cdef double turn[5]
    cdef double v_in, v_out, v, t_blend
    cdef int i
    for i in range(5):
        r_in[i] = (q_at[i] - q_in[i]) / t_in
    for i in range(5):
        r_out[i] = (q_out[i] - q_at[i]) / t_out
    v_in = _hypot(r_in, 3)
    v_out = _hypot(r_out, 3)
    v = _pmax(v_in, v_out)
    if v > 0.0:
        t_blend = _pmin(_pmin(t_in, t_out), 2.0 * v / accel)
    else:
        t_blend = _pmin(t_in, t_out)
    if v_in > 0.0 and v_out > 0.0:
        for i in range(5):
            turn[i] = (r_out[i] / v_out - r_in[i] / v_in) * v
    else:
        for i in range(5):
            turn[i] = r_out[i] - r_in[i]
    mm[0] = _hypot(turn, 3) * t_blend / 8.0
    deg[0] = _hypot(&turn[3], 2) * t_blend / 8.0


cdef double _line_accel(const double* d_xyz, const double* d_ab, double accel,
                        double accel_deg) noexcept nogil:
    # gwrite.line_accel
    cdef double dtot = _hypot(d_xyz, 3)
    cdef double mx = fabs(d_xyz[0]), ma = fabs(d_ab[0]), tmax
    cdef int i
    for i in range(1, 3):
        if fabs(d_xyz[i]) > mx:
            mx = fabs(d_xyz[i])
    if fabs(d_ab[1]) > ma:
        ma = fabs(d_ab[1])
    tmax = _pmax(mx / accel, ma / accel_deg)
    return dtot / tmax if dtot > 0.0 and tmax > 0.0 else accel


cdef inline void _emit(W* w, long long code, long long arg, long long ab, double val,
                       long long aux=0) noexcept nogil:
    w.code[w.m] = code
    w.arg[w.m] = arg
    w.ab[w.m] = ab
    w.val[w.m] = val
    w.aux[w.m] = aux
    w.m += 1


cdef inline const double* _last_held(W* w) noexcept nogil:
    # the last held-back point, else the last written
    return &w.run[5 * (w.run_n - 1)] if w.run_n else w.last_q


cdef double _rate(W* w, const double* qk, double dtk, double* step) noexcept nogil:
    # _Run.piece: (step, rate)
    step[0] = _dist(_last_held(w), qk, 5)
    return step[0] / dtk if dtk > 0.0 else 0.0


cdef bint _dips(W* w, const double* qk, double dtk, const double* lead,
                double* step) noexcept nogil:
    # _Run.dips; the piece's length into step (unset where nothing is held)
    cdef double rate, moved, x
    cdef bint dip
    cdef int i
    if not w.run_n:
        return False
    rate = _rate(w, qk, dtk, step)
    moved = fabs(lead[0] - w.lead0[0])
    for i in range(1, 5):
        x = fabs(lead[i] - w.lead0[i])
        if x > moved:
            moved = x
    dip = w.trough < w.peak * (1.0 - DIP_SHARE) and rate > w.trough * (1.0 + DIP_SHARE)
    return dip or moved > w.tol


cdef void _hold(W* w, long long k, const double* qk, double dtk, const double* lead,
                double plan, double known=-1.0) noexcept nogil:
    # _Run.hold; known >= 0: the piece's length, as _dips just measured it from
    # the same held point (its rate then as _rate makes it)
    cdef const double* prev = _last_held(w)
    cdef double step, rate, xyz_rate
    cdef int i
    if known >= 0.0:
        step = known
        rate = step / dtk if dtk > 0.0 else 0.0
    else:
        rate = _rate(w, qk, dtk, &step)
    if not w.run_n:
        w.peak = 0.0
        w.trough = 0.0
        for i in range(5):
            w.lead0[i] = lead[i]
        w.plan_peak = 0.0
        w.stretch = INFINITY
        w.len_sum = 0.0
        w.dt_sum = 0.0
    w.len_sum += step
    w.dt_sum += dtk
    xyz_rate = _dist(prev, qk, 3) / dtk if dtk > 0.0 else 0.0
    if plan > 0.0 and xyz_rate > 0.5 * plan:
        w.plan_peak = _pmax(w.plan_peak, plan)
        w.stretch = _pmin(w.stretch, xyz_rate / plan)
    if rate >= w.peak:
        w.peak = rate
        w.trough = rate
    else:
        w.trough = _pmin(w.trough, rate)
    for i in range(5):
        w.run[5 * w.run_n + i] = qk[i]
    w.run_n += 1
    w.run_src = k


cdef double _chord_time(W* w, double arc_mm=0.0) noexcept nogil:
    cdef double length = w.len_sum, total = w.dt_sum, t, xyz
    if w.run_n == 1 or w.peak <= 0.0 or length <= 0.0:
        return total
    t = _pmin(total, length / w.peak)
    if w.plan_peak > 0.0 and w.run_n and w.n > 0:
        xyz = _pmax(_dist(w.last_q, &w.run[5 * (w.run_n - 1)], 3), arc_mm)
        t = _pmax(t, xyz / (w.plan_peak * w.stretch))
    return t


cdef double _scale(W* w) noexcept nogil:
    """10.0**decimals (exact: a power of ten below 1e23 is a double)."""
    cdef double scale = 1.0
    cdef long long c
    for c in range(w.decimals):
        scale = scale * 10.0
    return scale


cdef bint _fit_tilt(W* w, const double* qk, const double* pts, Py_ssize_t npts,
                    double* out) noexcept nogil:
    # _Run.fit_tilt: False where none fits (out then holds nothing). Each point's
    # τ made once, for A and B both: each tilt's bounds narrowed point by point in
    # the reference's order, so the same bits; a point or a tilt that fails fails
    # the fit whichever tilt the reference looks at first.
    cdef const double* a = w.last_q
    cdef const double* p
    cdef double d[3]
    cdef double x[3]
    cdef double s[2]
    cdef double own[2]
    cdef double lo[2]
    cdef double hi[2]
    cdef double h, dd, tau, r
    cdef Py_ssize_t j
    cdef int i, c
    h = w.tilt_fit - 0.5 / _scale(w)
    if h <= 0.0:
        return False
    for i in range(3):
        d[i] = qk[i] - a[i]
    for i in range(3):
        x[i] = d[i] * d[i]
    dd = _fsum(x, 3)
    if dd == 0:
        return False
    for c in range(2):
        s[c] = w.last_ab[c]
        own[c] = qk[3 + c] - s[c]
        lo[c] = own[c] - h
        hi[c] = own[c] + h
    for j in range(npts):
        p = &pts[5 * j]
        for i in range(3):
            x[i] = (p[i] - a[i]) * d[i]
        tau = _fsum(x, 3) / dd
        tau = 0.0 if tau < 0.0 else (1.0 if tau > 1.0 else tau)
        for c in range(2):
            r = p[3 + c] - s[c]
            if tau > 0.0:
                lo[c] = _pmax(lo[c], (r - h) / tau)
                hi[c] = _pmin(hi[c], (r + h) / tau)
            elif fabs(r) > h:
                return False
    for c in range(2):
        if lo[c] > hi[c]:
            return False
        out[c] = s[c] + _pmin(_pmax(own[c], lo[c]), hi[c])
    return True


cdef int _chord_check(W* w, const double* qk, const double* pts, Py_ssize_t npts,
                      double* fit) noexcept nogil:
    # _Run.chord_check: with CHORD_FIT the fitted end tilt in fit (2)
    cdef const double* a = w.last_q
    cdef const double* p
    cdef double d[5]
    cdef double x[5]
    cdef double off[5]
    cdef double dd, t
    cdef bint tilt_ok = True
    cdef Py_ssize_t j
    cdef int i
    if not npts or w.n == 0:
        return CHORD_OK
    for i in range(5):
        d[i] = qk[i] - a[i]
    for i in range(5):
        x[i] = d[i] * d[i]
    dd = _fsum(x, 5)
    if dd == 0:
        return CHORD_NO
    for j in range(npts):
        p = &pts[5 * j]
        for i in range(5):
            x[i] = (p[i] - a[i]) * d[i]
        t = _fsum(x, 5) / dd
        t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
        for i in range(5):
            off[i] = fabs(p[i] - (a[i] + t * d[i]))
        if sqrt(off[0] * off[0] + off[1] * off[1] + off[2] * off[2]) > w.tol:
            return CHORD_NO
        if off[3] > w.tilt_chord or off[4] > w.tilt_chord:
            if w.tilt_fit <= 0.0:
                return CHORD_NO
            tilt_ok = False
    if tilt_ok:
        return CHORD_OK
    return CHORD_FIT if _fit_tilt(w, qk, pts, npts, fit) else CHORD_NO


cdef inline bint _within(W* w, const double* qk) noexcept nogil:
    cdef double fit[2]
    return _chord_check(w, qk, w.run, w.run_n, fit) != CHORD_NO


cdef bint _fit_end(W* w, const double* qk, const double* pts, Py_ssize_t npts,
                   double* out) noexcept nogil:
    # _Run.fit_end: True with the fitted end tilt in out (the chord check's own)
    return _chord_check(w, qk, pts, npts, out) == CHORD_FIT


cdef void _blend_within_f(W* w, double length_n, double t_n, double a_n) noexcept nogil:
    cdef long long idx = w.prev_idx
    cdef double length = w.prev_len, t = w.prev_t
    cdef double v_p, v_n, a_t, v, lead, v_safe, stop_s, slow_s, f
    if idx == NONE or t <= 0.0 or length <= 0.0:
        return
    v_p = length / t
    v_n = length_n / t_n if t_n > 0.0 else 0.0
    a_t = w.prev_accel / 2.0
    v = _pmax(v_p, v_n)
    lead = SERVO_PERIOD_S * (2.0 if _pmin(t, t_n) < 2.0 * v / a_t else 1.0)
    if a_n >= a_t:
        v_safe = v - v_n * (1.0 - a_t / a_n) - a_t * lead
    else:
        v_safe = v - a_n * lead
    if v_safe >= v_p:
        return
    stop_s = v / (2.0 * a_t) + 3.0 * v / (2.0 * 2.0 * a_t)
    slow_s = t * (v_p / v_safe - 1.0) if v_safe > 0.0 else INFINITY
    if slow_s <= stop_s:
        f = 60.0 * v_safe / length
        if idx == CARRIED:
            w.patch = PATCH_F
            w.patch_f = f
        else:
            w.val[idx] = f
    else:
        _stop_prev(w)


cdef void _stop_prev(W* w) noexcept nogil:
    # _Run.stop_prev
    cdef long long idx = w.prev_idx
    if idx == CARRIED:
        w.patch = PATCH_STOP
    elif idx != NONE:
        # a G4 P0 after the line idx: the ops after it move down by one
        memmove(&w.code[idx + 2], &w.code[idx + 1], (w.m - idx - 1) * sizeof(long long))
        memmove(&w.arg[idx + 2], &w.arg[idx + 1], (w.m - idx - 1) * sizeof(long long))
        memmove(&w.ab[idx + 2], &w.ab[idx + 1], (w.m - idx - 1) * sizeof(long long))
        memmove(&w.val[idx + 2], &w.val[idx + 1], (w.m - idx - 1) * sizeof(double))
        memmove(&w.aux[idx + 2], &w.aux[idx + 1], (w.m - idx - 1) * sizeof(long long))
        w.code[idx + 1] = OP_G4P0
        w.arg[idx + 1] = 0
        w.ab[idx + 1] = 0
        w.val[idx + 1] = 0.0
        w.aux[idx + 1] = 0
        w.m += 1
    w.after_settle = 1
    w.prev_idx = NONE
    w.prev_blend = 0


cdef inline double _rise(double a, double b, double radius) noexcept nogil:
    return (b * (2.0 * a - b) if b < a else a * a) / (2.0 * radius)


cdef double _arc_blend_cut(double len_p, double t_p, double a_p, double r_p, double len_n,
                           double t_n, double a_n, double r_n) noexcept nogil:
    # gwrite.arc_blend_cut
    cdef double v_n, reach_p, reach_n, t_b, v_b, overlap, cut = 0.0, t, left, tn, gone, e, step
    cdef long long k
    if t_p <= 0.0 or t_n <= 0.0 or len_p <= 0.0 or len_n <= 0.0:
        return 0.0
    v_n = len_n / t_n
    reach_p = _pmin(len_p / t_p, sqrt(a_p * len_p))
    reach_n = _pmin(v_n, sqrt(a_n * len_n))
    t_b = _pmin(_pmin(len_p / reach_p, len_n / reach_n), _pmax(reach_p / a_p, reach_n / a_n))
    v_b = _pmin(reach_p, t_b * a_p)
    overlap = v_b * v_b / (2.0 * a_p)
    step = v_b / a_p / BLEND_STEPS
    for k in range(BLEND_STEPS + 1):
        t = <double>k * step
        left = _pmax(overlap - v_b * t + a_p * t * t / 2.0, 0.0)
        tn = t + SERVO_PERIOD_S
        if a_n * tn < v_n:
            gone = a_n * tn * tn / 2.0
        else:
            gone = v_n * tn - v_n * v_n / (2.0 * a_n)
        gone = _pmin(gone, len_n)
        e = 0.0
        if r_p > 0.0:
            e += _rise(left, gone, r_p)
        if r_n > 0.0:
            e += _rise(gone, left, r_n)
        cut = _pmax(cut, e)
    return cut


def arc_blend_cut(double len_p, double t_p, double a_p, double r_p, double len_n, double t_n,
                  double a_n, double r_n):
    """:func:`prsxy_post.kernel.gwrite.arc_blend_cut`, compiled."""
    return _arc_blend_cut(len_p, t_p, a_p, r_p, len_n, t_n, a_n, r_n)


cdef double _arc_cut(W* w, double length_n, double t_n, double a_n, double radius_n) noexcept nogil:
    # _Run.arc_cut
    cdef double a_p, a_next
    if w.prev_idx == NONE or (w.prev_radius <= 0.0 and radius_n <= 0.0):
        return 0.0
    a_p = w.prev_accel / (4.0 if w.prev_radius > 0.0 else 2.0)
    a_next = a_n / 2.0 if radius_n > 0.0 else a_n
    return _arc_blend_cut(w.prev_len, w.prev_t, a_p, w.prev_radius, length_n, t_n, a_next,
                          radius_n)


cdef long long _tilt_held(W* w, long long src, const double* q, double hold) noexcept nogil:
    if w.held_src != NONE:
        if fabs(q[3] - w.held_ab[0]) <= hold and fabs(q[4] - w.held_ab[1]) <= hold:
            return w.held_src
    w.held_ab[0] = q[3]
    w.held_ab[1] = q[4]
    w.held_src = src
    return src


cdef void _g1(W* w, long long src, const double* q_in, double t, bint exact,
              long long arc=NONE, double arc_len=0.0, long long plane=17,
              const double* fit=NULL, double radius=0.0) noexcept nogil:
    cdef double q[5]
    cdef double d_xyz[3]
    cdef double d_ab[2]
    cdef double length, accel, a_n, scale
    cdef long long ab_src
    cdef bint turns, parabolic, mode
    cdef int i
    for i in range(5):
        q[i] = q_in[i]  # q_in may be a held-back row the ops below do not touch
    exact = exact or w.all_exact != 0
    if fit != NULL:
        scale = _scale(w)
        for i in range(2):
            w.held_ab[i] = rint(fit[i] * scale) / scale + 0.0
            w.tilts[2 * w.nt + i] = w.held_ab[i]
        w.held_src = ab_src = w.npts + w.nt
        w.nt += 1
    else:
        ab_src = _tilt_held(w, src, q, w.tilt_hold if arc == NONE else w.arc_hold)
    turns = w.held_ab[0] != w.last_ab[0] or w.held_ab[1] != w.last_ab[1]
    length = _dist(w.last_q, q, 3) if arc == NONE else arc_len
    for i in range(3):
        d_xyz[i] = q[i] - w.last_q[i]
    for i in range(2):
        d_ab[i] = w.held_ab[i] - w.last_ab[i]
    accel = _line_accel(d_xyz, d_ab, w.accel, w.accel_deg)
    if arc != NONE:
        accel = w.accel
    w.last_ab[0] = w.held_ab[0]
    w.last_ab[1] = w.held_ab[1]
    if w.has_prev and w.prev_blend and (w.prev_turns or turns):
        a_n = accel / 2.0 if turns or exact else accel
        if _arc_cut(w, length, t, a_n, radius) > w.blend:
            _stop_prev(w)
        else:
            _blend_within_f(w, length, t, a_n)
    parabolic = w.has_prev and w.prev_blend and (w.prev_turns or turns)
    mode = (exact or w.after_settle != 0) and not (exact and parabolic and not w.all_exact)
    if mode != (w.exact != 0):
        _emit(w, OP_G61 if mode else OP_G64, 0, 0, 0.0)
        w.exact = mode
    if arc == NONE:
        _emit(w, OP_G1, src, ab_src, 60.0 / t)
    else:
        if plane != w.plane:
            _emit(w, OP_PLANE, 0, 0, 0.0, plane)
            w.plane = plane
        _emit(w, OP_ARC, src, ab_src, 60.0 / t, arc)
    w.has_prev = 1
    w.prev_idx = w.m - 1
    w.prev_len = length
    w.prev_t = t
    w.prev_turns = turns
    w.prev_blend = not mode and not exact
    w.prev_accel = accel
    w.prev_radius = radius
    w.after_settle = exact
    if exact:
        _emit(w, OP_G4P0, 0, 0, 0.0)
    for i in range(5):
        w.last_q[i] = q[i]
    w.n += 1


cdef void _write_held(W* w) noexcept nogil:
    cdef double qh[5]
    cdef double fit[2]
    cdef double t
    cdef bint fitted
    cdef int i
    if not w.run_n:
        return
    for i in range(5):
        qh[i] = w.run[5 * (w.run_n - 1) + i]
    fitted = _fit_end(w, qh, w.run, w.run_n - 1, fit)
    t = _chord_time(w)
    w.run_n = 0
    _g1(w, w.run_src, qh, t, False, NONE, 0.0, 17, &fit[0] if fitted else NULL)


cdef inline void _at_rest(W* w) noexcept nogil:
    if w.has_prev:
        w.prev_blend = 0


cdef void _resolve_corner(W* w, const double* q_next, double dt_next) noexcept nogil:
    cdef double qc[5]
    cdef double q_in[5]
    cdef double t = w.corner_t, mm, deg, t_in
    cdef long long src = w.corner_src, arc
    cdef bint exact = False, fitted
    cdef int i
    if w.corner_src == NONE:
        return
    for i in range(5):
        qc[i] = w.corner_q[i]
    w.corner_src = NONE
    # an arc's end: the corner is its last piece's (rule 5)
    arc = w.corner_arc
    t_in = t
    for i in range(5):
        q_in[i] = w.last_q[i]
    if arc != NONE:
        for i in range(5):
            q_in[i] = w.corner_in[i]
        t_in = w.ca_dt
    w.corner_arc = NONE
    fitted = w.corner_fit != 0
    w.corner_fit = 0
    if q_next != NULL and w.n > 0 and dt_next > 0.0:
        _corner_cut(q_in, qc, q_next, t_in, dt_next, w.accel, &mm, &deg)
        exact = mm > w.blend or deg > w.tilt_cut
    _g1(w, src, qc, t, exact, arc, w.ca_len, w.ca_plane, &qc[3] if fitted else NULL,
        w.ca_radius if arc != NONE else 0.0)


cdef inline bint _same5(const double* a, const double* b) noexcept nogil:
    cdef int i
    for i in range(5):
        if a[i] != b[i]:
            return False
    return True


cdef double _arc_time(W* w, long long a) noexcept nogil:
    # _Run.arc_time
    cdef double length = w.arc_f[2 * a], radius = w.arc_f[2 * a + 1], t, v
    t = _chord_time(w, length)
    if w.smooth > 0.0 and radius > 0.0:
        v = sqrt(24.0 * radius * w.smooth / 7.0) / SERVO_PERIOD_S
        t = _pmax(t, length / v)
    return t


cdef void _arc_in(W* w, long long a, double t, const double* q_before, const double* q_end,
                  double dt, double* out) noexcept nogil:
    # _Run.arc_in
    cdef double d[5]
    cdef double nrm, step
    cdef int i
    for i in range(5):
        d[i] = q_end[i] - q_before[i]
    nrm = _hypot(d, 3)
    if nrm <= 0.0 or t <= 0.0:
        for i in range(5):
            out[i] = q_before[i]
        return
    step = w.arc_f[2 * a] / t * dt / nrm
    for i in range(5):
        out[i] = q_end[i] - d[i] * step


cdef bint _center_tilt(W* w, long long a) noexcept nogil:
    # _Run.center_tilt, numpy's operations one column at a time
    cdef long long start = w.arc_i[4 * a], end = w.arc_i[4 * a + 1], nxt, j, rows[3]
    cdef double lo[2]
    cdef double hi[2]
    cdef double low[2]
    cdef double high[2]
    cdef double value[2]
    cdef double emax, emin, x, margin, scale, d
    cdef bint covers = True, loose
    cdef int c, r
    if w.tilt_hold <= 0.0 or w.held_src == NONE or not w.run_n:
        return False
    if not _same5(&w.run[5 * (w.run_n - 1)], &w.q[5 * start]):
        return False
    while end + 1 < w.npts and w.arc_of[end + 1] >= 0:
        nxt = w.arc_of[end + 1]
        if w.arc_i[4 * nxt] != end:
            break
        end = w.arc_i[4 * nxt + 1]
    rows[0] = start
    rows[1] = end
    rows[2] = end + 1 if end + 1 < w.npts - 1 else w.npts - 1
    for c in range(2):
        lo[c] = w.q[5 * start + 3 + c]
        hi[c] = lo[c]
        for j in range(start + 1, end + 1):
            x = w.q[5 * j + 3 + c]
            if x < lo[c]:
                lo[c] = x
            if x > hi[c]:
                hi[c] = x
        emax = w.q[5 * rows[0] + 3 + c]
        emin = emax
        for r in range(1, 3):
            x = w.q[5 * rows[r] + 3 + c]
            if x > emax:
                emax = x
            if x < emin:
                emin = x
        low[c] = _npmax(hi[c] - w.arc_hold, emax - w.tilt_hold)
        high[c] = _npmin(lo[c] + w.arc_hold, emin + w.tilt_hold)
        covers = covers and w.held_ab[c] >= low[c] and w.held_ab[c] <= high[c]
    if covers:
        return False  # the tilt held covers the run
    margin = 0.001 * w.tilt_hold
    loose = w.run_n == 1 and (low[0] + margin > high[0] - margin
                              or low[1] + margin > high[1] - margin)
    if loose:
        # the line to the start is one piece: the end and the point after it only
        for c in range(2):
            emax = w.q[5 * rows[1] + 3 + c]
            emin = emax
            x = w.q[5 * rows[2] + 3 + c]
            if x > emax:
                emax = x
            if x < emin:
                emin = x
            low[c] = _npmax(hi[c] - w.arc_hold, emax - w.tilt_hold)
            high[c] = _npmin(lo[c] + w.arc_hold, emin + w.tilt_hold)
    scale = 1.0
    for c in range(w.decimals):
        scale = scale * 10.0
    for c in range(2):
        if low[c] + margin <= high[c] - margin:
            value[c] = _npmin(_npmax(w.held_ab[c], low[c] + margin), high[c] - margin)
        else:
            d = w.q[5 * end + 3 + c] - w.q[5 * start + 3 + c]
            x = 1.0 if d > 0.0 else (-1.0 if d < 0.0 else 0.0)
            value[c] = w.q[5 * start + 3 + c] + x * (w.tilt_hold - margin)
        value[c] = rint(value[c] * scale) / scale + 0.0
        w.held_ab[c] = value[c]
        w.tilts[2 * w.nt + c] = value[c]
    w.held_src = w.npts + w.nt
    w.nt += 1
    return loose


cdef bint _tilt_leaves(W* w, const double* qk) noexcept nogil:
    if w.arc_hold <= 0.0 or w.held_src == NONE:
        return False
    return fabs(qk[3] - w.held_ab[0]) > w.arc_hold or fabs(qk[4] - w.held_ab[1]) > w.arc_hold


cdef void _write_arc_to(W* w, long long k, long long part) noexcept nogil:
    # _Run.write_arc_to
    cdef double qh[5]
    cdef double t
    cdef long long first, j, held_n
    cdef int i
    if not w.run_n:
        return
    if part >= 0:
        for i in range(5):
            qh[i] = w.run[5 * (w.run_n - 1) + i]
        t = _arc_time(w, part)
        w.run_n = 0
        _g1(w, w.run_src, qh, t, False, part, w.arc_f[2 * part], w.arc_i[4 * part + 2],
            NULL, w.arc_f[2 * part + 1])
        return
    held_n = w.run_n
    w.run_n = 0
    first = k - held_n
    for j in range(held_n):
        # the held rows stay as they are: _g1 copies its point, and holds none
        _g1(w, first + j, &w.run[5 * j], w.dt[first + j], False)


cdef bint _on_arc(W* w, long long k, const double* qk, double dtk, const double* lead,
                  double plan, bint bend) noexcept nogil:
    # _Run.on_arc
    cdef long long a = w.arc_of[k]
    cdef long long start = w.arc_i[4 * a], end = w.arc_i[4 * a + 1]
    cdef long long plane = w.arc_i[4 * a + 2], refit = w.arc_i[4 * a + 3]
    cdef double qh[5]
    cdef double held[2]
    cdef double t
    cdef bint settled
    cdef int i
    if k == start + 1:
        if _center_tilt(w, a):
            for i in range(5):
                qh[i] = w.run[5 * (w.run_n - 1) + i]
            held[0] = w.held_ab[0]
            held[1] = w.held_ab[1]
            t = _chord_time(w)
            w.run_n = 0
            _g1(w, w.run_src, qh, t, False, NONE, 0.0, 17, held)
        _write_held(w)
        settled = w.after_settle and not w.all_exact and not refit
        if settled or not _same5(w.last_q, &w.q[5 * start]):
            w.stop_at = k
            w.req_kind = REQ_REARC
            w.req_arc = a
            return True
    elif _tilt_leaves(w, qk):
        w.stop_at = k
        w.req_kind = REQ_ARC_TO
        w.req_arc = a
        return True
    _hold(w, k, qk, dtk, lead, plan)
    if k == end:
        t = _arc_time(w, a)
        w.run_n = 0
        if bend:
            for i in range(5):
                w.corner_q[i] = qk[i]
            w.corner_t = t
            w.corner_src = k
            w.corner_arc = a
            w.ca_dt = dtk
            w.ca_len = w.arc_f[2 * a]
            w.ca_radius = w.arc_f[2 * a + 1]
            w.ca_plane = plane
            _arc_in(w, a, t, &w.q[5 * (k - 1)], qk, dtk, w.corner_in)
        else:
            _g1(w, k, qk, t, False, a, w.arc_f[2 * a], plane, NULL, w.arc_f[2 * a + 1])
    return False


cdef void _chords(W* w, long long k, const double* qk, double dtk, double spd, bint bend,
                  const double* lead, double plan) noexcept nogil:
    # _Run.chords
    cdef double fit[2]
    cdef double t, step = -1.0  # the piece's length _dips measured, if it did
    cdef bint fitted
    cdef int i
    if w.tol > 0 and not bend and spd > 0:
        if not _within(w, qk) or _dips(w, qk, dtk, lead, &step):
            _write_held(w)
            step = -1.0  # from another point now
        _hold(w, k, qk, dtk, lead, plan, step)
        return
    if w.run_n and (not _within(w, qk) or _dips(w, qk, dtk, lead, &step)):
        _write_held(w)
        step = -1.0
    _hold(w, k, qk, dtk, lead, plan, step)
    fitted = _fit_end(w, qk, w.run, w.run_n - 1, fit)
    t = _chord_time(w)
    w.run_n = 0
    if spd > 0.0 and bend:
        # the corner's fitted tilt (if any) rides in its pose
        for i in range(5):
            w.corner_q[i] = qk[i]
        if fitted:
            w.corner_q[3] = fit[0]
            w.corner_q[4] = fit[1]
        w.corner_fit = fitted
        w.corner_t = t
        w.corner_src = k
        return
    _g1(w, k, qk, t, spd == 0.0, NONE, 0.0, 17, &fit[0] if fitted else NULL)


cdef bint _point(W* w, long long k, const double* qk, double dtk, long long line, double spd,
                 bint bend, bint fn, bint fn_end, bint dwell, const double* lead,
                 double plan, bint resume) noexcept nogil:
    # the writer's loop body for the point k (_Run.point): True where it stops
    cdef bint stands
    cdef int i
    if resume:
        if w.req_kind == REQ_ARC_TO:
            _write_arc_to(w, k, w.req_answer)
        w.stop_at = NONE
        w.req_kind = NONE
        _chords(w, k, qk, dtk, spd, bend, lead, plan)
        return False
    if w.n == 0:
        _emit(w, OP_G0, k, 0, 0.0)
        _emit(w, OP_G93, 0, 0, 0.0)
        w.last_ab[0] = qk[3]
        w.last_ab[1] = qk[4]
        for i in range(5):
            w.last_q[i] = qk[i]
        w.n = 1
        return False
    if w.corner_src != NONE:
        _resolve_corner(w, qk, dtk)
    if not w.has_line or line != w.last_line:
        _emit(w, OP_LINE, k, 0, 0.0)
        w.has_line = 1
        w.last_line = line
    w.t_total += dtk
    if fn:
        _write_held(w)
        _at_rest(w)
        if fn_end:
            _emit(w, OP_G94, 0, 0, 0.0)
        _emit(w, OP_FN, k, 0, 0.0)
        return False
    if dwell:
        stands = True
        for i in range(5):
            stands = stands and qk[i] == w.last_q[i]
        if stands:  # the pose stands: a dwell
            _write_held(w)
            _at_rest(w)
            _emit(w, OP_DWELL, k, 0, 0.0)
            return False
    if w.has_arcs and w.arc_of[k] >= 0:
        return _on_arc(w, k, qk, dtk, lead, plan, bend)
    _chords(w, k, qk, dtk, spd, bend, lead, plan)
    return False


cdef void _load(W* w, double[::1] f, long long[::1] iv, st):
    cdef double[::1] a
    cdef int i
    w.tol, w.blend, w.tilt_cut, w.tilt_hold, w.tilt_chord = f[0], f[1], f[2], f[3], f[4]
    w.accel, w.accel_deg, w.prev_accel, w.t_total, w.last_speed = f[5], f[6], f[7], f[8], f[9]
    w.peak, w.trough, w.plan_peak, w.stretch, w.len_sum = f[10], f[11], f[12], f[13], f[14]
    w.dt_sum, w.corner_t, w.prev_len, w.prev_t, w.patch_f = f[15], f[16], f[17], f[18], f[19]
    w.all_exact, w.n, w.has_line, w.last_line, w.run_n = iv[0], iv[1], iv[2], iv[3], iv[4]
    w.run_src, w.corner_src, w.held_src, w.exact = iv[5], iv[6], iv[7], iv[8]
    w.after_settle, w.prev_idx, w.prev_turns, w.prev_blend = iv[9], iv[10], iv[11], iv[12]
    w.has_prev, w.patch, w.keep = iv[13], iv[14], iv[15]
    w.smooth, w.arc_hold, w.speed0, w.ca_len, w.ca_dt = f[20], f[21], f[22], f[23], f[24]
    w.plane, w.stop_at, w.req_kind, w.req_arc = iv[16], iv[17], iv[18], iv[19]
    w.req_answer, w.corner_arc, w.ca_plane, w.ca_from, w.decimals = (
        iv[20], iv[21], iv[22], iv[23], iv[24])
    w.tilt_fit, w.corner_fit = f[25], iv[25]
    w.ca_radius, w.prev_radius = f[26], f[27]
    a = st.corner_in
    for i in range(5):
        w.corner_in[i] = a[i]
    a = st.last_q
    for i in range(5):
        w.last_q[i] = a[i]
    a = st.last_ab
    for i in range(2):
        w.last_ab[i] = a[i]
    a = st.held_ab
    for i in range(2):
        w.held_ab[i] = a[i]
    a = st.lead0
    for i in range(5):
        w.lead0[i] = a[i]
    a = st.corner_q
    for i in range(5):
        w.corner_q[i] = a[i]


cdef void _store(W* w, double[::1] f, long long[::1] iv, st):
    cdef double[::1] a
    cdef int i
    f[0], f[1], f[2], f[3], f[4] = w.tol, w.blend, w.tilt_cut, w.tilt_hold, w.tilt_chord
    f[5], f[6], f[7], f[8], f[9] = w.accel, w.accel_deg, w.prev_accel, w.t_total, w.last_speed
    f[10], f[11], f[12], f[13], f[14] = w.peak, w.trough, w.plan_peak, w.stretch, w.len_sum
    f[15], f[16], f[17], f[18], f[19] = w.dt_sum, w.corner_t, w.prev_len, w.prev_t, w.patch_f
    iv[0], iv[1], iv[2], iv[3], iv[4] = w.all_exact, w.n, w.has_line, w.last_line, w.run_n
    iv[5], iv[6], iv[7], iv[8] = w.run_src, w.corner_src, w.held_src, w.exact
    iv[9], iv[10], iv[11], iv[12] = w.after_settle, w.prev_idx, w.prev_turns, w.prev_blend
    iv[13], iv[14], iv[15] = w.has_prev, w.patch, w.keep
    f[20], f[21], f[22], f[23], f[24] = w.smooth, w.arc_hold, w.speed0, w.ca_len, w.ca_dt
    iv[16], iv[17], iv[18], iv[19] = w.plane, w.stop_at, w.req_kind, w.req_arc
    iv[20], iv[21], iv[22], iv[23], iv[24] = (
        w.req_answer, w.corner_arc, w.ca_plane, w.ca_from, w.decimals)
    f[25], iv[25] = w.tilt_fit, w.corner_fit
    f[26], f[27] = w.ca_radius, w.prev_radius
    a = st.corner_in
    for i in range(5):
        a[i] = w.corner_in[i]
    a = st.last_q
    for i in range(5):
        a[i] = w.last_q[i]
    a = st.last_ab
    for i in range(2):
        a[i] = w.last_ab[i]
    a = st.held_ab
    for i in range(2):
        a[i] = w.held_ab[i]
    a = st.lead0
    for i in range(5):
        a[i] = w.lead0[i]
    a = st.corner_q
    for i in range(5):
        a[i] = w.corner_q[i]


cdef bint _arcs_named(const long long[::1] arc_of, Py_ssize_t n_arcs) noexcept:
    """Whether every point's arc (-1: none) is a row of arc_i."""
    cdef Py_ssize_t k
    for k in range(arc_of.shape[0]):
        if arc_of[k] >= n_arcs:
            return False
    return True


cdef bint _ends_inside(const long long[:, ::1] arc_i, Py_ssize_t n) noexcept:
    """Whether every arc's start and end is a point of the chunk (0 <= j < n)."""
    cdef Py_ssize_t a, c
    for a in range(arc_i.shape[0]):
        for c in range(2):
            if arc_i[a, c] < 0 or arc_i[a, c] >= n:
                return False
    return True


cdef object _owner(x, Py_ssize_t rows, Py_ssize_t cols):
    """The buffer a stopped call left ``x`` a view of (its first entries, as
    :func:`gcode_ops` stores them), or None: a (rows', cols) float or a (4,
    rows') int64 array at the same address (``rows``: the entries needed)."""
    if not isinstance(x, np.ndarray):
        return None
    b = x.base
    if not isinstance(b, np.ndarray) or not b.flags.c_contiguous or b.ndim != 2:
        return None
    if b.__array_interface__["data"][0] != x.__array_interface__["data"][0]:
        return None
    if cols == 4:  # the int ops (4, capacity): x = b[:, :m].T
        if b.dtype != np.int64 or b.shape[0] != 4 or b.shape[1] < rows:
            return None
        if x.ndim != 2 or x.strides != (8, 8 * b.shape[1]):
            return None
    elif b.dtype != np.float64 or b.shape[1] != cols or b.shape[0] < rows:
        return None
    return b


cdef tuple _buffers(st, bint resume, Py_ssize_t cap, Py_ssize_t cap_t, Py_ssize_t n):
    """The op buffers of a call: ops (4, cap) int64 (code, arg, ab, aux), val
    (cap,), tilts (cap_t, 2), holding the ops so far of a resumed call. A call
    that resumes its own stop (``st.pend_*`` views of the buffers it left) goes on
    in them, without allocating or copying; others fill the state's scratch
    buffers (:class:`gwrite.Scratch`) again where they have room, else get new
    ones with room for a chunk's stops (twice the first call's need), kept there,
    the ops so far copied in."""
    cdef Py_ssize_t m0 = len(st.pend_i) if resume else 0
    cdef Py_ssize_t nt0 = len(st.pend_t) if resume else 0
    if resume:
        ops_i = _owner(st.pend_i, cap, 4)
        vb = st.pend_v.base if isinstance(st.pend_v, np.ndarray) else None
        tilts = _owner(st.pend_t, cap_t, 2)
        if (ops_i is not None and tilts is not None and isinstance(vb, np.ndarray)
                and vb.dtype == np.float64 and vb.ndim == 1 and vb.shape[0] == ops_i.shape[1]
                and vb.__array_interface__["data"][0]
                == st.pend_v.__array_interface__["data"][0]):
            return ops_i, vb, tilts
    bufs = _scratch(st, cap, cap_t)
    if bufs is None:
        bufs = (np.empty((4, cap + 14 * n + 16), dtype=np.int64),
                np.empty(cap + 14 * n + 16, dtype=np.float64),
                np.empty((cap_t + n + 1, 2), dtype=np.float64))
        if isinstance(getattr(st, "scratch", None), gwrite.Scratch):
            st.scratch.bufs = bufs
    ops_i, val, tilts = bufs
    if resume:
        # np.copyto, as the pending ops may be views of these buffers themselves
        np.copyto(ops_i[:, :m0], np.asarray(st.pend_i, dtype=np.int64).reshape(-1, 4).T)
        np.copyto(val[:m0], st.pend_v)
        np.copyto(tilts[:nt0], np.asarray(st.pend_t).reshape(-1, 2))
    return ops_i, val, tilts


cdef object _scratch(st, Py_ssize_t cap, Py_ssize_t cap_t):
    """The state's scratch buffers (ops, val, tilts) where they hold ``cap`` ops
    and ``cap_t`` tilts, else None."""
    sc = getattr(st, "scratch", None)
    if not isinstance(sc, gwrite.Scratch) or sc.bufs is None:
        return None
    ops_i, val, tilts = sc.bufs
    if ops_i.shape[1] < cap or val.shape[0] < cap or tilts.shape[0] < cap_t:
        return None
    return sc.bufs


def gcode_ops(st, q, dt, line, speed, block_end, fn, fn_end, dwell, lead, bint end,
              arc_of=None, arc_i=None, arc_f=None, fit=None):
    """:func:`prsxy_post.kernel.gwrite.gcode_ops`, compiled (``st.run_q`` must
    hold ``len(q)`` more points: :func:`gwrite.reserve`). With ``fit`` the call
    answers its stops itself (:func:`_refit`) and goes on. After a stop,
    ``st.pend_*`` are views of the call's op buffers, which the call resuming it
    fills on in place: copy the state (``copy.deepcopy``) to keep a stopped one."""
    if np.ndim(q) != 2 or np.shape(q)[1] != 5 or np.ndim(lead) != 2 or np.shape(lead)[1] != 5:
        raise ValueError(f"q and lead need (N, 5), got {np.shape(q)} and {np.shape(lead)}")
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=np.float64).reshape(-1, 5)
    cdef const double[::1] dtv = np.ascontiguousarray(dt, dtype=np.float64)
    cdef const long long[::1] lv = np.ascontiguousarray(line, dtype=np.int64)
    cdef const double[::1] sv = np.ascontiguousarray(speed, dtype=np.float64)
    cdef const unsigned char[::1] bv = np.ascontiguousarray(block_end, dtype=bool).view(np.uint8)
    cdef const unsigned char[::1] fv = np.ascontiguousarray(fn, dtype=bool).view(np.uint8)
    cdef const unsigned char[::1] ev = np.ascontiguousarray(fn_end, dtype=bool).view(np.uint8)
    cdef const unsigned char[::1] wv = np.ascontiguousarray(dwell, dtype=bool).view(np.uint8)
    cdef const double[:, ::1] ld = np.ascontiguousarray(lead, dtype=np.float64).reshape(-1, 5)
    cdef Py_ssize_t n = qv.shape[0], k0, m0, nt0
    cdef double[::1] f = st.f
    cdef long long[::1] iv = st.i
    cdef double[:, ::1] run = st.run_q
    cdef W w
    cdef bint resume, stopped = False
    has_arcs = arc_of is not None
    if not has_arcs:
        arc_of, arc_i, arc_f = np.zeros(0, np.int64), np.zeros((0, 4), np.int64), np.zeros((0, 2))
    elif fit is not None:  # refitted here: arc_of changes, the caller's stays
        arc_of = np.array(arc_of, dtype=np.int64)
    new = []
    cdef const long long[::1] aov = np.ascontiguousarray(arc_of, dtype=np.int64)
    cdef const long long[:, ::1] aiv = np.ascontiguousarray(arc_i, dtype=np.int64).reshape(-1, 4)
    cdef const double[:, ::1] afv = np.ascontiguousarray(arc_f, dtype=np.float64).reshape(-1, 2)
    if not (dtv.shape[0] == lv.shape[0] == sv.shape[0] == bv.shape[0] == fv.shape[0]
            == ev.shape[0] == wv.shape[0] == ld.shape[0] == n):
        raise ValueError(f"every input needs one row per point ({n})")
    if has_arcs and aov.shape[0] != n:
        raise ValueError(f"arc_of needs one row per point ({n}), got {aov.shape[0]}")
    if has_arcs and (not _arcs_named(aov, aiv.shape[0]) or aiv.shape[0] != afv.shape[0]):
        raise ValueError("arc_of names an arc arc_i and arc_f do not hold")
    if has_arcs and not _ends_inside(aiv, n):
        raise ValueError("an arc's start or end is no point of the chunk")
    if f.shape[0] != len(F_NAMES) or iv.shape[0] != len(I_NAMES) or run.shape[1] != 5:
        raise ValueError("not a gwrite.GState")
    if iv[4] + n > run.shape[0]:
        raise ValueError(f"st.run_q holds {run.shape[0]} points, {iv[4] + n} may be held")
    resume = iv[17] != NONE
    m0 = len(st.pend_i) if resume else 0
    nt0 = len(st.pend_t) if resume else 0
    ops_i, val, tilts = _buffers(st, resume, m0 + 14 * n + 16, nt0 + 3 * n + 4, n)
    code, arg, ab, aux = ops_i[0], ops_i[1], ops_i[2], ops_i[3]
    cdef long long[::1] cv = code, av = arg, abv = ab, xv = aux
    cdef double[::1] vv = val
    cdef double[:, ::1] tv = tilts
    _load(&w, f, iv, st)
    w.run = &run[0, 0]
    w.code, w.arg, w.ab, w.aux, w.val, w.m = &cv[0], &av[0], &abv[0], &xv[0], &vv[0], m0
    w.q = &qv[0, 0] if n else NULL
    w.dt = &dtv[0] if n else NULL
    w.npts = n
    w.has_arcs = has_arcs and n > 0
    w.arc_of = &aov[0] if aov.shape[0] else NULL
    w.arc_i = &aiv[0, 0] if aiv.shape[0] else NULL
    w.arc_f = &afv[0, 0] if afv.shape[0] else NULL
    w.tilts = &tv[0, 0]
    w.nt = nt0
    k0 = w.stop_at if resume else 0
    if not resume:
        w.speed0 = w.last_speed
        if n:
            w.last_speed = sv[n - 1]
    while True:
        with nogil:
            stopped = _decide(&w, k0, resume, qv, dtv, lv, sv, bv, fv, ev, wv, ld)
        if not stopped or fit is None:
            break  # else answered here, and on from the stop with the arcs refitted
        arc_i, arc_f = _refit(&w, q, fit, arc_of, arc_i, arc_f, new)
        aov, aiv, afv = arc_of, arc_i, arc_f
        w.arc_of, w.arc_i, w.arc_f = &aov[0], &aiv[0, 0], &afv[0, 0]
        k0, resume, stopped = w.stop_at, True, False
    if not stopped:
        with nogil:
            if end:
                _resolve_corner(&w, NULL, 0.0)
                _write_held(&w)
            _hand_out(&w)
    _store(&w, f, iv, st)
    st.fit_i, st.fit_f = _fitted(new)
    m = w.m
    if stopped:
        # the ops so far stay in the buffers: the next call resumes them in place
        st.pend_i = ops_i[:, :m].T
        st.pend_v = val[:m]
        st.pend_t = tilts[: w.nt]
        e = np.zeros(0, dtype=np.int64)
        return e, e.copy(), e.copy(), e.copy(), np.zeros(0), np.zeros((0, 2))
    st.pend_i = np.zeros((0, 4), dtype=np.int64)
    st.pend_v, st.pend_t = np.zeros(0), np.zeros((0, 2))
    return (code[:m].copy(), arg[:m].copy(), ab[:m].copy(), aux[:m].copy(), val[:m].copy(),
            tilts[: w.nt].copy())


cdef bint _decide(
    W* w, Py_ssize_t k0, bint resume, const double[:, ::1] qv, const double[::1] dtv,
    const long long[::1] lv, const double[::1] sv, const unsigned char[::1] bv,
    const unsigned char[::1] fv, const unsigned char[::1] ev, const unsigned char[::1] wv,
    const double[:, ::1] ld
) noexcept nogil:
    """The chunk's points from k0 (``_point`` each; with ``resume`` k0 goes on from
    a stop): True where it stops for a refit (``gwrite._decide`` without fit)."""
    cdef double prev_speed = w.speed0 if k0 == 0 else sv[k0 - 1], plan
    cdef Py_ssize_t k
    for k in range(k0, qv.shape[0]):
        # the plan's mean speed over the piece (it ramps linearly over a period)
        plan = 0.5 * (prev_speed + sv[k])
        prev_speed = sv[k]
        if _point(w, k, &qv[k, 0], dtv[k], lv[k], sv[k], bv[k], fv[k], ev[k], wv[k],
                  &ld[k, 0], plan, resume and k == k0):
            return True
    return False


cdef void _hand_out(W* w) noexcept nogil:
    """The call's end (``_Run.hand_out``): the line that waits for the next chunk,
    and the points and the arc the next chunk may name as the writer keeps them."""
    if w.has_prev and w.prev_blend and w.prev_idx != NONE:
        w.keep = w.prev_idx
        w.prev_idx = CARRIED
    else:
        w.keep = NONE
        w.prev_idx = NONE
    if w.run_src >= 0:
        w.run_src = -1
    if w.corner_src >= 0:
        w.corner_src = CORNER_SRC
    w.ca_from = NONE
    if w.corner_arc >= 0:
        w.ca_from = w.corner_arc
        w.corner_arc = CORNER_SRC
    if w.held_src != NONE:
        w.held_src = -3


cdef tuple _refit(W* w, q, fit, long long[::1] arc_of, arc_i, arc_f, list new):
    """The answer to the stop at ``w.stop_at`` (``gwrite.refit``): the arc's points
    from there on as arcs again, and for ARC_TO first the arc from its start to
    the point before as one arc where one fits (``w.req_answer``); ``arc_of``
    updated in place, the grown (arc_i, arc_f) returned, the new rows in ``new``."""
    cdef long long k = w.stop_at, a = w.req_arc
    cdef long long start = w.arc_i[4 * a], end = w.arc_i[4 * a + 1], plane = w.arc_i[4 * a + 2]
    cdef long long first = len(arc_i), j, p, e
    parts = []
    if w.req_kind == REQ_ARC_TO:
        ai, af = _arcs.refit_arcs(q[start:k], plane, 0, k - 1 - start, *fit)
        w.req_answer = -1
        if len(ai) == 1 and ai[0, 1] == k - 1 - start:
            ai[:, :2] += start
            parts.append((ai, af))
            w.req_answer = first
    first += sum(len(p[0]) for p in parts)
    for j in range(k, end + 1):
        arc_of[j] = -1
    ai, af = _arcs.refit_arcs(q[k : end + 1], plane, 0, end - k, *fit)
    ai[:, :2] += k
    parts.append((ai, af))
    for j in range(len(ai)):
        e = ai[j, 1]
        for p in range(ai[j, 0] + 1, e + 1):
            arc_of[p] = first + j
    new += parts
    grow_i = [arc_i] + [np.column_stack([r[:, :3], np.ones(len(r), np.int64)]) for r, _ in parts]
    grow_f = [arc_f] + [r[:, 3::2] for _, r in parts]
    return (np.ascontiguousarray(np.concatenate(grow_i), dtype=np.int64).reshape(-1, 4),
            np.ascontiguousarray(np.concatenate(grow_f), dtype=np.float64).reshape(-1, 2))


def _fitted(list new):
    """The rows of the arcs a call refitted, joined: (K, 4) int64, (K, 6)."""
    if not new:
        return np.zeros((0, 4), dtype=np.int64), np.zeros((0, 6))
    return (np.concatenate([a for a, _ in new]).astype(np.int64),
            np.concatenate([f for _, f in new]).astype(np.float64))
