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
- Acceleration: TA, a whole number of ms ("Turbo PMAC can use only integer values
  for TA and TS", User Manual, "Acceleration Parameters"), long enough that the
  move reaches its speed within the profile's acceleration limit; TS0 (no
  S-curve).
- Every move ends at rest: DWELL0 after it ("DWELL0" waits for the motion to end,
  as in the PVT programs), so no corner is blended (a blend over TA would cut it).
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


class CartesianWriter:
    """The program of a list of motions (module docstring)."""

    def __init__(self, profile: Profile, prov: Provenance, program: int = 1) -> None:
        self.profile = profile
        self.prov = prov
        self.program = program
        self.lines: list[str] = []
        self.functions: dict[str, str] = {}
        self.tool = 0.0
        self.plane = 17
        self.mode = ""

    def _accel_ms(self, speed: float, rotary: bool) -> int:
        lim = self.profile.limits
        a = lim.max_accel_deg_s2 if rotary else lim.max_accel_mm_s2
        return max(1, math.ceil(1000.0 * speed / a - 1e-9))

    def _timing(self, m: Motion, length_xyz: float, length_ab: float) -> str:
        """F (mm/s) and TA for X Y Z moves; TM and TA for A/B-only moves."""
        lim = self.profile.limits
        rapid = m.kind == "rapid"
        if length_xyz > 0.0:
            v = (lim.rapid_mm_min if rapid else m.feed) / 60.0
            return f"F{_f(v)} TA{self._accel_ms(v, False)}"
        rate = (lim.rapid_deg_min if rapid else m.feed) / 60.0
        tm = 1000.0 * length_ab / rate
        v = rate
        return f"TM{_f(tm)} TA{self._accel_ms(v, True)}"

    def _set_mode(self, mode: str) -> None:
        if mode != self.mode:
            self.lines.append(mode)
            self.mode = mode

    def begin(self) -> None:
        extra = [
            "Cartesian Turbo PMAC program for the embedded route: download the",
            "kinematics (`prsxy-post kinematics`) and the real-axis tables (`tables",
            "export --format pmac`) first; they compensate, this program is the",
            "G-code's geometry in the workpiece frame.",
            "Settings: I5150=1 and I5113 (the kinematics file sets them), I5190=1000",
            "(F in mm/s); TA and TS are in the program.",
            "Every move ends at rest (DWELL0): no corner is blended.",
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

    def motion(self, m: Motion) -> None:
        if m.kind == "curve":
            raise LimitError(
                f"line {m.line}: a G5 curve has no Turbo PMAC move",
                expected="lines and arcs for the Cartesian PMAC program (or the pmac format)",
            )
        if m.kind == "function":
            self.lines.append(f"; line {m.line}")
            self.lines.append("DWELL0")
            self.lines.append(self._function(m.words))
            return
        if m.kind == "dwell":
            self.lines += [f"; line {m.line}", f"DWELL{_f(m.duration * 1000.0)}"]
            return
        if m.tool_length != self.tool:
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
            self.lines.append(f"; line {m.line}")
            self._set_mode("LINEAR")
            dxyz = float(np.linalg.norm(e[:3] - s[:3]))
            dab = float(np.linalg.norm(e[3:] - s[3:]))
            self.lines += [self._timing(m, dxyz, dab), _pose(e), "DWELL0"]
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
        self.lines.append(f"; line {m.line}")
        if m.plane != self.plane:
            self.lines.append(PLANE_NORMAL[m.plane])
            self.plane = m.plane
        self._set_mode("CIRCLE2" if sweep > 0 else "CIRCLE1")
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
            timing = self._timing(m, arc_len, float(np.linalg.norm(end[3:] - start[3:])))
            vec = " ".join(
                f"{a}{_f(v)}" for i, (a, v) in enumerate(zip("IJK", ijk, strict=True)) if i != axis
            )
            self.lines += [timing, f"{_pose(end)} {vec}", "DWELL0"]
            start = end

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
    motions: Sequence[Motion], profile: Profile, prov: Provenance, start: Sequence[float]
) -> str:
    """The Cartesian Turbo PMAC program of ``motions``, starting at pose ``start``."""
    w = CartesianWriter(profile, prov)
    w.begin()
    w.start(start)
    for m in motions:
        w.motion(m)
    return w.finish()
