# cython: language_level=3, boundscheck=False, wraparound=False, cdivision=True
# cython: initializedcheck=False
"""The fast path compiled: the twin of :func:`prsxy_post.gcode.fast.fast_run`.

It reads each line itself instead of taking the regex's groups: a scanner that
accepts exactly what ``fast._FAST_LINE`` matches (the same groups, the same
``rest``), numbers parsed to the bits of Python's ``float()`` (an exact decimal
of at most 15 digits and 22 decimals is one correctly rounded division, as in
David Gay's strtod; any other goes through ``PyOS_string_to_double``, which is
what ``float()`` calls), the same arithmetic in the same order, and
:class:`~prsxy_post.gcode.motion.Motion` made here. ``(dx ** 2 + dy ** 2 + dz **
2) > 1e-24`` is decided by products where that cannot differ from CPython's
``pow``, by libm's ``pow`` elsewhere (an overflow: moved, as the reference's
OverflowError says). G2/G3 are computed
as ``moves.arc`` computes them (libm where ``math`` calls libm, CPython's own
``math.hypot``); a block the reference would refuse, or any number that is not
finite, goes to the reference's ``_fast_arc`` with the matched words as text.

Bound to the reference by :func:`bind` (this module imports nothing from the
package, so the package imports it, not the other way round).
"""

from libc.math cimport asin, atan2, cos, fabs, isfinite, sin
from libc.stdint cimport uint64_t
from cpython.float cimport PyFloat_AS_DOUBLE
from cpython.list cimport PyList_Append
from cpython.ref cimport PyObject

cdef extern from "Python.h":
    double PyOS_string_to_double(const char *s, char **endptr,
                                 PyObject *overflow_exception) except? -1.0
    Py_ssize_t PyUnicode_FindChar(object s, Py_UCS4 ch, Py_ssize_t start,
                                  Py_ssize_t end, int direction) except -2
    int PyUnicode_KIND(object s)
    void *PyUnicode_DATA(object s)
    Py_UCS4 PyUnicode_READ(int kind, void *data, Py_ssize_t index) nogil

cdef extern from *:
    """
    #include <math.h>
    #include <string.h>
    /* pow(d, 2.0) as CPython's float ** 2 calls it: the 2 is not a constant the
       compiler could turn into d * d (glibc's pow need not round as d * d does) */
    static double prsxy_square(double d) {
        volatile double two = 2.0;
        return pow(d, two);
    }
    /* whether a feed move moves in XYZ: (dx ** 2 + dy ** 2 + dz ** 2) > 1e-24 with
       CPython's pow. d * d is within an ulp of pow(d, 2) (glibc's pow is within
       one ulp), so away from the threshold (a factor of 10 either side) and from
       overflow the products decide the same; near it, and for NaN, infinities
       and huge values, pow decides. -1: pow overflowed (where CPython's
       float_pow raises OverflowError). */
    static int prsxy_moved(double dx, double dy, double dz) {
        if (fabs(dx) < 1e150 && fabs(dy) < 1e150 && fabs(dz) < 1e150) {
            double s = dx * dx + dy * dy + dz * dz;
            if (!(s >= 1e-25 && s <= 1e-23)) return s > 1e-24;
        }
        double d[3] = {dx, dy, dz}, sum = 0.0;
        for (int i = 0; i < 3; i++) {
            double r = prsxy_square(d[i]);
            if (isinf(r) && isfinite(d[i])) return -1;
            sum = i ? sum + r : r;
        }
        return sum > 1e-24;
    }
    /* the end point of a move: a new float where an axis word gave one, the start's
       own object where none did (the same value) */
    static PyObject *prsxy_end(PyObject *start, const double *e, const int *given) {
        PyObject *o = PyTuple_New(5);
        if (o == NULL) return NULL;
        for (int i = 0; i < 5; i++) {
            PyObject *v;
            if (given[i]) {
                v = PyFloat_FromDouble(e[i]);
                if (v == NULL) { Py_DECREF(o); return NULL; }
            } else {
                v = PyTuple_GET_ITEM(start, i);
                Py_INCREF(v);
            }
            PyTuple_SET_ITEM(o, i, v);
        }
        return o;
    }
    static int prsxy_same_bits(double a, double b) {
        return memcmp(&a, &b, sizeof a) == 0;
    }
    /* a Motion (a tuple subclass) filled in place, as tuple.__new__(cls, fields)
       does: `head` holds the 11 fields after line, kind, start, end and feed */
    static PyObject *prsxy_motion(PyObject *tp, PyObject *line, PyObject *kind,
                                  PyObject *start, PyObject *end, PyObject *rate,
                                  PyObject *head) {
        Py_ssize_t n = PyTuple_GET_SIZE(head), i;
        PyObject *o = ((PyTypeObject *)tp)->tp_alloc((PyTypeObject *)tp, n + 5);
        if (o == NULL) return NULL;
        PyObject *first[5] = {line, kind, start, end, rate};
        for (i = 0; i < 5; i++) {
            Py_INCREF(first[i]);
            PyTuple_SET_ITEM(o, i, first[i]);
        }
        for (i = 0; i < n; i++) {
            PyObject *v = PyTuple_GET_ITEM(head, i);
            Py_INCREF(v);
            PyTuple_SET_ITEM(o, i + 5, v);
        }
        return o;
    }
    static PyObject *prsxy_motion_of(PyObject *tp, PyObject *fields) {
        Py_ssize_t n = PyTuple_GET_SIZE(fields), i;
        PyObject *o = ((PyTypeObject *)tp)->tp_alloc((PyTypeObject *)tp, n);
        if (o == NULL) return NULL;
        for (i = 0; i < n; i++) {
            PyObject *v = PyTuple_GET_ITEM(fields, i);
            Py_INCREF(v);
            PyTuple_SET_ITEM(o, i, v);
        }
        return o;
    }
    """
    object prsxy_motion_of(object tp, tuple fields)
    double prsxy_square(double d) nogil
    int prsxy_moved(double dx, double dy, double dz) nogil
    tuple prsxy_end(tuple start, const double *e, const int *given)
    bint prsxy_same_bits(double a, double b) nogil
    object prsxy_motion(object tp, object line, object kind, object start, object end,
                        object rate, tuple head)

