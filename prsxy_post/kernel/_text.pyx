# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""Rows of fixed-point text compiled: the twin of
:func:`prsxy_post.kernel.text.format_fixed_rows`, the same bytes (the same scaled
integer, rint of |v| 10^d; Python's own text near a rounding tie; Python's for the
whole chunk when a value is too large), written row by row into one buffer."""

import numpy as np

from libc.math cimport fabs, floor, rint, signbit
from libc.stdint cimport int64_t, uint32_t
from cpython.list cimport PyList_New, PyList_SET_ITEM
from cpython.ref cimport Py_INCREF
from cpython.bytes cimport PyBytes_AS_STRING, PyBytes_FromStringAndSize
from cpython.unicode cimport PyUnicode_DecodeASCII
from libc.string cimport memcpy

cdef extern from "Python.h":
    # a new str of n ASCII characters (max char 127) and its bytes, to fill
    object PyUnicode_New(Py_ssize_t n, Py_UCS4 maxchar)
    void* PyUnicode_DATA(object o)

#: the characters str.splitlines breaks at
_BREAKS = "\n\r\x0b\x0c\x1c\x1d\x1e\x85\u2028\u2029"

cdef char _PAIRS[201]
for _i in range(100):
    _PAIRS[2 * _i] = 48 + _i // 10
    _PAIRS[2 * _i + 1] = 48 + _i % 10

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
    cdef char tmp[24]
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
    cdef bytes endb = end.encode("ascii").replace(b"\0", b"")
    cdef Py_ssize_t ne = len(endb)
    row_max += ne
    # not zeroed: every byte up to pos is written below
    buf = PyBytes_FromStringAndSize(NULL, n * row_max + 1)
    cdef char* out = PyBytes_AS_STRING(buf)
    cdef const char* pb = allpre
    cdef const char* eb = endb
    # one str a row straight from the buffer when each row is exactly one line (the
    # end is a newline, no prefix holds a line break); else Python's splitlines
    # over the whole text, as the reference does
    cdef bint one_line = end == "\n" and not any(ch in _BREAKS for ch in allpre.decode("ascii"))
    starts_a = np.empty(n + 1, np.intp)
    cdef Py_ssize_t[::1] starts = starts_a
    cdef uint32_t ipart, fpart
    cdef int q
    with nogil:
        for i in range(n):
            starts[i] = pos
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
                # both parts are below 10^9 (the bound on the values): 32 bits
                ipart = <uint32_t> (k // p10)
                fpart = <uint32_t> (k - (k // p10) * p10)
                nd = 0
                while True:
                    tmp[nd] = <char> (48 + ipart % 10)
                    nd += 1
                    ipart = ipart // 10
                    if ipart == 0:
                        break
                while nd > 0:
                    nd -= 1
                    out[pos] = tmp[nd]
                    pos += 1
                if d:
                    out[pos] = 46  # '.'
                    pos += 1
                    q = d - 1
                    while q >= 1:
                        out[pos + q - 1] = _PAIRS[2 * (fpart % 100)]
                        out[pos + q] = _PAIRS[2 * (fpart % 100) + 1]
                        fpart = fpart // 100
                        q -= 2
                    if q == 0:
                        out[pos] = <char> (48 + fpart % 10)
                    pos += d
            for j in range(ne):
                out[pos] = eb[j]
                pos += 1
        starts[n] = pos
    if not one_line:
        return PyUnicode_DecodeASCII(out, pos, NULL).splitlines(keepends=True)
    rows = PyList_New(n)
    for i in range(n):
        # the bytes are ASCII (digits, '-', '.', and prefixes encoded as ASCII)
        row = PyUnicode_New(starts[i + 1] - starts[i], 127)
        memcpy(PyUnicode_DATA(row), out + starts[i], starts[i + 1] - starts[i])
        Py_INCREF(row)
        PyList_SET_ITEM(rows, i, row)
    return rows
