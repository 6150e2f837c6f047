# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The forward kinematics' Newton iteration compiled: the twin of
:mod:`prsxy_post.kernel.fk`, operation for operation, each row's own (the Newton
steps of four rows side by side, ``LANES``; built with -ffp-contract=off: no fused
multiply-add), so the same bits."""

import numpy as np

from libc.math cimport M_PI, NAN, cos, fabs, isfinite, sin, sqrt

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


cdef struct Geo:
    double g[9]
    double u[9]
    double b[9]
    double L[3]


cdef Geo _geo(m) except *:
    """The FKArrays' (3, 3) and (3,) arrays copied into C (``ValueError`` on shapes)."""
    cdef Geo G
    cdef Py_ssize_t i, j
    g = np.asarray(m.g, dtype=float)
    u = np.asarray(m.u, dtype=float)
    b = np.asarray(m.b, dtype=float)
    L = np.asarray(m.L, dtype=float)
    if g.shape != (3, 3) or u.shape != (3, 3) or b.shape != (3, 3) or L.shape != (3,):
        raise ValueError("g, u and b must be (3, 3), L (3,)")
    for i in range(3):
        G.L[i] = L[i]
        for j in range(3):
            G.g[3 * i + j] = g[i, j]
            G.u[3 * i + j] = u[i, j]
            G.b[3 * i + j] = b[i, j]
    return G


cdef void _pose(
    const Geo* m, const double* off, const double* x, double* f, double* J, int js, double* Rout
) noexcept nogil:
    """f (6) at x (6), and J (6 × 6, row-major, entry e at J[e · js]) unless NULL
    (``fk._pose``, ``fk.fk_system``); R (9, row-major) into Rout unless NULL."""
    cdef double ca = cos(x[3]), sa = sin(x[3])
    cdef double cb = cos(x[4]), sb = sin(x[4])
    cdef double cg = cos(x[5]), sg = sin(x[5])
    cdef double R[9]
    cdef double r0, r1, r2, v0, v1, v2, w0, w1, w2, nw, e0, e1, e2, u0, u1, u2, c0, c1, c2
    cdef Py_ssize_t k
    R[0] = cb * cg + sb * sa * sg
    R[1] = sb * sa * cg - cb * sg
    R[2] = sb * ca
    R[3] = ca * sg
    R[4] = ca * cg
    R[5] = -sa
    R[6] = cb * sa * sg - sb * cg
    R[7] = sb * sg + cb * sa * cg
    R[8] = cb * ca
    if Rout != NULL:
        for k in range(9):
            Rout[k] = R[k]
    for k in range(3):
        r0 = R[0] * m.b[3 * k] + R[1] * m.b[3 * k + 1] + R[2] * m.b[3 * k + 2]
        r1 = R[3] * m.b[3 * k] + R[4] * m.b[3 * k + 1] + R[5] * m.b[3 * k + 2]
        r2 = R[6] * m.b[3 * k] + R[7] * m.b[3 * k + 1] + R[8] * m.b[3 * k + 2]
        u0 = m.u[3 * k]
        u1 = m.u[3 * k + 1]
        u2 = m.u[3 * k + 2]
        v0 = x[0] + r0 - m.g[3 * k]
        v1 = x[1] + r1 - m.g[3 * k + 1]
        v2 = x[2] + r2 - m.g[3 * k + 2]
        f[k] = v0 * u0 + v1 * u1 + v2 * u2
        w0 = v0 - off[3 * k]
        w1 = v1 - off[3 * k + 1]
        w2 = v2 - off[3 * k + 2]
        nw = sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        f[3 + k] = nw - m.L[k]
        if J == NULL:
            continue
        e0 = w0 / nw
        e1 = w1 / nw
        e2 = w2 / nw
        J[(6 * k) * js] = u0
        J[(6 * k + 1) * js] = u1
        J[(6 * k + 2) * js] = u2
        J[(6 * (3 + k)) * js] = e0
        J[(6 * (3 + k) + 1) * js] = e1
        J[(6 * (3 + k) + 2) * js] = e2
        c0 = r1 * u2 - r2 * u1
        c1 = r2 * u0 - r0 * u2
        c2 = r0 * u1 - r1 * u0
        J[(6 * k + 3) * js] = c0 * cb - c2 * sb
        J[(6 * k + 4) * js] = c1
        J[(6 * k + 5) * js] = c0 * R[2] + c1 * R[5] + c2 * R[8]
        c0 = r1 * e2 - r2 * e1
        c1 = r2 * e0 - r0 * e2
        c2 = r0 * e1 - r1 * e0
        J[(6 * (3 + k) + 3) * js] = c0 * cb - c2 * sb
        J[(6 * (3 + k) + 4) * js] = c1
        J[(6 * (3 + k) + 5) * js] = c0 * R[2] + c1 * R[5] + c2 * R[8]