#: 10^k, exact as doubles for k <= 22
cdef double _P10[23]
_P10[0] = 1.0
for _k in range(1, 23):
    _P10[_k] = _P10[_k - 1] * 10.0

#: the word letters after G, in the regex's order, upper and lower case
cdef Py_UCS4 _UP[10]
cdef Py_UCS4 _LOW[10]
for _k, _c in enumerate("XYZABIJKRF"):
    _UP[_k] = ord(_c)
    _LOW[_k] = ord(_c.lower())

# bound by bind(): Motion, the reference's _fast_arc and fast_run, the pure matcher
cdef object _Motion = None
cdef object _fast_arc = None
cdef object _pure_run = None
cdef object _pure_matches = None
cdef object _NAN = float("nan")
cdef double _MM_PER_INCH = 25.4
cdef object _hypot = None
cdef double _RT[2]  # LinuxCNC's radius tolerance, mm and inch
cdef double _SA[2]  # the spiral's absolute tolerance, mm and inch
cdef double _SR = 0.0  # its relative tolerance
cdef double _PI = 3.141592653589793


def bind(motion_type, fast_arc, pure_run, pure_matches, double mm_per_inch, nan, hypot,
         radius_tol, spiral_abs, double spiral_rel):
    """The reference's pieces this twin uses (gcode.fast calls it once): ``nan``
    is the very object the reference puts in a rapid (math.nan), so that motions
    compare equal as tuples (a tuple compares NaN by identity); ``hypot`` is
    Python's math.hypot (not libm's: CPython computes its own); the arc
    tolerances are moves.py's, by unit."""
    global _Motion, _fast_arc, _pure_run, _pure_matches, _NAN, _MM_PER_INCH, _hypot, _SR
    _Motion, _fast_arc, _pure_run, _pure_matches = motion_type, fast_arc, pure_run, pure_matches
    _MM_PER_INCH = mm_per_inch
    _NAN = nan
    _hypot = hypot
    _RT[0], _RT[1] = radius_tol["mm"], radius_tol["inch"]
    _SA[0], _SA[1] = spiral_abs["mm"], spiral_abs["inch"]
    _SR = spiral_rel


cdef struct Text:
    int kind  # the str's storage, for PyUnicode_READ
    void *data
    Py_ssize_t n


cdef inline void _text(str s, Text *t) noexcept:
    t.kind = PyUnicode_KIND(s)
    t.data = PyUnicode_DATA(s)
    t.n = len(s)


