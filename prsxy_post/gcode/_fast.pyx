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
cdef double _NAN_D = float("nan")  # _NAN's value
cdef Py_ssize_t _WIDTH = 21  # the columns of a row (rows.WIDTH)
cdef object _NEW_ROWS = None  # numpy.empty


def bind(motion_type, fast_arc, pure_run, pure_matches, double mm_per_inch, nan, hypot,
         radius_tol, spiral_abs, double spiral_rel, Py_ssize_t width, new_rows):
    """The reference's pieces this twin uses (gcode.fast calls it once): ``nan``
    is the very object the reference puts in a rapid (math.nan), so that motions
    compare equal as tuples (a tuple compares NaN by identity); ``hypot`` is
    Python's math.hypot (not libm's: CPython computes its own); the arc
    tolerances are moves.py's, by unit; ``width`` and ``new_rows`` (numpy.empty)
    the rows mode's rows (rows.WIDTH, whose ROW_* columns :func:`_row` writes)."""
    global _Motion, _fast_arc, _pure_run, _pure_matches, _NAN, _MM_PER_INCH, _hypot, _SR
    global _NAN_D, _NEW_ROWS
    if width != _WIDTH:
        raise ValueError(f"rows of {width} columns (this twin writes {_WIDTH})")
    _Motion, _fast_arc, _pure_run, _pure_matches = motion_type, fast_arc, pure_run, pure_matches
    _MM_PER_INCH = mm_per_inch
    _NAN = nan
    _NAN_D = nan
    _NEW_ROWS = new_rows
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


cdef struct Modal:
    double p[5]  # the position (st.pos) [mm, deg]
    double off[5]  # the program origin (it.offset())
    double feed  # st.feed
    double sc  # mm per program unit
    bint absolute
    bint inch
    bint arc_absolute
    int plane  # 17, 18 or 19; 0 for anything else (its arcs go to the reference)
    int mcode  # st.motion when it is 0, 1, 2 or 3, else -1


cdef bint _floats(object seq):
    for v in seq:
        if type(v) is not float:
            return False
    return True


cdef bint _modal(it, st, Modal *md) except -1:
    """The modal state the fast path reads, into ``md``; False where the state
    holds other types than the reference's floats (the reference runs then)."""
    cdef int j
    pos, off, feed = st.pos, it.offset(), st.feed
    if not (type(feed) is float and len(pos) == 5 and _floats(pos) and _floats(off)):
        return False
    for j in range(5):
        md.p[j], md.off[j] = pos[j], off[j]
    md.feed = feed
    md.inch = st.units == "inch"
    md.sc = _MM_PER_INCH if md.inch else 1.0
    md.absolute, md.arc_absolute = st.absolute, st.arc_absolute
    md.plane = st.plane if type(st.plane) is int and st.plane in (17, 18, 19) else 0
    md.mcode = -1
    motion = st.motion
    for j in range(4):
        if motion is not None and motion == j:
            md.mcode = j
            break
    return True


cdef void _end_point(Modal *md, Text *t, str s, Groups *gr, double *e, int *given) except *:
    """Where a move ends (moves.target; fast_run's own arithmetic, the same): a
    given word's value in mm from the program origin or, G91, from here."""
    cdef int j
    cdef double v
    for j in range(5):
        given[j] = gr.s[j] >= 0
        if given[j]:
            v = _number(t, s, gr.s[j], gr.e[j])
            if j < 3:
                v = v * md.sc
            e[j] = v + md.off[j] if md.absolute else md.p[j] + v
        else:
            e[j] = md.p[j]


