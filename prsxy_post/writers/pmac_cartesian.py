"""The embedded route's motion program: the G-code's own moves as a Cartesian
Turbo PMAC program, run through the kinematics ``prsxy-post kinematics`` writes.

The compensation lives in the controller (the inverse-kinematic program holds the
calibrated model and the virtual-axis map, the leadscrew and backlash tables the
real axes), so the program is the G-code's geometry, move for move, in the
workpiece frame: LINEAR moves for straight moves, CIRCLE1 (clockwise) and CIRCLE2
(counter-clockwise) for arcs with the centre as an I J K vector from the start
(the default INC(R)), in the plane NORMAL K-1 (G17), J-1 (G18) or I-1 (G19)
gives (Software Reference, LINEAR, CIRCLE1, CIRCLE2, NORMAL, {axis}{data}
{vector}{data}). Turbo PMAC segments every move at Isx13 and runs the inverse at
each segment's end (Software Reference, Isx13, Isx50); the motors are splined
between.

- Speed: F in mm/s (Isx90 = 1000, as the PVT programs have it) along X Y Z, the
  vector feedrate axes (User Manual, "Vector Feedrate Axes"); a move of A and B
  alone is timed with TM (ms). Rapids are LINEAR moves at the profile's rapid
  speed: Turbo PMAC's RAPID mode moves each motor on its own, not along the
  straight line G0 follows.
- Arcs: the spline between segment ends cuts an arc of radius R at speed v by
  R (1 − cos(v h / R)) / 3, h = Isx13; an arc runs no faster than keeps that to
  half the path tolerance (F lowered, never raised).
- Acceleration: TA, a whole number of ms ("Turbo PMAC can use only integer values
  for TA and TS", User Manual, "Acceleration Parameters"), long enough that the
  move reaches its speed within the profile's acceleration limit; TS0 (no
  S-curve).
- Blending: Turbo PMAC blends a LINEAR or CIRCLE move into the next unless a
  DWELL stands between them ("If more than one move is specified in succession
  with no pause in between, the first move will blend into the second with the
  same type of controlled acceleration as is done to and from a stop", User
  Manual, "Linear Blended Moves"; CIRCLE moves are blended moves, Software
  Reference TS). The blend takes the second move's TA around the junction: the
  first move's velocity ramps down over TA while the second's ramps up, centred
  on the junction, and the path is the sum of the two moves' displacements. So a
  blend is the sharp path averaged over a window of TA, and with Isx13 > 0 the
  segment ends of that path are splined (tests/pmac_segmented.py models it), a
  second average over the spline's kernel (variance h²/3, h = Isx13). At a
  junction of directions u1, u2 (sin θ = |u1 × u2|) and speeds v1, v2 the path
  then leaves the corner by at most, :func:`blend_deviation`,

      e = max(v1, v2) sin θ E[X⁺] + (a1 + a2) TA² / 32 + max(a1, a2) h² / 6,
      E[X⁺] ≤ √(TA² / 12 + h² / 3) / 2,

  X the averaging window's offset (with TS0 a box of TA, then the spline's
  kernel; E[X⁺] = E|X| / 2 ≤ σ / 2), v1, v2 the speeds the moves run at (a move
  shorter than TA at F runs D / TA), a1, a2 the moves' own path accelerations
  v² / R at the junction (0 on a line). The second term bounds how far the arcs
  leave their tangents within the window, the third is the spline's cut of a path
  curving at a (as on an arc, see Arcs). For the box alone (h → 0) on lines the
  deviation is exactly v TA sin θ / 8 at equal speeds (the window's mean of the
  corner's inside part: TA / 8), which tests/test_writers_pmac_cartesian.py holds
  the emulator to, with the bound over the executed corners and tangent joins.
  Poses are compared in X Y Z with A and B scaled by the path tolerance over the
  tool-axis tolerance, so one e bounds both.
  A junction is blended when e ≤ the profile's path tolerance, both moves are
  feeds at the same F (or rapids), the second move's TA fits the first (a blend's
  TA is cut to 2 (T(i) − TA(i) / 2) when longer, PMAC training manual, 5.6
  "Linear blended moves"; the writer keeps it within, so no two ramps overlap)
  and changes the velocity within the acceleration limits (an arc slowed for
  the spline blends into a line at F when its TA covers the change), in the same
  NORMAL plane, and
  turn by less than 90° (a reversal would turn back before its end); a tangent
  join (line into a tangent arc, the turns of a helix, a polyline of small turns)
  blends at full speed when e holds. Anywhere else the move ends at rest: DWELL0
  after it ("DWELL0" waits for the motion to end). How a blend across a NORMAL
  change, or into or out of an A/B move timed by TM, runs is not described in the
  manuals we have: those stop (the conservative choice). A blend between
  different F would run the slower move above its F for TA / 2 (the speed ramps
  centred on the junction): that stops too. The speed is not lowered into a
  corner: a corner that would be cut too far stops.
- Machine functions as the PVT programs carry them: DWELL0, then the words
  (M n calls PROG 1001, T n PROG 1002, D n PROG 1003, G n PROG 1000, S in Q127).
- A tool length offset (G43/G49) goes to Q100, which the kinematic programs add
  to the tool, then CMD"PMATCH" between DWELLs recomputes the axis positions from
  the motors ("The PMATCH function can be executed from within a motion program
  using CMD"PMATCH" with DWELLs both before and after", Software Reference, PMATCH).
- G5 curves (NURBS) have no Turbo PMAC move; the writer refuses them with their line.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..errors import LimitError
from .base import Provenance, header, words_text

if TYPE_CHECKING:
    from ..gcode import Motion
    from ..profile import Profile

#: digits after the point of positions [mm] and angles [deg]
DECIMALS = 7
PLANE_NORMAL = {17: "NORMAL K-1", 18: "NORMAL J-1", 19: "NORMAL I-1"}
#: the plane's normal axis index (x, y, z) and the unit normal
NORMAL_AXIS = {17: 2, 18: 1, 19: 0}
RESERVED = {"G": 1000, "M": 1001, "T": 1002, "D": 1003}


def _f(x: float) -> str:
    s = f"{x:.{DECIMALS}f}"
    return "0" if float(s) == 0.0 else s.rstrip("0").rstrip(".")


def _pose(q: Sequence[float] | np.ndarray) -> str:
    return " ".join(f"{a}{_f(v)}" for a, v in zip("XYZAB", q, strict=True))


def arc_sweep(m: Motion) -> tuple[np.ndarray, float]:
    """An arc's unit normal n and its signed sweep about n [rad] (+: counter-clockwise
    seen from n's + end), all its turns."""
    axis = NORMAL_AXIS[m.plane]
    n = np.zeros(3)
    n[axis] = 1.0
    assert m.center is not None
    c = np.array(m.center)
    u = np.array(m.start[:3]) - c
    v = np.array(m.end[:3]) - c
    u[axis] = v[axis] = 0.0
    phi = math.atan2(float(n @ np.cross(u, v)), float(u @ v))
    sense = 1 if m.rotation > 0 else -1
    if sense > 0 and phi <= 0.0:
        phi += 2 * math.pi
    if sense < 0 and phi >= 0.0:
        phi -= 2 * math.pi
    return n, phi + sense * 2 * math.pi * (abs(m.rotation) - 1)


