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
  or TM, TA) the time between the ramps' middles (TUM "Linear Blended Moves",
  "Acceleration Parameters"). Every move here is followed by DWELL0, so no two
  moves blend; :func:`run_segmented` refuses a move that is not.
- With Isx13 > 0 each move is cut into segments of Isx13 ms from its start; at
  each segment's end the axis positions are computed and the inverse-kinematic
  program turns them into motor positions (SRM Isx13, Isx50; TUM "Conversion
  from Axis to Motor Position": "every segment of the move"). Here the inverse
  is the project's chain (the map, then the calibrated IK): test_writers_pmac_
  kinematics holds the exported OPEN INVERSE to it within 0.01 count.
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
from dataclasses import dataclass

import numpy as np

from prsxy_post import chain, errormap, kinematics
from prsxy_post.profile import Profile

from .controllers import SERVO_MS

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


def fraction(t: np.ndarray, T: float, TA: float) -> np.ndarray:
    """The share of the move done at times t [s] (module docstring): ramps of TA,
    T between their middles (T ≥ TA), from rest to rest."""
    V = 1.0 / T
    total = T + TA
    t = np.clip(t, 0.0, total)
    up = 0.5 * V / TA * t**2
    flat = V * (t - TA / 2)
    down = 1.0 - 0.5 * V / TA * (total - t) ** 2
    return np.where(t < TA, up, np.where(t <= T, flat, down))


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
        if self.emap is not None:  # undo Q' = Q − e(Q'), as OPEN FORWARD does
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
    h = (seg_ms if seg_ms is not None else profile.period_ms) / 1000.0
    t: list[float] = []
    q: list[np.ndarray] = []
    tool: list[float] = []  # the tool the tip is judged with
    ik_tool: list[float] = []  # the tool the controller's inverse used (Q100)
    line: list[int] = []
    functions: list[tuple[int, str]] = []
    mode, normal = "LINEAR", 2
    F = TM = TA = None
    timed_by = "F"
    tlo = 0.0
    cur: np.ndarray | None = None
    cur_line = 0
    await_rest = False
    lines = text.splitlines()
    #: hold points not yet followed by a move: the spline leaves them towards the
    #: next move's points (its support is four points), so they are judged with
    #: the next move's line and tool (the motors stand while the tool changes)
    held: list[int] = []

    def hold() -> None:
        """The move ends at rest at its end point: the spline reaches it once the
        end is its last three points (two more segment ends held there)."""
        for _ in range(2):
            t.append(t[-1] + h)
            q.append(q[-1].copy())
            tool.append(tool[-1])
            ik_tool.append(ik_tool[-1])
            line.append(line[-1])
            held.append(len(t) - 1)

    for raw in lines:
        code = raw.split(";", 1)[0].strip()
        if raw.strip().startswith("; line "):
            cur_line = int(raw.strip()[7:].split(":")[0])
        if not code:
            continue
        if code in ("LINEAR", "CIRCLE1", "CIRCLE2"):
            mode = code
            continue
        if m := re.fullmatch(r"NORMAL ([IJK])-1", code):
            normal = NORMAL_AXIS[m.group(1)]
            continue
        if m := re.fullmatch(r"DWELL(\d+(?:\.\d+)?)", code):
            if await_rest:
                hold()
            await_rest = False
            ms = float(m.group(1))
            if ms > 0 and cur is not None:
                for _ in range(math.ceil(ms / (h * 1000) - 1e-9)):
                    t.append(t[-1] + h)
                    q.append(cur.copy())
                    tool.append(tlo)
                    ik_tool.append(tlo)
                    line.append(cur_line)
            continue
        if m := re.fullmatch(r"Q100=(-?\d+(?:\.\d+)?)", code):
            tlo = float(m.group(1))
            continue
        if code == 'CMD"PMATCH"':
            assert cur is not None
            # the axis positions of the motors as they stand, with the new tool
            P_now = kin.inverse(cur[None], np.array([ik_tool[-1]]))[0]
            cur = kin.forward(P_now, tlo)
            continue
        timing = dict(re.findall(r"\b(F|TM|TA)(\d+(?:\.\d+)?)", code))
        if timing and not _WORD.search(re.sub(r"\b(F|TM|TA)\d+(?:\.\d+)?", "", code)):
            if "F" in timing:
                F, timed_by = float(timing["F"]), "F"
            if "TM" in timing:
                TM, timed_by = float(timing["TM"]), "TM"
            if "TA" in timing:
                TA = float(timing["TA"])
            continue
        words = dict(_WORD.findall(code))
        if set("XYZAB") <= set(words):
            assert not await_rest, "a move not followed by DWELL0 would blend"
            end = np.array([float(words[a]) for a in "XYZAB"])
            await_rest = True
            if cur is None:  # the program's first move: where the machine is
                cur = end
                t.append(0.0)
                q.append(end)
                tool.append(tlo)
                ik_tool.append(tlo)
                line.append(cur_line)
                continue
            ijk = np.array([float(words.get(a, 0.0)) for a in "IJK"])
            pose, length = _path(mode, normal, cur, end, ijk)
            assert TA is not None
            ta = TA / 1000.0
            if timed_by == "F":
                assert F is not None and length > 0.0, code
                T = length / F
            else:
                assert TM is not None
                T = TM / 1000.0
            T = max(T, ta)
            total = T + ta
            ks = np.arange(1, math.ceil(total / h - 1e-9) + 1)
            u = fraction(ks * h, T, ta)
            u[-1] = 1.0
            pts = pose(u)
            for i in held:
                line[i] = cur_line
                tool[i] = tlo
            held.clear()
            t0 = t[-1]
            t.extend((t0 + ks * h).tolist())
            q.extend(list(pts))
            tool.extend([tlo] * len(ks))
            ik_tool.extend([tlo] * len(ks))
            line.extend([cur_line] * len(ks))
            cur = end
            continue
        if re.fullmatch(r"(?:[GMTDS]-?[\d.]+\s*)+", code):
            functions.append((len(t) - 1, code))
            continue
        # setup: CLOSE, &1, OPEN PROG, ABS, TS0
    ta_ = np.array(t)
    qa = np.array(q)
    toola = np.array(tool)
    P = kin.inverse(qa, np.array(ik_tool))
    # the servo clock's ticks from the start, each in the interval it falls in
    ticks = np.arange(1, int(ta_[-1] / (servo_ms / 1000.0)) + 1) * (servo_ms / 1000.0)
    k = np.clip(np.searchsorted(ta_, ticks, side="left") - 1, 0, len(ta_) - 2)
    s = (ticks - ta_[k]) / (ta_[k + 1] - ta_[k])
    P_dense = np.vstack([P[:1], bspline(P, s, k)])
    seg = np.concatenate([[0], k + 1])
    return SegmentedRun(
        ta_,
        qa,
        toola,
        np.array(line),
        P,
        np.concatenate([[0.0], ticks]),
        P_dense,
        seg,
        toola[seg],
        functions,
    )