cdef void _solve6(double* A, double* b, double* s) noexcept nogil:
    """s with A s = b (A 6 × 6 row-major and b overwritten): ``fk.solve6``."""
    cdef Py_ssize_t k, i, j, p
    cdef double big, a, t, lk
    for k in range(6):
        p = k
        big = fabs(A[6 * k + k])
        for i in range(k + 1, 6):
            a = fabs(A[6 * i + k])
            if a > big:  # never a NaN, nor over a NaN on the diagonal
                big = a
                p = i
        if p != k:
            for j in range(6):
                t = A[6 * k + j]
                A[6 * k + j] = A[6 * p + j]
                A[6 * p + j] = t
            t = b[k]
            b[k] = b[p]
            b[p] = t
        for i in range(k + 1, 6):
            lk = A[6 * i + k] / A[6 * k + k]
            for j in range(k + 1, 6):
                A[6 * i + j] = A[6 * i + j] - lk * A[6 * k + j]
            b[i] = b[i] - lk * b[k]
    for i in range(5, -1, -1):
        t = b[i]
        for j in range(i + 1, 6):
            t = t - A[6 * i + j] * s[j]
        s[i] = t / A[6 * i + i]


def _rows_of(off_in, x_in):
    cdef Py_ssize_t n = x_in.shape[0] if x_in.ndim == 2 else -1
    if x_in.shape != (n, 6) or off_in.shape != (n, 3, 3):
        raise ValueError("x must be (N, 6), off (N, 3, 3)")
    return n