def blend_deviation(
    v_in: np.ndarray, v_out: np.ndarray, acc_in: float, acc_out: float, ta_s: float, seg_s: float
) -> float:
    """How far Turbo PMAC's blend of two moves, splined between segment ends, may
    leave their path at the junction (module docstring, "Blending").

    Parameters
    ----------
    v_in, v_out : (k,) velocity of the first move at its end and of the second at
        its start [mm/s, A/B scaled to mm]
    acc_in, acc_out : the moves' own path acceleration there, v² / R (0 on a line)
        [mm/s²]
    ta_s : the blend's TA [s]; seg_s : the segmentation time Isx13 [s]

    Returns
    -------
    e = max(v1, v2) sin θ √(TA² / 12 + h² / 3) / 2 + (a1 + a2) TA² / 32
        + max(a1, a2) h² / 6  [mm]
    """
    s1, s2 = float(np.linalg.norm(v_in)), float(np.linalg.norm(v_out))
    if s1 == 0.0 or s2 == 0.0:
        return 0.0
    cos = float(v_in @ v_out) / (s1 * s2)
    sin = math.sqrt(max(0.0, 1.0 - cos * cos))
    corner = max(s1, s2) * sin * math.sqrt(ta_s**2 / 12.0 + seg_s**2 / 3.0) / 2.0
    return corner + (acc_in + acc_out) * ta_s**2 / 32.0 + max(acc_in, acc_out) * seg_s**2 / 6.0


@dataclass(frozen=True)
class _End:
    """A move's side at a junction: velocity (scaled pose units), path
    acceleration, what must match for a blend (rate and timing), the move's TA
    [ms] and its time T [s]."""

    v: np.ndarray
    acc: float
    key: tuple[object, ...]
    ta_ms: int
    T: float


