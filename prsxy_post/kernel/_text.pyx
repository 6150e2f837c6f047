# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""Rows of text compiled: the twins of :mod:`prsxy_post.kernel.text`, the same bytes.

:func:`format_fixed_rows`: the same scaled integer (rint of |v| 10^d), Python's own
text near a rounding tie, Python's for the whole chunk when a value is too large,
written row by row into one buffer. :func:`pvt_segment_text`: those rows with the
line comments and PVT times before them, or other texts in their place, in one
buffer."""

import numpy as np

from libc.math cimport fabs, floor, rint, signbit
from libc.stdint cimport int64_t, uint32_t, uint64_t
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


cdef class _Scaled:
    """The columns' values, their scaled integers and prefixes, ready to write."""
    cdef object vals_a, k_a, dec_a, p10_a, at_a
    cdef double[:, :] vals
    cdef int64_t[:, :] ks
    cdef int64_t[:] dec
    cdef int64_t[:] p10s
    cdef Py_ssize_t[:] at
    cdef bytes allpre
    cdef Py_ssize_t row_max


cdef _Scaled _scale(columns, Py_ssize_t ncol, Py_ssize_t n):
    """The columns scaled (rint of |v| 10^d; Python's rounding near a tie), or None
    when a value is too large (or not finite): then Python writes them."""
    cdef _Scaled s = _Scaled()
    cdef Py_ssize_t c, i, j
    cdef double x, t, lim, scale
    cdef int64_t p10
    cdef int d
    s.vals_a = np.empty((ncol, n))
    s.k_a = np.empty((ncol, n), np.int64)
    s.dec_a = np.empty(ncol, np.int64)
    s.p10_a = np.empty(ncol, np.int64)
    s.at_a = np.zeros(ncol + 1, np.intp)
    s.vals = s.vals_a
    s.ks = s.k_a
    s.dec = s.dec_a
    s.p10s = s.p10_a
    s.at = s.at_a
    s.row_max = 0
    pres = []
    for c in range(ncol):
        prefix, values, d = columns[c]
        pre = prefix.encode("ascii").replace(b"\0", b"")
        pres.append(pre)
        s.at[c + 1] = s.at[c] + len(pre)
        s.vals_a[c] = values
        s.dec[c] = d
        p10 = 1
        for j in range(d):
            p10 *= 10
        s.p10s[c] = p10
        scale = 10.0**d
        lim = min(10.0**_pure._INT_DIGITS, 2.0**52 / scale)
        ties = []
        for i in range(n):
            x = s.vals[c, i]
            if not (fabs(x) < lim):
                return None
            t = fabs(x) * scale
            s.ks[c, i] = <int64_t> rint(t)
            if fabs(t - floor(t) - 0.5) < 1e-6:
                ties.append(i)
        for i in ties:
            # near a tie the binary value decides: Python's own rounding
            s.ks[c, i] = int(f"{abs(float(s.vals[c, i])):.{d}f}".replace(".", ""))
        s.row_max += len(pre) + 1 + 20 + 1 + d
    s.allpre = b"".join(pres)
    return s


cdef inline Py_ssize_t _uint(char* out, Py_ssize_t pos, uint64_t v) noexcept nogil:
    """The decimal digits of v at out[pos]; the position after them."""
    cdef char tmp[24]
    cdef int nd = 0
    while True:
        tmp[nd] = <char> (48 + v % 10)
        nd += 1
        v = v // 10
        if v == 0:
            break
    while nd > 0:
        nd -= 1
        out[pos] = tmp[nd]
        pos += 1
    return pos


