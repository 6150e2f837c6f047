# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""Rows of fixed-point text compiled: the twin of
:func:`prsxy_post.kernel.text.format_fixed_rows`, the same bytes (the same scaled
integer, rint of |v| 10^d; Python's own text near a rounding tie; Python's for the
whole chunk when a value is too large), written row by row into one buffer."""

import numpy as np

from libc.math cimport fabs, floor, rint, signbit
from libc.stdint cimport int64_t

from . import text as _pure


def format_fixed_rows(columns, str end="\n"):
    """Rows of text, ``prefix value prefix value ...`` (``text.format_fixed_rows``)."""
    cdef Py_ssize_t ncol = len(columns)
    if ncol == 0:
        return []
    cdef Py_ssize_t n = len(columns[0][1])
    if n == 0:
        return []
    cdef Py_ssize_t c, i, j, pos = 0, row_max = 0
    cdef double x, t, lim, scale
    cdef int64_t k, ip, fp, p10
    cdef int d, nd
    vals_a = np.empty((ncol, n))
    k_a = np.empty((ncol, n), np.int64)
    dec_a = np.empty(ncol, np.int64)
    p10_a = np.empty(ncol, np.int64)
    pre_at = np.zeros(ncol + 1, np.intp)
    cdef double[:, :] vals = vals_a
    cdef int64_t[:, :] ks = k_a
    cdef int64_t[:] dec = dec_a
    cdef int64_t[:] p10s = p10_a
    cdef Py_ssize_t[:] at = pre_at
    pres = []
    for c in range(ncol):
        prefix, values, d = columns[c]
        pre = prefix.encode("ascii").replace(b"\0", b"")
        pres.append(pre)
        at[c + 1] = at[c] + len(pre)
        vals_a[c] = values
        dec[c] = d
        p10 = 1
        for j in range(d):
            p10 *= 10
        p10s[c] = p10
        scale = 10.0**d
        lim = min(10.0**_pure._INT_DIGITS, 2.0**52 / scale)
        ties = []
        for i in range(n):
            x = vals[c, i]
            if not (fabs(x) < lim):
                # a value too large (or not finite): Python prints the whole chunk
                return _pure.format_fixed_rows(columns, end)
            t = fabs(x) * scale
            ks[c, i] = <int64_t> rint(t)
            if fabs(t - floor(t) - 0.5) < 1e-6:
                ties.append(i)
        for i in ties:
            # near a tie the binary value decides: Python's own rounding
            ks[c, i] = int(f"{abs(float(vals[c, i])):.{d}f}".replace(".", ""))
        row_max += len(pre) + 1 + 20 + 1 + d
    cdef bytes allpre = b"".join(pres)
    cdef const unsigned char[:] pb = allpre if allpre else b"\0"
    cdef bytes endb = end.encode("ascii").replace(b"\0", b"")
    cdef const unsigned char[:] eb = endb if endb else b"\0"
    cdef Py_ssize_t ne = len(endb)
    row_max += ne
    buf = bytearray(n * row_max)
    cdef unsigned char[:] out = buf
    cdef unsigned char tmp[24]
    with nogil:
        for i in range(n):
            for c in range(ncol):
                for j in range(at[c], at[c + 1]):
                    out[pos] = pb[j]
                    pos += 1
                if signbit(vals[c, i]):
                    out[pos] = 45  # '-'
                    pos += 1
                k = ks[c, i]
                d = <int> dec[c]
                p10 = p10s[c]
                ip = k // p10
                fp = k - ip * p10
                nd = 0
                while True:
                    tmp[nd] = <unsigned char> (48 + ip % 10)
                    nd += 1
                    ip = ip // 10
                    if ip == 0:
                        break
                while nd > 0:
                    nd -= 1
                    out[pos] = tmp[nd]
                    pos += 1
                if d:
                    out[pos] = 46  # '.'
                    pos += 1
                    for j in range(d - 1, -1, -1):
                        out[pos + j] = <unsigned char> (48 + fp % 10)
                        fp = fp // 10
                    pos += d
            for j in range(ne):
                out[pos] = eb[j]
                pos += 1
    return bytes(buf[:pos]).decode("ascii").splitlines(keepends=True)