cdef int _center(Modal *md, Text *t, str s, Groups *gr, int m, const int *ax, double u0,
                 double v0, double u1, double v1, double *cu, double *cv) except -1:
    """moves.arc_center in the plane's axes ``ax`` (u, v, normal, and the word
    indices of the centre's two words and the third): 1 with the centre in
    ``cu``, ``cv`` [program units], 0 where the reference refuses the arc."""
    cdef double r, mu, mv, half, ar, theta, turn2, d, ca, cb, r1, r2, ae, re_
    cdef int la = ax[3], lb = ax[4]
    if gr.s[8] >= 0:  # R
        if gr.s[5] >= 0 or gr.s[6] >= 0 or gr.s[7] >= 0:
            return 0
        r = _number(t, s, gr.s[8], gr.e[8])
        if not isfinite(r) or (u0 == u1 and v0 == v1):
            return 0
        mu, mv = (u0 + u1) / 2.0, (v0 + v1) / 2.0
        half = _hyp(mu - u1, mv - v1)
        ar = fabs(r)
        if half - ar > _RT[md.inch]:
            return 0
        if ar == 0 or half / ar > 1 - 1e-12:
            half = ar
        if (m == 2 and r > 0) or (m == 3 and r < 0):
            theta = atan2(v1 - v0, u1 - u0) - _PI / 2
        else:
            theta = atan2(v1 - v0, u1 - u0) + _PI / 2
        turn2 = asin(half / ar) if ar > 0 else 0.0
        d = ar * cos(turn2)
        cu[0], cv[0] = mu + d * cos(theta), mv + d * sin(theta)
        return 1
    if (gr.s[la] < 0 and gr.s[lb] < 0) or gr.s[ax[5]] >= 0:  # I J K
        return 0
    if md.arc_absolute and (gr.s[la] < 0 or gr.s[lb] < 0):
        return 0
    ca = _number(t, s, gr.s[la], gr.e[la]) if gr.s[la] >= 0 else 0.0
    cb = _number(t, s, gr.s[lb], gr.e[lb]) if gr.s[lb] >= 0 else 0.0
    if not (isfinite(ca) and isfinite(cb)):
        return 0
    if md.arc_absolute:
        cu[0] = ca + md.off[ax[0]] / md.sc
        cv[0] = cb + md.off[ax[1]] / md.sc
    else:
        cu[0], cv[0] = u0 + ca, v0 + cb
    r1 = _hyp(cu[0] - u0, cv[0] - v0)
    r2 = _hyp(cu[0] - u1, cv[0] - v1)
    if r1 < _RT[md.inch] or r2 < _RT[md.inch]:
        return 0
    ae = fabs(r1 - r2)
    re_ = ae / (r2 if r2 > r1 else r1)  # Python's max(r1, r2)
    if ae > _SA[md.inch] * 100.0 or (re_ > _SR and ae > _SA[md.inch]):
        return 0
    return 1


#: per plane: u, v, normal (indices into x y z a b), the centre's words, the third
cdef int _AXES[3][6]
_AXES[0] = [0, 1, 2, 5, 6, 7]  # G17: I J (word indices: I 5, J 6, K 7)
_AXES[1] = [2, 0, 1, 7, 5, 6]  # G18: K I
_AXES[2] = [1, 2, 0, 6, 7, 5]  # G19: J K


cdef int _arc(Modal *md, Text *t, str s, Groups *gr, int m, double feed, double *e,
              int *given, double *c, double *rate) except -1:
    """A G2/G3 as moves.arc computes it (target, arc_center, sweep_of, arc_length,
    feed_rate; one turn, G94, no rotation): 1 with its end in ``e`` (``given``:
    the axis words given), centre in ``c`` [mm] and feed in ``rate``; 0 where
    the reference must decide: a block it refuses, or numbers that are not
    finite."""
    cdef double u0, v0, u1, v1, cu, cv, rad, a1, b1, sweep, length
    cdef const int *ax
    if md.plane == 0:
        return 0
    ax = _AXES[md.plane - 17]
    _end_point(md, t, s, gr, e, given)
    if not (_finite5(e) and _finite5(md.p)) or feed <= 0:
        return 0
    u0, v0 = md.p[ax[0]] / md.sc, md.p[ax[1]] / md.sc
    u1, v1 = e[ax[0]] / md.sc, e[ax[1]] / md.sc
    if not _center(md, t, s, gr, m, ax, u0, v0, u1, v1, &cu, &cv):
        return 0
    rad = _hyp(u0 - cu, v0 - cv) * md.sc
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
    length = _hyp(rad * sweep, e[ax[2]] - md.p[ax[2]])
    if length > 1e-12 or (md.p[3] - e[3] == 0 and md.p[4] - e[4] == 0):  # moves.feed_rate
        rate[0] = feed * (_MM_PER_INCH if md.inch else 1.0)
    else:
        rate[0] = feed
    c[ax[0]], c[ax[1]], c[ax[2]] = cu * md.sc, cv * md.sc, e[ax[2]]
    return 1


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


