# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""Rows of text compiled: the twins of :mod:`prsxy_post.kernel.text`, the same bytes.

Each value in one pass, read in place from the caller's array: the scaled integer
(rint of |v| 10^d, as the reference), Python's own text near a rounding tie, its
digits two at a time. A value too large (or not finite) stops the pass: then the
reference writes the whole chunk, as it does. :func:`format_fixed_rows` writes the
rows into one buffer and makes a str a row; :func:`pvt_segment_text` writes the
rows with the line comments and PVT times before them (or other texts in their
place) straight into the str it returns."""

import numpy as np

from libc.math cimport fabs, rint, signbit
from libc.stdint cimport int64_t, uint16_t, uint32_t, uint64_t
from cpython.list cimport PyList_New, PyList_SET_ITEM
from cpython.mem cimport PyMem_Free, PyMem_Malloc
from cpython.ref cimport Py_INCREF
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



cdef struct Col:
    # the column's values, read in place: the first one and the step in bytes
    const char* data
    Py_ssize_t step
    # its prefix (NUL bytes dropped, as the reference drops them)
    const char* pre
    Py_ssize_t npre
    # the prefix padded to 8 bytes, copied as one word when it fits
    char pre8[8]
    int d
    # 10^d (Python's float, as the reference's), the bound on |v|
    double scale, lim


cdef class _Cols:
    """The columns ready to write: values in place, prefixes, decimals."""
    cdef Col* c
    cdef Py_ssize_t ncol
    # the arrays and prefixes the pointers point into
    cdef list keep
    cdef bytes allpre
    #: the longest row the columns can make, without its end
    cdef Py_ssize_t row_max

    def __dealloc__(self):
        PyMem_Free(self.c)


cdef _Cols _columns(columns, Py_ssize_t n):
    """The columns read in place, or None where a decimal count is outside 0-19
    (the reference writes those); ValueError when a column's length is not n."""
    cdef _Cols s = _Cols()
    cdef Py_ssize_t c
    cdef const double[:] mv
    cdef bytes pad
    cdef int d
    s.ncol = len(columns)
    s.c = <Col*> PyMem_Malloc(max(s.ncol, 1) * sizeof(Col))
    if s.c == NULL:
        raise MemoryError()
    s.keep = []
    s.row_max = 0
    pres = []
    for c in range(s.ncol):
        prefix, values, dd = columns[c]
        v = np.asarray(values, dtype=np.float64)
        if v.ndim != 1 or len(v) != n:
            raise ValueError("every column must have a value a row")
        d = dd
        if not 0 <= d <= 19:
            return None
        mv = v
        pre = prefix.encode("ascii").replace(b"\0", b"")
        s.keep += [v, pre]
        pres.append(pre)
        s.c[c].data = <const char*> &mv[0] if n else NULL
        s.c[c].step = mv.strides[0]
        s.c[c].pre = pre
        s.c[c].npre = len(pre)
        pad = pre + b"\0" * 8
        memcpy(s.c[c].pre8, <const char*> pad, 8)
        s.c[c].d = d
        s.c[c].scale = 10.0**dd
        s.c[c].lim = min(10.0**_pure._INT_DIGITS, 2.0**52 / 10.0**dd)
        # sign, at most 20 whole digits, the point, the decimals
        s.row_max += len(pre) + 1 + 20 + 1 + d
    s.allpre = b"".join(pres)
    return s


cdef uint64_t _tie(double x, int d) except? 0:
    """Near a rounding tie the binary value decides: Python's own rounding."""
    return int(f"{abs(x):.{d}f}".replace(".", ""))


cdef uint64_t _P10[20]
_P10[0] = 1
for _i in range(1, 20):
    _P10[_i] = _P10[_i - 1] * 10


cdef uint64_t _P5[13]
_P5[0] = 1
for _i in range(1, 13):
    _P5[_i] = _P5[_i - 1] * 5