def fk_residual(m, off_in, x_in):
    """The six FK equations (N, 6) (``fk.fk_residual``)."""
    cdef Geo G = _geo(m)
    cdef Py_ssize_t n = _rows_of(off_in, x_in), i, j
    cdef const double[:, :, :] off = off_in
    cdef const double[:, :] x = x_in
    f_a = np.empty((n, 6))
    cdef double[:, ::1] f = f_a
    cdef double o[9]
    cdef double xr[6]
    with nogil:
        for i in range(n):
            for j in range(9):
                o[j] = off[i, j // 3, j % 3]
            for j in range(6):
                xr[j] = x[i, j]
            _pose(&G, o, xr, &f[i, 0], NULL, 1, NULL)
    return f_a


def fk_system(m, off_in, x_in):
    """f (N, 6) and J (N, 6, 6) (``fk.fk_system``)."""
    cdef Geo G = _geo(m)
    cdef Py_ssize_t n = _rows_of(off_in, x_in), i, j
    cdef const double[:, :, :] off = off_in
    cdef const double[:, :] x = x_in
    f_a = np.empty((n, 6))
    J_a = np.empty((n, 6, 6))
    cdef double[:, ::1] f = f_a
    cdef double[:, :, ::1] J = J_a
    cdef double o[9]
    cdef double xr[6]
    with nogil:
        for i in range(n):
            for j in range(9):
                o[j] = off[i, j // 3, j % 3]
            for j in range(6):
                xr[j] = x[i, j]
            _pose(&G, o, xr, &f[i, 0], &J[i, 0, 0], 1, NULL)
    return f_a, J_a


def solve6(J_in, r_in):
    """s (N, 6) with J s = r (``fk.solve6``)."""
    cdef Py_ssize_t n = J_in.shape[0] if J_in.ndim == 3 else -1, i, j
    if J_in.shape != (n, 6, 6) or r_in.shape != (n, 6):
        raise ValueError("J must be (N, 6, 6), r (N, 6)")
    cdef const double[:, :, :] J = J_in
    cdef const double[:, :] r = r_in
    s_a = np.empty((n, 6))
    cdef double[:, ::1] s = s_a
    cdef double A[36]
    cdef double b[6]
    with nogil:
        for i in range(n):
            for j in range(36):
                A[j] = J[i, j // 6, j % 6]
            for j in range(6):
                b[j] = r[i, j]
            _solve6(A, b, &s[i, 0])
    return s_a


cdef enum:
    # rows solved side by side: a row's Newton step is a chain of dependent
    # operations (each elimination needs the one before, the back substitution a
    # division a row); a lane a row, the same operation on LANES rows at once, in
    # the same order for each as a row at a time (so the same bits), overlaps them
    LANES = 4
    # rows forward_poses solves at a time (its scratch rows: 24 doubles each)
    BLOCK = 512


cdef void _solve6_lanes(double A[6][6][LANES], double b[6][LANES], double s[6][LANES]) noexcept nogil:
    """``_solve6`` on LANES systems at once: A[i][j][lane], b[i][lane], s[i][lane].

    The pivot row is copied out before the rows below subtract it, so the compiler
    knows they do not overlap and runs the lanes' operations side by side (one
    vector instruction for two lanes: each lane's own IEEE operations, the same
    bits; -ffp-contract=off, so never fused)."""
    cdef Py_ssize_t k, i, j, p, l
    cdef double big, a, t
    cdef double lk[LANES]
    cdef double tt[LANES]
    cdef double bk[LANES]
    cdef double ak[6][LANES]
    for k in range(6):
        for l in range(LANES):
            p = k
            big = fabs(A[k][k][l])
            for i in range(k + 1, 6):
                a = fabs(A[i][k][l])
                if a > big:  # never a NaN, nor over a NaN on the diagonal
                    big = a
                    p = i
            if p != k:
                for j in range(6):
                    t = A[k][j][l]
                    A[k][j][l] = A[p][j][l]
                    A[p][j][l] = t
                t = b[k][l]
                b[k][l] = b[p][l]
                b[p][l] = t
        for j in range(6):
            for l in range(LANES):
                ak[j][l] = A[k][j][l]
        for l in range(LANES):
            bk[l] = b[k][l]
        for i in range(k + 1, 6):
            for l in range(LANES):
                lk[l] = A[i][k][l] / ak[k][l]
            for j in range(k + 1, 6):
                for l in range(LANES):
                    A[i][j][l] = A[i][j][l] - lk[l] * ak[j][l]
            for l in range(LANES):
                b[i][l] = b[i][l] - lk[l] * bk[l]
    for i in range(5, -1, -1):
        for l in range(LANES):
            tt[l] = b[i][l]
        for j in range(i + 1, 6):
            for l in range(LANES):
                tt[l] = tt[l] - A[i][j][l] * s[j][l]
        for l in range(LANES):
            s[i][l] = tt[l] / A[i][i][l]


cdef void _pose_lanes(
    const Geo* m, double os[9][LANES], double xs[6][LANES], double A[6][6][LANES],
    double b[6][LANES]
) noexcept nogil:
    """``_pose`` of LANES rows at once (offsets os[j][lane], x xs[j][lane]): −f into
    b[i][lane], J into A[i][j][lane]; each lane's operations those of ``_pose``."""
    cdef double ca[LANES]
    cdef double sa[LANES]
    cdef double cb[LANES]
    cdef double sb[LANES]
    cdef double cg[LANES]
    cdef double sg[LANES]
    cdef double R[9][LANES]
    cdef double r0[LANES]
    cdef double r1[LANES]
    cdef double r2[LANES]
    cdef double w0[LANES]
    cdef double w1[LANES]
    cdef double w2[LANES]
    cdef double nw[LANES]
    cdef double v0, v1, v2, e0, e1, e2, c0, c1, c2
    cdef double b0, b1, b2, g0, g1, g2, u0, u1, u2, Lk
    cdef Py_ssize_t k, l
    for l in range(LANES):
        ca[l] = cos(xs[3][l])
        sa[l] = sin(xs[3][l])
        cb[l] = cos(xs[4][l])
        sb[l] = sin(xs[4][l])
        cg[l] = cos(xs[5][l])
        sg[l] = sin(xs[5][l])
    for l in range(LANES):
        R[0][l] = cb[l] * cg[l] + sb[l] * sa[l] * sg[l]
        R[1][l] = sb[l] * sa[l] * cg[l] - cb[l] * sg[l]
        R[2][l] = sb[l] * ca[l]
        R[3][l] = ca[l] * sg[l]
        R[4][l] = ca[l] * cg[l]
        R[5][l] = -sa[l]
        R[6][l] = cb[l] * sa[l] * sg[l] - sb[l] * cg[l]
        R[7][l] = sb[l] * sg[l] + cb[l] * sa[l] * cg[l]
        R[8][l] = cb[l] * ca[l]
    for k in range(3):
        b0 = m.b[3 * k]
        b1 = m.b[3 * k + 1]
        b2 = m.b[3 * k + 2]
        g0 = m.g[3 * k]
        g1 = m.g[3 * k + 1]
        g2 = m.g[3 * k + 2]
        u0 = m.u[3 * k]
        u1 = m.u[3 * k + 1]
        u2 = m.u[3 * k + 2]
        Lk = m.L[k]
        for l in range(LANES):
            r0[l] = R[0][l] * b0 + R[1][l] * b1 + R[2][l] * b2
            r1[l] = R[3][l] * b0 + R[4][l] * b1 + R[5][l] * b2
            r2[l] = R[6][l] * b0 + R[7][l] * b1 + R[8][l] * b2
            v0 = xs[0][l] + r0[l] - g0
            v1 = xs[1][l] + r1[l] - g1
            v2 = xs[2][l] + r2[l] - g2
            b[k][l] = -(v0 * u0 + v1 * u1 + v2 * u2)
            w0[l] = v0 - os[3 * k][l]
            w1[l] = v1 - os[3 * k + 1][l]
            w2[l] = v2 - os[3 * k + 2][l]
            nw[l] = w0[l] * w0[l] + w1[l] * w1[l] + w2[l] * w2[l]
        for l in range(LANES):
            nw[l] = sqrt(nw[l])
        for l in range(LANES):
            b[3 + k][l] = -(nw[l] - Lk)
            e0 = w0[l] / nw[l]
            e1 = w1[l] / nw[l]
            e2 = w2[l] / nw[l]
            A[k][0][l] = u0
            A[k][1][l] = u1
            A[k][2][l] = u2
            A[3 + k][0][l] = e0
            A[3 + k][1][l] = e1
            A[3 + k][2][l] = e2
            c0 = r1[l] * u2 - r2[l] * u1
            c1 = r2[l] * u0 - r0[l] * u2
            c2 = r0[l] * u1 - r1[l] * u0
            A[k][3][l] = c0 * cb[l] - c2 * sb[l]
            A[k][4][l] = c1
            A[k][5][l] = c0 * R[2][l] + c1 * R[5][l] + c2 * R[8][l]
            c0 = r1[l] * e2 - r2[l] * e1
            c1 = r2[l] * e0 - r0[l] * e2
            c2 = r0[l] * e1 - r1[l] * e0
            A[3 + k][3][l] = c0 * cb[l] - c2 * sb[l]
            A[3 + k][4][l] = c1
            A[3 + k][5][l] = c0 * R[2][l] + c1 * R[5][l] + c2 * R[8][l]


cdef inline bint _step(double* xr, const double* s, double limit, bint* conv) noexcept nogil:
    """x += s unless s is not finite; True when this row stops (``fk.forward_newton``)."""
    cdef bint finite = True, done = True
    cdef Py_ssize_t j
    for j in range(6):
        if not isfinite(s[j]):
            finite = False
        if not fabs(s[j]) < limit:
            done = False
    if not finite:
        for j in range(6):
            xr[j] = xr[j] + 0.0  # as the reference's step of 0.0 (-0.0 becomes 0.0)
        return True  # not converged
    for j in range(6):
        xr[j] = xr[j] + s[j]
    if done:
        conv[0] = True
    return done


cdef void _newton_rows(
    const Geo* G, const double* offs, const double[:, :] x0, double limit, int max_iter,
    double res_tol, double[:, ::1] x, char[::1] ok, double* Rs
) noexcept nogil:
    """``fk.forward_newton`` of the rows of x0 (N, 6), the hinges' offsets ``offs``
    (N × 9, a row's legs one after the other), LANES rows side by side; x (N, 6),
    ok (N,) out, and R at each solution (N × 9) into Rs unless NULL."""
    cdef Py_ssize_t n = x0.shape[0], i = 0, j, r
    cdef Py_ssize_t it, l, nl
    cdef double o[LANES][9]
    cdef double os[9][LANES]
    cdef double xr[LANES][6]
    cdef double xs[6][LANES]
    cdef double f[6]
    cdef double A[6][6][LANES]
    cdef double b[6][LANES]
    cdef double s[6][LANES]
    cdef double sr[6]
    cdef bint live[LANES]
    cdef bint conv[LANES]
    cdef bint more
    while i < n:
        nl = <int>min(<Py_ssize_t>LANES, n - i)
        for l in range(nl):
            r = i + l
            for j in range(9):
                o[l][j] = offs[9 * r + j]
            for j in range(6):
                xr[l][j] = x0[r, j]
            live[l] = True
            conv[l] = False
        for l in range(nl, LANES):
            live[l] = False
            for j in range(9):
                o[l][j] = 0.0
            for j in range(6):
                xr[l][j] = 0.0
        for j in range(9):
            for l in range(LANES):
                os[j][l] = o[l][j]
        for it in range(max_iter):
            for j in range(6):
                for l in range(LANES):
                    xs[j][l] = xr[l][j]
            _pose_lanes(G, os, xs, A, b)
            for l in range(LANES):
                if not live[l]:  # no row, or stopped: the identity (no NaN, no denormals)
                    for j in range(36):
                        A[j // 6][j % 6][l] = 1.0 if j % 7 == 0 else 0.0
                    for j in range(6):
                        b[j][l] = 0.0
            _solve6_lanes(A, b, s)
            more = False
            for l in range(nl):
                if live[l]:
                    for j in range(6):
                        sr[j] = s[j][l]
                    live[l] = not _step(xr[l], sr, limit, &conv[l])
                    more = more or live[l]
            if not more:
                break
        for l in range(nl):
            r = i + l
            _pose(G, o[l], xr[l], f, NULL, 1, &Rs[9 * r] if Rs != NULL else NULL)
            for j in range(6):
                if not fabs(f[j]) < res_tol:
                    conv[l] = False
                x[r, j] = xr[l][j]
            ok[r] = conv[l]
        i += nl


def forward_newton(m, off_in, x0_in, double limit, int max_iter, double res_tol):
    """x (N, 6), converged (N,): Newton on the six FK equations (``fk.forward_newton``)."""
    cdef Geo G = _geo(m)
    cdef Py_ssize_t n = _rows_of(off_in, x0_in)
    cdef const double[:, :, :] off = off_in
    cdef const double[:, :, ::1] offs = np.ascontiguousarray(off_in)
    cdef const double[:, :] x0 = x0_in
    x_a = np.empty((n, 6))
    ok_a = np.zeros(n, dtype=bool)
    cdef double[:, ::1] x = x_a
    cdef char[::1] ok = ok_a.view(np.int8)
    if n:
        with nogil:
            _newton_rows(&G, &offs[0, 0, 0], x0, limit, max_iter, res_tol, x, ok, NULL)
    return x_a, ok_a


cdef inline void _tip(
    const double* xr, const double* R, const double* t, const double* o, const double* D,
    double* q
) noexcept nogil:
    """q (5) of a solution xr (6) with its R (9) (``fk.tool_poses``): R t summed as
    numpy's einsum sums it, then − o + D; A and B in degrees (numpy's degrees)."""
    cdef Py_ssize_t k
    for k in range(3):
        q[k] = (
            xr[k]
            + (0.0 + (((0.0 + R[3 * k] * t[0]) + R[3 * k + 2] * t[2]) + (0.0 + R[3 * k + 1] * t[1])))
            - o[k]
            + D[k]
        )
    q[3] = xr[3] * (180.0 / M_PI)
    q[4] = xr[4] * (180.0 / M_PI)


def tool_poses(x_in, ok_in, t_in, origin_in, D_in):
    """q (N, 5): tool poses of FK solutions (``fk.tool_poses``)."""
    cdef Py_ssize_t n = x_in.shape[0] if x_in.ndim == 2 else -1, i, k
    if (
        x_in.shape != (n, 6)
        or ok_in.shape != (n,)
        or t_in.shape != (n, 3)
        or origin_in.shape != (3,)
        or D_in.shape != (n, 3)
    ):
        raise ValueError("x must be (N, 6), ok (N,), t (N, 3), origin (3,), D (N, 3)")
    cdef const double[:, ::1] x = np.ascontiguousarray(x_in)
    cdef const char[:] ok = np.asarray(ok_in, dtype=bool).view(np.int8)
    cdef const double[:, ::1] t = np.ascontiguousarray(t_in)
    cdef const double[::1] o = np.ascontiguousarray(origin_in)
    cdef const double[:, ::1] D = np.ascontiguousarray(D_in)
    q_a = np.empty((n, 5))
    cdef double[:, ::1] q = q_a
    cdef double ca, sa, cb, sb, cg, sg
    cdef double R[9]
    with nogil:
        for i in range(n):
            if not ok[i]:
                for k in range(5):
                    q[i, k] = NAN
                continue
            ca = cos(x[i, 3])
            sa = sin(x[i, 3])
            cb = cos(x[i, 4])
            sb = sin(x[i, 4])
            cg = cos(x[i, 5])
            sg = sin(x[i, 5])
            R[0] = cb * cg + sb * sa * sg
            R[1] = sb * sa * cg - cb * sg
            R[2] = sb * ca
            R[3] = ca * sg
            R[4] = ca * cg
            R[5] = -sa
            R[6] = cb * sa * sg - sb * cg
            R[7] = sb * sg + cb * sa * cg
            R[8] = cb * ca
            _tip(&x[i, 0], R, &t[i, 0], &o[0], &D[i, 0], &q[i, 0])
    return q_a


def _check_poses(x0_in, P_in, d_in, t_in, origin_in, D_in):
    cdef Py_ssize_t n = x0_in.shape[0] if x0_in.ndim == 2 else -1
    if (
        x0_in.shape != (n, 6)
        or P_in.ndim != 2
        or P_in.shape[0] != n
        or P_in.shape[1] < 3
        or d_in.shape != (3, 3)
        or t_in.shape != (n, 3)
        or origin_in.shape != (3,)
        or D_in.shape != (n, 3)
    ):
        raise ValueError(
            "x0 must be (N, 6), P (N, >= 3), d (3, 3), t (N, 3), origin (3,), D (N, 3)"
        )
    return n


def forward_poses(m, d_in, P_in, x0_in, t_in, origin_in, D_in, double limit, int max_iter,
                  double res_tol):
    """q (N, 5), converged (N,): the FK of motor positions whose guides are straight
    (``fk.forward_poses``): Newton and the tool poses in one pass, R taken from the
    residual check's pose."""
    q, ok, _ = _poses(m, d_in, P_in, x0_in, t_in, origin_in, D_in, limit, max_iter, res_tol,
                      0, 0, np.zeros(6))
    return q, ok


def forward_poses_anchored(m, d_in, P_in, x0_in, t_in, origin_in, D_in, double limit,
                           int max_iter, double res_tol, Py_ssize_t every, Py_ssize_t phase,
                           carry_in):
    """q (N, 5), converged (N,), carry (6,): ``forward_poses`` from the anchored
    starts (``fk.forward_poses_anchored``, ``fk.anchored_starts``)."""
    if every < 1:
        raise ValueError(f"every must be >= 1, not {every}")
    if np.shape(carry_in) != (6,):
        raise ValueError("carry must be (6,)")
    return _poses(m, d_in, P_in, x0_in, t_in, origin_in, D_in, limit, max_iter, res_tol,
                  every, phase, np.array(carry_in, dtype=float))


cdef inline void _near(double* dl, const double* reach, bint ok) noexcept nogil:
    """dl (6) set to 0.0 unless ok and every |dl_j| <= reach_j (``fk.anchored_starts``;
    a NaN is not near)."""
    cdef Py_ssize_t j
    for j in range(6):
        if not fabs(dl[j]) <= reach[j]:
            ok = False
    if not ok:
        for j in range(6):
            dl[j] = 0.0


cdef Py_ssize_t _starts(
    const Geo* G, const double* offs, const double[:, :] x0, Py_ssize_t every, Py_ssize_t phase,
    double limit, int max_iter, double res_tol, double* carry, const double* reach,
    double[:, ::1] aoffs, double[:, ::1] ax0, double[:, ::1] ax, char[::1] aok,
    double[:, ::1] st
) noexcept nogil:
    """``fk.anchored_starts`` of the rows of x0 (n, 6) (offsets ``offs``, n × 9) into
    st; the anchors' rows in the scratch rows aoffs, ax0, ax, aok; carry (6) in and
    out; ``reach`` (6) ``fk.ANCHOR_REACH``. Returns how many anchors there were."""
    cdef Py_ssize_t n = x0.shape[0], first = (every - phase % every) % every
    cdef Py_ssize_t na = 0, r, j, k
    cdef double dl[6]
    r = first
    while r < n:
        for j in range(9):
            aoffs[na, j] = offs[9 * r + j]
        for j in range(6):
            ax0[na, j] = x0[r, j]
        na += 1
        r += every
    if na:
        _newton_rows(G, &aoffs[0, 0], ax0[:na], limit, max_iter, res_tol, ax, aok[:na], NULL)
    for j in range(6):
        dl[j] = carry[j]
    _near(dl, reach, True)
    k = -1
    for r in range(n):
        if r >= first and (r - first) % every == 0:
            k += 1
            for j in range(6):
                dl[j] = ax[k, j] - ax0[k, j]
            _near(dl, reach, aok[k])
        for j in range(6):
            st[r, j] = x0[r, j] + dl[j]
    for j in range(6):
        carry[j] = dl[j]
    return na


def _poses(m, d_in, P_in, x0_in, t_in, origin_in, D_in, double limit, int max_iter,
           double res_tol, Py_ssize_t every, Py_ssize_t phase, carry_in):
    """The FK of ``forward_poses``, from the anchored starts where every >= 1."""
    cdef Geo G = _geo(m)
    cdef Py_ssize_t n = _check_poses(x0_in, P_in, d_in, t_in, origin_in, D_in), i, j, k
    cdef const double[:, :] P = P_in
    cdef const double[:, :] dv = d_in
    cdef const double[:, :] x0 = x0_in
    cdef const double[:, ::1] t = np.ascontiguousarray(t_in)
    cdef const double[::1] o = np.ascontiguousarray(origin_in)
    cdef const double[:, ::1] D = np.ascontiguousarray(D_in)
    cdef double[::1] carry = carry_in
    # the offsets, solutions and rotations of BLOCK rows at a time, in buffers made
    # once a call: a chunk's worth of each would be fresh pages (faulted in and
    # zeroed by the kernel) for values read once
    cdef Py_ssize_t nb = min(n, <Py_ssize_t>BLOCK), b0, m_b
    cdef Py_ssize_t na = nb // every + 1 if every >= 1 else 1
    offs_a = np.empty((nb, 9))
    x_a = np.empty((nb, 6))
    R_a = np.empty((nb, 9))
    st_a = np.empty((nb if every >= 1 else 0, 6))
    aoffs_a = np.empty((na, 9))
    ax0_a = np.empty((na, 6))
    ax_a = np.empty((na, 6))
    aok_a = np.zeros(na, dtype=np.int8)
    ok_a = np.zeros(n, dtype=bool)
    q_a = np.empty((n, 5))
    cdef double[:, ::1] offs = offs_a
    cdef double[:, ::1] x = x_a
    cdef double[:, ::1] R = R_a
    cdef double[:, ::1] st = st_a
    cdef double[:, ::1] aoffs = aoffs_a
    cdef double[:, ::1] ax0 = ax0_a
    cdef double[:, ::1] ax = ax_a
    cdef char[::1] aok = aok_a
    cdef char[::1] ok = ok_a.view(np.int8)
    cdef double[:, ::1] q = q_a
    cdef double dd[9]
    cdef double reach[6]
    for j in range(9):
        dd[j] = dv[j // 3, j % 3]
    for j in range(6):
        reach[j] = _pure.ANCHOR_REACH[j]
    if every >= 1:  # a carry beyond the reach is not handed on, rows or not
        _near(&carry[0], reach, True)
    if n == 0:
        return q_a, ok_a, carry_in
    with nogil:
        b0 = 0
        while b0 < n:
            m_b = min(nb, n - b0)
            # the hinges' offsets a_k − g_k = P_k d_k (``Geometry.hinge_offset``)
            for i in range(m_b):
                for k in range(3):
                    for j in range(3):
                        offs[i, 3 * k + j] = P[b0 + i, k] * dd[3 * k + j]
            if every >= 1:
                _starts(&G, &offs[0, 0], x0[b0 : b0 + m_b], every, (phase + b0) % every, limit,
                        max_iter, res_tol, &carry[0], reach, aoffs, ax0, ax, aok, st)
                _newton_rows(&G, &offs[0, 0], st[:m_b], limit, max_iter, res_tol, x,
                             ok[b0 : b0 + m_b], &R[0, 0])
            else:
                _newton_rows(&G, &offs[0, 0], x0[b0 : b0 + m_b], limit, max_iter, res_tol, x,
                             ok[b0 : b0 + m_b], &R[0, 0])
            for i in range(m_b):
                if not ok[b0 + i]:
                    for k in range(5):
                        q[b0 + i, k] = NAN
                    continue
                _tip(&x[i, 0], &R[i, 0], &t[b0 + i, 0], &o[0], &D[b0 + i, 0], &q[b0 + i, 0])
            b0 += m_b
    return q_a, ok_a, carry_in
