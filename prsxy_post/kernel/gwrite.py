"""The corrected G-code writer's per-point decisions: which points become lines,
each line's time and F, its G61 / G64 P mode, a G4 P0 after it, a line before it
slowed down or stopped.

The plain-Python reference (Python's floats, ``math.fsum``, and CPython 3.11's
``hypot`` and ``dist`` from :mod:`prsxy_post.kernel.vnorm` on every Python);
``_gwrite.pyx`` is its compiled twin, the same operations in the same order (the
same bits: CPython's exactly rounded ``fsum`` and 3.11's ``hypot``, which is not
libm's, written out there). The rules (why each, with LinuxCNC's
source) are :mod:`prsxy_post.writers.linuxcnc`'s; this module only decides.

A chunk's points go in as arrays, with a :class:`GState` carried from chunk to
chunk (the held-back points, the held corner, the tilt last written, the last
line written, which the next may slow down or stop). Out comes one op per output
line (:data:`OPS`): the writer makes each line's text from its op, its point's
row text and its F value. A point held back over a chunk's end is named by a
negative index: ``RUN_SRC`` (-1) the last held-back point, ``CORNER_SRC`` (-2)
the held corner, ``HELD_SRC`` (-3) the tilt written last, whose text the writer
keeps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from . import arcs as _arcs
from . import vnorm

#: LinuxCNC's servo period [s]: a parabolic blend's next line leads by one
SERVO_PERIOD_S = 1e-3
#: the steps :func:`arc_blend_cut` samples a blend in
BLEND_STEPS = 64
#: how much a chord's pieces may slow down and speed up again (a share of their rate)
DIP_SHARE = 1e-3

#: op codes, one output line each: the first point (G0 and its row), G93, a line
#: comment, G61, G64 P, a G1 (its point, the point whose A B it writes, F), G4 P0,
#: G94 (before a program end), a machine function, a dwell (G4 P dt)
G0, G93, LINE, G61, G64, G1, G4P0, G94, FN, DWELL, ARC, PLANE = range(12)
OPS = ("G0", "G93", "LINE", "G61", "G64", "G1", "G4P0", "G94", "FN", "DWELL", "ARC", "PLANE")
#: a text kept from an earlier chunk: the last held-back point, the held corner,
#: the A B written last; NONE: no such point
RUN_SRC, CORNER_SRC, HELD_SRC, NONE = -1, -2, -3, -9
#: ``prev_idx`` of a line the writer carried over from the chunk before (its first)
CARRIED = -1

#: the float scalars of the state (``GState.f``), by index
F_NAMES = (
    "tol", "blend", "tilt_cut", "tilt_hold", "tilt_chord", "accel", "accel_deg",
    "prev_accel", "t_total", "last_speed", "peak", "trough", "plan_peak", "stretch",
    "len_sum", "dt_sum", "corner_t", "prev_len", "prev_t", "patch_f",
    "smooth", "arc_hold", "speed0", "ca_len", "ca_dt", "tilt_fit", "ca_radius",
    "prev_radius",
)  # fmt: skip
#: the integer scalars of the state (``GState.i``), by index
I_NAMES = (
    "all_exact", "n", "has_line", "last_line", "run_n", "run_src", "corner_src",
    "held_src", "exact", "after_settle", "prev_idx", "prev_turns", "prev_blend",
    "has_prev", "patch", "keep",
    "plane", "stop_at", "req_kind", "req_arc", "req_answer", "corner_arc", "ca_plane",
    "ca_from", "decimals", "corner_fit",
)  # fmt: skip
#: what the chunk did to the line carried from the chunk before (``patch``): its F
#: lowered to ``patch_f``, or a G4 P0 after it
PATCH_NONE, PATCH_F, PATCH_STOP = 0, 1, 2
#: what the kernel asks of the writer where it stops mid chunk (``i[stop_at]`` the
#: point, ``i[req_arc]`` the arc): its points from the stop as arcs again
#: (``arcs.refit_arcs``), and with ARC_TO first the arc from its start to the point
#: before as one arc (``i[req_answer]``: its index, or -1 where none fits)
REQ_REARC, REQ_ARC_TO = 1, 2
#: a chord against the points it replaces (``_Run.chord_check``): fails, passes
#: with the compensated tilt, passes with a fitted end tilt
CHORD_NO, CHORD_OK, CHORD_FIT = 0, 1, 2
#: the columns of the arcs' integer rows (``arc_i``) and float rows (``arc_f``)
A_START, A_END, A_PLANE, A_REFIT = range(4)
A_LEN, A_RADIUS = range(2)


class Scratch:
    """The op buffers of a compiled :func:`gcode_ops` call, kept for the writer's
    next call: buffers with room for a chunk's worst case (14 ops a point) of which
    a call fills about a thirtieth, and numpy asks the OS for huge pages for
    arrays this large, so a fresh set costs a 2 MiB page zeroed for each array
    touched. Holds no state: a copy or a pickle of it starts empty.

    Attributes
    ----------
    bufs : tuple or None
        ops (4, capacity) int64, val (capacity,), tilts (capacity', 2), or None.
    """

    __slots__ = ("bufs",)

    def __init__(self) -> None:
        self.bufs: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def __deepcopy__(self, memo: dict[int, object]) -> Scratch:
        return Scratch()

    def __reduce__(self) -> tuple[type[Scratch], tuple[()]]:
        return (Scratch, ())


@dataclass
class GState:
    """The writer's state between chunks (mutable; both kernels update it in place).

    f : (len(F_NAMES),) float64; i : (len(I_NAMES),) int64; last_q (5,) the last
    point written [mm, mm, mm, deg, deg]; last_ab (2,) A B written last [deg];
    held_ab (2,) the tilt held; lead0 (5,) the tables' lead at the run's first
    point [mm]; corner_q (5,) the held corner; run_q (capacity, 5) the held-back
    points (``i[run_n]`` of them); corner_in (5,) where a line into the held
    corner closing an arc would start (``_Run.arc_in``); pend_i (M, 4) int64 and
    pend_v (M,) the ops of a chunk stopped mid way (code, arg, ab, aux; val),
    pend_t (J, 2) its centered tilts [deg]; scratch, the op buffers a compiled
    call may fill again (:class:`Scratch`: no state, a copy starts without).
    """

    f: np.ndarray
    i: np.ndarray
    last_q: np.ndarray
    last_ab: np.ndarray
    held_ab: np.ndarray
    lead0: np.ndarray
    corner_q: np.ndarray
    run_q: np.ndarray
    corner_in: np.ndarray
    pend_i: np.ndarray
    pend_v: np.ndarray
    pend_t: np.ndarray
    #: the arcs a call with ``fit`` refitted itself (:func:`gcode_ops`), rows as
    #: :func:`.arcs.refit_arcs` gives them, numbered on from the call's arc_i
    fit_i: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), dtype=np.int64))
    fit_f: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    scratch: Scratch = field(default_factory=lambda: Scratch(), repr=False, compare=False)


def new_state(
    tol: float,
    blend: float,
    tilt_cut: float,
    tilt_hold: float,
    tilt_chord: float,
    accel: float,
    accel_deg: float,
    all_exact: bool,
    smooth: float = 0.0,
    arc_hold: float = 0.0,
    decimals: int = 4,
    tilt_fit: float = 0.0,
) -> GState:
    """A writer's state before its first point (module docstring; the settings'
    meanings are :class:`prsxy_post.writers.linuxcnc.GcodeWriter`'s)."""
    f = np.zeros(len(F_NAMES))
    i = np.zeros(len(I_NAMES), dtype=np.int64)
    for name, v in (
        ("tol", tol),
        ("blend", blend),
        ("tilt_cut", tilt_cut),
        ("tilt_hold", tilt_hold),
        ("tilt_chord", tilt_chord),
        ("accel", accel),
        ("accel_deg", accel_deg),
        ("prev_accel", accel),
        ("stretch", math.inf),
        ("smooth", smooth),
        ("arc_hold", arc_hold),
        ("tilt_fit", tilt_fit),
    ):
        f[F_NAMES.index(name)] = v
    for name, iv in (
        ("all_exact", int(all_exact)),
        ("exact", int(all_exact)),
        ("after_settle", 1),
        ("run_src", NONE),
        ("corner_src", NONE),
        ("held_src", NONE),
        ("prev_idx", NONE),
        ("keep", NONE),
        ("plane", 17),
        ("stop_at", NONE),
        ("req_arc", NONE),
        ("req_answer", NONE),
        ("corner_arc", NONE),
        ("ca_from", NONE),
        ("decimals", decimals),
    ):
        i[I_NAMES.index(name)] = iv
    z5 = np.zeros(5)
    return GState(
        f,
        i,
        z5.copy(),
        np.zeros(2),
        np.zeros(2),
        z5.copy(),
        z5.copy(),
        np.zeros((8, 5)),
        z5.copy(),
        np.zeros((0, 4), dtype=np.int64),
        np.zeros(0),
        np.zeros((0, 2)),
    )


def reserve(st: GState, more: int) -> None:
    """Room in ``st.run_q`` for ``more`` held-back points beyond those held."""
    n = int(st.i[I_NAMES.index("run_n")])
    if n + more > len(st.run_q):
        grown = np.zeros((max(2 * len(st.run_q), n + more), 5))
        grown[:n] = st.run_q[:n]
        st.run_q = grown


def corner_cut(
    q_in: list[float],
    q_at: list[float],
    q_out: list[float],
    t_in: float,
    t_out: float,
    accel: float,
) -> tuple[float, float]:
    """How far LinuxCNC's parabolic blend of the lines q_in → q_at → q_out may cut
    the corner at q_at: (X Y Z [mm], A B [deg]).

    Poses (5,) [mm, mm, mm, deg, deg], line times t_in, t_out [s], the path
    acceleration ``accel`` [mm/s²]. The blend lasts t = min(t_in, t_out, 2 v / a)
    at the larger X Y Z speed v, and the pose's direction per mm of X Y Z turns
    from d_in to d_out over it: |d_out − d_in| v t / 8 (lines that turn A or B
    alone: |r_out − r_in| t / 8). An upper bound with the written speeds
    (:mod:`prsxy_post.writers.linuxcnc`).
    """
    r_in = [(b - a) / t_in for a, b in zip(q_in, q_at, strict=True)]
    r_out = [(b - a) / t_out for a, b in zip(q_at, q_out, strict=True)]
    v_in, v_out = vnorm.hypot(*r_in[:3]), vnorm.hypot(*r_out[:3])
    v = max(v_in, v_out)
    t_blend = min(t_in, t_out, 2.0 * v / accel) if v > 0.0 else min(t_in, t_out)
    if v_in > 0.0 and v_out > 0.0:
        # the turn of the path's direction (per mm of X Y Z travel): a change of
        # speed along the same line cuts nothing
        turn = [(o / v_out - i / v_in) * v for i, o in zip(r_in, r_out, strict=True)]
    else:
        turn = [o - i for i, o in zip(r_in, r_out, strict=True)]
    return vnorm.hypot(*turn[:3]) * t_blend / 8.0, vnorm.hypot(*turn[3:]) * t_blend / 8.0


def line_accel(d_xyz: list[float], d_ab: list[float], accel: float, accel_deg: float) -> float:
    """A line's acceleration limit along its X Y Z path [mm/s²], as LinuxCNC's canon
    sets it: the path length over the longest time an axis takes at its own limit
    (``getStraightAcceleration``, emccanon.cc:612-721), up to √3 times the axes'
    limit on a diagonal; ``accel`` [mm/s²] and ``accel_deg`` [deg/s²] the axes'
    limits."""
    dtot = vnorm.hypot(*d_xyz)
    tmax = max(
        max(abs(d) for d in d_xyz) / accel,
        max(abs(d) for d in d_ab) / accel_deg,
    )
    return dtot / tmax if dtot > 0.0 and tmax > 0.0 else accel


def arc_blend_cut(
    len_p: float,
    t_p: float,
    a_p: float,
    r_p: float,
    len_n: float,
    t_n: float,
    a_n: float,
    r_n: float,
) -> float:
    """How far LinuxCNC's parabolic blend of a move into the next cuts the arc
    among them [mm] (the writer's module docstring, rule 5): the previous move
    ``len_p`` [mm] written to take ``t_p`` [s], its tangential acceleration
    ``a_p`` [mm/s²], an arc of least radius ``r_p`` [mm] or a line (0); the next
    ``len_n``, ``t_n``, ``a_n``, ``r_n`` the same.

    LinuxCNC starts the blend once the previous move, slowing to a stop at a_p,
    is below its blend speed v_b (``tcIsBlending``, tc.c:529-540;
    :func:`blend_speed`), so its last L₀ = v_b² / (2 a_p)
    overlap the next move, which speeds up from rest at a_n towards L_n / t_n a
    servo cycle ahead (rule 4). Their sum leaves the path where one is an arc:
    with ``a`` the arc's length from the join and ``b`` the line's (the arc's
    remaining length and the next's progress, or the arc's progress and the
    previous line's remaining length), the sum lies b (2 a − b) / (2 R) from the
    path where b < a, a² / (2 R) beyond (the arc's rise over its tangent, small
    angles: within 1 % of the exact circle's where the cut is 0.01 to 1 µm,
    tests/test_kernel_gwrite.py); the two rises summed where both are arcs. The
    cut is the largest over ``BLEND_STEPS`` instants of the blend; measured: a
    R0.22 arc into a line turning A ran 9.8 µm off on LinuxCNC, 9.86 µm here.
    """
    if t_p <= 0.0 or t_n <= 0.0 or len_p <= 0.0 or len_n <= 0.0:
        return 0.0
    v_n = len_n / t_n
    v_b = blend_speed(len_p, t_p, a_p, len_n, t_n, a_n)
    overlap = v_b * v_b / (2.0 * a_p)
    cut = 0.0
    step = v_b / a_p / BLEND_STEPS
    for k in range(BLEND_STEPS + 1):
        t = k * step
        left = max(overlap - v_b * t + a_p * t * t / 2.0, 0.0)
        tn = t + SERVO_PERIOD_S
        if a_n * tn < v_n:
            gone = a_n * tn * tn / 2.0
        else:
            gone = v_n * tn - v_n * v_n / (2.0 * a_n)
        gone = min(gone, len_n)
        e = 0.0
        if r_p > 0.0:
            e += _rise(left, gone, r_p)
        if r_n > 0.0:
            e += _rise(gone, left, r_n)
        cut = max(cut, e)
    return cut


def blend_speed(
    len_p: float, t_p: float, a_p: float, len_n: float, t_n: float, a_n: float
) -> float:
    """The speed v_b [mm/s] below which LinuxCNC starts a parabolic blend of a move
    ``len_p`` [mm] written to take ``t_p`` [s], tangential acceleration ``a_p``
    [mm/s²], into the next (``len_n``, ``t_n``, ``a_n``; all > 0):

        v_b = min(v̂_p, a_p t_b),  t_b = min(L_p / v̂_p, L_n / v̂_n, max(v̂_p / a_p, v̂_n / a_n))

    with v̂ = min(L / t, √(a L)) (``tpComputeBlendVelocity``, tp.c:2209-2247;
    ``tpCalculateTriangleVel``, tp.c:757-766). :func:`arc_blend_cut`'s timing."""
    reach_p = min(len_p / t_p, math.sqrt(a_p * len_p))
    reach_n = min(len_n / t_n, math.sqrt(a_n * len_n))
    t_b = min(min(len_p / reach_p, len_n / reach_n), max(reach_p / a_p, reach_n / a_n))
    return min(reach_p, t_b * a_p)


def _rise(a: float, b: float, radius: float) -> float:
    """How far the sum of a move along an arc, ``a`` [mm] from the join, and one
    along its tangent, ``b`` [mm] from it, lies from the arc and the tangent
    (:func:`arc_blend_cut`)."""
    return (b * (2.0 * a - b) if b < a else a * a) / (2.0 * radius)


class _Run:
    """The reference's working state: :class:`GState` as Python floats and lists,
    and the ops written so far."""

    # GState.f's and .i's scalars (F_NAMES, I_NAMES)
    tol: float
    blend: float
    tilt_cut: float
    tilt_hold: float
    tilt_chord: float
    accel: float
    accel_deg: float
    prev_accel: float
    t_total: float
    last_speed: float
    peak: float
    trough: float
    plan_peak: float
    stretch: float
    len_sum: float
    dt_sum: float
    corner_t: float
    prev_len: float
    prev_t: float
    patch_f: float
    smooth: float
    arc_hold: float
    speed0: float
    ca_len: float
    ca_dt: float
    tilt_fit: float
    ca_radius: float
    prev_radius: float
    all_exact: int
    n: int
    has_line: int
    last_line: int
    run_n: int
    run_src: int
    corner_src: int
    held_src: int
    exact: int
    after_settle: int
    prev_idx: int
    prev_turns: int
    prev_blend: int
    has_prev: int
    patch: int
    keep: int
    plane: int
    stop_at: int
    req_kind: int
    req_arc: int
    req_answer: int
    corner_arc: int
    ca_plane: int
    ca_from: int
    decimals: int
    corner_fit: int

    def __init__(self, st: GState) -> None:
        for name, v in zip(F_NAMES, st.f.tolist(), strict=True):
            setattr(self, name, v)
        for name, iv in zip(I_NAMES, st.i.tolist(), strict=True):
            setattr(self, name, iv)
        self.last_q: list[float] = st.last_q.tolist()
        self.last_ab: list[float] = st.last_ab.tolist()
        self.held_ab: list[float] = st.held_ab.tolist()
        self.lead0: list[float] = st.lead0.tolist()
        self.corner_q: list[float] = st.corner_q.tolist()
        self.run: list[list[float]] = st.run_q[: self.run_n].tolist()
        self.corner_in: list[float] = st.corner_in.tolist()
        # a chunk stopped mid way (stop_at) goes on with its ops so far
        pend = st.pend_i.T.tolist() if self.stop_at != NONE else [[], [], [], []]
        self.code: list[int] = pend[0]
        self.arg: list[int] = pend[1]
        self.ab: list[int] = pend[2]
        self.aux: list[int] = pend[3]
        self.val: list[float] = st.pend_v.tolist() if self.stop_at != NONE else []
        self.tilts: list[list[float]] = st.pend_t.tolist() if self.stop_at != NONE else []
        # the chunk's points and arcs (gcode_ops sets them)
        self.q: list[list[float]] = []
        self.dt: list[float] = []
        self.arc_of: list[int] = []
        self.arc_i: list[list[int]] = []
        self.arc_f: list[list[float]] = []

    def store(self, st: GState) -> None:
        self.run_n = len(self.run)
        st.f[:] = [getattr(self, n) for n in F_NAMES]
        st.i[:] = [int(getattr(self, n)) for n in I_NAMES]
        st.last_q[:] = self.last_q
        st.last_ab[:] = self.last_ab
        st.held_ab[:] = self.held_ab
        st.lead0[:] = self.lead0
        st.corner_q[:] = self.corner_q
        if self.run:
            st.run_q[: self.run_n] = self.run
        st.corner_in[:] = self.corner_in
        if self.stop_at != NONE:
            st.pend_i = np.array([self.code, self.arg, self.ab, self.aux], dtype=np.int64).T
            st.pend_v = np.array(self.val, dtype=np.float64)
            st.pend_t = np.array(self.tilts, dtype=np.float64).reshape(-1, 2)
        else:
            st.pend_i = np.zeros((0, 4), dtype=np.int64)
            st.pend_v, st.pend_t = np.zeros(0), np.zeros((0, 2))

    def emit(self, code: int, arg: int = 0, ab: int = 0, val: float = 0.0, aux: int = 0) -> None:
        self.code.append(code)
        self.arg.append(arg)
        self.ab.append(ab)
        self.val.append(val)
        self.aux.append(aux)

    # the decisions, in the order and arithmetic the writer made them

    def piece(self, qk: list[float], dtk: float) -> tuple[float, float]:
        """The piece from the last held-back (or written) point to qk: (length, rate)."""
        prev = self.run[-1] if self.run else self.last_q
        step = vnorm.dist(prev, qk)
        return step, (step / dtk if dtk > 0.0 else 0.0)

    def dips(self, qk: list[float], dtk: float, lead: list[float]) -> bool:
        """Would the piece to qk speed up again after the held-back pieces slowed
        down, or move what the real-axis tables add to a motor by more than ``tol``
        (a motor crossing its play, whose timing its points carry)? A chord is timed
        at its fastest piece (``chord_time``): it may hold a rise and a fall of the
        planned speed, not a dip."""
        if not self.run:
            return False
        _, rate = self.piece(qk, dtk)
        moved = max(abs(a - b) for a, b in zip(lead, self.lead0, strict=True))
        dip = self.trough < self.peak * (1.0 - DIP_SHARE) and rate > self.trough * (1.0 + DIP_SHARE)
        return dip or moved > self.tol

    def hold(self, k: int, qk: list[float], dtk: float, lead: list[float], plan: float) -> None:
        """Hold back the point k, qk (its piece's time dtk, the tables' lead, the
        plan's mean speed over the piece)."""
        prev = self.run[-1] if self.run else self.last_q
        step, rate = self.piece(qk, dtk)
        if not self.run:
            self.peak, self.trough, self.lead0 = 0.0, 0.0, lead
            self.plan_peak, self.stretch = 0.0, math.inf
            self.len_sum, self.dt_sum = 0.0, 0.0
        self.len_sum += step
        self.dt_sum += dtk
        xyz_rate = vnorm.dist(prev[:3], qk[:3]) / dtk if dtk > 0.0 else 0.0
        if plan > 0.0 and xyz_rate > 0.5 * plan:
            # a piece that moves X Y Z about as planned (not a turn of A or B alone,
            # planned in degrees per second): how far it stretches the planned path
            self.plan_peak = max(self.plan_peak, plan)
            self.stretch = min(self.stretch, xyz_rate / plan)
        if rate >= self.peak:
            self.peak = self.trough = rate
        else:
            self.trough = min(self.trough, rate)
        self.run.append(qk)
        self.run_src = k

    def chord_time(self, arc_mm: float = 0.0) -> float:
        """The time of the chord through the held-back points: its length at the rate
        of its fastest piece, and its X Y Z no faster than the plan's fastest speed
        times the least stretch of its pieces. LinuxCNC speeds up and slows down
        along a line by its own acceleration limit (the profile's, as the plan's); a
        line between stops timed at its mean speed cruised at the mean, below the
        plan's speed. The pieces' lengths and times are summed left to right. An
        arc's X Y Z run ``arc_mm`` [mm], its length, rather than the chord's."""
        length, total = self.len_sum, self.dt_sum
        if len(self.run) == 1 or self.peak <= 0.0 or length <= 0.0:
            return total
        t = min(total, length / self.peak)
        if self.plan_peak > 0.0 and self.run and self.n > 0:
            # LinuxCNC runs the chord's X Y Z at one speed; where a piece stretches
            # the planned path less than another, the tool ran faster than planned
            # there: no faster than the plan's fastest speed on the piece that
            # stretches least
            xyz = max(vnorm.dist(self.last_q[:3], self.run[-1][:3]), arc_mm)
            t = max(t, xyz / (self.plan_peak * self.stretch))
        return t

    def within(self, qk: list[float]) -> bool:
        """Would the chord from the last written point to qk pass the held-back points,
        within ``tol`` in X Y Z and ``tilt_chord`` in A and B, or, where A and B
        stray further, within ``tol`` and a fitted end tilt (``fit_tilt``)?"""
        return self.chord_check(qk, self.run)[0] != CHORD_NO

    def chord_check(self, qk: list[float], pts: list[list[float]]) -> tuple[int, list[float]]:
        """The chord from the last written point to qk against the points ``pts``:
        CHORD_NO, CHORD_OK (within ``tol`` in X Y Z and ``tilt_chord`` in A and B of
        the compensated chord) or CHORD_FIT (X Y Z within ``tol``, A and B within
        ``tilt_fit`` of a line from the tilt written last to a fitted end tilt),
        with that end tilt (``fit_tilt``; empty unless CHORD_FIT).

        Each point p is taken at its nearest place along the chord a + t d,
        t = clip((p − a)·d / d·d, 0, 1) (A and B read as mm at 1 mm per degree), and
        its offset |p − (a + t d)| judged. The dot products exactly rounded
        (``math.fsum``), so that the twin can give the same bits."""
        if not pts or self.n == 0:
            return CHORD_OK, []
        a = self.last_q
        d = [x - y for x, y in zip(qk, a, strict=True)]
        dd = math.fsum(x * x for x in d)
        if dd == 0:
            return CHORD_NO, []
        tol, tilt = self.tol, self.tilt_chord
        tilt_ok = True
        for p in pts:
            t = math.fsum((x - y) * z for x, y, z in zip(p, a, d, strict=True)) / dd
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
            off = [abs(x - (y + t * z)) for x, y, z in zip(p, a, d, strict=True)]
            if math.sqrt(off[0] * off[0] + off[1] * off[1] + off[2] * off[2]) > tol:
                return CHORD_NO, []
            if off[3] > tilt or off[4] > tilt:
                if self.tilt_fit <= 0.0:
                    return CHORD_NO, []  # no fit (machines with play): no need to go on
                tilt_ok = False
        if tilt_ok:
            return CHORD_OK, []
        fit = self.fit_tilt(qk, pts)
        return (CHORD_FIT, fit) if fit else (CHORD_NO, [])

    def fit_tilt(self, qk: list[float], pts: list[list[float]]) -> list[float]:
        """The end tilt [deg] of the line from the last written point (its written
        tilt s) to qk that keeps A and B of qk and of every point p within h =
        ``tilt_fit`` (less the written value's rounding) of the line's, LinuxCNC
        moving A and B in proportion to X Y Z along a line (``tcGetPosReal``): with
        τ_p = (p − a)·d / d·d in X Y Z (clipped to [0, 1]), the end e keeps
        |p_A − s − τ_p (e − s)| ≤ h for each p and |qk_A − e| ≤ h, an interval of
        e (its Chebyshev fit, the end shared with the next line); the value
        nearest qk's own in it. Empty where none does (or h is 0: machines with
        play, which keep the tilt as compensated)."""
        h = self.tilt_fit - 0.5 / 10.0**self.decimals
        if h <= 0.0:
            return []
        a = self.last_q
        d = [qk[0] - a[0], qk[1] - a[1], qk[2] - a[2]]
        dd = math.fsum(x * x for x in d)
        if dd == 0:
            return []
        taus = []
        for p in pts:
            tau = math.fsum((p[j] - a[j]) * d[j] for j in range(3)) / dd
            taus.append(0.0 if tau < 0.0 else (1.0 if tau > 1.0 else tau))
        out = []
        for c in range(2):
            s = self.last_ab[c]
            own = qk[3 + c] - s
            lo, hi = own - h, own + h
            for p, tau in zip(pts, taus, strict=True):
                r = p[3 + c] - s
                if tau > 0.0:
                    lo = max(lo, (r - h) / tau)
                    hi = min(hi, (r + h) / tau)
                elif abs(r) > h:
                    return []
            if lo > hi:
                return []
            out.append(s + min(max(own, lo), hi))
        return out

    def fit_end(self, qk: list[float], pts: list[list[float]]) -> list[float]:
        """The fitted end tilt of the chord to qk over ``pts`` where only a fit
        passes them (``chord_check``, which made it), else empty (qk's own tilt, or
        the one held)."""
        verdict, fit = self.chord_check(qk, pts)
        return fit if verdict == CHORD_FIT else []

    def write_held(self) -> None:
        """Write the last held-back point (it becomes the new chord start)."""
        if not self.run:
            return
        qh, src = self.run[-1], self.run_src
        fit = self.fit_end(qh, self.run[:-1])
        t = self.chord_time()
        self.run = []
        self.g1(src, qh, t, False, fit=fit)  # only points in motion are held back

    def at_rest(self) -> None:
        """A machine function or a dwell follows: LinuxCNC blends nothing across it."""
        if self.has_prev:
            self.prev_blend = 0

    def resolve_corner(self, q_next: list[float] | None, dt_next: float) -> None:
        """Write the held block end, in G61 where LinuxCNC's parabolic blend would
        cut the corner there by more than ``blend`` in X Y Z or ``tilt_cut`` in A
        and B (the writer's module docstring)."""
        if self.corner_src == NONE:
            return
        qc, t, src = self.corner_q, self.corner_t, self.corner_src
        self.corner_src = NONE
        # an arc's end: the corner is its last piece's (rule 5)
        arc, q_in, t_in = self.corner_arc, self.last_q, t
        if arc != NONE:
            q_in, t_in = self.corner_in, self.ca_dt
        self.corner_arc = NONE
        fit = qc[3:5] if self.corner_fit else []
        self.corner_fit = 0
        exact = False
        if q_next is not None and self.n > 0 and dt_next > 0.0:
            mm, deg = corner_cut(q_in, qc, q_next, t_in, dt_next, self.accel)
            exact = mm > self.blend or deg > self.tilt_cut
        radius = self.ca_radius if arc != NONE else 0.0
        self.g1(src, qc, t, exact, arc, self.ca_len, self.ca_plane, fit, radius)

    def tilt_held(self, src: int, q: list[float], hold: float) -> int:
        """The point whose A and B the line to ``q`` (the point ``src``) writes: the
        tilt last written while q's is within ``hold`` of it (``tilt_hold``, an arc's
        ``arc_hold``: a line that moves A or B by any amount LinuxCNC blends
        parabolically), else q's own."""
        if self.held_src != NONE:
            ab = self.held_ab
            if abs(q[3] - ab[0]) <= hold and abs(q[4] - ab[1]) <= hold:
                return int(self.held_src)
        self.held_ab = q[3:5]
        self.held_src = src
        return src

    def g1(
        self,
        src: int,
        q: list[float],
        t: float,
        exact: bool,
        arc: int = NONE,
        arc_len: float = 0.0,
        plane: int = 17,
        fit: list[float] | None = None,
        radius: float = 0.0,
    ) -> None:
        """Write the line to ``q`` (the point ``src``) taking ``t`` seconds, in G61
        where ``exact`` (a line ending where the motion stands, or at a corner
        LinuxCNC's blend would cut too far), else in G64 P. Where LinuxCNC would
        blend the line before into this one parabolically, that line is slowed down
        or stopped (``blend_within_f``), and an exact line goes in G64 P, its G4 P0
        stopping it all the same (the writer's module docstring, rule 4). With
        ``arc`` (an arc's index, or CORNER_SRC: the held corner's), the move is that
        G2/G3 of ``arc_len`` [mm] in ``plane`` (rule 5), its least ``radius`` [mm],
        its acceleration limit the axes' (emccanon.cc:1783-1791); where LinuxCNC
        would blend an arc and a line parabolically, the line before stops there if
        the blend would cut the arc by more than ``blend`` (:func:`arc_blend_cut`).
        With ``fit`` (a chord's fitted end tilt, ``fit_tilt``) the line writes that
        tilt, rounded as written: a new row of the chunk's tilts."""
        exact = exact or bool(self.all_exact)
        if fit:
            value = np.round(np.asarray(fit, dtype=float), self.decimals) + 0.0
            self.held_ab = value.tolist()
            self.held_src = ab_src = len(self.q) + len(self.tilts)
            self.tilts.append(self.held_ab)
        else:
            ab_src = self.tilt_held(src, q, self.tilt_hold if arc == NONE else self.arc_hold)
        turns = self.held_ab != self.last_ab
        length = vnorm.dist(self.last_q[:3], q[:3]) if arc == NONE else arc_len
        ab_now = list(self.held_ab)
        accel = line_accel(
            [b - a for a, b in zip(self.last_q[:3], q[:3], strict=True)],
            [b - a for a, b in zip(self.last_ab, ab_now, strict=True)],
            self.accel,
            self.accel_deg,
        )
        if arc != NONE:
            accel = self.accel
        self.last_ab = ab_now
        # LinuxCNC blends the line before into this one parabolically where it was
        # written in G64 P (no G4 P0 after it) and one of the two turns A or B
        if self.has_prev and self.prev_blend and (self.prev_turns or turns):
            # this line's own acceleration is halved where its end is a parabolic
            # join too: it turns A or B, or it is exact (G64 P and G4 P0, below)
            a_n = accel / 2.0 if turns or exact else accel
            if self.arc_cut(length, t, a_n, radius) > self.blend:
                self.stop_prev()
            else:
                self.blend_within_f(length, t, a_n)
        parabolic = self.has_prev and self.prev_blend and (self.prev_turns or turns)
        # the first line after a dwell runs in G61 too: LinuxCNC refills its queue
        # while it runs
        mode = (exact or bool(self.after_settle)) and not (
            exact and parabolic and not self.all_exact
        )
        if mode != bool(self.exact):
            self.emit(G61 if mode else G64)
            self.exact = int(mode)
        if arc == NONE:
            self.emit(G1, src, ab_src, 60.0 / t)
        else:
            if plane != self.plane:
                self.emit(PLANE, 0, 0, 0.0, plane)
                self.plane = plane
            self.emit(ARC, src, ab_src, 60.0 / t, arc)
        self.has_prev, self.prev_idx, self.prev_len, self.prev_t = 1, len(self.code) - 1, length, t
        self.prev_turns, self.prev_blend = int(turns), int(not mode and not exact)
        self.prev_accel, self.prev_radius = accel, radius
        self.after_settle = int(exact)
        if exact:
            # LinuxCNC ends a line mid servo cycle and starts the next in the same
            # cycle; a dwell waits for the motion to end
            self.emit(G4P0)
        self.last_q = q
        self.n += 1

    def blend_within_f(self, length_n: float, t_n: float, a_n: float) -> None:
        """Keep LinuxCNC's parabolic blend of the previous line into the next one
        (``length_n`` [mm] in ``t_n`` [s], speeding up at ``a_n`` [mm/s²])
        within the larger of the two lines' written speeds: lower the previous
        line's F, or, where that costs more time than a stop or where either line
        is shorter than the blend, stop it there (G4 P0 after it, the next line in
        G61).

        The previous line slows down at a_t = a / 2 from v0 (at most its own
        speed v_p), the next speeds up towards v_n at a_n (a / 2 or a) from a
        servo cycle T earlier: their sum peaks at v0 + v_n (1 − a_t / a_n) + a_t T
        (the writer's module docstring, rule 4). So v_p ≤ max(v_p, v_n) − v_n
        (1 − a_t / a_n) − a_t T.
        """
        idx, length, t = self.prev_idx, self.prev_len, self.prev_t
        if idx == NONE or t <= 0.0 or length <= 0.0:
            return
        v_p = length / t
        v_n = length_n / t_n if t_n > 0.0 else 0.0
        a_t = self.prev_accel / 2.0
        v = max(v_p, v_n)
        # a blend lasts v / a_t, and the line after it stops or blends again: a line
        # shorter than twice that overlaps the blends, and the next leads by up to a
        # cycle more (1.026 x F on a helix of 9 ms chords at F600 with one cycle's
        # lead; 1.025 x F on pocket.ngc's helix of 8.5 ms chords at F400, blend 6.7 ms)
        lead = SERVO_PERIOD_S * (2.0 if min(t, t_n) < 2.0 * v / a_t else 1.0)
        if a_n >= a_t:
            v_safe = v - v_n * (1.0 - a_t / a_n) - a_t * lead
        else:
            v_safe = v - a_n * lead
        if v_safe >= v_p:
            return
        # the time a stop costs: the previous line slows down at a_t, the next
        # (G61) speeds up from rest at a and stops at its end, the one after it
        # speeds up again
        stop_s = v / (2.0 * a_t) + 3.0 * v / (2.0 * 2.0 * a_t)
        slow_s = t * (v_p / v_safe - 1.0) if v_safe > 0.0 else math.inf
        if slow_s <= stop_s:
            f = 60.0 * v_safe / length
            if idx == CARRIED:  # the line carried from the chunk before
                self.patch, self.patch_f = PATCH_F, f
            else:
                self.val[idx] = f
        else:
            self.stop_prev()

    def stop_prev(self) -> None:
        """Stop the previous line at its end: G4 P0 after it (still in G64 P: its
        end has no next line to blend with, as the task waits), the next line in
        G61."""
        idx = self.prev_idx
        if idx == CARRIED:
            self.patch = PATCH_STOP
        elif idx != NONE:
            self.code.insert(idx + 1, G4P0)
            self.arg.insert(idx + 1, 0)
            self.ab.insert(idx + 1, 0)
            self.val.insert(idx + 1, 0.0)
            self.aux.insert(idx + 1, 0)
        self.after_settle = 1
        self.prev_idx, self.prev_blend = NONE, 0

    def arc_cut(self, length_n: float, t_n: float, a_n: float, radius_n: float) -> float:
        """How far LinuxCNC's parabolic blend of the previous move into the next
        (``length_n`` [mm] in ``t_n`` [s], speeding up at ``a_n`` [mm/s²], an arc
        of least radius ``radius_n`` [mm] or a line: 0) would cut an arc among
        them [mm]; 0 where neither is an arc (:func:`arc_blend_cut`)."""
        if self.prev_idx == NONE or (self.prev_radius <= 0.0 and radius_n <= 0.0):
            return 0.0
        # LinuxCNC's tangential acceleration of an arc is half its limit
        # (tcGetTangentialMaxAccel, tc.c:73-85), halved again at a parabolic join
        a_p = self.prev_accel / (4.0 if self.prev_radius > 0.0 else 2.0)
        a_next = a_n / 2.0 if radius_n > 0.0 else a_n
        return arc_blend_cut(
            self.prev_len, self.prev_t, a_p, self.prev_radius, length_n, t_n, a_next, radius_n
        )

    def hand_out(self) -> None:
        """The call's end: the last line waits for the next chunk (``keep``: its op,
        or CARRIED, the line carried in) where LinuxCNC may blend it into the next
        line, whose F or stop that line decides; else ``keep`` is NONE."""
        if self.has_prev and self.prev_blend and self.prev_idx != NONE:
            self.keep, self.prev_idx = self.prev_idx, CARRIED
        else:
            self.keep, self.prev_idx = NONE, NONE
        # the points the next chunk may name: the state holds them (held_ab,
        # corner_q, the run's last row), the writer keeps their text
        if self.run_src >= 0:
            self.run_src = RUN_SRC
        if self.corner_src >= 0:
            self.corner_src = CORNER_SRC
        # the arc the held corner closes: the writer keeps it (ca_from its index)
        self.ca_from = NONE
        if self.corner_arc >= 0:
            self.ca_from, self.corner_arc = self.corner_arc, CORNER_SRC
        if self.held_src != NONE:
            self.held_src = HELD_SRC

    # arcs (the writer's module docstring, rule 5)

    def arc_time(self, a: int) -> float:
        """The held-back points' time as the arc ``a``: a chord's (``chord_time``)
        with the arc's length, and no faster than LinuxCNC's smoothing allows: its
        commanded path runs (7/24) (v T)² / R inside an arc of radius R at the speed
        v, within ``smooth`` where v ≤ √(24 R smooth / 7) / T."""
        length, radius = self.arc_f[a][A_LEN], self.arc_f[a][A_RADIUS]
        t = self.chord_time(length)
        if self.smooth > 0.0 and radius > 0.0:
            v = math.sqrt(24.0 * radius * self.smooth / 7.0) / SERVO_PERIOD_S
            t = max(t, length / v)
        return t

    def arc_in(
        self, a: int, t: float, q_before: list[float], q_end: list[float], dt: float
    ) -> list[float]:
        """Where a line into the arc's end would start to arrive in ``dt`` at the
        arc's written speed, along its last piece: its corner is judged as if
        LinuxCNC ran the end at the arc's speed."""
        d = [b - x for x, b in zip(q_before, q_end, strict=True)]
        n = vnorm.hypot(*d[:3])
        if n <= 0.0 or t <= 0.0:
            return q_before
        step = self.arc_f[a][A_LEN] / t * dt / n
        return [e - x * step for e, x in zip(q_end, d, strict=True)]

    def center_tilt(self, a: int) -> bool:
        """Before a run of arcs whose start is still held back: hold A and B from
        its start at the value nearest the one held that covers the run's tilt
        within ``arc_hold`` and its ends' within ``tilt_hold`` (or, where none
        does, at the start's moved towards the run's end by that much), so that the
        arcs turn them as seldom as possible (rule 5). The line to the start writes
        it; the value is a new row of the chunk's tilts (its ``ab``: N + row)."""
        if self.tilt_hold <= 0.0 or self.held_src == NONE or not self.run:
            return False
        start, end = self.arc_i[a][A_START], self.arc_i[a][A_END]
        if self.run[-1] != self.q[start]:
            return False
        n = len(self.q)
        while end + 1 < n and self.arc_of[end + 1] >= 0:
            nxt = self.arc_i[self.arc_of[end + 1]]
            if nxt[A_START] != end:
                break
            end = nxt[A_END]
        q = np.asarray(self.q)
        ab = q[start : end + 1, 3:5]
        lo, hi = ab.min(axis=0), ab.max(axis=0)
        held = np.asarray(self.held_ab, dtype=float)
        # within arc_hold of every point, and within tilt_hold of the start and of
        # the end and the point after it (the lines to the start and from the end
        # are chords: a chord that turned A or B into a stop slowed LinuxCNC's arc)
        ends = q[[start, end, min(end + 1, n - 1)], 3:5]
        low = np.maximum(hi - self.arc_hold, ends.max(axis=0) - self.tilt_hold)
        high = np.minimum(lo + self.arc_hold, ends.min(axis=0) + self.tilt_hold)
        if np.all(held >= low) and np.all(held <= high):
            return False  # the tilt held covers the run
        margin = 0.001 * self.tilt_hold  # the written value's rounding
        loose = len(self.run) == 1 and bool(np.any(low + margin > high - margin))
        if loose:
            # none does, and the line to the start is one piece (no point between to
            # stray from it): the start, an arc's point, may stay arc_hold from the
            # value as the others; the end and the point after it within tilt_hold
            # still (a line from the end that turned A or B halved the last arc's
            # acceleration, tcGetOverallMaxAccel: 1.08 x the plan on a helix)
            tail = q[[end, min(end + 1, n - 1)], 3:5]
            low = np.maximum(hi - self.arc_hold, tail.max(axis=0) - self.tilt_hold)
            high = np.minimum(lo + self.arc_hold, tail.min(axis=0) + self.tilt_hold)
        value = np.where(
            low + margin <= high - margin,
            np.clip(held, low + margin, high - margin),
            ab[0] + np.sign(ab[-1] - ab[0]) * (self.tilt_hold - margin),
        )
        value = np.round(value, self.decimals) + 0.0
        self.held_ab = value.tolist()
        self.held_src = n + len(self.tilts)
        self.tilts.append(self.held_ab)
        return loose

    def tilt_leaves(self, qk: list[float]) -> bool:
        """Would the point qk's A or B be written anew on an arc? Never where the
        tilt is not held (a machine with play: every line turns it)."""
        if self.arc_hold <= 0.0 or self.held_src == NONE:
            return False
        ab = self.held_ab
        return abs(qk[3] - ab[0]) > self.arc_hold or abs(qk[4] - ab[1]) > self.arc_hold

    def write_arc_to(self, k: int, part: int) -> None:
        """Write the held-back points of the arc up to the point before k as the arc
        ``part`` (the writer's refit from the arc's start), or, where none fits
        (``part`` < 0), each as a line of its own piece."""
        if not self.run:
            return
        if part >= 0:
            qh, src = self.run[-1], self.run_src
            t = self.arc_time(part)
            self.run = []
            self.g1(
                src,
                qh,
                t,
                False,
                part,
                self.arc_f[part][A_LEN],
                self.arc_i[part][A_PLANE],
                radius=self.arc_f[part][A_RADIUS],
            )
            return
        held, self.run = self.run, []
        first = k - len(held)  # the held points are the arc's, up to k - 1
        for j, qh in enumerate(held):
            self.g1(first + j, qh, self.dt[first + j], False)

    def on_arc(
        self, k: int, qk: list[float], dtk: float, lead: list[float], plan: float, bend: bool
    ) -> bool:
        """The point k on an arc after its start: held back, the arc written at its
        end (held as the corner at a block's end). True where the writer must refit
        first (``stop_at``, ``req_kind``, ``req_arc``): the arc starts after a stop
        or where the line to its start was not written, or A or B leave the held
        tilt here (the arc ends a point before, a line of one piece turns them)."""
        a = self.arc_of[k]
        start, end, plane, refit = self.arc_i[a]
        if k == start + 1:
            if self.center_tilt(a):
                # the line to the start writes the value, further than tilt_hold
                # from the start's own (a line of one piece: center_tilt)
                qh, src = self.run[-1], self.run_src
                t = self.chord_time()
                self.run = []
                self.g1(src, qh, t, False, fit=list(self.held_ab))
            self.write_held()  # the arc starts where a line ends
            # the line after a stop runs in G61: one piece, and the arc from its end
            settled = self.after_settle and not self.all_exact and not refit
            if settled or self.last_q != self.q[start]:
                self.stop_at, self.req_kind, self.req_arc = k, REQ_REARC, a
                return True
        elif self.tilt_leaves(qk):
            self.stop_at, self.req_kind, self.req_arc = k, REQ_ARC_TO, a
            return True
        self.hold(k, qk, dtk, lead, plan)
        if k == end:
            t = self.arc_time(a)
            self.run = []
            if bend:  # its corner is known with the next point
                self.corner_q, self.corner_t, self.corner_src = qk, t, k
                self.corner_arc, self.ca_dt = a, dtk
                self.ca_len, self.ca_plane = self.arc_f[a][A_LEN], plane
                self.ca_radius = self.arc_f[a][A_RADIUS]
                self.corner_in = self.arc_in(a, t, self.q[k - 1], qk, dtk)
            else:
                self.g1(
                    k, qk, t, False, a, self.arc_f[a][A_LEN], plane, radius=self.arc_f[a][A_RADIUS]
                )
        return False

    def point(self, k: int, row: tuple, resume: bool) -> bool:
        """The writer's loop body for the point k (``row``: its values); with
        ``resume``, from where the writer answered its request. True where it stops
        for a request (``on_arc``)."""
        qk, dtk, line, spd, bend, fn, fn_end, dwell, lead, plan = row
        if resume:
            if self.req_kind == REQ_ARC_TO:
                self.write_arc_to(k, self.req_answer)
            self.stop_at = self.req_kind = NONE
            return self.chords(k, qk, dtk, spd, bend, lead, plan)
        if self.n == 0:
            self.emit(G0, k)
            self.emit(G93)
            self.last_ab = qk[3:5]
            self.last_q = qk
            self.n = 1
            return False
        if self.corner_src != NONE:
            self.resolve_corner(qk, dtk)
        if not self.has_line or line != self.last_line:
            self.emit(LINE, k)
            self.has_line, self.last_line = 1, line
        self.t_total += dtk
        if fn:
            self.write_held()
            self.at_rest()
            if fn_end:
                self.emit(G94)
            self.emit(FN, k)
            return False
        if dwell and qk == self.last_q:  # the pose stands: a dwell
            self.write_held()
            self.at_rest()
            self.emit(DWELL, k)
            return False
        if self.arc_of and self.arc_of[k] >= 0:
            return self.on_arc(k, qk, dtk, lead, plan, bend)
        return self.chords(k, qk, dtk, spd, bend, lead, plan)

    def chords(
        self,
        k: int,
        qk: list[float],
        dtk: float,
        spd: float,
        bend: bool,
        lead: list[float],
        plan: float,
    ) -> bool:
        """The point k off arcs: held back while a chord passes the held points, else
        written (a block's end held as the corner)."""
        if self.tol > 0 and not bend and spd > 0:
            if not self.within(qk) or self.dips(qk, dtk, lead):
                self.write_held()
            self.hold(k, qk, dtk, lead, plan)
            return False
        if self.run and (not self.within(qk) or self.dips(qk, dtk, lead)):
            self.write_held()
        self.hold(k, qk, dtk, lead, plan)
        fit = self.fit_end(qk, self.run[:-1])
        t = self.chord_time()
        self.run = []
        if spd > 0.0 and bend:
            # the corner's fitted tilt (if any) rides in its pose
            self.corner_q, self.corner_t, self.corner_src = qk[:3] + fit if fit else qk, t, k
            self.corner_fit = int(bool(fit))
            return False
        self.g1(k, qk, t, spd == 0.0, fit=fit)
        return False


Ops = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]