cdef inline bint _taken(Groups *gr) noexcept:
    """A line the fast path may take: nothing after its words, an axis word."""
    return not gr.rest and (
        gr.s[0] >= 0 or gr.s[1] >= 0 or gr.s[2] >= 0 or gr.s[3] >= 0 or gr.s[4] >= 0
    )


cdef double _straight_rate(Modal *md, int m, double f, const double *e) noexcept:
    """fast_run's feed of a G1: f in mm/min when XYZ move (or A and B stay), else
    deg/min."""
    cdef int moved = prsxy_moved(e[0] - md.p[0], e[1] - md.p[1], e[2] - md.p[2])
    if moved < 0:
        moved = 1  # a square past the largest float (the reference's OverflowError)
    return f * md.sc if (moved or (e[3] == md.p[3] and e[4] == md.p[4])) else f


def fast_run(it, list lines, Py_ssize_t i, Py_ssize_t n0):
    """:func:`prsxy_post.gcode.fast.fast_run` over ``lines`` (the batch) from ``i``:
    the same motions and state, the index of the first line not taken."""
    return _fast(it, lines, i, n0, False)


def fast_rows(it, list lines, Py_ssize_t i, Py_ssize_t n0):
    """:func:`fast_run` in rows mode (:mod:`prsxy_post.gcode.rows`): the moves it
    makes itself go into ``it.out`` as runs of rows (``(n, WIDTH)`` float arrays)
    instead of Motions, in their place among the Motions the reference's arcs
    make; the same state, the same index returned."""
    return _fast(it, lines, i, n0, True)


cdef void _row(double[:, ::1] R, Py_ssize_t r, Py_ssize_t line, int kind, const double *p,
               const double *e, double rate, int plane, const double *c, int rotation,
               double tool_length, double path_tol) noexcept:
    """Row ``r`` of a run (rows.ROW_* columns)."""
    cdef int j
    R[r, 0] = <double>line
    R[r, 1] = kind
    for j in range(5):
        R[r, 2 + j] = p[j]
        R[r, 7 + j] = e[j]
    R[r, 12] = rate
    R[r, 13] = plane
    for j in range(3):
        R[r, 14 + j] = c[j]
    R[r, 17] = rotation
    R[r, 18] = tool_length
    R[r, 19] = path_tol
    R[r, 20] = 0.0


cdef object _filled(object run, Py_ssize_t nrow):
    """The rows written of a run: the array itself when full, else a copy of them
    (a view would hold the room for the rest of the batch until its chunk is
    planned)."""
    if nrow == len(run):
        return run
    return run[:nrow].copy()


