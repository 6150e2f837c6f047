"""Turbo PMAC running a Cartesian program through its kinematics, as the tests
run it: segmentation, the inverse at each segment's end, motors splined between.

The rules (SRM = Software Reference, TUM = User Manual), each as modelled here:

- ``LINEAR`` / ``CIRCLE1`` (clockwise) / ``CIRCLE2`` (counter-clockwise) are modal
  move modes; ``NORMAL K-1`` / ``J-1`` / ``I-1`` picks the circle's plane (XY, ZX,
  YZ, seen from the normal axis' + end as G17, G18, G19); a move line gives the
  end ``X Y Z A B`` (ABS) and, on a circle, the centre as ``I J K`` from the start
  (INC(R)) (SRM LINEAR, CIRCLE1, CIRCLE2, NORMAL).
- ``F`` is the speed along X, Y, Z (the vector feedrate axes; the arc's length
  with the normal axis on a helix), in mm/s with Isx90 = 1000; ``TM`` the move
  time in ms; the last of F and TM given holds (SRM F, TM; TUM "Vector Feedrate
  Axes").
- ``TA`` (whole ms) the acceleration time, ``TS0`` no S-curve: a move from rest
  to rest accelerates over TA, runs at D / T, decelerates over TA, T = max(D / F
  or TM, TA) the time between the ramps' middles ("the acceleration time is the
  minimum time for an individual blended move", TUM "Acceleration Parameters",
  "Linear Blended Moves"; PMAC User Manual, "Short Moves").
- Blending: moves with no DWELL between them blend: "If more than one move is
  specified in succession with no pause in between, the first move will blend
  into the second with the same type of controlled acceleration as is done to and
  from a stop" (TUM "Linear Blended Moves"); CIRCLE moves are blended moves as
  LINEAR ones are (SRM TS: "LINEAR and CIRCLE mode blended moves"). Modelled as
  each move keeping its own velocity profile, its ramps centred on the times
  between moves, and the path the sum of the moves' displacements (so the
  velocity of the first ramps down over the TA while the second ramps up). The
  TA of a blend is the TA in force at the second move; the final stop uses the
  TA in force at the DWELL ("If the final deceleration to a stop should use a
  different TA or TS ... declare the new TA ... after the final move command in
  the sequence, but before the DWELL", PMAC User Manual, "Linear Blended Moves").
  A blend's TA may not be longer than twice what the move before has left after
  its own ramp, TA(i+1) ≤ 2 (T(i) − TA(i) / 2), else it is cut to that (PMAC
  training manual, 5.6 "Linear blended moves"), so no two ramps overlap. A DWELL
  stops the blending and the move before ends at rest (SRM DWELL; PUM "When No
  Calculation Ahead"); a machine function, Q100= or PMATCH must follow a DWELL
  here (the writer puts one there; :func:`run_segmented` refuses them otherwise).
- With Isx13 > 0 each move, or each sequence of blended moves, is cut into
  segments of Isx13 ms from its start; at each segment's end the axis positions
  are computed and the inverse-kinematic program turns them into motor positions
  (SRM Isx13, Isx50; TUM "Conversion from Axis to Motor Position": "every segment
  of the move"). Here the inverse is the project's chain (the map, then the
  calibrated IK): test_writers_pmac_kinematics holds the exported OPEN INVERSE to
  it within 0.01 count.
- Between segment ends the motors are fine-interpolated at the servo clock by a
  cubic spline, modelled as the spline of Turbo PMAC's SPLINE mode: "LINEAR and
  SPLINE modes are 2nd and 3rd-order B-splines, respectively, which pass to the
  inside of programmed points" (TUM "Use of PVT in Contouring"); its velocity at
  a point is (X(n+1) − X(n−1)) / 2T and its position misses the point by
  (Dist(n+1) − Dist(n)) / 6 (PMAC User Manual, SPLINE1, "Quantifying the Position
  Adjustment"): the uniform cubic B-spline of the segment ends. The manuals we
  have do not write out the segmentation's own fine interpolation; this
  reading (the spline of SPLINE mode) is an assumption the figures depend on.
- A move that ends at rest (DWELL0 after it) ends on its end point: SPLINE "adds
  a zero-distance segment ... at the beginning and end of a series of splined
  moves" (PMAC User Manual, SPLINE1, "Added Pieces"), so between two moves the
  end point is held for two more segment ends (the one added after the first
  move, the one before the next), where the B-spline comes to rest on it.
- ``DWELL{ms}`` stands; ``Q100=`` then ``CMD"PMATCH"`` changes the tool length
  offset and recomputes the axis positions from the motors (SRM PMATCH).
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from prsxy_post import chain, errormap, kinematics
from prsxy_post.profile import Profile

from .controllers import MM_PER_DEG, SERVO_MS

_WORD = re.compile(r"([XYZABIJK])(-?\d+(?:\.\d+)?)")
NORMAL_AXIS = {"K": 2, "J": 1, "I": 0}


@dataclass
class SegmentedRun:
    """A Cartesian program executed through the kinematics.

    t, q, tool, line : (n,) / (n, 5) the segment ends: time [s], axis pose,
        tool length offset, G-code line
    P : (n, 5) motor positions at the segment ends [mm]
    t_dense, P_dense : the spline at the servo clock
    seg : (m,) the segment end each dense sample's interval ends at
    jseg, jline : what :func:`controllers.judge` takes as seg and point_line: for
        each dense sample the two moves it is judged against, jline[jseg − 1] and
        jline[jseg]. At rest, the lines of its interval's segment ends; in a
        sequence of blended moves, the move its progress along the path is in and
        the neighbour it is nearer (a move shorter than a segment's advance is
        crossed between two segment ends)
    tool_dense : (m,) tool length offset of each dense sample
    functions : (segment index, words) of every machine function
    """

    t: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    line: np.ndarray
    P: np.ndarray
    t_dense: np.ndarray
    P_dense: np.ndarray
    seg: np.ndarray
    tool_dense: np.ndarray
    functions: list[tuple[int, str]]
    jseg: np.ndarray
    jline: np.ndarray


def _ramped(x: np.ndarray, A: float) -> np.ndarray:
    """∫ of a unit velocity step smoothed over a ramp of A [s] starting at x = 0."""
    if A <= 0.0:
        return np.maximum(x, 0.0)
    return np.where(x <= 0.0, 0.0, np.where(x < A, 0.5 * x**2 / A, x - 0.5 * A))


def share(t: np.ndarray, start: float, T: float, ta_in: float, ta_out: float) -> np.ndarray:
    """The share of a move done at times t [s]: its sharp interval is [start, start
    + T], its speed ramps up over ta_in centred on ``start`` and down over ta_out
    centred on ``start + T`` (module docstring: the same profile from rest or in a
    blend); 0 before, 1 after."""
    up = _ramped(t - (start - ta_in / 2), ta_in)
    down = _ramped(t - (start + T - ta_out / 2), ta_out)
    return np.clip((up - down) / T, 0.0, 1.0)


def bspline(P: np.ndarray, s: np.ndarray, k: np.ndarray) -> np.ndarray:
    """The uniform cubic B-spline of points P (n, 5) (the ends held), in interval
    k → k + 1 at fractions s."""
    n = len(P)
    idx = np.clip(np.stack([k - 1, k, k + 1, k + 2]), 0, n - 1)
    s = s[:, None]
    w = [(1 - s) ** 3, 3 * s**3 - 6 * s**2 + 4, -3 * s**3 + 3 * s**2 + 3 * s + 1, s**3]
    return sum(wi * P[ix] for wi, ix in zip(w, idx, strict=True)) / 6.0  # type: ignore[return-value]


class _Kin:
    """The controller's kinematics for a profile: the chain's map and calibrated IK."""

    def __init__(self, profile: Profile) -> None:
        self.geo = chain.ik_geometry(profile, chain.Stages())
        self.emap = errormap.from_profile(profile)

    def inverse(self, q: np.ndarray, tool: np.ndarray) -> np.ndarray:
        qp = chain.correct_virtual(q, self.emap) if self.emap is not None else q
        ik = kinematics.inverse(self.geo, qp, tool)
        assert np.all(ik.reachable), "a segment end out of reach"
        return ik.P

    def forward(self, P: np.ndarray, tool: float) -> np.ndarray:
        q, ok = kinematics.forward(self.geo, P[None], tool)
        assert ok[0]
        out = q[0]
        if self.emap is not None:  # undo Q' = Q − e(Q), as OPEN FORWARD does
            u = out.copy()
            for _ in range(5):
                u = u + out - chain.correct_virtual(u[None], self.emap)[0]
            out = u
        return out


def _path(mode: str, normal: int, a: np.ndarray, b: np.ndarray, ijk: np.ndarray):
    """pose(u) (k,) → (k, 5) of one move, and its X Y Z length [mm]."""
    if mode == "LINEAR":
        return (lambda u: a + u[:, None] * (b - a)), float(np.linalg.norm(b[:3] - a[:3]))
    n = np.zeros(3)
    n[normal] = 1.0
    c = a[:3] + ijk
    c[normal] = 0.0  # the normal axis moves on its own (a helix)
    r0 = a[:3] - c
    r0 -= (r0 @ n) * n
    r1 = b[:3] - c
    r1 -= (r1 @ n) * n
    phi = math.atan2(float(n @ np.cross(r0, r1)), float(r0 @ r1))
    if mode == "CIRCLE2" and phi <= 1e-12:
        phi += 2 * math.pi
    if mode == "CIRCLE1" and phi >= -1e-12:
        phi -= 2 * math.pi
    radius = float(np.linalg.norm(r0))

    def pose(u: np.ndarray) -> np.ndarray:
        ang = u[:, None] * phi
        out = a + u[:, None] * (b - a)
        perp = r0[None] * np.cos(ang) + np.cross(n, r0)[None] * np.sin(ang)
        xyz = c + perp + (a[normal] + u * (b[normal] - a[normal]))[:, None] * n
        out[:, :3] = xyz
        return out

    return pose, math.hypot(radius * abs(phi), float(b[normal] - a[normal]))


@dataclass
class _Move:
    """One programmed move: from a to b along pose(u), T between its ramps'
    middles, ta the TA in force at it (the blend into it)."""

    a: np.ndarray
    b: np.ndarray
    pose: Callable[[np.ndarray], np.ndarray]
    T: float
    ta: float
    line: int
    length: float


@dataclass
class _Chain:
    """A sequence of moves run from rest to rest: its time span [s], the moves'
    starts between ramp middles [s], times, TAs, lengths and lines."""

    t0: float
    t1: float
    starts: np.ndarray
    T: list[float]
    ta: list[float]
    lengths: np.ndarray
    lines: list[int]

    def judged_lines(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """For times t in the span: the line whose move the progress is in, and
        the line of the neighbour it is nearer."""
        progress = sum(
            self.lengths[i] * share(t, float(self.starts[i]), self.T[i], self.ta[i], self.ta[i + 1])
            for i in range(len(self.T))
        )
        bounds = np.concatenate([[0.0], np.cumsum(self.lengths)])
        n = len(self.T)
        o = np.clip(np.searchsorted(bounds[:-1], progress, side="right") - 1, 0, n - 1)
        frac = (progress - bounds[o]) / np.where(self.lengths[o] > 0, self.lengths[o], 1.0)
        nb = np.clip(np.where(frac < 0.5, o - 1, o + 1), 0, n - 1)
        lines = np.array(self.lines)
        return lines[o], lines[nb]


class _Controller:
    """The coordinate system's state while a program runs: the segment ends so far
    (time, axis pose, tools, line) and the modes in force."""

    def __init__(self, kin: _Kin, h: float) -> None:
        self.kin, self.h = kin, h
        self.t: list[float] = []
        self.q: list[np.ndarray] = []
        self.tool: list[float] = []  # the tool the tip is judged with
        self.ik_tool: list[float] = []  # the tool the controller's inverse used (Q100)
        self.line: list[int] = []
        self.functions: list[tuple[int, str]] = []
        self.mode, self.normal = "LINEAR", 2
        self.F: float | None = None
        self.TM: float | None = None
        self.TA: float | None = None
        self.timed_by = "F"
        self.tlo = 0.0
        self.cur: np.ndarray | None = None
        self.cur_line = 0
        self.await_rest = False
        #: the moves since the last rest, blended into each other
        self.chain: list[_Move] = []
        #: every sequence run so far
        self.chains: list[_Chain] = []
        #: hold points not yet followed by a move: the spline leaves them towards
        #: the next move's points (its support is four points), so they are judged
        #: with the next move's line and tool (the motors stand while a tool changes)
        self.held: list[int] = []

    def _append(self, t: float, q: np.ndarray, tool: float, ik_tool: float, line: int) -> None:
        self.t.append(t)
        self.q.append(q)
        self.tool.append(tool)
        self.ik_tool.append(ik_tool)
        self.line.append(line)

    def hold(self) -> None:
        """The move ends at rest at its end point (module docstring): two more
        segment ends there."""
        for _ in range(2):
            self._append(self.t[-1] + self.h, self.q[-1].copy(), self.tool[-1],
                         self.ik_tool[-1], self.line[-1])  # fmt: skip
            self.held.append(len(self.t) - 1)

    def flush(self) -> None:
        """Run the moves blended since the last rest and bring them to rest
        (module docstring): the segment ends of their summed displacements."""
        if self.await_rest:
            self.hold()
            self.await_rest = False
        if not self.chain:
            return
        assert self.TA is not None
        T = [mv.T for mv in self.chain]
        ta = [mv.ta for mv in self.chain] + [self.TA / 1000.0]
        for i in range(1, len(ta)):  # TA(i+1) ≤ 2 (T(i) − TA(i) / 2)
            ta[i] = min(ta[i], 2.0 * (T[i - 1] - ta[i - 1] / 2.0))
        starts = ta[0] / 2 + np.concatenate([[0.0], np.cumsum(T)[:-1]])
        total = ta[0] / 2 + sum(T) + ta[-1] / 2
        ks = np.arange(1, math.ceil(total / self.h - 1e-9) + 1)
        tt = ks * self.h
        q = np.repeat(self.chain[0].a[None], len(tt), axis=0)
        for i, mv in enumerate(self.chain):
            u = share(tt, float(starts[i]), T[i], ta[i], ta[i + 1])
            u[tt >= total] = 1.0
            q = q + mv.pose(u) - mv.pose(np.zeros(1))
        q[-1] = self.chain[-1].b
        # a segment end belongs to the move its progress along the path is in (the
        # moves' shares times their lengths, A/B at the judge's mm per degree): in a
        # blend of moves at different speeds the pose runs ahead of or behind the
        # times between ramp middles
        lengths = np.array([mv.length for mv in self.chain])
        progress = sum(
            mv.length * share(tt, float(starts[i]), T[i], ta[i], ta[i + 1])
            for i, mv in enumerate(self.chain)
        )
        bounds = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
        owner = np.clip(np.searchsorted(bounds, progress, side="right") - 1, 0, len(T) - 1)
        self.chains.append(
            _Chain(
                self.t[-1],
                self.t[-1] + float(tt[-1]),
                starts + self.t[-1],
                T,
                ta,
                lengths,
                [mv.line for mv in self.chain],
            )
        )
        for i in self.held:
            self.line[i] = self.chain[0].line
            self.tool[i] = self.tlo
        self.held.clear()
        t0 = self.t[-1]
        for tk, qk, o in zip((t0 + tt).tolist(), q, owner.tolist(), strict=True):
            self._append(tk, qk, self.tlo, self.tlo, self.chain[o].line)
        self.cur = self.chain[-1].b
        self.chain.clear()
        self.hold()

    def dwell(self, ms: float) -> None:
        self.flush()
        if ms > 0 and self.cur is not None:
            for _ in range(math.ceil(ms / (self.h * 1000) - 1e-9)):
                self._append(self.t[-1] + self.h, self.cur.copy(), self.tlo, self.tlo,
                             self.cur_line)  # fmt: skip

    def pmatch(self) -> None:
        """The axis positions of the motors as they stand, with the new tool."""
        assert self.cur is not None
        P_now = self.kin.inverse(self.cur[None], np.array([self.ik_tool[-1]]))[0]
        self.cur = self.kin.forward(P_now, self.tlo)

    def timing(self, words: dict[str, str]) -> None:
        if "F" in words:
            self.F, self.timed_by = float(words["F"]), "F"
        if "TM" in words:
            self.TM, self.timed_by = float(words["TM"]), "TM"
        if "TA" in words:
            self.TA = float(words["TA"])

    def move(self, words: dict[str, str], code: str) -> None:
        """A move: it joins the moves to blend until the next DWELL (module
        docstring)."""
        end = np.array([float(words[a]) for a in "XYZAB"])
        if self.cur is None:  # the program's first move: where the machine is
            self.cur = end
            self._append(0.0, end, self.tlo, self.tlo, self.cur_line)
            self.await_rest = True
            return
        assert not self.await_rest, "the first move must end at rest (DWELL0)"
        start = self.chain[-1].b if self.chain else self.cur
        ijk = np.array([float(words.get(a, 0.0)) for a in "IJK"])
        pose, length = _path(self.mode, self.normal, start, end, ijk)
        assert self.TA is not None
        ta = self.TA / 1000.0
        if self.timed_by == "F":
            assert self.F is not None and length > 0.0, code
            T = length / self.F
        else:
            assert self.TM is not None
            T = self.TM / 1000.0
        length5 = math.hypot(length, float(np.linalg.norm(end[3:] - start[3:])) * MM_PER_DEG)
        self.chain.append(_Move(start, end, pose, max(T, ta), ta, self.cur_line, length5))

    def command(self, raw: str) -> None:
        """One line of the program."""
        code = raw.split(";", 1)[0].strip()
        if raw.strip().startswith("; line "):
            self.cur_line = int(raw.strip()[7:].split(":")[0])
        if not code:
            return
        if code in ("LINEAR", "CIRCLE1", "CIRCLE2"):
            self.mode = code
        elif m := re.fullmatch(r"NORMAL ([IJK])-1", code):
            self.normal = NORMAL_AXIS[m.group(1)]
        elif m := re.fullmatch(r"DWELL(\d+(?:\.\d+)?)", code):
            self.dwell(float(m.group(1)))
        elif m := re.fullmatch(r"Q100=(-?\d+(?:\.\d+)?)", code):
            assert not self.chain, "Q100 changed while moves blend"
            self.tlo = float(m.group(1))
        elif code == 'CMD"PMATCH"':
            assert not self.chain, "PMATCH while moves blend"
            self.pmatch()
        elif _TIMING.fullmatch(code):
            self.timing(dict(re.findall(r"\b(F|TM|TA)(\d+(?:\.\d+)?)", code)))
        elif set("XYZAB") <= set(words := dict(_WORD.findall(code))):
            self.move(words, code)
        elif re.fullmatch(r"(?:[GMTDS]-?[\d.]+\s*)+", code):
            assert not self.chain, "a machine function while moves blend"
            self.functions.append((len(self.t) - 1, code))
        # else setup: CLOSE, &1, OPEN PROG, ABS, TS0


_TIMING = re.compile(r"(?:(?:F|TM|TA)\d+(?:\.\d+)?\s*)+")


def run_segmented(
    text: str,
    profile: Profile,
    seg_ms: float | None = None,
    servo_ms: float = SERVO_MS,
) -> SegmentedRun:
    """Execute a Cartesian program (module docstring) on the kinematics of
    ``profile`` with segmentation time ``seg_ms`` (default: the profile's period,
    what ``prsxy-post kinematics`` sets Isx13 to)."""
    kin = _Kin(profile)
    c = _Controller(kin, (seg_ms if seg_ms is not None else profile.period_ms) / 1000.0)
    for raw in text.splitlines():
        c.command(raw)
    c.flush()  # the program's end brings blended moves to rest
    t, tool = np.array(c.t), np.array(c.tool)
    P = kin.inverse(np.array(c.q), np.array(c.ik_tool))
    # the servo clock's ticks from the start, each in the interval it falls in
    ticks = np.arange(1, int(t[-1] / (servo_ms / 1000.0)) + 1) * (servo_ms / 1000.0)
    k = np.clip(np.searchsorted(t, ticks, side="left") - 1, 0, len(t) - 2)
    s = (ticks - t[k]) / (t[k + 1] - t[k])
    seg = np.concatenate([[0], k + 1])
    line = np.array(c.line)
    t_dense = np.concatenate([[0.0], ticks])
    ja, jb = line[np.maximum(seg - 1, 0)], line[seg]
    for ch in c.chains:
        sel = (t_dense > ch.t0) & (t_dense <= ch.t1)
        if np.any(sel):
            ja[sel], jb[sel] = ch.judged_lines(t_dense[sel])
    jline = np.column_stack([ja, jb]).ravel()
    jseg = 2 * np.arange(len(t_dense)) + 1
    return SegmentedRun(
        t,
        np.array(c.q),
        tool,
        np.array(c.line),
        P,
        np.concatenate([[0.0], ticks]),
        np.vstack([P[:1], bspline(P, s, k)]),
        seg,
        tool[seg],
        c.functions,
        jseg,
        jline,
    )
