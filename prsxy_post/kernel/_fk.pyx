# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The forward kinematics' per-row arithmetic compiled: the twin of
:mod:`prsxy_post.kernel.fk`, operation for operation (built with
-ffp-contract=off: no fused multiply-add), so the same bits."""

import numpy as np

from libc.math cimport fabs, isfinite, sqrt

from . import fk as _pure


def rotation_cs(ca, sa, cb, sb, cg, sg):
    """R_y(B) R_x(A) R_z(γ) from the cosines and sines (``fk.rotation_cs``)."""
    args = (ca, sa, cb, sb, cg, sg)
    if not all(isinstance(x, np.ndarray) and x.ndim == 1 and x.dtype == np.float64 for x in args):
        return _pure.rotation_cs(*args)
    cdef Py_ssize_t n = len(ca), i
    if any(len(x) != n for x in args):
        return _pure.rotation_cs(*args)
    cdef const double[:] a_c = ca
    cdef const double[:] a_s = sa
    cdef const double[:] b_c = cb
    cdef const double[:] b_s = sb
    cdef const double[:] g_c = cg
    cdef const double[:] g_s = sg
    R_a = np.empty((n, 3, 3))
    cdef double[:, :, ::1] R = R_a
    cdef double xa, ya, xb, yb, xg, yg
    with nogil:
        for i in range(n):
            xa = a_c[i]
            ya = a_s[i]
            xb = b_c[i]
            yb = b_s[i]
            xg = g_c[i]
            yg = g_s[i]
            R[i, 0, 0] = xb * xg + yb * ya * yg
            R[i, 0, 1] = yb * ya * xg - xb * yg
            R[i, 0, 2] = yb * xa
            R[i, 1, 0] = xa * yg
            R[i, 1, 1] = xa * xg
            R[i, 1, 2] = -ya
            R[i, 2, 0] = xb * ya * yg - yb * xg
            R[i, 2, 1] = yb * yg + xb * ya * xg
            R[i, 2, 2] = xb * xa
    return R_a


def fk_equations(m, c_in, rb_in, p3_in, off_in=None):
    """w, |w|, f: the six FK equations (``fk.fk_equations``)."""
    cdef Py_ssize_t n = c_in.shape[0], i, k
    if (
        c_in.shape != (n, 3)
        or rb_in.shape != (n, 3, 3)
        or p3_in.shape != (n, 3)
        or (off_in is not None and off_in.shape != (n, 3, 3))
    ):
        raise ValueError("c and p3 must be (N, 3), rb and off (N, 3, 3)")
    cdef const double[:, :] c = c_in
    cdef const double[:, :, :] rb = rb_in
    cdef const double[:, :] p3 = p3_in
    cdef bint straight = off_in is None
    cdef const double[:, :, :] off = np.broadcast_to(
        np.zeros(1) if straight else off_in, (n, 3, 3)
    )
    cdef const double[:, :] d = np.ascontiguousarray(m.d, dtype=float)
    cdef const double[:, :] g = np.ascontiguousarray(m.g, dtype=float)
    cdef const double[:, :] u = np.ascontiguousarray(m.u, dtype=float)
    cdef const double[:] L = np.ascontiguousarray(m.L, dtype=float)
    w_a = np.empty((n, 3, 3))
    nw_a = np.empty((n, 3))
    f_a = np.empty((n, 6))
    cdef double[:, :, ::1] w = w_a
    cdef double[:, ::1] nw = nw_a
    cdef double[:, ::1] f = f_a
    cdef double v0, v1, v2, w0, w1, w2
    with nogil:
        for i in range(n):
            for k in range(3):
                v0 = c[i, 0] + rb[i, k, 0] - g[k, 0]
                v1 = c[i, 1] + rb[i, k, 1] - g[k, 1]
                v2 = c[i, 2] + rb[i, k, 2] - g[k, 2]
                f[i, k] = v0 * u[k, 0] + v1 * u[k, 1] + v2 * u[k, 2]
                if straight:
                    w0 = v0 - p3[i, k] * d[k, 0]
                    w1 = v1 - p3[i, k] * d[k, 1]
                    w2 = v2 - p3[i, k] * d[k, 2]
                else:
                    w0 = v0 - off[i, k, 0]
                    w1 = v1 - off[i, k, 1]
                    w2 = v2 - off[i, k, 2]
                w[i, k, 0] = w0
                w[i, k, 1] = w1
                w[i, k, 2] = w2
                nw[i, k] = sqrt(w0 * w0 + w1 * w1 + w2 * w2)
                f[i, 3 + k] = nw[i, k] - L[k]
    return w_a, nw_a, f_a


def fk_jacobian_parts(m, R_in, rb_in, w_in, nw_in, cb_in, sb_in):
    """J's columns of c, R b_k × u_k, R b_k × w_k/|w_k|, the axes as columns
    (``fk.fk_jacobian_parts``)."""
    cdef Py_ssize_t n = R_in.shape[0], i, k, j
    if (
        any(a.shape != (n, 3, 3) for a in (R_in, rb_in, w_in))
        or nw_in.shape != (n, 3)
        or cb_in.shape != (n,)
        or sb_in.shape != (n,)
    ):
        raise ValueError("R, rb and w must be (N, 3, 3), |w| (N, 3), cos B and sin B (N,)")
    cdef const double[:, :, :] R = R_in
    cdef const double[:, :, :] rb = rb_in
    cdef const double[:, :, :] w = w_in
    cdef const double[:, :] nw = nw_in
    cdef const double[:] cb = cb_in
    cdef const double[:] sb = sb_in
    cdef const double[:, :] u = np.ascontiguousarray(m.u, dtype=float)
    axes_a = np.empty((n, 3, 3))
    J_a = np.empty((n, 6, 6))
    cu_a = np.empty((n, 3, 3))
    cw_a = np.empty((n, 3, 3))
    cdef double[:, :, ::1] axes = axes_a
    cdef double[:, :, ::1] J = J_a
    cdef double[:, :, ::1] cu = cu_a
    cdef double[:, :, ::1] cw = cw_a
    cdef double e0, e1, e2, r0, r1, r2
    with nogil:
        for i in range(n):
            axes[i, 0, 0] = cb[i]
            axes[i, 0, 1] = 0.0
            axes[i, 0, 2] = -sb[i]
            axes[i, 1, 0] = 0.0
            axes[i, 1, 1] = 1.0
            axes[i, 1, 2] = 0.0
            for j in range(3):
                axes[i, 2, j] = R[i, j, 2]
            for k in range(3):
                e0 = w[i, k, 0] / nw[i, k]
                e1 = w[i, k, 1] / nw[i, k]
                e2 = w[i, k, 2] / nw[i, k]
                for j in range(3):
                    J[i, k, j] = u[k, j]
                J[i, 3 + k, 0] = e0
                J[i, 3 + k, 1] = e1
                J[i, 3 + k, 2] = e2
                r0 = rb[i, k, 0]
                r1 = rb[i, k, 1]
                r2 = rb[i, k, 2]
                cu[i, k, 0] = r1 * u[k, 2] - r2 * u[k, 1]
                cu[i, k, 1] = r2 * u[k, 0] - r0 * u[k, 2]
                cu[i, k, 2] = r0 * u[k, 1] - r1 * u[k, 0]
                cw[i, k, 0] = r1 * e2 - r2 * e1
                cw[i, k, 1] = r2 * e0 - r0 * e2
                cw[i, k, 2] = r0 * e1 - r1 * e0
    return J_a, cu_a, cw_a, axes_a.transpose(0, 2, 1)


def newton_step(x_in, step_in, double limit):
    """x + step, done, bad: one batched Newton update (``fk.newton_step``)."""
    cdef Py_ssize_t n = x_in.shape[0], k = x_in.shape[1], i, j
    if step_in.shape != x_in.shape:
        raise ValueError("x and step must have the same shape (N, k)")
    cdef const double[:, :] x = x_in
    cdef const double[:, :] step = step_in
    out_a = np.empty((n, k))
    done_a = np.empty(n, dtype=bool)
    bad_a = np.empty(n, dtype=bool)
    cdef double[:, ::1] out = out_a
    cdef char[::1] done = done_a.view(np.int8)
    cdef char[::1] bad = bad_a.view(np.int8)
    cdef double s, big
    cdef bint finite
    with nogil:
        for i in range(n):
            finite = True
            for j in range(k):
                if not isfinite(step[i, j]):
                    finite = False
            big = 0.0
            for j in range(k):
                s = step[i, j] if finite else 0.0
                out[i, j] = x[i, j] + s
                if fabs(s) > big:
                    big = fabs(s)
            bad[i] = not finite
            done[i] = finite and big < limit
    return out_a, done_a, bad_a
