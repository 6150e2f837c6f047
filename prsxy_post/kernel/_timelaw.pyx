# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The time law compiled: :mod:`prsxy_post.kernel.timelaw` block by block (and point
by point), the same operations in the same order, so the two agree to the bit.
Compiled with -O2 -ffp-contract=off (no fused multiply-adds, which would round
differently from numpy's separate multiply and add)."""

import numpy as np

from libc.math cimport INFINITY, fabs, isfinite, sqrt

from .timelaw import BISECT_STEPS as _STEPS
from .timelaw import TimeLaw

cdef int BISECT_STEPS = _STEPS

cdef extern from *:
    """
    #include <stdint.h>
    #include <string.h>
    /* c ? a : b, bit for bit, with no branch: the bisection's choices are as
       good as random, and a mispredicted branch costs more than the arithmetic */
    static inline double prsxy_pick(int c, double a, double b) {
        uint64_t ua, ub, m = (uint64_t)0 - (uint64_t)(c != 0);
        memcpy(&ua, &a, sizeof ua);
        memcpy(&ub, &b, sizeof ub);
        ua = (ua & m) | (ub & ~m);
        memcpy(&a, &ua, sizeof a);
        return a;
    }

    /* timelaw.trapezoids' room at peak x, L - s1 - s3, the reference's operations in
       its order; a phase's time max(dv / a, h) where dv > 0 (h a number: h > t ? h : t
       is numpy's maximum(t, h), NaN kept) */
    static inline double prsxy_room(double x, double v0, double v1, double a, double L,
                                    double h) {
        double d0 = x - v0, d1 = x - v1, t1 = d0 / a, t3 = d1 / a;
        t1 = prsxy_pick(d0 > 0, h > t1 ? h : t1, 0.0);
        t3 = prsxy_pick(d1 > 0, h > t3 ? h : t3, 0.0);
        return L - 0.5 * (v0 + x) * t1 - 0.5 * (v1 + x) * t3;
    }

    #if defined(__SSE2__)
    #include <emmintrin.h>
    #endif

    /* for m blocks side by side (contiguous v0, v1, a, L): the largest x in [lo, hi]
       with room(x) >= 0 (cruise: >= h x) after `steps` halvings, into lo. Two blocks a
       vector where SSE2 is there: each lane rounds as the scalar operation does
       (maxpd(h, t) is h > t ? h : t; and/andnot select bits), so the same bits */
    static void prsxy_bisect(Py_ssize_t m, double *lo, double *hi, const double *v0,
                             const double *v1, const double *a, const double *L,
                             double h, int cruise, int steps) {
        Py_ssize_t j, pairs = 0;
        int s;
        double mid, r;
        int good;
    #if defined(__SSE2__)
        const __m128d half = _mm_set1_pd(0.5), zero = _mm_setzero_pd(), hv = _mm_set1_pd(h);
        pairs = m / 2 * 2;
    #endif
        for (s = 0; s < steps; s++) {
    #if defined(__SSE2__)
            for (j = 0; j < pairs; j += 2) {
                __m128d l = _mm_loadu_pd(lo + j), u = _mm_loadu_pd(hi + j);
                __m128d b0 = _mm_loadu_pd(v0 + j), b1 = _mm_loadu_pd(v1 + j);
                __m128d x = _mm_mul_pd(half, _mm_add_pd(l, u));
                __m128d d0 = _mm_sub_pd(x, b0), d1 = _mm_sub_pd(x, b1);
                __m128d ac = _mm_loadu_pd(a + j);
                __m128d t1 = _mm_and_pd(_mm_cmpgt_pd(d0, zero), _mm_max_pd(hv, _mm_div_pd(d0, ac)));
                __m128d t3 = _mm_and_pd(_mm_cmpgt_pd(d1, zero), _mm_max_pd(hv, _mm_div_pd(d1, ac)));
                __m128d s1 = _mm_mul_pd(_mm_mul_pd(half, _mm_add_pd(b0, x)), t1);
                __m128d s3 = _mm_mul_pd(_mm_mul_pd(half, _mm_add_pd(b1, x)), t3);
                __m128d rv = _mm_sub_pd(_mm_sub_pd(_mm_loadu_pd(L + j), s1), s3);
                __m128d g = cruise ? _mm_cmpge_pd(rv, _mm_mul_pd(hv, x))
                                   : _mm_cmpge_pd(rv, zero);
                _mm_storeu_pd(lo + j, _mm_or_pd(_mm_and_pd(g, x), _mm_andnot_pd(g, l)));
                _mm_storeu_pd(hi + j, _mm_or_pd(_mm_and_pd(g, u), _mm_andnot_pd(g, x)));
            }
    #endif
            for (j = pairs; j < m; j++) {
                mid = 0.5 * (lo[j] + hi[j]);
                r = prsxy_room(mid, v0[j], v1[j], a[j], L[j], h);
                good = cruise ? (r >= h * mid) : (r >= 0);
                lo[j] = prsxy_pick(good, mid, lo[j]);
                hi[j] = prsxy_pick(good, hi[j], mid);
            }
        }
    }
    """
    double prsxy_pick(int c, double a, double b) nogil
    double prsxy_room(double x, double v0, double v1, double a, double L, double h) nogil
    void prsxy_bisect(
        Py_ssize_t m, double *lo, double *hi, const double *v0, const double *v1,
        const double *a, const double *L, double h, int cruise, int steps,
    ) nogil


cdef inline double _max(double a, double b) noexcept nogil:
    # numpy's maximum: the first when it is NaN or not below the second (NaN carries)
    return a if (a >= b or a != a) else b


cdef inline double _clip_lo(double x, double lo) noexcept nogil:
    # numpy's clip of a float below: x when NaN, else the larger (lo on a tie)
    if x != x:
        return x
    return x if x > lo else lo


cdef inline double _clip_hi(double x, double hi) noexcept nogil:
    if x != x:
        return x
    return x if x < hi else hi


cdef inline double _t(double d, double a, double hmin) noexcept nogil:
    # timelaw._phases: a phase's time, max(Δv / a, hmin) where the speed changes
    # (hmin is a number: numpy's maximum keeps d / a when it is NaN or not below)
    cdef double x = d / a
    return prsxy_pick(d > 0, x if not (hmin > x) else hmin, 0.0)


cdef void _bisect_some(
    double[:, ::1] w,
    const Py_ssize_t[::1] idx,
    Py_ssize_t m,
    const double[::1] v0,
    const double[::1] v1,
    const double[::1] a,
    const double[::1] L,
    double hmin,
    bint cruise,
) noexcept nogil:
    # the peaks w[0] of blocks idx[:m] bisected from [max(v0, v1), w[0]]: their
    # values gathered side by side into w[1:7], then the peaks back
    cdef Py_ssize_t j, i
    if m == 0:
        return
    for j in range(m):
        i = idx[j]
        w[1, j] = _max(v0[i], v1[i])
        w[2, j] = w[0, i]
        w[3, j] = v0[i]
        w[4, j] = v1[i]
        w[5, j] = a[i]
        w[6, j] = L[i]
    prsxy_bisect(
        m, &w[1, 0], &w[2, 0], &w[3, 0], &w[4, 0], &w[5, 0], &w[6, 0], hmin, cruise,
        BISECT_STEPS,
    )
    for j in range(m):
        w[0, idx[j]] = w[1, j]


def trapezoids(v0_in, v1_in, length, accel, vmax, stop, duration, double min_phase):
    """The compiled twin of ``timelaw.trapezoids``: the same TimeLaw."""
    v0_c = np.ascontiguousarray(v0_in, dtype=float)
    v1_c = np.ascontiguousarray(v1_in, dtype=float)
    L_c = np.ascontiguousarray(length, dtype=float)
    a_c = np.ascontiguousarray(accel, dtype=float)
    cdef const double[::1] v0 = v0_c, v1 = v1_c, L_ = L_c, a_ = a_c
    cdef const double[:] vm = vmax, dur = duration
    cdef Py_ssize_t n = v0.shape[0], i, j, m
    if not (
        v1.shape[0] == n and L_.shape[0] == n and a_.shape[0] == n
        and vm.shape[0] == n and dur.shape[0] == n and len(stop) == n
    ):
        raise ValueError("every input must have one row per block")
    cdef const unsigned char[:] st = np.ascontiguousarray(stop, dtype=np.uint8)
    out = np.empty((7, n))
    cdef double[:, :] o = out
    work = np.empty((7, n))
    # the peak; the bisections' lo and hi; their blocks' v0, v1, a and L side by side
    cdef double[:, ::1] w = work
    idx_a = np.empty(n, dtype=np.intp)
    cdef Py_ssize_t[::1] idx = idx_a
    cdef double a, L, b0, b1, hmin = min_phase, top, lo, t2_top, vp, t1, t2, t3
    cdef double left, tau
    cdef bint single
    if n == 0:
        return TimeLaw(v0_in, v1_in, *out)
    with nogil:
        # the highest peak with the rising and falling phases fitting in the block
        m = 0
        for i in range(n):
            top = _max(vm[i], _max(v0[i], v1[i]))
            w[0, i] = top
            if not (prsxy_room(top, v0[i], v1[i], a_[i], L_[i], hmin) >= 0):
                idx[m] = i
                m += 1
        _bisect_some(w, idx, m, v0, v1, a_, L_, hmin, False)
        # the cruise between them: none, or at least min_phase long
        m = 0
        for i in range(n):
            top = w[0, i]
            L = L_[i]
            t2_top = prsxy_room(top, v0[i], v1[i], a_[i], L, hmin) / top if top > 0 else INFINITY
            if (t2_top * top > 1e-9 * _max(1.0, L)) and (t2_top < hmin):
                idx[m] = i
                m += 1
        _bisect_some(w, idx, m, v0, v1, a_, L_, hmin, True)
        for i in range(n):
            b0 = v0[i]
            b1 = v1[i]
            a = a_[i]
            L = L_[i]
            lo = _max(b0, b1)
            vp = w[0, i]
            t1 = _t(vp - b0, a, hmin)
            t3 = _t(vp - b1, a, hmin)
            left = L - 0.5 * (b0 + vp) * t1 - 0.5 * (b1 + vp) * t3
            if left <= 1e-9 * _max(L, 1.0):
                left = 0.0
            t2 = left / vp if vp > 0 else 0.0
            single = not st[i] and (
                (prsxy_room(lo, b0, b1, a, L, hmin) < 0)
                or ((t2 > 0) and (t2 < hmin) and (t1 + t3 > 0))
            )
            if single and b0 + b1 > 0:
                tau = 2.0 * L / (b0 + b1)
                if b1 >= b0:
                    vp = b1
                    t1 = tau
                    t3 = 0.0
                elif b1 < b0:
                    vp = b0
                    t1 = 0.0
                    t3 = tau
                t2 = 0.0
            o[0, i] = vp
            o[1, i] = (vp - b0) / t1 if t1 > 0 else 0.0
            o[2, i] = (vp - b1) / t3 if t3 > 0 else 0.0
            if st[i]:
                t1 = 0.0
                t2 = dur[i]
                t3 = 0.0
            o[3, i] = t1
            o[4, i] = t2
            o[5, i] = t3
            o[6, i] = t1 + t2 + t3
    return TimeLaw(v0_in, v1_in, *out)


def along(law, k, tau):
    """The compiled twin of ``timelaw.along``: (s, v) at local times ``tau`` of
    blocks ``k``."""
    cdef const double[:] v0 = law.v0, v1 = law.v1, vp = law.vp, a1 = law.a1, a3 = law.a3
    cdef const double[:] t1 = law.t1, t2 = law.t2, t3 = law.t3
    cdef const Py_ssize_t[:] kk = np.ascontiguousarray(k, dtype=np.intp)
    cdef const double[:] tt = np.ascontiguousarray(tau, dtype=float)
    cdef Py_ssize_t n = kk.shape[0], i, j, nb = v0.shape[0]
    if tt.shape[0] != n:
        raise ValueError("k and tau must have one row per point")
    for i in range(n):
        if not 0 <= kk[i] < nb:
            raise IndexError(f"block {kk[i]} is out of range for {nb} blocks")
    s_out = np.empty(n)
    v_out = np.empty(n)
    cdef double[:] s = s_out, v = v_out
    cdef double b0, p, c1, c3, p1, p2, p3, x, tc, td, s1
    with nogil:
        for i in range(n):
            j = kk[i]
            b0 = v0[j]
            p = vp[j]
            c1 = a1[j]
            c3 = a3[j]
            p1 = t1[j]
            p2 = t2[j]
            p3 = t3[j]
            x = tt[i]
            s1 = b0 * p1 + 0.5 * c1 * (p1 * p1)
            tc = _max(x, 0.0)
            if tc <= p1:
                s[i] = b0 * tc + 0.5 * c1 * (tc * tc)
            elif tc <= p1 + p2:
                s[i] = s1 + p * (tc - p1)
            else:
                td = _clip_hi(_clip_lo(tc - p1 - p2, 0.0), p3)
                s[i] = s1 + p * p2 + p * td - 0.5 * c3 * (td * td)
            if x <= p1:
                v[i] = b0 + c1 * x
            elif x <= p1 + p2:
                v[i] = p
            else:
                v[i] = _max(p - c3 * (x - p1 - p2), v1[j])
    return s_out, v_out


def phase_times(law, counts):
    """The compiled twin of ``timelaw.phase_times``: (blk, tau, step, last)."""
    cdef const double[:] t1 = law.t1, t2 = law.t2, t3 = law.t3, dur = law.duration
    cdef const long long[:, :] c = np.ascontiguousarray(counts, dtype=np.int64)
    cdef Py_ssize_t nb = c.shape[0], b, ph, j, k, p = 0, n = 0
    if c.shape[1] != 3 or t1.shape[0] != nb:
        raise ValueError("counts must be (n, 3) for n blocks")
    for b in range(nb):
        for ph in range(3):
            if c[b, ph] < 0:
                raise ValueError("a phase cannot have fewer than no steps")
            n += c[b, ph]
    blk_a = np.empty(n, dtype=np.intp)
    tau_a = np.empty(n)
    step_a = np.empty(n)
    last_a = np.zeros(n, dtype=bool)
    cdef Py_ssize_t[:] blk = blk_a
    cdef double[:] tau = tau_a, stp = step_a
    cdef unsigned char[:] last = last_a.view(np.uint8)
    cdef double before[3]
    cdef double length[3]
    cdef double h
    with nogil:
        for b in range(nb):
            before[0] = 0.0
            before[1] = t1[b]
            before[2] = t1[b] + t2[b]
            length[0] = t1[b]
            length[1] = t2[b]
            length[2] = t3[b]
            for ph in range(3):
                k = c[b, ph]
                if k == 0:
                    continue
                h = length[ph] / <double>k
                for j in range(1, k + 1):
                    blk[p] = b
                    stp[p] = h
                    tau[p] = before[ph] + <double>j * h
                    p += 1
            # numpy marks the point before a block of no points again: the same
            if c[b, 0] + c[b, 1] + c[b, 2] > 0:
                last[p - 1] = 1
                tau[p - 1] = dur[b]
    return blk_a, tau_a, step_a, last_a


def backward_pass(const double[:] length, const double[:] accel, const double[:] vj):
    """The compiled twin of ``timelaw.backward_pass``."""
    cdef Py_ssize_t n = vj.shape[0], k
    if length.shape[0] != n or accel.shape[0] != n:
        raise ValueError("every input must have one row per block")
    out = np.array(vj, dtype=float)
    cdef double[:] v = out
    cdef double nxt = v[n - 1] if n else 0.0, lim
    with nogil:
        for k in range(n - 2, -1, -1):
            lim = sqrt(nxt * nxt + 2.0 * accel[k + 1] * length[k + 1])
            if v[k] > lim:
                v[k] = lim
            nxt = v[k]
    return out


def forward_pass(
    const double[:] length, const double[:] accel, const double[:] v_back, double v_start=0.0
):
    """The compiled twin of ``timelaw.forward_pass``."""
    cdef Py_ssize_t n = v_back.shape[0], k
    if length.shape[0] != n or accel.shape[0] != n:
        raise ValueError("every input must have one row per block")
    out = np.array(v_back, dtype=float)
    cdef double[:] v = out
    cdef double prev = v_start, lim
    with nogil:
        for k in range(n):
            lim = sqrt(prev * prev + 2.0 * accel[k] * length[k])
            if v[k] > lim:
                v[k] = lim
            prev = v[k]
    return out


cdef inline double _min(double a, double b) noexcept nogil:
    # numpy's minimum over arrays: the first when it is NaN or below the second, else
    # the second (so the second on a tie of ±0.0)
    return a if (a < b or a != a) else b


def play_stops(
    dq_out_in, dq_in_in, dP_out_in, dP_in_in, cross_in, Py_ssize_t head,
    double reversal_slope, double stand_slope, double gain_max,
):
    """The compiled twin of ``timelaw.play_stops``."""
    cdef const double[:, :] dq_out = dq_out_in, dq_in = dq_in_in
    cdef const double[:, :] dP_out = dP_out_in, dP_in = dP_in_in
    cdef const unsigned char[:] cross = np.ascontiguousarray(cross_in, dtype=np.uint8)
    cdef Py_ssize_t n = dq_out.shape[0], i, c, m = max(n - 1, 0)
    for arr in (dq_out_in, dq_in_in, dP_out_in, dP_in_in):
        if arr.shape != (n, 5):
            raise ValueError("tangents and motor slopes must be (n, 5) each")
    if cross.shape[0] != n or head != 3:
        raise ValueError("cross_in must be (n,), and the head's motors the first three")
    out = np.zeros(m, dtype=bool)
    cdef unsigned char[:] stop = out.view(np.uint8)
    cdef double a, b, lo, hi, t, p, gain
    cdef bint rev_head, rev_table, head_off, faster
    cdef bint rev[5]
    with nogil:
        for i in range(m):
            rev_head = False
            rev_table = False
            head_off = False
            for c in range(5):
                a = fabs(dP_out[i, c])
                b = fabs(dP_in[i + 1, c])
                lo = _min(a, b)
                hi = _max(a, b)
                rev[c] = (dP_out[i, c] * dP_in[i + 1, c] < 0.0) and (
                    hi > reversal_slope) and (lo > stand_slope)
                if c < head:
                    rev_head = rev_head or rev[c]
                    head_off = head_off or ((hi > reversal_slope) and (lo <= stand_slope))
                else:
                    rev_table = rev_table or rev[c]
            faster = False
            for c in range(head, 5):
                # the table motor's column against the path's tangent along its
                # axis (x for the first table motor, y for the second)
                t = dq_out[i, c - head]
                p = dP_out[i, c]
                gain = 1.0 - 2.0 * t * p + p * p
                faster = faster or (rev[c] and gain > gain_max)
                t = dq_in[i + 1, c - head]
                p = dP_in[i + 1, c]
                gain = 1.0 - 2.0 * t * p + p * p
                faster = faster or (rev[c] and gain > gain_max)
            stop[i] = (
                rev_head or (rev_table and head_off) or faster or (cross[i + 1] and head_off)
            )
    return out


cdef inline double _sign(double x) noexcept nogil:
    # numpy's sign: NaN kept, ±0.0 as it is
    if x > 0:
        return 1.0
    if x < 0:
        return -1.0
    return x


def set_offs(d_in_in, d_out_in, vmax_in, way_in, stood_in, double reversal_slope,
             double stand_slope, double v_eps):
    """The compiled twin of ``timelaw.set_offs``: the blocks in one pass, each
    motor's way and standing carried from block to block."""
    cdef const double[:, :] d_in = d_in_in, d_out = d_out_in
    cdef const double[:] vmax = vmax_in
    cdef Py_ssize_t n = d_in.shape[0], k = d_in.shape[1], i, c
    if d_out.shape[0] != n or d_out.shape[1] != k or vmax.shape[0] != n:
        raise ValueError("d_in and d_out must be (n, k) and vmax (n,), a block a row")
    way_a = np.array(way_in, dtype=float)
    stood_a = np.array(stood_in, dtype=bool)
    if way_a.shape != (k,) or stood_a.shape != (k,):
        raise ValueError(f"way and stood must be ({k},), a motor each")
    cdef double[::1] way = way_a
    cdef unsigned char[::1] stood = stood_a.view(np.uint8)
    cross_a = np.zeros(n, dtype=bool)
    cdef unsigned char[::1] cross = cross_a.view(np.uint8)
    cdef double a, b
    cdef bint hit
    with nogil:
        for i in range(n):
            hit = False
            for c in range(k):
                a = d_in[i, c]
                b = d_out[i, c]
                # against the way before the start, having stood at the end before
                if stood[c] and fabs(a) * vmax[i] > v_eps and _sign(a) == -way[c]:
                    hit = True
                # a way is set where a motor moves clearly (a sign of 0 sets none)
                if fabs(a) > reversal_slope and _sign(a) != 0:
                    way[c] = _sign(a)
                if fabs(b) > reversal_slope and _sign(b) != 0:
                    way[c] = _sign(b)
                stood[c] = fabs(b) <= stand_slope
            cross[i] = hit
    return cross_a, way_a, stood_a


def junction_speeds(dq_in, dq_out, dot, vmax, length, seg, stops, angular, tool_length, tol,
                    tol_deg, curv_r, play, r):
    """The compiled twin of ``timelaw.junction_speeds``: junction by junction."""
    cdef const double[:, ::1] qi = np.ascontiguousarray(dq_in, dtype=np.float64)
    cdef const double[:, ::1] qo = np.ascontiguousarray(dq_out, dtype=np.float64)
    cdef const double[::1] dt_ = np.ascontiguousarray(dot, dtype=np.float64)
    cdef const double[::1] vm = np.ascontiguousarray(vmax, dtype=np.float64)
    cdef const double[::1] ln = np.ascontiguousarray(length, dtype=np.float64)
    cdef const double[::1] sg = np.ascontiguousarray(seg, dtype=np.float64)
    cdef const unsigned char[::1] st = np.ascontiguousarray(stops, dtype=bool).view(np.uint8)
    cdef const unsigned char[::1] an_ = np.ascontiguousarray(angular, dtype=bool).view(np.uint8)
    cdef const double[::1] tl = np.ascontiguousarray(tool_length, dtype=np.float64)
    cdef const double[::1] to = np.ascontiguousarray(tol, dtype=np.float64)
    cdef const double[::1] td = np.ascontiguousarray(tol_deg, dtype=np.float64)
    cdef const double[::1] cr = np.ascontiguousarray(curv_r, dtype=np.float64)
    cdef const unsigned char[::1] pl = np.ascontiguousarray(play, dtype=bool).view(np.uint8)
    cdef Py_ssize_t n = vm.shape[0], i
    for name, got in (("length", len(ln)), ("seg", len(sg)), ("stops", len(st)),
                      ("angular", len(an_)), ("tool_length", len(tl)), ("tol", len(to)),
                      ("tol_deg", len(td)), ("curv_r", len(cr))):
        if got != n:
            raise ValueError(f"{name} must have one value a block ({n}, as vmax), got {got}")
    if qi.shape[0] != n or qo.shape[0] != n or qi.shape[1] != 5 or qo.shape[1] != 5:
        raise ValueError(f"dq_in and dq_out must be ({n}, 5), one row a block")
    cdef Py_ssize_t nj = n - 1 if n > 1 else 0
    if n > 1 and (dt_.shape[0] != nj or pl.shape[0] != nj):
        raise ValueError(f"dot and play must have one value a junction ({nj}), got "
                         f"{dt_.shape[0]} and {pl.shape[0]}")
    vj_a = np.zeros(n)
    corner_a = np.zeros(n + 1, dtype=bool)
    if n < 2:
        return vj_a, corner_a
    cdef double[::1] vj = vj_a
    cdef unsigned char[::1] co = corner_a.view(np.uint8)
    cdef double period2 = 2.0 * float(r.period)
    cdef double min_phase = r.min_phase, a_xyz = r.a_xyz, a_ab = r.a_ab
    cdef double an4 = 4.0 * float(r.an), gain = r.tol_gain, eps = r.eps, exact = r.exact
    cdef double dx, dab, x, h0, h1, h_lo, v_tol, v_acc, r_min, p, v
    cdef bint stop
    with nogil:
        for i in range(nj):
            x = qi[i + 1, 0] - qo[i, 0]
            dx = x * x
            x = qi[i + 1, 1] - qo[i, 1]
            dx = dx + x * x
            x = qi[i + 1, 2] - qo[i, 2]
            dx = sqrt(dx + x * x)
            x = qi[i + 1, 3] - qo[i, 3]
            dab = x * x
            x = qi[i + 1, 4] - qo[i, 4]
            dab = sqrt(dab + x * x)
            # the shortest step beside the junction (lookahead._shortest_steps)
            h0 = _min(_min(0.0 if st[i] else ln[i] / vm[i], 0.5 * sg[i] / vm[i]), min_phase)
            h1 = _min(_min(0.0 if st[i + 1] else ln[i + 1] / vm[i + 1],
                             0.5 * sg[i + 1] / vm[i + 1]), min_phase)
            h_lo = _min(h0, h1)
            v_tol = _min(gain * to[i] / (period2 * dx) if dx > eps else INFINITY,
                          gain * td[i] / (period2 * dab) if dab > eps else INFINITY)
            v_acc = _min(a_xyz * h_lo / (2.0 * dx) if dx > eps else INFINITY,
                          a_ab * h_lo / (2.0 * dab) if dab > eps else INFINITY)
            r_min = _min(cr[i], cr[i + 1])
            if isfinite(r_min) and dx > eps:  # next to an arc
                p = 2.0 * dx / (h_lo if h_lo > 0 else INFINITY)
                v_acc = _min(v_acc, 0.5 * r_min * (-p + sqrt(p * p + an4 / r_min)))
            v = _min(_min(vm[i], vm[i + 1]), _min(v_tol, v_acc))
            stop = ((dt_[i] <= 0.0 and dx > eps and not an_[i] and not an_[i + 1])
                    or st[i] or st[i + 1] or an_[i] or an_[i + 1] or tl[i] != tl[i + 1]
                    or to[i] == exact or pl[i])
            vj[i] = 0.0 if stop else v
            co[i + 1] = (not stop) and (dx > eps or dab > eps)
    return vj_a, corner_a