cdef struct Groups:
    int g  # the G group's digit, -1 when it did not match
    Py_ssize_t s[10]  # start of each number (sign included), -1 when absent
    Py_ssize_t e[10]  # its end
    bint rest  # text after the matched words


cdef inline bint _blank(Py_UCS4 c) noexcept:
    return c == 32 or c == 9


cdef inline bint _digit(Py_UCS4 c) noexcept:
    return 48 <= c <= 57


cdef inline Py_UCS4 _at(Text *t, Py_ssize_t i) noexcept:
    return PyUnicode_READ(t.kind, t.data, i) if i < t.n else 0


cdef void _scan(Text *t, Groups *gr) noexcept:
    """The groups ``fast._FAST_LINE`` gives for a line (possessive: each optional
    group matches as far as it can or not at all)."""
    cdef Py_ssize_t n = t.n, p = 0, q, z
    cdef Py_UCS4 c
    cdef int k
    gr.g = -1
    while p < n and _blank(_at(t, p)):
        p += 1
    # [Nn] blanks digits+ blanks
    c = _at(t, p)
    if c == 78 or c == 110:
        q = p + 1
        while q < n and _blank(_at(t, q)):
            q += 1
        if q < n and _digit(_at(t, q)):
            while q < n and _digit(_at(t, q)):
                q += 1
            while q < n and _blank(_at(t, q)):
                q += 1
            p = q
    # [Gg] blanks 0*([0-3])(?![0-9.]) blanks: 0* gives one zero back for G00
    c = _at(t, p)
    if c == 71 or c == 103:
        q = p + 1
        while q < n and _blank(_at(t, q)):
            q += 1
        z = q
        while q < n and _at(t, q) == 48:
            q += 1
        c = _at(t, q)
        if 49 <= c <= 51 and not (_digit(_at(t, q + 1)) or _at(t, q + 1) == 46):
            gr.g = <int>c - 48
            q += 1
        elif q > z and not (_digit(c) or c == 46):
            gr.g = 0
        if gr.g >= 0:
            while q < n and _blank(_at(t, q)):
                q += 1
            p = q
    # each word: letter blanks ([-+]? (digits+ .? digits* | . digits+)) blanks
    for k in range(10):
        gr.s[k] = -1
        c = _at(t, p)
        if c != _UP[k] and c != _LOW[k]:
            continue
        q = p + 1
        while q < n and _blank(_at(t, q)):
            q += 1
        z = q
        c = _at(t, q)
        if c == 43 or c == 45:
            q += 1
        c = _at(t, q)
        if _digit(c):
            while q < n and _digit(_at(t, q)):
                q += 1
            if q < n and _at(t, q) == 46:
                q += 1
            while q < n and _digit(_at(t, q)):
                q += 1
        elif c == 46 and _digit(_at(t, q + 1)):
            q += 1
            while q < n and _digit(_at(t, q)):
                q += 1
        else:
            continue
        gr.s[k] = z
        gr.e[k] = q
        while q < n and _blank(_at(t, q)):
            q += 1
        p = q
    gr.rest = p < n


cdef double _number(Text *t, str s, Py_ssize_t a, Py_ssize_t b) except? -1.0:
    """float(s[a:b]) for a matched number (ASCII: sign, digits, at most one dot);
    ``t``: the text of ``s``."""
    cdef bint neg = False
    cdef uint64_t m = 0
    cdef int digits = 0, decimals = 0
    cdef bint dot = False
    cdef Py_ssize_t p = a
    cdef Py_UCS4 c
    c = _at(t, p)
    if c == 45 or c == 43:
        neg = c == 45
        p += 1
    while p < b:
        c = _at(t, p)
        p += 1
        if c == 46:
            dot = True
            continue
        if dot:
            decimals += 1
        if m == 0 and c == 48:
            continue  # a leading zero: no significant digit
        digits += 1
        m = m * 10 + (<int>c - 48)
        if digits > 15:
            return _slow(s, a, b)
    if decimals > 22:
        return _slow(s, a, b)
    cdef double v = <double>m / _P10[decimals]
    return -v if neg else v


cdef double _slow(str s, Py_ssize_t a, Py_ssize_t b) except? -1.0:
    cdef bytes t = s[a:b].encode("ascii")
    return PyOS_string_to_double(t, NULL, NULL)


