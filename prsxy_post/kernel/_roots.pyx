# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The root search's step compiled: :mod:`prsxy_post.kernel.roots` root by root,
the same operations in the same order (see that module), so the two agree to the
bit. numpy's ``fmin`` and ``clip`` as numpy's. Compiled with -O2
-ffp-contract=off (no fused multiply-adds)."""

import numpy as np

from libc.math cimport fabs, isfinite


def _lengths(str what, Py_ssize_t n, **lengths):
    """Refuse arrays whose ``lengths`` (name: length) are not ``n`` before the
    loop runs without bounds checks: a ValueError naming what was expected and
    what was got."""
    for name, got in lengths.items():
        if got != n:
            raise ValueError(f"{name} must have {what} ({n} values, as the first), got {got}")


cdef inline double _fmin(double a, double b) noexcept nogil:
    # numpy's fmin: the other where one is NaN, else the less (the second on a tie)
    if a != a:
        return b
    if b != b:
        return a
    return a if a < b else b


cdef inline double _clip(double x, double lo, double hi) noexcept nogil:
    # numpy's clip with array bounds (x not NaN): x where greater than lo, else lo;
    # then that where less than hi, else hi (a tie of ±0.0 takes the bound)
    x = x if x > lo else lo
    return x if x < hi else hi


def _flags(a):
    return np.ascontiguousarray(a, dtype=np.uint8)


def seek_step(x, v, going, ok, moved, new, accel, h, s_a, v_a, s_b, v_b, last,
              double margin, double time_s):
    """One false-position step of the roots: :func:`roots.seek_step`."""
    cdef Py_ssize_t m = len(x), i, j = 0, q = len(v)
    _lengths("one value a root, as x", m, going=len(going), ok=len(ok), moved=len(moved),
             new=len(new), accel=len(accel), h=len(h), s_a=len(s_a), v_a=len(v_a),
             s_b=len(s_b), v_b=len(v_b), last=len(last))
    cdef const unsigned char[::1] gi = _flags(going)
    cdef Py_ssize_t asked = 0
    for i in range(m):
        asked += gi[i] != 0
    if asked != q:
        raise ValueError(f"v must have one value a root going ({asked}), got {q}")
    cdef const double[::1] vv = np.ascontiguousarray(v, dtype=float)
    cdef const double[::1] nw = np.ascontiguousarray(new, dtype=float)
    cdef const double[::1] ac = np.ascontiguousarray(accel, dtype=float)
    cdef const double[::1] hh = np.ascontiguousarray(h, dtype=float)
    out_x = np.array(x, dtype=float)
    out_sa, out_va = np.array(s_a, dtype=float), np.array(v_a, dtype=float)
    out_sb, out_vb = np.array(s_b, dtype=float), np.array(v_b, dtype=float)
    out_last = np.array(last, dtype=np.int_)
    out_go, out_ok, out_mv = np.array(_flags(going)), np.array(_flags(ok)), np.array(_flags(moved))
    cdef double[::1] X = out_x, SA = out_sa, VA = out_va, SB = out_sb, VB = out_vb
    cdef long[::1] L = out_last
    cdef unsigned char[::1] G = out_go, OK = out_ok, MV = out_mv
    cdef double vm, s_o, v_o, secant, slow, x_new
    cdef bint known, new_way, turned
    with nogil:
        for i in range(m):
            if not G[i]:
                continue
            vm = vv[j]
            j += 1
            known = isfinite(vm)
            if not known:
                # not known: the root leaves the search, and the bracket with it
                vm = 0.0
                OK[i] = 0
                G[i] = 0
                continue
            new_way = nw[i] * vm > 0
            if new_way:
                s_o, v_o = SA[i], VA[i]
            else:
                s_o, v_o = SB[i], VB[i]
            secant = fabs(vm - v_o) / (fabs(X[i] - s_o) * hh[i])
            slow = _fmin(fabs(ac[i]), secant)
            if fabs(vm) * margin <= slow * time_s:
                G[i] = 0
                continue
            MV[i] = 1
            turned = new_way
            if turned:
                if L[i] == 1:
                    VA[i] = 0.5 * VA[i]
                L[i] = 1
                SB[i], VB[i] = X[i], vm
            else:
                if L[i] == -1:
                    VB[i] = 0.5 * VB[i]
                L[i] = -1
                SA[i], VA[i] = X[i], vm
            x_new = SA[i] - VA[i] * (SB[i] - SA[i]) / (VB[i] - VA[i])
            if isfinite(x_new):
                X[i] = _clip(x_new, SA[i], SB[i])
    return (
        out_x, out_go.view(bool), out_ok.view(bool), out_mv.view(bool),
        out_sa, out_va, out_sb, out_vb, out_last,
    )