cdef object _fast(it, list lines, Py_ssize_t i, Py_ssize_t n0, bint rows):
    cdef Groups gr
    cdef Text t
    cdef Modal md
    cdef Py_ssize_t nlines = len(lines), k = i, nrow = 0, mark
    cdef bint new_motion = False
    cdef int m, plane
    cdef int given[5]
    cdef double f, rate_d, last_rate = 0.0, tool_length = 0.0, path_tol = 0.0
    cdef double e[5]
    cdef double c[3]
    cdef double zero[3]
    cdef double[:, ::1] R
    if i >= nlines:
        return i
    cdef str s = lines[i]
    _text(s, &t)
    _scan(&t, &gr)
    st = it.st
    if not _taken(&gr) or (
        st.ended or st.inverse_time or st.comp_side or st.rotation or st.arc_not_allowed
        or it.detached is not None or it.queue
    ):
        return i
    if not _modal(it, st, &md):  # a state the reference keeps other types in
        return _pure_run(it, _pure_matches(lines), i, n0)
    motion, feed_obj, last_rate_obj = st.motion, st.feed, None
    head = (0, None, 0, 0.0, st.tool_length, st.tool, st.spindle * st.spindle_dir, False,
            st.path_tol, (), None)
    out, here = it.out, tuple(st.pos)  # the start, as the position's float objects
    run = None  # rows mode: the run of rows under way
    if rows:
        tool_length = float(st.tool_length)
        path_tol = _NAN if st.path_tol is None else float(st.path_tol)
        plane = md.plane
        zero[0] = zero[1] = zero[2] = 0.0
    while k < nlines:
        if k > i:
            s = lines[k]
            _text(s, &t)
            _scan(&t, &gr)
            if not _taken(&gr):
                break
        m = gr.g if gr.g >= 0 else md.mcode
        if m < 0:
            break
        if gr.s[9] >= 0:
            f = _number(&t, s, gr.s[9], gr.e[9])
            if f < 0 or (f == 0 and m):
                break
        elif m and md.feed <= 0:
            break
        else:
            f = md.feed
        if rows and run is None:
            run = _NEW_ROWS((nlines - k, _WIDTH))
            R = run
        if m >= 2:
            if not _arc(&md, &t, s, &gr, m, f, e, given, c, &rate_d):
                # the reference decides, with the words as text
                st.pos, st.motion, st.feed = list(md.p), motion, feed_obj
                mark = len(out)
                if not _fast_arc(it, m, _words(s, &gr), n0 + k + 1):
                    break
                if rows and nrow and len(out) > mark:  # the rows so far go before it
                    out.insert(mark, _filled(run, nrow))
                    run, nrow = None, 0
                pos = st.pos
                here, md.p = tuple(pos), pos
                motion, feed_obj = st.motion, st.feed
                md.feed, md.mcode = feed_obj, m  # _fast_arc leaves st.motion = m
                k += 1
                continue
            if rows:
                _row(R, nrow, n0 + k + 1, 2, md.p, e, rate_d, plane, c, 2 * m - 5,
                     tool_length, path_tol)
                nrow += 1
            else:
                end = prsxy_end(here, e, given)
                PyList_Append(out, prsxy_motion_of(
                    _Motion,
                    (n0 + k + 1, "arc", here, end, rate_d, st.plane, (c[0], c[1], c[2]),
                     2 * m - 5) + head[3:],
                ))
                here = end
        else:
            if gr.s[5] >= 0 or gr.s[6] >= 0 or gr.s[7] >= 0 or gr.s[8] >= 0:
                break
            _end_point(&md, &t, s, &gr, e, given)
            if rows:
                rate_d = _NAN_D if m == 0 else _straight_rate(&md, m, f, e)
                _row(R, nrow, n0 + k + 1, 0 if m == 0 else 1, md.p, e, rate_d, 0, zero, 0,
                     tool_length, path_tol)
                nrow += 1
            else:
                if m == 0:
                    rate, kind = _NAN, "rapid"
                else:
                    rate_d, kind = _straight_rate(&md, m, f, e), "feed"
                    if last_rate_obj is None or not prsxy_same_bits(rate_d, last_rate):
                        last_rate, last_rate_obj = rate_d, rate_d  # one float object per rate
                    rate = last_rate_obj
                end = prsxy_end(here, e, given)
                PyList_Append(out, prsxy_motion(_Motion, n0 + k + 1, kind, here, end, rate, head))
                here = end
        if gr.s[9] >= 0:
            md.feed, feed_obj = f, f
        if gr.g >= 0:
            new_motion = True  # (an arc: the reference's _fast_arc clears cycle_il)
        if gr.g >= 0 or m >= 2:
            motion, md.mcode = m, m
        md.p = e
        k += 1
    if nrow:
        PyList_Append(out, _filled(run, nrow))
    if k > i:
        st.pos, st.motion, st.feed = list(md.p), motion, feed_obj
        if new_motion:
            st.cycle_il = None
        it.started = True
    return k