class CartesianWriter:
    """The program of a list of motions (module docstring)."""

    def __init__(
        self,
        profile: Profile,
        prov: Provenance,
        program: int = 1,
        seg_ms: float | None = None,
        blend: bool = True,
    ) -> None:
        self.profile = profile
        self.prov = prov
        self.program = program
        self.lines: list[str] = []
        self.functions: dict[str, str] = {}
        self.tool = 0.0
        self.plane = 17
        self.mode = ""
        interp = profile.interpolation
        #: mm of path per degree of tool axis: the tolerances' ratio
        self.mm_per_deg = interp.path_tolerance_mm / (interp.path_tolerance_arcsec / 3600.0)
        self.tolerance = interp.path_tolerance_mm
        self.seg_s = (seg_ms if seg_ms is not None else profile.period_ms) / 1000.0
        #: the last move's end and the index of the DWELL0 after it
        self.last: tuple[_End, int] | None = None
        self.blended = 0
        self.blend = blend
        self.stopped = 0

    def _accel_ms(self, speed: float, rotary: bool) -> int:
        lim = self.profile.limits
        a = lim.max_accel_deg_s2 if rotary else lim.max_accel_mm_s2
        return max(1, math.ceil(1000.0 * speed / a - 1e-9))

    def arc_speed(self, radius: float) -> float:
        """The fastest an arc of ``radius`` [mm] may run [mm/s]: the spline between
        segment ends cuts it by R (1 − cos(v h / R)) / 3 (tests/test_writers_pmac_
        cartesian.py holds the closed form), kept to half the path tolerance."""
        x = 1.0 - 1.5 * self.tolerance / radius
        return math.inf if x <= -1.0 else radius / self.seg_s * math.acos(x)

    def _timing(
        self, m: Motion, length_xyz: float, length_ab: float, radius: float = 0.0
    ) -> tuple[str, int, float]:
        """F (mm/s) and TA for X Y Z moves (an arc no faster than :meth:`arc_speed`);
        TM and TA for A/B-only moves; with the TA [ms] and the move's time T =
        max(D / F or TM, TA) [s]."""
        lim = self.profile.limits
        rapid = m.kind == "rapid"
        if length_xyz > 0.0:
            v = (lim.rapid_mm_min if rapid else m.feed) / 60.0
            if radius > 0.0:
                v = min(v, self.arc_speed(radius))
            ta = self._accel_ms(v, False)
            return f"F{_f(v)} TA{ta}", ta, max(length_xyz / v, ta / 1000.0)
        rate = (lim.rapid_deg_min if rapid else m.feed) / 60.0
        tm = 1000.0 * length_ab / rate
        ta = self._accel_ms(rate, True)
        return f"TM{_f(tm)} TA{ta}", ta, max(tm, ta) / 1000.0

    def _scaled(self, d: np.ndarray) -> np.ndarray:
        """A pose difference (5,) with A/B in mm at the tolerances' ratio."""
        out = np.array(d, dtype=float)
        out[3:] *= self.mm_per_deg
        return out

    def _join(self, start: _End) -> None:
        """Blend into the move starting with ``start`` (drop the DWELL0 after the
        last move) when the module docstring's rules allow it."""
        if self.last is None or not self.blend:
            return
        end, idx = self.last
        self.last = None
        ta = start.ta_ms / 1000.0
        lim = self.profile.limits
        dv = start.v - end.v
        if (
            end.key != start.key
            or float(end.v @ start.v) <= 0.0
            # the blend's ramp must fit the move before: TA(i+1) ≤ 2 (T(i) − TA(i) / 2)
            or end.T < (end.ta_ms / 1000.0 + ta) / 2.0 - 1e-12
            # and change the velocity within the acceleration limits
            or float(np.linalg.norm(dv[:3])) > lim.max_accel_mm_s2 * ta * (1 + 1e-9)
            or float(np.linalg.norm(dv[3:])) / self.mm_per_deg
            > lim.max_accel_deg_s2 * ta * (1 + 1e-9)
        ):
            self.stopped += 1
            return
        e = blend_deviation(end.v, start.v, end.acc, start.acc, start.ta_ms / 1000.0, self.seg_s)
        if e > self.tolerance:
            self.stopped += 1
            return
        assert self.lines[idx] == "DWELL0"
        del self.lines[idx]
        self.blended += 1

    def _emit(self, timing: str, move: str, end: _End) -> None:
        self.lines += [timing, move, "DWELL0"]
        self.last = (end, len(self.lines) - 1)

    def _set_mode(self, mode: str) -> None:
        if mode != self.mode:
            self.lines.append(mode)
            self.mode = mode

    def begin(self) -> None:
        rest = (
            [
                "Moves blend where the blend stays within the path tolerance (with",
                f"Isx13 = {self.seg_s * 1000:g} ms); elsewhere a move ends at rest (DWELL0).",
            ]
            if self.blend
            else ["Every move ends at rest (DWELL0): no corner is blended."]
        )
        extra = [
            "Cartesian Turbo PMAC program for the embedded route: download the",
            "kinematics (`prsxy-post kinematics`) and the real-axis tables (`tables",
            "export --format pmac`) first; they compensate, this program is the",
            "G-code's geometry in the workpiece frame.",
            "Settings: I5150=1 and I5113 (the kinematics file sets them), I5190=1000",
            "(F in mm/s); TA and TS are in the program.",
            *rest,
            "Machine functions (S, T, M, G, D words) run at rest as in the PVT",
            "programs: M n calls PROG 1001 at N(n*1000), T n PROG 1002, D n PROG 1003,",
            "G n PROG 1000; S puts the speed in Q127.",
        ]
        self.lines += ["; " + x for x in header(self.prov, self.profile, extra)]
        self.lines += ["CLOSE", "&1", f"OPEN PROG {self.program} CLEAR", "ABS", "TS0"]

    def start(self, q: Sequence[float]) -> None:
        """The machine's first pose: a LINEAR move there (it is there already)."""
        self._set_mode("LINEAR")
        v = self.profile.limits.rapid_mm_min / 60.0
        self.lines += [f"F{_f(v)} TA{self._accel_ms(v, False)}", _pose(q), "DWELL0"]
        self.last = None

    def motion(self, m: Motion) -> None:
        if m.kind == "curve":
            raise LimitError(
                f"line {m.line}: a G5 curve has no Turbo PMAC move",
                expected="lines and arcs for the Cartesian PMAC program (or the pmac format)",
            )
        if m.kind in ("function", "dwell"):
            self.last = None  # the DWELL0 after the last move stays: a stop
        if m.kind == "function":
            self.lines.append(f"; line {m.line}")
            self.lines.append("DWELL0")
            self.lines.append(self._function(m.words))
            return
        if m.kind == "dwell":
            self.lines += [f"; line {m.line}", f"DWELL{_f(m.duration * 1000.0)}"]
            return
        if m.tool_length != self.tool:
            self.last = None
            self.lines += [
                f"; line {m.line}: tool length offset {m.tool_length:g} mm",
                "DWELL0",
                f"Q100={_f(m.tool_length)}",
                'CMD"PMATCH"',
                "DWELL0",
            ]
            self.tool = m.tool_length
        s, e = np.array(m.start), np.array(m.end)
        if m.kind in ("rapid", "feed"):
            if np.array_equal(s, e):
                return
            dxyz = float(np.linalg.norm(e[:3] - s[:3]))
            dab = float(np.linalg.norm(e[3:] - s[3:]))
            timing, ta, T = self._timing(m, dxyz, dab)
            v = self._scaled(e - s) / T
            rapid = m.kind == "rapid"
            key = ("rapid" if rapid else "feed", 0.0 if rapid else m.feed, dxyz > 0.0)
            self._join(_End(v, 0.0, key, ta, T))
            self.lines.append(f"; line {m.line}")
            self._set_mode("LINEAR")
            self._emit(timing, _pose(e), _End(v, 0.0, key, ta, T))
            return
        if m.kind == "arc":
            self._arc(m)
            return
        raise LimitError(f"line {m.line}: a {m.kind} motion has no Turbo PMAC move")

    def _arc(self, m: Motion) -> None:
        n, sweep = arc_sweep(m)
        axis = NORMAL_AXIS[m.plane]
        assert m.center is not None
        c = np.array(m.center)
        s, e = np.array(m.start), np.array(m.end)
        turns = max(1, abs(m.rotation))
        if m.plane != self.plane:
            self.last = None  # a blend across NORMAL: not described, stop
        first = True
        # whole turns first (end = start in the plane), then the rest of the sweep;
        # the normal axis and A, B move in proportion to the angle
        pieces = [2 * math.pi * math.copysign(1.0, sweep)] * (turns - 1)
        pieces.append(sweep - sum(pieces))
        done = 0.0
        start = s.copy()
        radius = float(np.linalg.norm((s[:3] - c) - ((s[:3] - c) @ n) * n))
        for piece in pieces:
            done += piece
            frac = done / sweep
            end = s + frac * (e - s)
            end[:3] = e[:3] if frac == 1.0 else _rotated(s[:3], c, n, done)
            end[axis] = s[axis] + frac * (e[axis] - s[axis])
            ijk = c - start[:3]
            ijk[axis] = 0.0
            arc_len = math.hypot(radius * abs(piece), float(end[axis] - start[axis]))
            timing, ta, T = self._timing(
                m, arc_len, float(np.linalg.norm(end[3:] - start[3:])), radius
            )
            vec = " ".join(
                f"{a}{_f(v)}" for i, (a, v) in enumerate(zip("IJK", ijk, strict=True)) if i != axis
            )
            key = ("feed", m.feed, True)
            acc = (radius * piece / T) ** 2 / radius if radius > 0.0 else 0.0
            v_in, v_out = (self._arc_velocity(start, end, c, n, piece, T, p) for p in (start, end))
            if first:
                self._join(_End(v_in, acc, key, ta, T))
                self.lines.append(f"; line {m.line}")
                if m.plane != self.plane:
                    self.lines.append(PLANE_NORMAL[m.plane])
                    self.plane = m.plane
                self._set_mode("CIRCLE2" if sweep > 0 else "CIRCLE1")
                first = False
            else:  # the turns of one arc meet tangentially
                self._join(_End(v_in, acc, key, ta, T))
            self._emit(timing, f"{_pose(end)} {vec}", _End(v_out, acc, key, ta, T))
            start = end

    def _arc_velocity(
        self,
        a: np.ndarray,
        b: np.ndarray,
        c: np.ndarray,
        n: np.ndarray,
        piece: float,
        T: float,
        at: np.ndarray,
    ) -> np.ndarray:
        """The velocity (scaled pose units) of the arc piece a → b about c, n
        (sweep ``piece`` in time T) at its point ``at``: the turn, the normal axis and
        A/B in proportion."""
        r = at[:3] - c
        r = r - (r @ n) * n
        v = np.zeros(5)
        v[:3] = (piece / T) * np.cross(n, r) + ((b[:3] - a[:3]) @ n / T) * n
        v[3:] = (b[3:] - a[3:]) / T
        return self._scaled(v)

    def _function(self, words: tuple[tuple[str, float], ...]) -> str:
        for letter, value in words:
            if letter in RESERVED:
                self.functions[f"{letter}{value:g}"] = (
                    f"PROG {RESERVED[letter]} N{round(value * 1000)}"
                )
            elif letter == "S":
                self.functions["S"] = "Q127"
        return words_text(words)

    def finish(self) -> str:
        tail = ["CLOSE"]
        if self.functions:
            tail.insert(
                0,
                "; machine functions this program calls: "
                + ", ".join(f"{k} ({v})" for k, v in sorted(self.functions.items())),
            )
        return "\n".join(self.lines + tail) + "\n"