cdef inline double _hyp(double a, double b) except? -1.0:
    return _hypot(a, b)  # CPython's own hypot, as moves.py's


cdef inline bint _finite5(const double *v) noexcept:
    return isfinite(v[0]) and isfinite(v[1]) and isfinite(v[2]) and isfinite(v[3]) and isfinite(v[4])


cdef object _arc(Text *t, str s, Groups *gr, int m, int plane, bint inch, double sc,
                 bint absolute, bint arc_absolute, const double *off, const double *h,
                 tuple here, double feed, double *e, int *given, object line,
                 object plane_obj, tuple tail):
    """The Motion of a G2/G3 as moves.arc makes it (target, arc_center, sweep_of,
    arc_length, feed_rate; one turn, G94, no rotation), or None where the reference
    must decide: a block it refuses, or numbers that are not finite."""
    cdef int iu, iv, iw, la, lb, third, j
    cdef double v, u0, v0, u1, v1, cu, cv, r, mu, mv, half, ar, theta, turn2, d
    cdef double ca, cb, r1, r2, ae, re_, rad, a1, b1, sweep, length, rate
    if plane == 17:
        iu, iv, iw, la, lb, third = 0, 1, 2, 5, 6, 7  # word indices: I 5, J 6, K 7
    elif plane == 18:
        iu, iv, iw, la, lb, third = 2, 0, 1, 7, 5, 6
    elif plane == 19:
        iu, iv, iw, la, lb, third = 1, 2, 0, 6, 7, 5
    else:
        return None
    for j in range(5):  # moves.target
        given[j] = gr.s[j] >= 0
        if given[j]:
            v = _number(t, s, gr.s[j], gr.e[j]) * (sc if j < 3 else 1.0)
            e[j] = v + off[j] if absolute else h[j] + v
        else:
            e[j] = h[j]
    if not (_finite5(e) and _finite5(h)) or feed <= 0:
        return None
    u0, v0, u1, v1 = h[iu] / sc, h[iv] / sc, e[iu] / sc, e[iv] / sc
    if gr.s[8] >= 0:  # moves.arc_center, R
        if gr.s[5] >= 0 or gr.s[6] >= 0 or gr.s[7] >= 0:
            return None
        r = _number(t, s, gr.s[8], gr.e[8])
        if not isfinite(r) or (u0 == u1 and v0 == v1):
            return None
        mu, mv = (u0 + u1) / 2.0, (v0 + v1) / 2.0
        half = _hyp(mu - u1, mv - v1)
        ar = fabs(r)
        if half - ar > _RT[inch]:
            return None
        if ar == 0 or half / ar > 1 - 1e-12:
            half = ar
        if (m == 2 and r > 0) or (m == 3 and r < 0):
            theta = atan2(v1 - v0, u1 - u0) - _PI / 2
        else:
            theta = atan2(v1 - v0, u1 - u0) + _PI / 2
        turn2 = asin(half / ar) if ar > 0 else 0.0
        d = ar * cos(turn2)
        cu, cv = mu + d * cos(theta), mv + d * sin(theta)
    else:  # moves.arc_center, I J K
        if (gr.s[la] < 0 and gr.s[lb] < 0) or gr.s[third] >= 0:
            return None
        if arc_absolute and (gr.s[la] < 0 or gr.s[lb] < 0):
            return None
        ca = _number(t, s, gr.s[la], gr.e[la]) if gr.s[la] >= 0 else 0.0
        cb = _number(t, s, gr.s[lb], gr.e[lb]) if gr.s[lb] >= 0 else 0.0
        if not (isfinite(ca) and isfinite(cb)):
            return None
        if arc_absolute:
            cu = ca + off[iu] / sc
            cv = cb + off[iv] / sc
        else:
            cu, cv = u0 + ca, v0 + cb
        r1 = _hyp(cu - u0, cv - v0)
        r2 = _hyp(cu - u1, cv - v1)
        if r1 < _RT[inch] or r2 < _RT[inch]:
            return None
        ae = fabs(r1 - r2)
        re_ = ae / (r2 if r2 > r1 else r1)  # Python's max(r1, r2)
        if ae > _SA[inch] * 100.0 or (re_ > _SR and ae > _SA[inch]):
            return None
    rad = _hyp(u0 - cu, v0 - cv) * sc
    a1 = atan2(v0 - cv, u0 - cu)  # moves.sweep_of, one turn
    b1 = atan2(v1 - cv, u1 - cu)
    if m == 3:
        if b1 <= a1:
            b1 += 2 * _PI
        sweep = (b1 - a1) + 0.0  # + (rotation - 1) * 2 * pi
    else:
        if a1 <= b1:
            a1 += 2 * _PI
        sweep = (b1 - a1) + 0.0  # + (rotation + 1) * 2 * pi
    length = _hyp(rad * sweep, e[iw] - h[iw])
    if length > 1e-12 or (h[3] - e[3] == 0 and h[4] - e[4] == 0):  # moves.feed_rate
        rate = feed * (_MM_PER_INCH if inch else 1.0)
    else:
        rate = feed
    cdef double c[3]
    c[iu], c[iv], c[iw] = cu * sc, cv * sc, e[iw]
    end = prsxy_end(here, e, given)
    return prsxy_motion_of(
        _Motion, (line, "arc", here, end, rate, plane_obj, (c[0], c[1], c[2]), 1 if m == 3 else -1)
        + tail
    )


