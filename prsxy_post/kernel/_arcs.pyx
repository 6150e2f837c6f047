# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The arc search compiled: :mod:`prsxy_post.kernel.arcs` point by point, the same
operations in the same order (see that module), so the two agree to the bit: sums
left to right, radii sqrt(u² + v²), the C library's atan2, numpy's floor remainder
(fmod, then the divisor's sign) and numpy's round (rint(x 10^d) / 10^d). A fit's
checks run in one pass over the points and stop at the first that fails (every
failing check gives the same "no arc"). Compiled with -O2 -ffp-contract=off (no
fused multiply-adds)."""

import numpy as np

from libc.math cimport sqrt, atan2, fmod, rint, fabs, copysign, M_PI

cdef enum:
    MIN_POINTS = 4
    WINDOW = 4
cdef double MAX_SWEEP = 1.5 * M_PI
cdef double TWO_PI = 2.0 * M_PI


cdef inline void _axes(int plane, int* iu, int* iv, int* iw) noexcept nogil:
    """The plane's first and second axis and its normal (arcs.PLANES)."""
    if plane == 17:
        iu[0], iv[0], iw[0] = 0, 1, 2
    elif plane == 18:
        iu[0], iv[0], iw[0] = 2, 0, 1
    else:
        iu[0], iv[0], iw[0] = 1, 2, 0


cdef inline double _wrap(double d) noexcept nogil:
    """(d + π) % 2π − π with numpy's floor remainder."""
    cdef double x = d + M_PI
    cdef double m = fmod(x, TWO_PI)
    if m != 0.0:
        if (m < 0.0) != (TWO_PI < 0.0):
            m += TWO_PI
    else:
        m = copysign(0.0, TWO_PI)
    return m - M_PI


cdef bint _center(const double* q, Py_ssize_t m, int iu, int iv, double p10,
                  double* cc) noexcept nogil:
    """The center of the arc from q's first row to its last through the rows between
    (m ≥ 3) in the plane's (u, v), as written: cc[0], cc[1]; False where the points
    lie on the chord (arcs.fit's first part)."""
    cdef Py_ssize_t i, last = (m - 1) * 5
    cdef double su = q[iu], sv = q[iv], eu = q[last + iu], ev = q[last + iv]
    cdef double cu, cv, chord, nu, nv, mu, mv, k, xu, xv, a, b, t
    cdef double bb = 0.0, ab = 0.0
    cu = eu - su
    cv = ev - sv
    chord = sqrt(cu * cu + cv * cv)
    if not chord > 0.0:
        return False
    nu = -cv / chord
    nv = cu / chord
    mu = 0.5 * (su + eu)
    mv = 0.5 * (sv + ev)
    k = 0.25 * chord * chord
    for i in range(1, m - 1):
        xu = q[i * 5 + iu] - mu
        xv = q[i * 5 + iv] - mv
        a = xu * xu + xv * xv - k
        b = 2.0 * (nu * xu + nv * xv)
        if i == 1:
            bb = b * b
            ab = a * b
        else:
            bb = bb + b * b
            ab = ab + a * b
    if not bb > 0.0:
        return False
    t = ab / bb
    cc[0] = su + rint((mu + t * nu - su) * p10) / p10
    cc[1] = sv + rint((mv + t * nv - sv) * p10) / p10
    return True


cdef bint _angles(const double* q, Py_ssize_t m, int iu, int iv, double ccu, double ccv,
                  double tol_mm, double* rho, double* phi) noexcept nogil:
    """Each row's radius rho[i] and angle from the first phi[i] (unwrapped); False
    where a radius leaves the band of the ends' by more than ``tol_mm`` or the
    angles do not advance one way."""
    cdef Py_ssize_t i, last = (m - 1) * 5
    cdef double pu, pv, r0, r1, r_lo, r_hi, ang, prev, step
    cdef int way = 0
    pu = q[iu] - ccu
    pv = q[iv] - ccv
    r0 = sqrt(pu * pu + pv * pv)
    prev = atan2(pv, pu)
    pu = q[last + iu] - ccu
    pv = q[last + iv] - ccv
    r1 = sqrt(pu * pu + pv * pv)
    if r1 < r0:
        r_lo = r1
        r_hi = r0
    else:
        r_lo = r0
        r_hi = r1
    r_hi = r_hi + tol_mm
    if r0 > r_hi or r0 < r_lo - tol_mm:
        return False
    rho[0] = r0
    phi[0] = 0.0
    for i in range(1, m):
        pu = q[i * 5 + iu] - ccu
        pv = q[i * 5 + iv] - ccv
        rho[i] = sqrt(pu * pu + pv * pv)
        if rho[i] > r_hi or rho[i] < r_lo - tol_mm:
            return False
        ang = atan2(pv, pu)
        step = _wrap(ang - prev)
        prev = ang
        if step > 0.0:
            if way < 0:
                return False
            way = 1
        elif step < 0.0:
            if way > 0:
                return False
            way = -1
        else:
            return False
        if i == 1:
            phi[i] = step
        else:
            phi[i] = phi[i - 1] + step
    return True


cdef bint _fit(const double* q, Py_ssize_t m, int plane, double tol_mm, double tol_deg,
               double p10, double* rho, double* phi, double* out) noexcept nogil:
    """arcs.fit of the m rows (5 values each) at q: out[0..6] ccw, the center X Y Z,
    the length, the error, the radius; False where no arc fits. rho, phi: m
    values of scratch each."""
    cdef int iu, iv, iw
    cdef Py_ssize_t i, last = (m - 1) * 5
    cdef double cc[2]
    cdef double sw, ew, r0, r1, r_lo, sweep, f, radial, axial, e, err = 0.0
    cdef double sa, sb, ea, eb, x, y, spiral
    if m < 3:
        return False
    _axes(plane, &iu, &iv, &iw)
    if not _center(q, m, iu, iv, p10, cc):
        return False
    if not _angles(q, m, iu, iv, cc[0], cc[1], tol_mm, rho, phi):
        return False
    sweep = phi[m - 1]
    if not fabs(sweep) <= MAX_SWEEP:
        return False
    r0 = rho[0]
    r1 = rho[m - 1]
    r_lo = r1 if r1 < r0 else r0
    sw = q[iw]
    ew = q[last + iw]
    sa = q[3]
    sb = q[4]
    ea = q[last + 3]
    eb = q[last + 4]
    for i in range(m):
        f = phi[i] / sweep
        radial = rho[i] - (r0 + (r1 - r0) * f)
        axial = q[i * 5 + iw] - (sw + (ew - sw) * f)
        e = sqrt(radial * radial + axial * axial)
        if not e <= tol_mm:
            return False
        if i == 0 or e > err:
            err = e
        if not fabs(q[i * 5 + 3] - (sa + (ea - sa) * f)) <= tol_deg:
            return False
        if not fabs(q[i * 5 + 4] - (sb + (eb - sb) * f)) <= tol_deg:
            return False
    out[0] = 1.0 if sweep > 0.0 else 0.0
    out[1 + iu] = cc[0]
    out[1 + iv] = cc[1]
    out[1 + iw] = sw
    x = r_lo * fabs(sweep)
    y = r1 - r0
    spiral = sqrt(x * x + y * y)
    out[4] = sqrt(spiral * spiral + (ew - sw) * (ew - sw))
    out[5] = err
    out[6] = r_lo
    return True


cdef bint _keeps(const double* rate, const double* lead, Py_ssize_t s, Py_ssize_t e,
                 double lead_tol, double dip_share) noexcept nogil:
    """arcs._keeps of rate[s + 1 : e + 1], lead[s : e + 1]."""
    cdef Py_ssize_t i, j, d0 = -1
    cdef double peak = 0.0, low = 0.0, lo_f = 1.0 - dip_share, hi_f = 1.0 + dip_share
    for i in range(s + 1, e + 1):
        for j in range(5):
            if fabs(lead[i * 5 + j] - lead[s * 5 + j]) > lead_tol:
                return False
    for i in range(s + 1, e + 1):
        if i == s + 1 or rate[i] > peak:
            peak = rate[i]
        if rate[i] < peak * lo_f:
            d0 = i
            break
    if d0 < 0:
        return True
    for i in range(d0, e + 1):
        if i == d0 or rate[i] < low:
            low = rate[i]
        if not rate[i] <= low * hi_f:
            return False
    return True


cdef bint _tilt_within(const double* q, Py_ssize_t s, Py_ssize_t e, double span) noexcept nogil:
    """Whether A and B each change by no more than ``span`` over rows s..e."""
    cdef Py_ssize_t i, j
    cdef double lo, hi, v
    for j in range(3, 5):
        lo = q[s * 5 + j]
        hi = lo
        for i in range(s + 1, e + 1):
            v = q[i * 5 + j]
            if v > hi:
                hi = v
            if v < lo:
                lo = v
        if hi - lo > span:
            return False
    return True


cdef double _sag(const double* q, Py_ssize_t s, Py_ssize_t e) noexcept nogil:
    """arcs._sag of rows s..e."""
    cdef Py_ssize_t i, j
    cdef double d[3]
    cdef double r[3]
    cdef double dd, u, off, worst = 0.0
    for j in range(3):
        d[j] = q[e * 5 + j] - q[s * 5 + j]
    dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
    for i in range(s, e + 1):
        if dd > 0.0:
            u = ((q[i * 5] - q[s * 5]) * d[0] + (q[i * 5 + 1] - q[s * 5 + 1]) * d[1]
                 + (q[i * 5 + 2] - q[s * 5 + 2]) * d[2]) / dd
            if u < 0.0:
                u = 0.0
            elif u > 1.0:
                u = 1.0
        else:
            u = 0.0
        for j in range(3):
            r[j] = q[i * 5 + j] - (q[s * 5 + j] + u * d[j])
        off = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
        if i == s or off > worst:
            worst = off
    return worst


cdef struct Search:
    const double* q
    const double* rate
    const double* lead
    double tol_mm
    double tol_deg
    double p10
    double dip_share
    double tilt_span
    double* rho
    double* phi


cdef int _fits(Search* S, Py_ssize_t s, Py_ssize_t e, int plane, double* out) noexcept nogil:
    """The plane of the best arc over rows s..e (``plane``, or every plane where 0)
    with its row in ``out``, or 0: find_arcs's ``fits``."""
    cdef double cand[7]
    cdef int p, best = 0
    cdef int j
    if not _keeps(S.rate, S.lead, s, e, S.tol_mm, S.dip_share):
        return 0
    if not _tilt_within(S.q, s, e, S.tilt_span):
        return 0
    for p in range(17, 20):
        if plane != 0 and p != plane:
            continue
        if _fit(&S.q[s * 5], e - s + 1, p, S.tol_mm, S.tol_deg, S.p10, S.rho, S.phi, cand):
            if best == 0 or cand[5] < out[5]:
                best = p
                for j in range(7):
                    out[j] = cand[j]
    return best


def _rows(arc_i, arc_f, Py_ssize_t count):
    return np.ascontiguousarray(arc_i[:count]), np.ascontiguousarray(arc_f[:count])


def fit_arc(q, int plane, double tol_mm, double tol_deg, int decimals):
    """arcs.fit_arc, compiled."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=float)
    if plane < 17 or plane > 19:
        raise ValueError(f"plane must be 17, 18 or 19, got {plane}")
    if qv.shape[1] != 5:
        raise ValueError(f"q must have 5 values a point, got {qv.shape[1]}")
    cdef Py_ssize_t m = qv.shape[0]
    out = np.full(7, np.nan)
    cdef double[::1] ov = out
    cdef double[::1] scratch = np.empty(2 * m + 2)
    cdef double[7] got
    cdef double p10 = 10.0 ** decimals
    cdef int j
    if m >= 3 and _fit(&qv[0, 0], m, plane, tol_mm, tol_deg, p10, &scratch[0],
                       &scratch[m], got):
        for j in range(7):
            ov[j] = got[j]
    return out


def find_arcs(q, free, ends, rate, lead, double tol_mm, double tol_deg, int decimals,
              double dip_share, double tilt_span):
    """arcs.find_arcs, compiled."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=float)
    cdef Py_ssize_t n = qv.shape[0]
    if qv.shape[1] != 5:
        raise ValueError(f"q must have 5 values a point, got {qv.shape[1]}")
    for name, arr in (("free", free), ("ends", ends), ("rate", rate), ("lead", lead)):
        if len(arr) != n:
            raise ValueError(f"{name} must have one value a point ({n}, as q), got {len(arr)}")
    cdef const double[:, ::1] lv = np.ascontiguousarray(lead, dtype=float)
    if n and lv.shape[1] != 5:
        raise ValueError(f"lead must have 5 values a point, got {lv.shape[1]}")
    cdef const double[::1] rv = np.ascontiguousarray(rate, dtype=float)
    cdef const unsigned char[::1] fv = np.ascontiguousarray(free, dtype=bool).view(np.uint8)
    cdef const unsigned char[::1] ev = np.ascontiguousarray(ends, dtype=bool).view(np.uint8)
    arc_i = np.empty((n // MIN_POINTS + 1, 4), dtype=np.int64)
    arc_f = np.empty((n // MIN_POINTS + 1, 6))
    cdef long long[:, ::1] ai = arc_i
    cdef double[:, ::1] af = arc_f
    if n < MIN_POINTS + 1:
        return _rows(arc_i, arc_f, 0)
    cdef double[::1] scratch = np.empty(2 * n + 2)
    cdef long long[::1] first = np.empty(n, dtype=np.int64)
    cdef long long[::1] lastf = np.empty(n, dtype=np.int64)
    cdef unsigned char[::1] bends = np.zeros(n, dtype=np.uint8)
    cdef Search S
    S.q = &qv[0, 0]
    S.rate = &rv[0]
    S.lead = &lv[0, 0]
    S.tol_mm = tol_mm
    S.tol_deg = tol_deg
    S.p10 = 10.0 ** decimals
    S.dip_share = dip_share
    S.tilt_span = tilt_span
    S.rho = &scratch[0]
    S.phi = &scratch[n]
    cdef Py_ssize_t count = 0
    with nogil:
        count = _search(&S, n, &fv[0], &ev[0], &first[0], &lastf[0], &bends[0], &ai[0, 0],
                        &af[0, 0])
    return _rows(arc_i, arc_f, count)


cdef void _bends(const double* q, Py_ssize_t n, double tol_mm, const unsigned char* free,
                 unsigned char* out) noexcept nogil:
    """arcs._bends & free."""
    cdef Py_ssize_t k, j, w = WINDOW
    cdef double d[3]
    cdef double x[3]
    cdef double r[3]
    cdef double dd, u, off
    if n < 2 * w + 1:
        return
    for k in range(w, n - w):
        for j in range(3):
            d[j] = q[(k + w) * 5 + j] - q[(k - w) * 5 + j]
            x[j] = q[k * 5 + j] - q[(k - w) * 5 + j]
        dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        u = (x[0] * d[0] + x[1] * d[1] + x[2] * d[2]) / (dd if dd > 0.0 else 1.0)
        for j in range(3):
            r[j] = q[k * 5 + j] - (q[(k - w) * 5 + j] + u * d[j])
        off = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2])
        out[k] = (off > tol_mm) and (dd > 0.0) and free[k]


cdef Py_ssize_t _search(Search* S, Py_ssize_t n, const unsigned char* free,
                        const unsigned char* ends, long long* first, long long* lastf,
                        unsigned char* bends, long long* ai, double* af) noexcept nogil:
    """arcs.find_arcs's loop: the arcs' rows into ai, af; their count."""
    cdef Py_ssize_t i, a, c, before, start, hi, e, bad, lo, hi_try, mid, step
    cdef Py_ssize_t i0 = 0, count = 0, good_e
    cdef int plane, got, good_plane
    cdef double cand[7]
    cdef double good[7]
    cdef int j
    _bends(S.q, n, S.tol_mm, free, bends)
    # each run of free points: its first and last index, for each of its points
    i = 0
    while i < n:
        if not free[i]:
            first[i] = -1
            lastf[i] = -1
            i += 1
            continue
        a = i
        while i < n and free[i]:
            i += 1
        for c in range(a, i):
            first[c] = a
            lastf[c] = i - 1
    for c in range(n):
        if not bends[c] or c < i0:
            continue
        before = first[c] - 1
        start = before if (before >= 0 and ends[before]) else before + 1
        if start < i0:
            start = i0
        if start >= n - 1 or not free[start + 1]:
            continue
        hi = lastf[start + 1]
        if hi + 1 < n and ends[hi + 1]:
            hi += 1
        plane = 0
        good_plane = 0
        good_e = -1
        step = MIN_POINTS
        e = start + step
        bad = hi + 1
        while e <= hi:
            got = _fits(S, start, e, plane, cand)
            if got == 0:
                bad = e
                break
            good_e = e
            good_plane = got
            for j in range(7):
                good[j] = cand[j]
            plane = got  # the run grows in the plane it started in
            step *= 2
            e = start + step
        if good_plane == 0:
            i0 = start + MIN_POINTS
            continue
        lo = good_e
        hi_try = bad if bad < hi + 1 else hi + 1
        while hi_try - lo > 1:
            mid = (lo + hi_try) // 2
            got = _fits(S, start, mid, plane, cand)
            if got == 0:
                hi_try = mid
            else:
                lo = mid
                good_e = mid
                good_plane = got
                for j in range(7):
                    good[j] = cand[j]
        if not _sag(S.q, start, good_e) <= S.tol_mm:
            ai[count * 4] = start
            ai[count * 4 + 1] = good_e
            ai[count * 4 + 2] = good_plane
            ai[count * 4 + 3] = 1 if good[0] > 0.0 else 0
            for j in range(6):
                af[count * 6 + j] = good[1 + j]
            count += 1
        i0 = good_e
    return count


def refit_arcs(q, int plane, Py_ssize_t start, Py_ssize_t end, double tol_mm, double tol_deg,
               int decimals):
    """arcs.refit_arcs, compiled."""
    cdef const double[:, ::1] qv = np.ascontiguousarray(q, dtype=float)
    cdef Py_ssize_t n = qv.shape[0]
    if plane < 17 or plane > 19:
        raise ValueError(f"plane must be 17, 18 or 19, got {plane}")
    if qv.shape[1] != 5:
        raise ValueError(f"q must have 5 values a point, got {qv.shape[1]}")
    if start < 0 or end >= n:
        raise ValueError(f"start and end must be points of q (0 to {n - 1}), got {start}, {end}")
    cdef Py_ssize_t cap = (end - start) // 2 + 1 if end > start else 1
    arc_i = np.empty((cap, 4), dtype=np.int64)
    arc_f = np.empty((cap, 6))
    cdef long long[:, ::1] ai = arc_i
    cdef double[:, ::1] af = arc_f
    cdef double[::1] scratch = np.empty(2 * n + 2)
    cdef double p10 = 10.0 ** decimals
    cdef double cand[7]
    cdef double good[7]
    cdef Py_ssize_t s = start, e, bad, lo, hi, mid, good_e, count = 0
    cdef int j
    cdef const double* qp = &qv[0, 0]
    cdef double* rho = &scratch[0]
    cdef double* phi = &scratch[n]
    with nogil:
        while end - s >= 2:
            good_e = -1
            e = s + 2
            bad = end + 1
            while e <= end:
                if not _fit(&qp[s * 5], e - s + 1, plane, tol_mm, tol_deg, p10, rho, phi, cand):
                    bad = e
                    break
                good_e = e
                for j in range(7):
                    good[j] = cand[j]
                e = s + 2 * (e - s)
            if good_e < 0:
                s += 1
                continue
            lo = good_e
            hi = bad if bad < end + 1 else end + 1
            while hi - lo > 1:
                mid = (lo + hi) // 2
                if not _fit(&qp[s * 5], mid - s + 1, plane, tol_mm, tol_deg, p10, rho, phi,
                            cand):
                    hi = mid
                else:
                    lo = mid
                    good_e = mid
                    for j in range(7):
                        good[j] = cand[j]
            ai[count, 0] = s
            ai[count, 1] = good_e
            ai[count, 2] = plane
            ai[count, 3] = 1 if good[0] > 0.0 else 0
            for j in range(6):
                af[count, j] = good[1 + j]
            count += 1
            s = good_e
    return _rows(arc_i, arc_f, count)