def gcode_ops(
    st: GState,
    q: np.ndarray,
    dt: np.ndarray,
    line: np.ndarray,
    speed: np.ndarray,
    block_end: np.ndarray,
    fn: np.ndarray,
    fn_end: np.ndarray,
    dwell: np.ndarray,
    lead: np.ndarray,
    end: bool,
    arc_of: np.ndarray | None = None,
    arc_i: np.ndarray | None = None,
    arc_f: np.ndarray | None = None,
    fit: tuple[float, float, int] | None = None,
) -> Ops:
    """A chunk's points decided: one op per output line.

    q (N, 5) the written poses [mm, mm, mm, deg, deg] (rounded as written); dt (N,)
    each point's segment time [s]; line (N,) int64 the source lines; speed (N,)
    the plan's speed at each point; block_end, fn (a machine function there),
    fn_end (it ends the program), dwell (N,) bool; lead (N, 5) what the real-axis
    tables add to each motor [mm]. ``end``: after the points, the program's end
    (the held corner and points written). ``st`` is updated in place: the line
    carried in from the chunk before (the writer's first, it waits for this
    chunk) lowered or stopped in ``i[patch]``, ``f[patch_f]`` (the writer clears
    it); the line that waits for the next chunk in ``i[keep]`` (its op, or
    CARRIED still, or NONE: none waits).

    Arcs (rule 5; the writer finds them, ``writers.arcs.find_arcs``): arc_of (N,)
    int64 the arc each point lies on after its start (-1: none); arc_i (M, 4)
    int64 each arc's start, end, plane and whether it is a refit (:data:`A_START`
    ...); arc_f (M, 2) its X Y Z length [mm] and least radius [mm]. Where the
    writer must refit (``i[stop_at]`` ≥ 0: :data:`REQ_REARC`, :data:`REQ_ARC_TO`)
    the call returns no ops; the writer answers (changing arc_of, adding arcs) and
    calls again with the same points: the chunk goes on from there. With ``fit`` (tol_mm,
    tol_deg, decimals) it refits itself (:func:`refit`; the arcs in ``st.fit_i``, ``fit_f``).

    Returns
    -------
    code, arg, ab, aux : (M,) int64
        Each line's op (:data:`OPS`), its point (a G1's, an ARC's, a G0's, a line
        comment's, a machine function's, a dwell's; :data:`RUN_SRC` /
        :data:`CORNER_SRC` for one kept from a chunk before), a G1's or an ARC's
        point whose A B it writes (or :data:`HELD_SRC`; N + j: the j-th centered
        tilt), an ARC's arc (CORNER_SRC: the one the writer kept) or a PLANE's
        plane (17, 18, 19).
    val : (M,) float64
        A G1's or an ARC's F (inverse time [1/min]).
    tilts : (J, 2) float64
        The tilts held before runs of arcs (``_Run.center_tilt``) and the chords'
        fitted end tilts (``_Run.fit_tilt``) [deg].
    """
    r = _Run(st)
    resume = r.stop_at != NONE
    k0 = r.stop_at if resume else 0
    if not resume:
        r.speed0 = r.last_speed
        if len(speed):
            r.last_speed = float(speed[-1])
    # the plan's mean speed over each piece (it ramps linearly over a period)
    spd = speed.tolist()
    plan = [0.5 * (a + b) for a, b in zip([r.speed0, *spd[:-1]], spd, strict=False)]
    r.q, r.dt = q.tolist(), dt.tolist()
    if arc_of is not None and arc_i is not None and arc_f is not None:
        r.arc_of, r.arc_i, r.arc_f = arc_of.tolist(), arc_i.tolist(), arc_f.tolist()
    cols = [x.tolist() for x in (line, speed, block_end, fn, fn_end, dwell, lead)]
    rows = list(zip(r.q, r.dt, *cols, plan, strict=True))
    new: list[tuple[np.ndarray, np.ndarray]] = []
    stopped = _decide(r, rows, k0, resume, q, fit, new)
    if not stopped:
        if end:
            r.resolve_corner(None, 0.0)
            r.write_held()
        r.hand_out()
    reserve(st, len(r.run) - int(st.i[I_NAMES.index("run_n")]))
    r.store(st)
    st.fit_i, st.fit_f = _fitted(new)
    if stopped:
        empty = np.zeros(0, dtype=np.int64)
        return empty, empty, empty, empty, np.zeros(0), np.zeros((0, 2))
    return (
        np.array(r.code, dtype=np.int64),
        np.array(r.arg, dtype=np.int64),
        np.array(r.ab, dtype=np.int64),
        np.array(r.aux, dtype=np.int64),
        np.array(r.val, dtype=np.float64),
        np.array(r.tilts, dtype=np.float64).reshape(-1, 2),
    )