def matches_of(list batch):
    """What :func:`fast_run` reads for a batch: the lines themselves, or none (no
    fast path) when a line holds a line end (the regex would see two lines)."""
    for line in batch:
        if PyUnicode_FindChar(line, 10, 0, len(<str>line), 1) >= 0:
            return []
    return batch


cdef tuple _words(str s, Groups *gr):
    """The regex's groups as text (G, X .. F, rest) for the reference's _fast_arc."""
    cdef int k
    out = [str(gr.g) if gr.g >= 0 else ""]
    for k in range(10):
        out.append(s[gr.s[k]:gr.e[k]] if gr.s[k] >= 0 else "")
    out.append("")
    return tuple(out)


cdef bint _floats(object seq):
    for v in seq:
        if type(v) is not float:
            return False
    return True


def fast_run(it, list lines, Py_ssize_t i, Py_ssize_t n0):
    """:func:`prsxy_post.gcode.fast.fast_run` over ``lines`` (the batch) from ``i``:
    the same motions and state, the index of the first line not taken."""
    cdef Groups gr
    cdef Text t
    cdef Py_ssize_t nlines = len(lines), k
    cdef str s
    if i >= nlines:
        return i
    s = lines[i]
    _text(s, &t)
    _scan(&t, &gr)
    if gr.rest or (gr.s[0] < 0 and gr.s[1] < 0 and gr.s[2] < 0 and gr.s[3] < 0 and gr.s[4] < 0):
        return i
    st = it.st
    if (
        st.ended
        or st.inverse_time
        or st.comp_side
        or st.rotation
        or st.arc_not_allowed
        or it.detached is not None
        or it.queue
    ):
        return i
    pos = st.pos
    feed_obj = st.feed
    off = it.offset()
    if not (type(feed_obj) is float and _floats(pos) and _floats(off) and len(pos) == 5):
        # a state the reference keeps other types in: it runs (the types stay)
        return _pure_run(it, _pure_matches(lines), i, n0)
    cdef double x = pos[0], y = pos[1], z = pos[2], a = pos[3], b = pos[4]
    cdef double ox = off[0], oy = off[1], oz = off[2], oa = off[3], ob = off[4]
    cdef double feed = PyFloat_AS_DOUBLE(feed_obj)
    motion = st.motion
    cdef int mcode = -1, m, c
    for c in range(4):
        if motion is not None and motion == c:
            mcode = c
            break
    cdef double sc = _MM_PER_INCH if st.units == "inch" else 1.0
    cdef bint absolute = st.absolute
    cdef bint inch = st.units == "inch"
    cdef bint arc_absolute = st.arc_absolute
    plane_obj = st.plane
    cdef int plane = plane_obj if type(plane_obj) is int else 0
    cdef double offs[5]
    cdef double h[5]
    offs[0], offs[1], offs[2], offs[3], offs[4] = ox, oy, oz, oa, ob
    head = (0, None, 0, 0.0, st.tool_length, st.tool, st.spindle * st.spindle_dir, False,
            st.path_tol, (), None)
    tail = head[3:]
    out = it.out
    cdef bint new_motion = False
    cdef int moved, j
    cdef double f, d2
    cdef double e[5]
    cdef int given[5]
    cdef double last_rate = 0.0
    last_rate_obj = None
    here = (pos[0], pos[1], pos[2], pos[3], pos[4])  # the start, as float objects
    k = i
    while k < nlines:
        if k > i:
            s = lines[k]
            _text(s, &t)
            _scan(&t, &gr)
            if gr.rest or (
                gr.s[0] < 0 and gr.s[1] < 0 and gr.s[2] < 0 and gr.s[3] < 0 and gr.s[4] < 0
            ):
                break
        m = gr.g if gr.g >= 0 else mcode
        if m < 0:
            break
        if gr.s[9] >= 0:
            f = _number(&t, s, gr.s[9], gr.e[9])
            if f < 0 or (f == 0 and m):
                break
        elif m and feed <= 0:
            break
        else:
            f = feed
        if m >= 2:
            h[0], h[1], h[2], h[3], h[4] = x, y, z, a, b
            done = _arc(&t, s, &gr, m, plane, inch, sc, absolute, arc_absolute, offs, h, here,
                        f, e, given, n0 + k + 1, plane_obj, tail)
            if done is not None:
                PyList_Append(out, done)
                here = done[3]
                x, y, z, a, b = e[0], e[1], e[2], e[3], e[4]
                if gr.s[9] >= 0:
                    feed = f
                    feed_obj = f
                if gr.g >= 0:
                    new_motion = True  # the reference's _fast_arc clears cycle_il
                motion = m
                mcode = m
                k += 1
                continue
            st.pos, st.motion, st.feed = [x, y, z, a, b], motion, feed_obj
            if not _fast_arc(it, m, _words(s, &gr), n0 + k + 1):
                break
            pos = st.pos
            here = (pos[0], pos[1], pos[2], pos[3], pos[4])
            x, y, z, a, b = pos[0], pos[1], pos[2], pos[3], pos[4]
            motion, feed_obj = st.motion, st.feed
            feed = feed_obj
            mcode = m  # the reference's _fast_arc leaves st.motion = m
            k += 1
            continue
        if gr.s[5] >= 0 or gr.s[6] >= 0 or gr.s[7] >= 0 or gr.s[8] >= 0:
            break
        for j in range(5):
            given[j] = gr.s[j] >= 0
        if absolute:
            e[0] = _number(&t, s, gr.s[0], gr.e[0]) * sc + ox if given[0] else x
            e[1] = _number(&t, s, gr.s[1], gr.e[1]) * sc + oy if given[1] else y
            e[2] = _number(&t, s, gr.s[2], gr.e[2]) * sc + oz if given[2] else z
            e[3] = _number(&t, s, gr.s[3], gr.e[3]) + oa if given[3] else a
            e[4] = _number(&t, s, gr.s[4], gr.e[4]) + ob if given[4] else b
        else:
            e[0] = x + _number(&t, s, gr.s[0], gr.e[0]) * sc if given[0] else x
            e[1] = y + _number(&t, s, gr.s[1], gr.e[1]) * sc if given[1] else y
            e[2] = z + _number(&t, s, gr.s[2], gr.e[2]) * sc if given[2] else z
            e[3] = a + _number(&t, s, gr.s[3], gr.e[3]) if given[3] else a
            e[4] = b + _number(&t, s, gr.s[4], gr.e[4]) if given[4] else b
        if gr.s[9] >= 0:
            feed = f
            feed_obj = f
        if gr.g >= 0:
            motion = gr.g
            mcode = gr.g
            new_motion = True
        if m == 0:
            rate = _NAN
            kind = "rapid"
        else:
            kind = "feed"
            moved = prsxy_moved(e[0] - x, e[1] - y, e[2] - z)
            if moved < 0:
                moved = 1  # a square past the largest float (the reference's OverflowError)
            d2 = f * sc if (moved or (e[3] == a and e[4] == b)) else f
            if last_rate_obj is None or not prsxy_same_bits(d2, last_rate):
                last_rate, last_rate_obj = d2, d2  # one float object per rate
            rate = last_rate_obj
        end = prsxy_end(here, e, given)
        PyList_Append(out, prsxy_motion(_Motion, n0 + k + 1, kind, here, end, rate, head))
        here = end
        x, y, z, a, b = e[0], e[1], e[2], e[3], e[4]
        k += 1
    if k > i:
        st.pos = [x, y, z, a, b]
        st.motion = motion
        st.feed = feed_obj
        if new_motion:
            st.cycle_il = None
        it.started = True
    return k
