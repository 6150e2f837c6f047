# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""Poses on lines and arcs compiled: :func:`prsxy_post.kernel.path.poses` point by
point, the same operations in the same order (see that module), so the two agree to
the bit. cos and sin are the C library's, as the reference's (kernel/libm.py).
Compiled with -O2 -ffp-contract=off (no fused multiply-adds)."""

import numpy as np

from libc.math cimport cos, sin


def poses(p, k, s):
    """The compiled twin of ``path.poses``: (q, dq) (N, 5) each."""
    cdef const double[:, :] start = p.start, end = p.end, center = p.center
    cdef const double[:] length = p.length, theta0 = p.theta0, sweep = p.sweep
    cdef const double[:] r0 = p.r0, r1 = p.r1
    cdef const unsigned char[:] arc = np.ascontiguousarray(p.arc, dtype=np.uint8)
    cdef const Py_ssize_t[:] iu = np.ascontiguousarray(p.iu, dtype=np.intp)
    cdef const Py_ssize_t[:] iv = np.ascontiguousarray(p.iv, dtype=np.intp)
    cdef const Py_ssize_t[:] kk = np.ascontiguousarray(k, dtype=np.intp)
    cdef const double[:] ss = np.ascontiguousarray(s, dtype=float)
    cdef Py_ssize_t n = kk.shape[0], nb = length.shape[0], i, j, c, u, v
    if ss.shape[0] != n:
        raise ValueError("k and s must have one row per point")
    if start.shape[1] != 5 or end.shape[1] != 5 or center.shape[1] != 3:
        raise ValueError("start and end must be (n, 5), center (n, 3)")
    for i in range(n):
        if not 0 <= kk[i] < nb:
            raise IndexError(f"block {kk[i]} is out of range for {nb} blocks")
    for j in range(nb):
        if arc[j] and not (0 <= iu[j] < 3 and 0 <= iv[j] < 3):
            raise ValueError(f"arc {j}: its plane's axes must be among the first three")
    q_out = np.empty((n, 5))
    dq_out = np.empty((n, 5))
    cdef double[:, :] q = q_out, dq = dq_out
    cdef double L, x, frac, d, th, dr, r, co, sn, sw
    with nogil:
        for i in range(n):
            j = kk[i]
            L = length[j]
            if L > 0:
                x = ss[i] / L
                # numpy's clip of a float: NaN stays, else max then min
                if x == x:
                    x = x if x > 0.0 else 0.0
                    x = x if x < 1.0 else 1.0
                frac = x
            else:
                frac = 1.0
            for c in range(5):
                d = end[j, c] - start[j, c]
                dq[i, c] = d / L if L > 0 else 0.0
                q[i, c] = start[j, c] + d * frac
            if arc[j]:
                sw = sweep[j]
                th = theta0[j] + sw * frac
                dr = r1[j] - r0[j]
                r = r0[j] + dr * frac
                co = cos(th)
                sn = sin(th)
                u = iu[j]
                v = iv[j]
                q[i, u] = center[j, u] + r * co
                q[i, v] = center[j, v] + r * sn
                dq[i, u] = (dr * co - r * sw * sn) / L
                dq[i, v] = (dr * sn + r * sw * co) / L
                if frac >= 1.0:
                    for c in range(5):
                        q[i, c] = end[j, c]
    return q_out, dq_out


def velocities(v_in, dq_in, blk_in, corner_in, dq_out_in, dq_next_in):
    """The compiled twin of ``path.velocities``: (N, 5)."""
    cdef const double[:] v = np.ascontiguousarray(v_in, dtype=float)
    cdef const double[:, :] dq = dq_in, dq_out = dq_out_in, dq_next = dq_next_in
    cdef const Py_ssize_t[:] blk = np.ascontiguousarray(blk_in, dtype=np.intp)
    cdef const unsigned char[:] corner = np.ascontiguousarray(corner_in, dtype=np.uint8)
    cdef Py_ssize_t n = v.shape[0], nb = dq_out.shape[0], i, c, k
    if dq_in.shape != (n, 5) or blk.shape[0] != n or corner.shape[0] != n:
        raise ValueError("v, dq, blk and corner must have one row per point, dq five columns")
    if dq_out_in.shape != (nb, 5) or dq_next_in.shape != (nb, 5):
        raise ValueError("dq_out and dq_next must be (n, 5) for n blocks")
    for i in range(n):
        if corner[i] and not 0 <= blk[i] < nb:
            raise IndexError(f"block {blk[i]} is out of range for {nb} blocks")
    out = np.empty((n, 5))
    cdef double[:, :] q = out
    cdef double h
    with nogil:
        for i in range(n):
            if corner[i]:
                k = blk[i]
                h = 0.5 * v[i]
                for c in range(5):
                    q[i, c] = h * (dq_out[k, c] + dq_next[k, c])
            else:
                for c in range(5):
                    q[i, c] = v[i] * dq[i, c]
    return out