def _decide(
    r: _Run,
    rows: list[tuple],
    k0: int,
    resume: bool,
    q: np.ndarray,
    fit: tuple[float, float, int] | None,
    new: list[tuple[np.ndarray, np.ndarray]],
) -> bool:
    """The chunk's points from k0 (``_Run.point`` each; with ``resume`` k0 goes on
    from a stop). Without ``fit``, True where it stops for a refit (the caller
    answers); with it, each stop answered here (:func:`refit`) and gone on from."""
    for k in range(k0, len(rows)):
        if r.point(k, rows[k], resume and k == k0):
            if fit is None:
                return True
            refit(r, q, fit, new)
            r.point(k, rows[k], True)
    return False


def refit(
    r: _Run, q: np.ndarray, fit: tuple[float, float, int], new: list[tuple[np.ndarray, np.ndarray]]
) -> None:
    """The answer to a stop (``r.stop_at``, ``r.req_kind``, ``r.req_arc``), as the
    writer gave it: the arc's points from the stop k on as arcs again
    (:func:`.arcs.refit_arcs`, in its plane; those no arc fits left to lines), and
    for ARC_TO first the arc from its start to k - 1 as one arc where one fits
    (``r.req_answer``: its index, else -1). The arcs are appended to the call's
    (refitted) and their rows to ``new``; ``fit``: tol_mm, tol_deg, decimals.
    Each refit gets the points it fits alone (the fits read nothing else)."""
    k, a = r.stop_at, r.req_arc
    start, end, plane = r.arc_i[a][A_START], r.arc_i[a][A_END], r.arc_i[a][A_PLANE]
    first = len(r.arc_i)

    def add(lo: int, rows: tuple[np.ndarray, np.ndarray]) -> None:
        ai, af = rows
        ai[:, :2] += lo  # the slice's indices, the chunk's again
        new.append((ai, af))
        for row_i, row_f in zip(ai.tolist(), af.tolist(), strict=True):
            r.arc_i.append([row_i[0], row_i[1], row_i[2], 1])
            r.arc_f.append([row_f[3], row_f[5]])

    if r.req_kind == REQ_ARC_TO:
        part = _arcs.refit_arcs(q[start:k], plane, 0, k - 1 - start, *fit)
        r.req_answer = -1
        if len(part[0]) == 1 and int(part[0][0, A_END]) == k - 1 - start:
            add(start, part)
            r.req_answer = first
    first = len(r.arc_i)
    r.arc_of[k : end + 1] = [-1] * (end + 1 - k)
    add(k, _arcs.refit_arcs(q[k : end + 1], plane, 0, end - k, *fit))
    for j in range(first, len(r.arc_i)):
        s, e = r.arc_i[j][A_START], r.arc_i[j][A_END]
        r.arc_of[s + 1 : e + 1] = [j] * (e - s)


def _fitted(new: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    """The rows of the arcs a call refitted, joined: (K, 4) int64, (K, 6)."""
    if not new:
        return np.zeros((0, 4), dtype=np.int64), np.zeros((0, 6))
    return (
        np.concatenate([a for a, _ in new]).astype(np.int64),
        np.concatenate([f for _, f in new]).astype(np.float64),
    )