cdef inline Py_ssize_t _row(
    char* out, Py_ssize_t pos, Py_ssize_t i, Py_ssize_t ncol, _Scaled s, const char* pb
) noexcept nogil:
    """Row i of the columns (prefix, value, ...) at out[pos], without its end."""
    cdef Py_ssize_t c, j
    cdef int64_t k, p10
    cdef uint32_t fpart
    cdef int d, q
    for c in range(ncol):
        for j in range(s.at[c], s.at[c + 1]):
            out[pos] = pb[j]
            pos += 1
        if signbit(s.vals[c, i]):
            out[pos] = 45  # '-'
            pos += 1
        k = s.ks[c, i]
        d = <int> s.dec[c]
        p10 = s.p10s[c]
        # both parts are below 10^9 (the bound on the values)
        pos = _uint(out, pos, <uint64_t> (k // p10))
        fpart = <uint32_t> (k - (k // p10) * p10)
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
    return pos


def format_fixed_rows(columns, str end="\n"):
    """Rows of text, ``prefix value prefix value ...`` (``text.format_fixed_rows``)."""
    cdef Py_ssize_t ncol = len(columns)
    if ncol == 0:
        return []
    cdef Py_ssize_t n = len(columns[0][1])
    if n == 0:
        return []
    cdef _Scaled s = _scale(columns, ncol, n)
    if s is None:
        # a value too large (or not finite): Python prints the whole chunk
        return _pure.format_fixed_rows(columns, end)
    cdef Py_ssize_t i, j, pos = 0
    cdef bytes endb = end.encode("ascii").replace(b"\0", b"")
    cdef Py_ssize_t ne = len(endb)
    # not zeroed: every byte up to pos is written below
    buf = PyBytes_FromStringAndSize(NULL, n * (s.row_max + ne) + 1)
    cdef char* out = PyBytes_AS_STRING(buf)
    cdef const char* pb = s.allpre
    cdef const char* eb = endb
    # one str a row straight from the buffer when each row is exactly one line (the
    # end is a newline, no prefix holds a line break); else Python's splitlines
    # over the whole text, as the reference does
    cdef bint one_line = end == "\n" and not any(ch in _BREAKS for ch in s.allpre.decode("ascii"))
    starts_a = np.empty(n + 1, np.intp)
    cdef Py_ssize_t[::1] starts = starts_a
    with nogil:
        for i in range(n):
            starts[i] = pos
            pos = _row(out, pos, i, ncol, s, pb)
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


cdef inline Py_ssize_t _text(char* out, Py_ssize_t pos, const char* t, Py_ssize_t n) noexcept nogil:
    memcpy(out + pos, t, n)
    return pos + n


cdef inline Py_ssize_t _signed(char* out, Py_ssize_t pos, int64_t v, uint64_t* a) noexcept:
    """A minus sign where v < 0; |v| into ``a`` (exact for INT64_MIN too)."""
    if v < 0:
        out[pos] = 45
        pos += 1
        a[0] = (<uint64_t> 0) - (<uint64_t> v)
    else:
        a[0] = <uint64_t> v
    return pos


cdef Py_ssize_t _pvt_time(char* out, Py_ssize_t pos, int64_t v) noexcept:
    """A PVT time of ``v`` quanta of 1/4096 ms, exactly: the whole milliseconds,
    then the twelve decimals of the fraction written to the last non-zero one, at
    least four, and a newline."""
    cdef uint64_t a, r
    cdef int nd, p
    pos = _signed(out, pos, v, &a)
    pos = _uint(out, pos, a >> 12)
    out[pos] = 46  # '.'
    pos += 1
    r = (a & 4095) * 244140625  # 1/4096 = 0.000244140625
    nd = 12
    while nd > 4 and r % 10 == 0:
        r = r // 10
        nd -= 1
    p = nd
    while p > 0:
        out[pos + p - 1] = <char> (48 + r % 10)
        r = r // 10
        p -= 1
    pos += nd
    out[pos] = 10
    return pos + 1


def pvt_segment_text(columns, line, new_line, quanta, new_time, other_rows, other_text):
    """A PVT program's points as one text (``text.pvt_segment_text``)."""
    cdef Py_ssize_t m = len(line)
    cdef Py_ssize_t ncol = len(columns)
    if m == 0 or ncol == 0:
        return _pure.pvt_segment_text(
            columns, line, new_line, quanta, new_time, other_rows, other_text
        )
    cdef _Scaled s = _scale(columns, ncol, m)
    if (
        s is None
        or b"\0" in b"".join(p[0].encode("ascii") for p in columns)
        or any(ch in _BREAKS for ch in s.allpre.decode("ascii"))
        or not all(t.isascii() for t in other_text)
    ):
        # values too large (Python writes them), prefixes the reference drops NUL
        # bytes of or splits rows at, texts beyond ASCII: the reference's text
        return _pure.pvt_segment_text(
            columns, line, new_line, quanta, new_time, other_rows, other_text
        )
    if (
        any(len(a) != m for a in (new_line, quanta, new_time))
        or any(len(col[1]) != m for col in columns)
        or len(other_rows) != len(other_text)
    ):
        raise ValueError("every column and row array must have a value a row, "
                         "and other_rows a text each")
    cdef const int64_t[::1] ln = np.ascontiguousarray(line, dtype=np.int64)
    cdef const int64_t[::1] qt = np.ascontiguousarray(quanta, dtype=np.int64)
    cdef const char[::1] nl = np.ascontiguousarray(new_line, dtype=bool).view(np.int8)
    cdef const char[::1] nt = np.ascontiguousarray(new_time, dtype=bool).view(np.int8)
    q_at = np.asarray(qt)[np.asarray(nt).astype(bool)]
    if not np.all((-_pure.PVT_MAX_QUANTA < q_at) & (q_at < _pure.PVT_MAX_QUANTA)):
        return _pure.pvt_segment_text(
            columns, line, new_line, quanta, new_time, other_rows, other_text
        )
    # the rows replaced: which text (index into `others`) or -1
    oth_a = np.full(m, -1, np.intp)
    oth_a[np.asarray(other_rows, dtype=np.intp)] = np.arange(len(other_rows))
    cdef const Py_ssize_t[::1] oth = oth_a
    others = [t.encode("ascii") for t in other_text]
    cdef Py_ssize_t extra = sum(len(t) for t in others)
    cdef list olist = others
    # per row at most: "; line " + sign + 20 digits + "\n", "PVT" + sign + 20 + "." +
    # 12 + "\n", the row and its newline
    cdef Py_ssize_t size = m * (s.row_max + 29 + 38 + 1) + extra + 1
    buf = PyBytes_FromStringAndSize(NULL, size)
    cdef char* out = PyBytes_AS_STRING(buf)
    cdef const char* pb = s.allpre
    cdef Py_ssize_t i, pos = 0
    cdef uint64_t a
    cdef bytes ot
    for i in range(m):
        if nl[i]:
            pos = _text(out, pos, "; line ", 7)
            pos = _signed(out, pos, ln[i], &a)
            pos = _uint(out, pos, a)
            out[pos] = 10
            pos += 1
        if nt[i]:
            pos = _text(out, pos, "PVT", 3)
            pos = _pvt_time(out, pos, qt[i])
        if oth[i] >= 0:
            ot = <bytes> olist[oth[i]]
            pos = _text(out, pos, ot, len(ot))
        else:
            pos = _row(out, pos, i, ncol, s, pb)
            out[pos] = 10
            pos += 1
    return PyUnicode_DecodeASCII(out, pos, NULL)