cdef inline int _ndigits(uint64_t v) noexcept nogil:
    """How many decimal digits v has (1 for 0)."""
    cdef int n = 1
    if v < 10000:
        # the usual whole part of a position or speed: a few compares
        return 1 + (v >= 10) + (v >= 100) + (v >= 1000)
    while n < 20 and v >= _P10[n]:
        n += 1
    return n


cdef inline void _digits(char* end, uint64_t v, int n) noexcept nogil:
    """The n lowest decimal digits of v (leading zeros kept) ending before ``end``,
    two at a time; 32-bit arithmetic once v fits."""
    cdef uint32_t r, w
    while n >= 2 and v > <uint64_t> 4294967295:
        r = <uint32_t> (v % 100)
        v = v // 100
        end -= 2
        memcpy(end, &_PAIRS[2 * r], 2)
        n -= 2
    w = <uint32_t> v
    while n >= 2:
        r = w % 100
        w = w // 100
        end -= 2
        memcpy(end, &_PAIRS[2 * r], 2)
        n -= 2
    if n:
        (end - 1)[0] = <char> (48 + w % 10)


cdef inline Py_ssize_t _uint(char* out, Py_ssize_t pos, uint64_t v) noexcept nogil:
    """The decimal digits of v at out[pos]; the position after them."""
    cdef int n = _ndigits(v)
    _digits(out + pos + n, v, n)
    return pos + n


cdef inline Py_ssize_t _whole4(char* out, Py_ssize_t pos, uint32_t w) noexcept nogil:
    """w < 10^4 at out[pos] without a branch on its length: its four digits in
    one word (the first character in the lowest byte), the leading zeros shifted
    out, four bytes stored; the position after the digits."""
    cdef uint32_t hi = w // 100
    cdef uint16_t a, b
    cdef uint32_t word
    cdef int nw = 1 + (w >= 10) + (w >= 100) + (w >= 1000)
    memcpy(&a, &_PAIRS[2 * hi], 2)
    memcpy(&b, &_PAIRS[2 * (w - hi * 100)], 2)
    word = (<uint32_t> a | (<uint32_t> b << 16)) >> (8 * (4 - nw))
    memcpy(out + pos, &word, 4)
    return pos + nw


