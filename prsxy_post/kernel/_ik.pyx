# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The closed-form inverse kinematics compiled: :func:`prsxy_post.kernel.ik.inverse_rows`
row by row, the same operations in the same order (see that module), so the two
agree to the bit. Compiled with -O2 -ffp-contract=off (no fused multiply-adds, which
would round differently from numpy's separate multiply and add)."""

import numpy as np

from libc.math cimport acos, atan2, cos, fabs, fmod, sin, sqrt, copysign, signbit, NAN, M_PI
from libc.stdint cimport uint64_t
from libc.string cimport memcpy

from . import ik as _pure

cdef extern from *:
    """
    #ifndef PRSXY_CYTHON_VERSION
    #define PRSXY_CYTHON_VERSION "3"
    #endif
    """
    const char* PRSXY_CYTHON_VERSION

#: The Cython that compiled this module (setup.py defines it).
CYTHON = PRSXY_CYTHON_VERSION.decode("ascii")

cdef double DEG2RAD = M_PI / 180.0  # numpy's radians: x * (pi / 180)
cdef double TWO_PI = 2 * M_PI


cdef inline double _wrap(double a) nogil:
    # numpy's remainder (npy_divmod): fmod, then moved to the divisor's sign
    cdef double x = a + M_PI
    cdef double mod
    # fmod(x, y) is x itself for |x| < |y| (fmod is exact): the call only beyond
    if fabs(x) < TWO_PI:
        mod = x
    else:
        mod = fmod(x, TWO_PI)
    if mod != 0.0:
        if (TWO_PI < 0) != (mod < 0):
            mod += TWO_PI
    else:
        mod = copysign(0.0, TWO_PI)
    return mod - M_PI


cdef struct _Geo:
    double u[3][3]
    double b[3][3]
    double g[3][3]
    double d[3][3]
    double L2[3]
    double gu[3]
    double nul[4]
    double Mp[3][4]
    double origin[3]
    double tx
    double ty
    # the table: 1 + s_x, 1 + s_y, σ, and the straightness (k_x, k_y) when given
    double sx1
    double sy1
    double sq
    bint straight
    double kx
    double ky


cdef _Geo _geo(m):
    """The geometry's arrays as C doubles."""
    cdef _Geo G
    cdef Py_ssize_t k, j
    G.tx = float(m.tool[0])
    G.ty = float(m.tool[1])
    G.sx1 = 1.0 + float(m.scale_x)
    G.sy1 = 1.0 + float(m.scale_y)
    G.sq = float(m.squareness)
    G.straight = m.straightness is not None
    G.kx = 0.0
    G.ky = 0.0
    if G.straight:
        G.kx = float(m.straightness[0])
        G.ky = float(m.straightness[1])
    for k in range(3):
        G.L2[k] = float(m.L2[k])
        G.gu[k] = float(m.gu[k])
        G.origin[k] = float(m.origin[k])
        for j in range(3):
            G.u[k][j] = float(m.u[k, j])
            G.b[k][j] = float(m.b[k, j])
            G.g[k][j] = float(m.g[k, j])
            G.d[k][j] = float(m.d[k, j])
        for j in range(4):
            G.Mp[k][j] = float(m.Mp[k, j])
    for j in range(4):
        G.nul[j] = float(m.nul[j])
    return G


cdef struct _Tilt:
    # what step 1 of the IK takes from the tilts A, B alone (``ik.platform_cols``):
    # their cosines and sines, the legs' and the tip's terms of r(γ), and
    # Kc cos γ + Ks sin γ as ρ cos(γ − φ)
    double ca
    double sa
    double cb
    double sb
    double rz2
    double cos_z
    double sin_z
    double rho
    double phi
    double const_legs[3]
    double cos_legs[3]
    double sin_legs[3]


cdef inline void _tilt(const _Geo* G, double qa, double qb, _Tilt* T) noexcept nogil:
    """Step 1 of the IK, its part that depends on A and B [deg] only."""
    cdef double a_rad, b_rad, ca, sa, cb, sb, uR0, uR1, uR2, rz0, rz1, Kc, Ks
    cdef int k
    a_rad = qa * DEG2RAD
    b_rad = qb * DEG2RAD
    ca = cos(a_rad)
    sa = sin(a_rad)
    cb = cos(b_rad)
    sb = sin(b_rad)
    for k in range(3):
        uR0 = cb * G.u[k][0] - sb * G.u[k][2]
        uR1 = sb * sa * G.u[k][0] + ca * G.u[k][1] + cb * sa * G.u[k][2]
        uR2 = sb * ca * G.u[k][0] - sa * G.u[k][1] + cb * ca * G.u[k][2]
        T.const_legs[k] = G.gu[k] - uR2 * G.b[k][2]
        T.cos_legs[k] = -(uR0 * G.b[k][0] + uR1 * G.b[k][1])
        T.sin_legs[k] = -(uR1 * G.b[k][0] - uR0 * G.b[k][1])
    rz0 = -sb
    rz1 = cb * sa
    T.rz2 = cb * ca
    T.cos_z = -(rz0 * G.tx + rz1 * G.ty)
    T.sin_z = -(rz1 * G.tx - rz0 * G.ty)
    Kc = (T.cos_legs[0] * G.nul[0] + T.cos_legs[1] * G.nul[1] + T.cos_legs[2] * G.nul[2]
          + T.cos_z * G.nul[3])
    Ks = (T.sin_legs[0] * G.nul[0] + T.sin_legs[1] * G.nul[1] + T.sin_legs[2] * G.nul[2]
          + T.sin_z * G.nul[3])
    T.rho = sqrt(Kc * Kc + Ks * Ks)
    T.phi = atan2(Ks, Kc)
    T.ca = ca
    T.sa = sa
    T.cb = cb
    T.sb = sb


cdef inline void _spin(
    const _Geo* G, const _Tilt* T, double qz, double tzi, double* o
) noexcept nogil:
    """Step 1 of the IK from its tilts' part ``T``, the height z and the tool's
    ``tzi``: o = (ca, sa, cb, sb, cg, sg, gamma, c0, c1, c2)."""
    cdef double r_legs[3]
    cdef double const_z, K0, ratio, delta, g1, g2, gamma, cg, sg, r_z
    cdef int k, j
    const_z = G.origin[2] + qz - T.rz2 * tzi
    K0 = (T.const_legs[0] * G.nul[0] + T.const_legs[1] * G.nul[1]
          + T.const_legs[2] * G.nul[2] + const_z * G.nul[3])
    ratio = -K0 / T.rho
    if fabs(ratio) <= 1.0:
        delta = acos(ratio)
    else:
        delta = NAN
    g1 = _wrap(T.phi + delta)
    g2 = _wrap(T.phi - delta)
    gamma = g1 if fabs(g1) <= fabs(g2) else g2
    cg = cos(gamma)
    sg = sin(gamma)
    for k in range(3):
        r_legs[k] = T.const_legs[k] + T.cos_legs[k] * cg + T.sin_legs[k] * sg
    r_z = const_z + T.cos_z * cg + T.sin_z * sg
    for j in range(3):
        o[7 + j] = r_legs[0] * G.Mp[j][0] + r_legs[1] * G.Mp[j][1] + r_legs[2] * G.Mp[j][2] + r_z * G.Mp[j][3]
    o[0] = T.ca
    o[1] = T.sa
    o[2] = T.cb
    o[3] = T.sb
    o[4] = cg
    o[5] = sg
    o[6] = gamma


cdef inline void _platform(
    const _Geo* G, double qz, double qa, double qb, double tzi, double* o
) noexcept nogil:
    """Step 1 of the IK for one pose (``ik.platform_cols``): o = (ca, sa, cb, sb,
    cg, sg, gamma, c0, c1, c2)."""
    cdef _Tilt T
    _tilt(G, qa, qb, &T)
    _spin(G, &T, qz, tzi, o)


def platform_cols(m, const double[:, :] q, const double[:] tz):
    """Step 1 of the IK, spin γ and centre c for poses ``q`` (N, 5) [mm, deg]: the
    compiled twin of ``ik.platform_cols``."""
    cdef Py_ssize_t n = q.shape[0], i, j
    if q.shape[1] != 5 or tz.shape[0] != n:
        raise ValueError("q must be (N, 5) and tz (N,)")
    cdef _Geo G = _geo(m)
    cols_a = np.empty((7, n))
    c_a = np.empty((n, 3))
    cdef double[:, ::1] cols = cols_a
    cdef double[:, ::1] c = c_a
    cdef double o[10]
    with nogil:
        for i in range(n):
            _platform(&G, q[i, 2], q[i, 3], q[i, 4], tz[i], o)
            for j in range(7):
                cols[j, i] = o[j]
            for j in range(3):
                c[i, j] = o[7 + j]
    return _pure.PlatformCols(*cols_a, c_a)


cdef inline void _row(
    const _Geo* G, double q0, double q1, double q2, double q3, double q4, double tzi,
    double* P
) noexcept nogil:
    """One pose's motor positions P[0..4] (``ik.inverse_rows``, straight guides)."""
    cdef double o[10]
    _platform(G, q2, q3, q4, tzi, o)
    _legs(G, o, q0, q1, tzi, P)


cdef inline bint _same(double x, double y) noexcept nogil:
    """x and y the same bits (NaN: never; 0.0 is not −0.0)."""
    return x == y and signbit(x) == signbit(y)


cdef inline void _stepped(
    const _Geo* G, const _Tilt* T, const double* o, double q2, double q3, double q4,
    double s0, double s1, double s2, double s3, double s4, double tzi, double* P
) noexcept nogil:
    """The motor positions P[0..4] of the pose s stepped from q, whose step 1 of
    the IK is ``T``, ``o``: the part of step 1 that s shares with q to the bit (its
    tilts; and its height) is q's, the same numbers as :func:`_row` of s."""
    cdef _Tilt Ts
    cdef double os[10]
    if _same(s3, q3) and _same(s4, q4):
        if _same(s2, q2):
            _legs(G, o, s0, s1, tzi, P)
        else:
            _spin(G, T, s2, tzi, os)
            _legs(G, os, s0, s1, tzi, P)
    else:
        _tilt(G, s3, s4, &Ts)
        _spin(G, &Ts, s2, tzi, os)
        _legs(G, os, s0, s1, tzi, P)


cdef inline void _legs(
    const _Geo* G, const double* o, double q0, double q1, double tzi, double* P
) noexcept nogil:
    """Motor positions P[0..4] from step 1 of the IK, ``o`` (:func:`_platform`),
    and the pose's x, y."""
    cdef double ca, sa, cb, sb, cg, sg
    cdef double c[3]
    cdef double v[3]
    cdef double x, y, y2, z2, w0, w1, w2, rbx, rby, rbz
    cdef double dv, disc, Dx, Dy, p5, p6, t0, t1, t2
    cdef int k, j
    ca = o[0]
    sa = o[1]
    cb = o[2]
    sb = o[3]
    cg = o[4]
    sg = o[5]
    c[0] = o[7]
    c[1] = o[8]
    c[2] = o[9]
    for k in range(3):
        # R b_k (ik.rotate), then v_k = c + R b_k − g_k
        w0 = G.b[k][0]
        w1 = G.b[k][1]
        w2 = G.b[k][2]
        x = cg * w0 - sg * w1
        y = sg * w0 + cg * w1
        y2 = ca * y - sa * w2
        z2 = sa * y + ca * w2
        rbx = cb * x + sb * z2
        rby = y2
        rbz = -sb * x + cb * z2
        v[0] = c[0] + rbx - G.g[k][0]
        v[1] = c[1] + rby - G.g[k][1]
        v[2] = c[2] + rbz - G.g[k][2]
        dv = v[0] * G.d[k][0] + v[1] * G.d[k][1] + v[2] * G.d[k][2]
        disc = dv * dv - (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + G.L2[k]
        P[k] = dv + sqrt(disc)
    # R t
    t0 = G.tx
    t1 = G.ty
    t2 = tzi
    x = cg * t0 - sg * t1
    y = sg * t0 + cg * t1
    y2 = ca * y - sa * t2
    z2 = sa * y + ca * t2
    Dx = G.origin[0] + q0 - (c[0] + (cb * x + sb * z2))
    Dy = G.origin[1] + q1 - (c[1] + y2)
    p6 = Dy / G.sy1
    p5 = (Dx - G.sq * p6) / G.sx1
    if G.straight:
        for j in range(4):
            p6 = (Dy - G.kx * ((p5 / 1000.0) * (p5 / 1000.0))) / G.sy1
            p5 = (Dx - G.sq * p6 - G.ky * ((p6 / 1000.0) * (p6 / 1000.0))) / G.sx1
    P[3] = p5
    P[4] = p6


cdef inline void _platform_kept(
    const _Geo* G, double qz, double qa, double qb, double tzi, _Tilt* T, double* o,
    double* kept
) noexcept nogil:
    """Step 1 of the IK into ``T`` (:func:`_tilt`) and ``o`` (:func:`_spin`), each
    made again only when its inputs are not the ones ``kept`` (A, B; z, the tool)
    holds, to the bit (NaN: none). Poses along a path keep their tilts, and often
    their height, from point to point: the same inputs give the same numbers."""
    if _same(qa, kept[0]) and _same(qb, kept[1]):
        if _same(qz, kept[2]) and _same(tzi, kept[3]):
            return
    else:
        _tilt(G, qa, qb, T)
        kept[0] = qa
        kept[1] = qb
    _spin(G, T, qz, tzi, o)
    kept[2] = qz
    kept[3] = tzi


def inverse_rows(m, const double[:, :] q, const double[:] tz):
    """Motor positions P (N, 5) [mm]; the compiled twin of ``ik.inverse_rows``.
    A geometry with bowed guides goes to the reference (its Newton sums are
    numpy's einsum, whose order is numpy's own)."""
    if m.bow is not None:
        return _pure.inverse_rows(m, np.asarray(q), np.asarray(tz))
    cdef Py_ssize_t n = q.shape[0], i, k
    if q.shape[1] != 5 or tz.shape[0] != n:
        raise ValueError("q must be (N, 5) and tz (N,)")
    cdef _Geo G = _geo(m)
    out = np.empty((n, 5))
    cdef double[:, ::1] P = out
    cdef double o[10]
    cdef _Tilt T
    cdef double kept[4]
    kept[0] = NAN
    kept[1] = NAN
    kept[2] = NAN
    kept[3] = NAN
    with nogil:
        for i in range(n):
            _platform_kept(&G, q[i, 2], q[i, 3], q[i, 4], tz[i], &T, o, kept)
            _legs(&G, o, q[i, 0], q[i, 1], tz[i], &P[i, 0])
    return out


def derivative_rows(m, const double[:, :] q, const double[:, :] dq, const double[:] tz,
                    const double[:, :] P, double step):
    """(N, 5) the IK's one-sided difference along ``dq`` over ``step`` from poses
    ``q`` whose IK is ``P``: the compiled twin of ``ik.derivative_rows``."""
    if m.bow is not None:
        return _pure.derivative_rows(
            m, np.asarray(q), np.asarray(dq), np.asarray(tz), np.asarray(P), step
        )
    cdef Py_ssize_t n = q.shape[0], i, k
    if q.shape[1] != 5 or dq.shape[0] != n or dq.shape[1] != 5 or tz.shape[0] != n \
            or P.shape[0] != n or P.shape[1] != 5:
        raise ValueError("q, dq and P must be (N, 5) and tz (N,), one row a pose")
    cdef _Geo G = _geo(m)
    out = np.empty((n, 5))
    cdef double[:, ::1] D = out
    cdef double Ps[5]
    cdef double o[10]
    cdef _Tilt T
    cdef double kept[4]
    cdef double sa, sb
    kept[0] = NAN
    kept[1] = NAN
    kept[2] = NAN
    kept[3] = NAN
    with nogil:
        for i in range(n):
            sa = q[i, 3] + step * dq[i, 3]
            sb = q[i, 4] + step * dq[i, 4]
            _platform_kept(&G, q[i, 2] + step * dq[i, 2], sa, sb, tz[i], &T, o, kept)
            _legs(&G, o, q[i, 0] + step * dq[i, 0], q[i, 1] + step * dq[i, 1], tz[i], Ps)
            for k in range(5):
                D[i, k] = (Ps[k] - P[i, k]) / step
    return out


cdef inline bint _bits(double x, double y) noexcept nogil:
    """x and y the same 8 bytes (as numpy compares rows viewed as bytes)."""
    cdef uint64_t a, b
    memcpy(&a, &x, 8)
    memcpy(&b, &y, 8)
    return a == b


cdef inline void _slope(
    const _Geo* G, _Tilt* T, double* o, double* kept, const double* q, const double* P,
    const double* dq, double sign, double tzi, double step, double* d
) noexcept nogil:
    """d[0..4] = sign · (P(q + step · sign · dq) − P) / step: ``derivative_rows``
    of one row along ``dq`` (sign 1) or back along it (sign −1), whose IK is P."""
    cdef double s[5]
    cdef double Ps[5]
    cdef int c
    for c in range(5):
        if sign < 0:
            s[c] = q[c] + step * (-dq[c])
        else:
            s[c] = q[c] + step * dq[c]
    _platform_kept(G, s[2], s[3], s[4], tzi, T, o, kept)
    _legs(G, o, s[0], s[1], tzi, Ps)
    for c in range(5):
        if sign < 0:
            d[c] = -((Ps[c] - P[c]) / step)
        else:
            d[c] = (Ps[c] - P[c]) / step


def end_slopes(m, const double[:, :] start, const double[:, :] end,
               const double[:, :] dq_in, const double[:, :] dq_out, const double[:] tz,
               double step):
    """The motors' dP/ds (d_in, d_out) at n blocks' starts and ends: the compiled
    twin of ``ik.end_slopes``, each block's four IK rows in one pass."""
    if m.bow is not None:
        return _pure.end_slopes(
            m, np.asarray(start), np.asarray(end), np.asarray(dq_in), np.asarray(dq_out),
            np.asarray(tz), step
        )
    cdef Py_ssize_t n = start.shape[0], j, c
    if (start.shape[1] != 5 or end.shape[0] != n or end.shape[1] != 5
            or dq_in.shape[0] != n or dq_in.shape[1] != 5 or dq_out.shape[0] != n
            or dq_out.shape[1] != 5 or tz.shape[0] != n):
        raise ValueError("start, end, dq_in and dq_out must be (n, 5) and tz (n,), a block a row")
    cdef _Geo G = _geo(m)
    din_a = np.empty((n, 5))
    dout_a = np.empty((n, 5))
    cdef double[:, ::1] din = din_a
    cdef double[:, ::1] dout = dout_a
    cdef double q[5]
    cdef double dq[5]
    cdef double P0[5]
    cdef double Pe[5]
    cdef double o[10]
    cdef _Tilt T
    cdef double kept[4]
    cdef bint again
    kept[0] = NAN
    kept[1] = NAN
    kept[2] = NAN
    kept[3] = NAN
    with nogil:
        for j in range(n):
            # the start: the block before's end's IK where it is that end to the bit
            for c in range(5):
                q[c] = start[j, c]
                dq[c] = dq_in[j, c]
            again = j > 0
            if again:
                again = _bits(tz[j], tz[j - 1])
                for c in range(5):
                    if not _bits(q[c], end[j - 1, c]):
                        again = False
            if again:
                for c in range(5):
                    P0[c] = Pe[c]
            else:
                _platform_kept(&G, q[2], q[3], q[4], tz[j], &T, o, kept)
                _legs(&G, o, q[0], q[1], tz[j], P0)
            _slope(&G, &T, o, kept, q, P0, dq, 1.0, tz[j], step, &din[j, 0])
            for c in range(5):
                q[c] = end[j, c]
                dq[c] = dq_out[j, c]
            _platform_kept(&G, q[2], q[3], q[4], tz[j], &T, o, kept)
            _legs(&G, o, q[0], q[1], tz[j], Pe)
            _slope(&G, &T, o, kept, q, Pe, dq, -1.0, tz[j], step, &dout[j, 0])
    return din_a, dout_a


def motion_rows(m, const double[:, :] q, const double[:, :] qdot, const double[:] tz,
                double step):
    """The IK P (N, 5) of poses ``q`` and its velocity V (N, 5) along ``qdot``
    (0 where a row's ``qdot`` is): the compiled twin of ``ik.motion_rows``, both in
    one pass over the rows."""
    if m.bow is not None:
        return _pure.motion_rows(m, np.asarray(q), np.asarray(qdot), np.asarray(tz), step)
    cdef Py_ssize_t n = q.shape[0], i, k
    if q.shape[1] != 5 or qdot.shape[0] != n or qdot.shape[1] != 5 or tz.shape[0] != n:
        raise ValueError("q and qdot must be (N, 5) and tz (N,), one row a pose")
    cdef _Geo G = _geo(m)
    P_a = np.empty((n, 5))
    V_a = np.empty((n, 5))
    cdef double[:, ::1] P = P_a
    cdef double[:, ::1] V = V_a
    cdef double Ps[5]
    cdef double o[10]
    cdef _Tilt T
    cdef double kept[4]
    kept[0] = NAN
    kept[1] = NAN
    kept[2] = NAN
    kept[3] = NAN
    with nogil:
        for i in range(n):
            _platform_kept(&G, q[i, 2], q[i, 3], q[i, 4], tz[i], &T, o, kept)
            _legs(&G, o, q[i, 0], q[i, 1], tz[i], &P[i, 0])
            if (qdot[i, 0] != 0.0 or qdot[i, 1] != 0.0 or qdot[i, 2] != 0.0
                    or qdot[i, 3] != 0.0 or qdot[i, 4] != 0.0):
                _stepped(&G, &T, o, q[i, 2], q[i, 3], q[i, 4],
                         q[i, 0] + step * qdot[i, 0], q[i, 1] + step * qdot[i, 1],
                         q[i, 2] + step * qdot[i, 2], q[i, 3] + step * qdot[i, 3],
                         q[i, 4] + step * qdot[i, 4], tz[i], Ps)
                for k in range(5):
                    V[i, k] = (Ps[k] - P[i, k]) / step
            else:
                for k in range(5):
                    V[i, k] = 0.0
    return P_a, V_a


def jacobian_rows(m, const double[:, :] q, const double[:] tz, double step, P=None):
    """(N, 5, 5) ∂P_i/∂q_j by the IK's one-sided differences over ``step`` along
    each coordinate, from ``P`` (the IK of ``q``; solved here when None): the
    compiled twin of ``ik.jacobian_rows``."""
    if m.bow is not None:
        return _pure.jacobian_rows(
            m, np.asarray(q), np.asarray(tz), step, None if P is None else np.asarray(P)
        )
    cdef Py_ssize_t n = q.shape[0], i, j, k
    if q.shape[1] != 5 or tz.shape[0] != n:
        raise ValueError("q must be (N, 5) and tz (N,), one row a pose")
    cdef const double[:, :] Pv
    cdef bint given = P is not None
    if given:
        Pv = P
        if Pv.shape[0] != n or Pv.shape[1] != 5:
            raise ValueError(f"P must be ({n}, 5) as q, got {np.shape(P)}")
    cdef _Geo G = _geo(m)
    out = np.empty((n, 5, 5))
    cdef double[:, :, ::1] J = out
    cdef double P0[5]
    cdef double Ps[5]
    cdef double qs[5]
    cdef double o[10]
    cdef _Tilt T
    cdef double kept[4]
    kept[0] = NAN
    kept[1] = NAN
    kept[2] = NAN
    kept[3] = NAN
    with nogil:
        for i in range(n):
            _platform_kept(&G, q[i, 2], q[i, 3], q[i, 4], tz[i], &T, o, kept)
            if given:
                for k in range(5):
                    P0[k] = Pv[i, k]
            else:
                _legs(&G, o, q[i, 0], q[i, 1], tz[i], P0)
            for j in range(5):
                for k in range(5):
                    qs[k] = q[i, k]
                qs[j] = q[i, j] + step
                _stepped(&G, &T, o, q[i, 2], q[i, 3], q[i, 4],
                         qs[0], qs[1], qs[2], qs[3], qs[4], tz[i], Ps)
                for k in range(5):
                    J[i, k, j] = (Ps[k] - P0[k]) / step
    return out
