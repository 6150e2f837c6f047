# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The closed-form inverse kinematics compiled: :func:`prsxy_post.kernel.ik.inverse_rows`
row by row, the same operations in the same order (see that module), so the two
agree to the bit. Compiled with -O2 -ffp-contract=off (no fused multiply-adds, which
would round differently from numpy's separate multiply and add)."""

import numpy as np

from libc.math cimport acos, atan2, cos, fabs, fmod, sin, sqrt, copysign, NAN, M_PI

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
    cdef double mod = fmod(x, TWO_PI)
    if mod != 0.0:
        if (TWO_PI < 0) != (mod < 0):
            mod += TWO_PI
    else:
        mod = copysign(0.0, TWO_PI)
    return mod - M_PI


def inverse_rows(m, const double[:, :] q, const double[:] tz):
    """Motor positions P (N, 5) [mm]; the compiled twin of ``ik.inverse_rows``.
    A geometry with bowed guides goes to the reference (its Newton sums are
    numpy's einsum, whose order is numpy's own)."""
    if m.bow is not None:
        return _pure.inverse_rows(m, np.asarray(q), np.asarray(tz))
    cdef Py_ssize_t n = q.shape[0], i, k, j
    if q.shape[1] != 5 or tz.shape[0] != n:
        raise ValueError("q must be (N, 5) and tz (N,)")
    cdef double u[3][3]
    cdef double b[3][3]
    cdef double g[3][3]
    cdef double d[3][3]
    cdef double L2[3]
    cdef double gu[3]
    cdef double nul[4]
    cdef double Mp[3][4]
    cdef double origin[3]
    cdef double tx = float(m.tool[0]), ty = float(m.tool[1])
    cdef double sx1 = 1.0 + float(m.scale_x), sy1 = 1.0 + float(m.scale_y)
    cdef double sq = float(m.squareness)
    cdef bint straight = m.straightness is not None
    cdef double kx = 0.0, ky = 0.0
    if straight:
        kx = float(m.straightness[0])
        ky = float(m.straightness[1])
    for k in range(3):
        L2[k] = float(m.L2[k])
        gu[k] = float(m.gu[k])
        origin[k] = float(m.origin[k])
        for j in range(3):
            u[k][j] = float(m.u[k, j])
            b[k][j] = float(m.b[k, j])
            g[k][j] = float(m.g[k, j])
            d[k][j] = float(m.d[k, j])
        for j in range(4):
            Mp[k][j] = float(m.Mp[k, j])
    for j in range(4):
        nul[j] = float(m.nul[j])

    out = np.empty((n, 5))
    cdef double[:, :] P = out
    cdef double a_rad, b_rad, ca, sa, cb, sb, uR0, uR1, uR2
    cdef double const_legs[3]
    cdef double cos_legs[3]
    cdef double sin_legs[3]
    cdef double r_legs[3]
    cdef double c[3]
    cdef double v[3]
    cdef double rz0, rz1, rz2, const_z, cos_z, sin_z, K0, Kc, Ks, rho, phi, ratio, delta
    cdef double g1, g2, gamma, cg, sg, r_z, x, y, y2, z2, w0, w1, w2, rbx, rby, rbz
    cdef double dv, disc, Dx, Dy, p5, p6, t0, t1, t2
    with nogil:
        for i in range(n):
            a_rad = q[i, 3] * DEG2RAD
            b_rad = q[i, 4] * DEG2RAD
            ca = cos(a_rad)
            sa = sin(a_rad)
            cb = cos(b_rad)
            sb = sin(b_rad)
            for k in range(3):
                uR0 = cb * u[k][0] - sb * u[k][2]
                uR1 = sb * sa * u[k][0] + ca * u[k][1] + cb * sa * u[k][2]
                uR2 = sb * ca * u[k][0] - sa * u[k][1] + cb * ca * u[k][2]
                const_legs[k] = gu[k] - uR2 * b[k][2]
                cos_legs[k] = -(uR0 * b[k][0] + uR1 * b[k][1])
                sin_legs[k] = -(uR1 * b[k][0] - uR0 * b[k][1])
            rz0 = -sb
            rz1 = cb * sa
            rz2 = cb * ca
            const_z = origin[2] + q[i, 2] - rz2 * tz[i]
            cos_z = -(rz0 * tx + rz1 * ty)
            sin_z = -(rz1 * tx - rz0 * ty)
            K0 = const_legs[0] * nul[0] + const_legs[1] * nul[1] + const_legs[2] * nul[2] + const_z * nul[3]
            Kc = cos_legs[0] * nul[0] + cos_legs[1] * nul[1] + cos_legs[2] * nul[2] + cos_z * nul[3]
            Ks = sin_legs[0] * nul[0] + sin_legs[1] * nul[1] + sin_legs[2] * nul[2] + sin_z * nul[3]
            rho = sqrt(Kc * Kc + Ks * Ks)
            phi = atan2(Ks, Kc)
            ratio = -K0 / rho
            if fabs(ratio) <= 1.0:
                delta = acos(ratio)
            else:
                delta = NAN
            g1 = _wrap(phi + delta)
            g2 = _wrap(phi - delta)
            gamma = g1 if fabs(g1) <= fabs(g2) else g2
            cg = cos(gamma)
            sg = sin(gamma)
            for k in range(3):
                r_legs[k] = const_legs[k] + cos_legs[k] * cg + sin_legs[k] * sg
            r_z = const_z + cos_z * cg + sin_z * sg
            for j in range(3):
                c[j] = r_legs[0] * Mp[j][0] + r_legs[1] * Mp[j][1] + r_legs[2] * Mp[j][2] + r_z * Mp[j][3]
            for k in range(3):
                # R b_k (ik.rotate), then v_k = c + R b_k − g_k
                w0 = b[k][0]
                w1 = b[k][1]
                w2 = b[k][2]
                x = cg * w0 - sg * w1
                y = sg * w0 + cg * w1
                y2 = ca * y - sa * w2
                z2 = sa * y + ca * w2
                rbx = cb * x + sb * z2
                rby = y2
                rbz = -sb * x + cb * z2
                v[0] = c[0] + rbx - g[k][0]
                v[1] = c[1] + rby - g[k][1]
                v[2] = c[2] + rbz - g[k][2]
                dv = v[0] * d[k][0] + v[1] * d[k][1] + v[2] * d[k][2]
                disc = dv * dv - (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + L2[k]
                P[i, k] = dv + sqrt(disc)
            # R t
            t0 = tx
            t1 = ty
            t2 = tz[i]
            x = cg * t0 - sg * t1
            y = sg * t0 + cg * t1
            y2 = ca * y - sa * t2
            z2 = sa * y + ca * t2
            Dx = origin[0] + q[i, 0] - (c[0] + (cb * x + sb * z2))
            Dy = origin[1] + q[i, 1] - (c[1] + y2)
            p6 = Dy / sy1
            p5 = (Dx - sq * p6) / sx1
            if straight:
                for j in range(4):
                    p6 = (Dy - kx * ((p5 / 1000.0) * (p5 / 1000.0))) / sy1
                    p5 = (Dx - sq * p6 - ky * ((p6 / 1000.0) * (p6 / 1000.0))) / sx1
            P[i, 3] = p5
            P[i, 4] = p6
    return out