def _rotated(p: np.ndarray, c: np.ndarray, n: np.ndarray, angle: float) -> np.ndarray:
    """p turned about the axis through c along unit n by ``angle`` (right-handed);
    its component along n is kept."""
    r = p - c
    along = (r @ n) * n
    perp = r - along
    return c + along + perp * math.cos(angle) + np.cross(n, perp) * math.sin(angle)


def write_program(
    motions: Sequence[Motion],
    profile: Profile,
    prov: Provenance,
    start: Sequence[float],
    seg_ms: float | None = None,
    blend: bool = True,
) -> str:
    """The Cartesian Turbo PMAC program of ``motions``, starting at pose ``start``,
    its blends judged for segmentation time ``seg_ms`` (Isx13; default the
    profile's period, what ``prsxy-post kinematics`` sets); ``blend=False`` ends
    every move at rest."""
    return fed(motions, profile, prov, start, seg_ms, blend).finish()


def fed(
    motions: Sequence[Motion],
    profile: Profile,
    prov: Provenance,
    start: Sequence[float],
    seg_ms: float | None = None,
    blend: bool = True,
) -> CartesianWriter:
    """The writer with every motion fed, not yet finished: what
    :func:`write_program` writes, and how many junctions blended and stopped."""
    w = CartesianWriter(profile, prov, seg_ms=seg_ms, blend=blend)
    w.begin()
    w.start(start)
    for m in motions:
        w.motion(m)
    return w