cdef inline void _decimals(char* end, uint64_t f, int d) noexcept nogil:
    """The d decimals of f (f < 10^d, leading zeros kept) ending before ``end``:
    from 4 on, the last four apart from the others (two chains of divisions, not
    one) and stored as one word."""
    cdef uint32_t lo, lo_hi
    cdef uint16_t a, b
    cdef uint32_t word
    if d < 4 or d > 9:
        _digits(end, f, d)
        return
    lo = <uint32_t> (f % 10000)
    _digits(end - 4, f // 10000, d - 4)
    lo_hi = lo // 100
    memcpy(&a, &_PAIRS[2 * lo_hi], 2)
    memcpy(&b, &_PAIRS[2 * (lo - lo_hi * 100)], 2)
    word = <uint32_t> a | (<uint32_t> b << 16)
    memcpy(end - 4, &word, 4)


cdef inline uint64_t _whole(uint64_t k, int d) noexcept nogil:
    """k // 10^d, by a constant for the usual d (a multiplication, not a division)."""
    if d == 7:
        return k // 10000000
    if d == 4:
        return k // 10000
    if d == 5:
        return k // 100000
    if d == 6:
        return k // 1000000
    if d == 8:
        return k // 100000000
    if d == 9:
        return k // 1000000000
    if d == 3:
        return k // 1000
    return k // _P10[d]


cdef inline Py_ssize_t _put(
    char* out, Py_ssize_t pos, double x, uint64_t k, int d
) noexcept nogil:
    """``%.{d}f`` of x at out[pos], given k, |x| 10^d rounded; the position after."""
    cdef uint64_t w
    cdef int nw
    # no branch on the sign (a speed's is no better than a coin toss to predict)
    out[pos] = 45  # '-'
    pos += signbit(x) != 0
    w = _whole(k, d)
    if w < 10000:
        pos = _whole4(out, pos, <uint32_t> w)
    else:
        nw = _ndigits(w)
        _digits(out + pos + nw, w, nw)
        pos += nw
    if d:
        out[pos] = 46  # '.'
        pos += d + 1
        _decimals(out + pos, k - w * _P10[d], d)
    return pos


cdef inline double _value(const Col* c, Py_ssize_t i) noexcept nogil:
    return (<const double*> (c.data + i * c.step))[0]


cdef inline Py_ssize_t _fixed(char* out, Py_ssize_t pos, const Col* c, Py_ssize_t i) noexcept nogil:
    """Value i of column c in fixed point at out[pos] (``%.{d}f``); the position
    after it, -1 when the value is too large for the integer digits (or not
    finite), -2 near a rounding tie (:func:`_fixed_tie` writes it)."""
    cdef double x = _value(c, i)
    cdef double a = fabs(x)
    cdef double t, r
    if not (a < c.lim):
        return -1
    t = a * c.scale
    r = rint(t)
    # floor(t) from rint(t) without a branch (rint rounds up half the time): both
    # are whole doubles below 2^52, so r - 1 is exact
    if fabs(t - (r - <double> (r > t)) - 0.5) < 1e-6:
        return -2
    return _put(out, pos, x, <uint64_t> (<int64_t> r), c.d)


cdef Py_ssize_t _fixed_tie(char* out, Py_ssize_t pos, const Col* c, Py_ssize_t i) except -3:
    """Value i of column c near a rounding tie, where the binary value decides:
    Python's own rounding (as the reference)."""
    cdef double x = _value(c, i)
    return _put(out, pos, x, _tie(x, c.d), c.d)


cdef inline Py_ssize_t _row(char* out, Py_ssize_t pos, Py_ssize_t i, _Cols s) except -2:
    """Row i of the columns (prefix, value, ...) at out[pos], without its end; -1
    where a value is too large."""
    cdef Py_ssize_t c, at
    cdef const Col* col
    for c in range(s.ncol):
        col = &s.c[c]
        if col.npre <= 8:
            memcpy(out + pos, col.pre8, 8)
        else:
            memcpy(out + pos, col.pre, col.npre)
        pos += col.npre
        at = _fixed(out, pos, col, i)
        if at == -2:
            at = _fixed_tie(out, pos, col, i)
        if at < 0:
            return -1
        pos = at
    return pos


#: a buffer kept from one call to the next: a fresh one each call would be fresh
#: pages, each faulted in and zeroed by the system (a large part of the time)
cdef char* _spare = NULL
#: the largest buffer kept [bytes] (a segment of 20 000 PMAC points takes 7 MB)
cdef Py_ssize_t _KEEP_MAX = 64 << 20
cdef Py_ssize_t _spare_n = 0


cdef char* _take(Py_ssize_t n) except NULL:
    """A buffer of at least n bytes, the kept one where it is large enough; the
    caller owns it until :func:`_give` (a call running meanwhile makes its own)."""
    global _spare, _spare_n
    cdef char* buf = _spare
    if buf != NULL and _spare_n >= n:
        _spare = NULL
        return buf
    buf = <char*> PyMem_Malloc(n)
    if buf == NULL:
        raise MemoryError()
    return buf


cdef void _give(char* buf, Py_ssize_t n) noexcept:
    """Keep buf (n bytes) for the next call, the larger of it and the one kept,
    up to :data:`_KEEP_MAX`."""
    global _spare, _spare_n
    if n > _KEEP_MAX:
        # an unusually large call: its buffer is not held for the process's life
        PyMem_Free(buf)
    elif _spare == NULL or n > _spare_n:
        PyMem_Free(_spare)
        _spare = buf
        _spare_n = n
    else:
        PyMem_Free(buf)


cdef str _ascii(const char* data, Py_ssize_t n):
    """A str of the n ASCII bytes at data (no check: digits, signs, points and
    texts encoded as ASCII)."""
    cdef object text = PyUnicode_New(n, 127)
    memcpy(PyUnicode_DATA(text), data, n)
    return text


def format_fixed_rows(columns, str end="\n"):
    """Rows of text, ``prefix value prefix value ...`` (``text.format_fixed_rows``)."""
    cdef Py_ssize_t ncol = len(columns)
    if ncol == 0:
        return []
    cdef Py_ssize_t n = len(columns[0][1])
    if n == 0:
        return []
    cdef _Cols s = _columns(columns, n)
    cdef list rows = None
    if s is not None:
        rows = _rows_of(s, n, end)
    # a decimal count beyond 0-19, or a value too large (or not finite): Python
    # prints the whole chunk
    return _pure.format_fixed_rows(columns, end) if rows is None else rows


cdef list _rows_of(_Cols s, Py_ssize_t n, str end):
    """The rows of :func:`format_fixed_rows`, or None where a value is too large."""
    cdef bytes endb = end.encode("ascii").replace(b"\0", b"")
    cdef Py_ssize_t size = n * (s.row_max + len(endb)) + 1
    # not zeroed: every byte up to the text's end is written
    cdef char* out = _take(size)
    try:
        return _fixed_rows(out, s, n, end, endb)
    finally:
        _give(out, size)


cdef list _fixed_rows(char* out, _Cols s, Py_ssize_t n, str end, bytes endb):
    """The rows of :func:`format_fixed_rows` written at out."""
    cdef Py_ssize_t i, pos = 0
    cdef Py_ssize_t ne = len(endb)
    cdef const char* eb = endb
    # one str a row straight from the buffer when each row is exactly one line (the
    # end is a newline, no prefix holds a line break); else Python's splitlines
    # over the whole text, as the reference does
    cdef bint one_line = end == "\n" and not any(ch in _BREAKS for ch in s.allpre.decode("ascii"))
    starts_a = np.empty(n + 1, np.intp)
    cdef Py_ssize_t[::1] starts = starts_a
    for i in range(n):
        starts[i] = pos
        pos = _row(out, pos, i, s)
        if pos < 0:
            # a value too large (or not finite): Python prints the whole chunk
            return None
        memcpy(out + pos, eb, ne)
        pos += ne
    starts[n] = pos
    if not one_line:
        return PyUnicode_DecodeASCII(out, pos, NULL).splitlines(keepends=True)
    rows = PyList_New(n)
    for i in range(n):
        row = _ascii(out + starts[i], starts[i + 1] - starts[i])
        Py_INCREF(row)
        PyList_SET_ITEM(rows, i, row)
    return rows


cdef inline Py_ssize_t _signed(char* out, Py_ssize_t pos, int64_t v, uint64_t* a) noexcept:
    """A minus sign where v < 0; |v| into ``a`` (exact for INT64_MIN too)."""
    if v < 0:
        out[pos] = 45
        pos += 1
        a[0] = (<uint64_t> 0) - (<uint64_t> v)
    else:
        a[0] = <uint64_t> v
    return pos


cdef inline Py_ssize_t _pvt_time(char* out, Py_ssize_t pos, int64_t v) noexcept:
    """A PVT time of ``v`` quanta of 1/4096 ms, exactly: the whole milliseconds,
    then the twelve decimals of the fraction written to the last non-zero one, at
    least four, and a newline."""
    cdef uint64_t a, f, r
    cdef int nd, tz = 12
    pos = _signed(out, pos, v, &a)
    pos = _uint(out, pos, a >> 12)
    out[pos] = 46  # '.'
    pos += 1
    # f / 4096 ms = f 5^12 / 10^12 ms: its trailing decimal zeros are the factors
    # of 2 of f (at most 11), so the decimals to write are f / 2^tz times 5^(12 - tz)
    f = a & 4095
    if f:
        tz = 0
        while not (f & 1):
            f >>= 1
            tz += 1
    nd = 12 - tz
    r = f * _P5[nd]
    if nd < 4:
        r *= _P10[4 - nd]
        nd = 4
    _digits(out + pos + nd, r, nd)
    pos += nd
    out[pos] = 10
    return pos + 1


cdef bint _reference_only(columns, _Cols s, quanta, new_time, other_text):
    """Where the reference's own text must be written: decimals beyond 0-19,
    prefixes it drops NUL bytes of or splits rows at, texts beyond ASCII, PVT
    times beyond its integer formatter."""
    if s is None:
        return True
    if (
        b"\0" in b"".join(p[0].encode("ascii") for p in columns)
        or any(ch in _BREAKS for ch in s.allpre.decode("ascii"))
        or not all(t.isascii() for t in other_text)
    ):
        return True
    q_at = np.asarray(quanta, dtype=np.int64)[np.asarray(new_time, dtype=bool)]
    return not np.all((-_pure.PVT_MAX_QUANTA < q_at) & (q_at < _pure.PVT_MAX_QUANTA))


def pvt_segment_text(columns, line, new_line, quanta, new_time, other_rows, other_text):
    """A PVT program's points as one text (``text.pvt_segment_text``)."""
    cdef Py_ssize_t m = len(line)
    cdef Py_ssize_t ncol = len(columns)
    args = (columns, line, new_line, quanta, new_time, other_rows, other_text)
    if m == 0 or ncol == 0:
        return _pure.pvt_segment_text(*args)
    if (
        any(len(a) != m for a in (new_line, quanta, new_time))
        or len(other_rows) != len(other_text)
    ):
        raise ValueError("every column and row array must have a value a row, "
                         "and other_rows a text each")
    cdef _Cols s = _columns(columns, m)
    if _reference_only(columns, s, quanta, new_time, other_text):
        return _pure.pvt_segment_text(*args)
    cdef const int64_t[::1] ln = np.ascontiguousarray(line, dtype=np.int64)
    cdef const int64_t[::1] qt = np.ascontiguousarray(quanta, dtype=np.int64)
    cdef const char[::1] nl = np.ascontiguousarray(new_line, dtype=bool).view(np.int8)
    cdef const char[::1] nt = np.ascontiguousarray(new_time, dtype=bool).view(np.int8)
    # the rows replaced: which text (index into `others`) or -1
    oth_a = np.full(m, -1, np.intp)
    oth_a[np.asarray(other_rows, dtype=np.intp)] = np.arange(len(other_rows))
    cdef const Py_ssize_t[::1] oth = oth_a
    cdef list others = [t.encode("ascii") for t in other_text]
    cdef Py_ssize_t extra = sum(len(t) for t in others)
    # per row at most: "; line " + sign + 20 digits + "\n", "PVT" + sign + 20 + "." +
    # 12 + "\n", the row and its newline
    cdef Py_ssize_t size = m * (s.row_max + 29 + 38 + 1) + extra + 1
    cdef char* out = _take(size)
    cdef Py_ssize_t pos
    try:
        pos = _segment(out, s, m, ln, nl, qt, nt, oth, others)
        # a value too large (or not finite): Python writes the chunk
        return _pure.pvt_segment_text(*args) if pos < 0 else _ascii(out, pos)
    finally:
        _give(out, size)


cdef Py_ssize_t _segment(
    char* out, _Cols s, Py_ssize_t m, const int64_t[::1] ln, const char[::1] nl,
    const int64_t[::1] qt, const char[::1] nt, const Py_ssize_t[::1] oth, list others,
) except -2:
    """The text of :func:`pvt_segment_text` at out; its length, or -1 where a value
    is too large for the integer digits."""
    cdef Py_ssize_t i, pos = 0
    cdef uint64_t a
    cdef bytes ot
    for i in range(m):
        if nl[i]:
            memcpy(out + pos, b"; line ", 7)
            pos = _signed(out, pos + 7, ln[i], &a)
            pos = _uint(out, pos, a)
            out[pos] = 10
            pos += 1
        if nt[i]:
            memcpy(out + pos, b"PVT", 3)
            pos = _pvt_time(out, pos + 3, qt[i])
        if oth[i] >= 0:
            ot = <bytes> others[oth[i]]
            memcpy(out + pos, <const char*> ot, len(ot))
            pos += len(ot)
        else:
            pos = _row(out, pos, i, s)
            if pos < 0:
                return -1
            out[pos] = 10
            pos += 1
    return pos
