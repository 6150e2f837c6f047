"""The controllers, as the tests run them: written programs executed from their text.

Turbo PMAC (Software Reference, Program Command Specification):

- ``PVT{data}`` puts the program in PVT mode with a segment time of {data} ms;
  it is modal until the next PVT (or TM) command. With I42 = 0 the time is kept
  as 12 integer and 12 fractional bits of a ms (User Manual, "PVT-Mode Moves"), so
  only whole 1/4096 ms run as written: :func:`run_pmac` refuses a time between two
  (whether the controller would round or truncate it the manual does not say).
- In PVT mode a move line gives each axis ``{pos}:{vel}``; "taking the starting
  position and velocity (from the previous segment), the ending position and
  velocity, and the segment time, Turbo PMAC computes the unique cubic position
  profile (parabolic velocity profile) to meet these constraints" (PVT{data}).
- ``DWELL{data}`` holds for {data} ms; the motors are at rest after it, so the
  next PVT segment starts from zero velocity.
- ``RAPID`` moves to a point outside the PVT sequence (used once per program or
  part, where the machine already is).
- Letters G, M, T, D, S outside a move line are machine functions (no motion).
- ``;`` starts a comment.
- The trajectory generator computes each motor's commanded position once every
  servo cycle ("a Turbo PMAC program exists to pass data to the trajectory
  generator routines that compute the series of commanded positions for the motors
  every servo cycle", User Manual, How Turbo PMAC Executes a Motion Program); I10
  gives it the time it advances each servo interrupt (Software Reference, I10), and
  the default servo cycle is 442 µs (Software Reference, Isx94's note). A motor is
  commanded only at those instants: :func:`run_pmac` with ``servo_ms`` samples the
  cubics there, the clock starting with each move from rest (after a DWELL, or the
  program's start), and a motor brought to rest holds its end position for the
  next servo cycle, so that position is commanded too.

LinuxCNC (G-code): a G1 moves along a straight line in the controller's Cartesian
space, which its kinematics turn into joint commands; corners blend within the
G64 P tolerance (the blend's deviation is bounded by P, LinuxCNC's G-code docs,
"G64"), so the tests hold the straight polyline to the path with that allowance.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from prsxy_post import axiscomp, gcode, kinematics, simulate
from prsxy_post.profile import MOTORS, Profile

AXES = "UVWXY"
#: 0.5 µm for 0.5 arcsec: how an A/B error weighs against a distance
MM_PER_DEG = 0.5e-3 / (0.5 / 3600.0)
_MOVE = re.compile(r"([UVWXY])(-?\d+\.\d+):(-?\d+\.\d+)")


@dataclass
class PmacRun:
    """A PMAC program executed: the points as written and the motion between them.

    P, V : (n, 5) positions and velocities at the points (the RAPID start first)
    t : (n,) time at each point [s]
    line : (n,) the G-code line of each point (from the ``; line`` comments)
    t_dense, P_dense : the commanded motion sampled inside every segment
    seg : (m,) the point each dense sample's segment ends at
    functions : (point index, words) of every machine function
    dwells : (point index, ms) of every DWELL
    parts : how many programs (OPEN PROG ... CLOSE) the text held
    """

    P: np.ndarray
    V: np.ndarray
    t: np.ndarray
    line: np.ndarray
    t_dense: np.ndarray
    P_dense: np.ndarray
    seg: np.ndarray
    functions: list[tuple[int, str]]
    dwells: list[tuple[int, float]]
    parts: int


def hermite(
    P0: np.ndarray, V0: np.ndarray, P1: np.ndarray, V1: np.ndarray, h: float, s: np.ndarray
) -> np.ndarray:
    """The cubic through (P0, V0) and (P1, V1) over time h, at fractions s (m,) → (m, 5)."""
    s = s[:, None]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    return h00 * P0 + h10 * h * V0 + h01 * P1 + h11 * h * V1


#: Turbo PMAC's default servo cycle [ms] (module docstring)
SERVO_MS = 0.442


def _servo_fractions(t0: float, h: float, origin: float, servo_s: float) -> np.ndarray:
    """The fractions of a segment [t0, t0 + h] at which the servo clock that ticks
    at ``origin + k * servo_s`` falls, the segment's start excluded, its end included."""
    eps = 1e-9 * servo_s  # a tick on the segment's end counts (sums of floats)
    k0 = int(np.floor((t0 - origin + eps) / servo_s)) + 1
    k1 = int(np.floor((t0 + h - origin + eps) / servo_s))
    ticks = origin + servo_s * np.arange(k0, k1 + 1)
    return np.clip((ticks - t0) / h, 0.0, 1.0)


def run_pmac(
    texts: list[str], substeps: int = 16, servo_ms: float | None = None, servo_phase: float = 0.0
) -> PmacRun:
    """Execute PMAC program text(s), run one after the other, as the controller does.

    The motion between the points is sampled ``substeps`` times a segment, evenly,
    or, with ``servo_ms``, at the servo clock as the controller commands it (module
    docstring). ``servo_phase`` (a share of a cycle) moves the ticks later than the
    controller's, for measuring how much a result owes to where they fall.
    """
    P: list[np.ndarray] = []
    V: list[np.ndarray] = []
    t: list[float] = []
    line: list[int] = []
    functions: list[tuple[int, str]] = []
    dwells: list[tuple[int, float]] = []
    dense_t: list[np.ndarray] = []
    dense_P: list[np.ndarray] = []
    dense_seg: list[np.ndarray] = []
    seg_ms = None
    cur_line = 0
    parts = 0
    at_rest = True
    s = np.linspace(0.0, 1.0, substeps + 1)[1:]
    servo_s = None if servo_ms is None else servo_ms / 1000.0
    origin = 0.0  # where the servo clock started ticking for the moves

    def hold() -> None:
        """A motor brought to rest holds its end position from the next tick on: that
        position is commanded (sampled here at the move's end)."""
        if servo_s is None or not dense_t:
            return
        last = next((float(a[-1]) for a in reversed(dense_t) if len(a)), None)
        # not where a tick fell on the end already (within the sums' rounding: a
        # sample a femtosecond away would make a speed of nothing over nothing)
        if last is None or t[-1] - last > 1e-9:
            dense_t.append(np.array([t[-1]]))
            dense_P.append(P[-1][None, :].copy())
            dense_seg.append(np.array([len(P) - 1]))

    for text in texts:
        for raw in text.splitlines():
            code = raw.split(";", 1)[0].strip()
            if raw.strip().startswith("; line "):
                cur_line = int(raw.strip()[7:])
            if not code:
                continue
            if code.startswith("OPEN PROG") or code == "OPEN ROT":
                parts += 1
                continue
            if code.startswith("RAPID"):
                pos = dict(re.findall(r"([UVWXY])(-?\d+\.\d+)", code))
                p = np.array([float(pos[a]) for a in AXES])
                if P:
                    # a part starts where the previous one ended: the RAPID must not move
                    assert np.array_equal(p, P[-1]), f"RAPID moves: {P[-1]} -> {p}"
                    continue
                P.append(p)
                V.append(np.zeros(5))
                t.append(0.0)
                line.append(cur_line)
                continue
            if code.startswith("PVT"):
                seg_ms = float(code[3:])
                assert (seg_ms * 4096).is_integer(), f"{code}: off the 1/4096 ms grid"
                continue
            if code.startswith("DWELL"):
                assert not np.any(V[-1]) or at_rest, "a DWELL after a point with velocity"
                ms = float(code[5:])
                hold()
                if ms > 0:
                    dwells.append((len(P), ms))
                    h = ms / 1000.0
                    dense_t.append(t[-1] + s * h)
                    dense_P.append(np.repeat(P[-1][None, :], len(s), axis=0))
                    dense_seg.append(np.full(len(s), len(P)))
                    P.append(P[-1].copy())
                    V.append(np.zeros(5))
                    t.append(t[-1] + h)
                    line.append(cur_line)
                at_rest = True
                continue
            mv = _MOVE.findall(code)
            if mv:
                assert seg_ms is not None, "a PVT move before any PVT time"
                d = {a: (float(p), float(v)) for a, p, v in mv}
                assert set(d) == set(AXES), code
                p1 = np.array([d[a][0] for a in AXES])
                v1 = np.array([d[a][1] for a in AXES])
                v0 = np.zeros(5) if at_rest else V[-1]
                h = seg_ms / 1000.0
                f = s
                if servo_s is not None:
                    if at_rest:  # the clock of a move from rest starts with it
                        origin = t[-1] + servo_phase * servo_s
                    f = _servo_fractions(t[-1], h, origin, servo_s)
                dense_t.append(t[-1] + f * h)
                dense_P.append(hermite(P[-1], v0, p1, v1, h, f))
                dense_seg.append(np.full(len(f), len(P)))
                P.append(p1)
                V.append(v1)
                t.append(t[-1] + h)
                line.append(cur_line)
                at_rest = False
                continue
            if re.fullmatch(r"(?:[GMTDS]-?[\d.]+\s*)+", code):
                assert not np.any(V[-1]), "a machine function while moving"
                functions.append((len(P) - 1, code))
                continue
            # setup lines: CLOSE, &n, #n->..., ABS, OPEN ROT, DEFINE ..., B0, DELETE ...
    hold()  # the program's end
    # the run begins at the start point: the play model starts there (approached
    # from below, the contract says), not at the first sample of the first segment
    return PmacRun(
        np.array(P),
        np.array(V),
        np.array(t),
        np.array(line),
        np.concatenate([[0.0], *dense_t]),
        np.vstack([P[0][None, :], *dense_P]),
        np.concatenate([[0], *dense_seg]).astype(int),
        functions,
        dwells,
        parts,
    )


def machine_executes(
    truth: Profile, t: np.ndarray, P_cmd: np.ndarray, tool: np.ndarray
) -> np.ndarray:
    """What the truth machine does with a continuous command: each motor's driven
    part follows the contract's play model along the (densely sampled) command,
    then the forward kinematics of the true geometry; (m, 5) tip poses."""
    tables = axiscomp.profile_tables(truth)
    P = P_cmd.copy()
    for col, m in enumerate(MOTORS):
        if m in tables:
            P[:, col] = axiscomp.play_model(tables[m], P_cmd[:, col])
    geo = simulate.truth_geometry(truth)
    q, ok = kinematics.forward(geo, P, tool)
    assert np.all(ok), "the forward kinematics did not converge"
    return q


@dataclass
class Trace:
    """How far an executed motion strays: the worst values and where."""

    path_mm: float
    ab_deg: float
    speed_ratio: float
    accel_mm_s2: float
    worst_line: int
    #: the largest speed over the programmed feed [mm/s] (≤ 0 within F)
    speed_excess_mm_s: float = 0.0


def judge(
    motions: list[gcode.Motion],
    q: np.ndarray,
    t: np.ndarray,
    seg: np.ndarray,
    point_line: np.ndarray,
    tool: np.ndarray,
    rapid_mm_min: float,
) -> Trace:
    """Hold a continuous executed motion against the G-code's own geometry.

    Each sample lies in the segment between two points; it is judged against the
    motions of those two points' lines (a segment crosses at most one block end).
    """
    from .test_tracking import path_distance

    by_line: dict[int, list[gcode.Motion]] = {}
    for m in motions:
        if m.kind in ("dwell", "function"):
            continue
        if m.kind in ("arc", "curve") or m.start != m.end:
            by_line.setdefault(m.line, []).append(m)
    la = point_line[np.maximum(seg - 1, 0)]
    lb = point_line[seg]
    dist = np.full(len(q), np.inf)
    ab = np.full(len(q), np.inf)
    feed = np.zeros(len(q))
    for a, b in {(int(x), int(y)) for x, y in zip(la, lb, strict=True)}:
        sel = np.flatnonzero((la == a) & (lb == b))
        cands = by_line.get(a, []) + (by_line.get(b, []) if b != a else [])
        if not cands:
            # the path stands (a dwell, a function, a tool change): the pose must not move
            cands = []
        for m in cands:
            d, e = path_distance(m, q[sel])
            # the nearer motion in both senses: mm and degrees at the tolerances' ratio
            better = np.maximum(d, e * MM_PER_DEG) < np.maximum(dist[sel], ab[sel] * MM_PER_DEG)
            dist[sel] = np.where(better, d, dist[sel])
            ab[sel] = np.where(better, e, ab[sel])
            rate = rapid_mm_min if m.kind == "rapid" else m.feed
            feed[sel] = np.maximum(feed[sel], rate)
    moving = np.isfinite(dist)
    path = float(dist[moving].max()) if np.any(moving) else 0.0
    abe = float(ab[moving].max()) if np.any(moving) else 0.0
    worst = int(lb[moving][np.argmax(dist[moving])]) if np.any(moving) else 0
    # speed and acceleration along the executed motion (same tool, moving samples)
    dt = np.diff(t)
    same = (tool[1:] == tool[:-1]) & (dt > 0) & moving[1:] & moving[:-1]
    v = np.linalg.norm(np.diff(q[:, :3], axis=0), axis=1) / np.where(dt > 0, dt, 1.0)
    ratio = v / np.where(feed[1:] > 0, feed[1:] / 60.0, np.inf)
    speed_ratio = float(ratio[same].max()) if np.any(same) else 0.0
    excess = v - np.where(feed[1:] > 0, feed[1:] / 60.0, np.inf)
    speed_excess = float(excess[same].max()) if np.any(same) else 0.0
    acc = 0.0
    if len(q) > 2:
        vel = np.diff(q[:, :3], axis=0) / np.where(dt > 0, dt, 1.0)[:, None]
        tm = 0.5 * (t[1:] + t[:-1])
        dv = np.diff(vel, axis=0) / np.where(np.diff(tm) > 0, np.diff(tm), 1.0)[:, None]
        ok = same[1:] & same[:-1]
        if np.any(ok):
            acc = float(np.linalg.norm(dv, axis=1)[ok].max())
    return Trace(path, abe, speed_ratio, acc, worst, speed_excess)


@dataclass
class GcodeRun:
    """Corrected G-code executed as LinuxCNC moves: straight lines between points in
    its Cartesian space (XYZAB), timed by G93 inverse time.

    q : (n, 5) the written points; t : (n,) time at each; line : (n,) source line
    q_dense, t_dense, seg : the segments sampled (arcs as LinuxCNC runs them)
    functions, dwells, blend : machine-function lines, G4 dwells (point, s), the G64 P
    arcs : the G2/G3 moves, by the index of the point they end at
    """

    q: np.ndarray
    t: np.ndarray
    line: np.ndarray
    q_dense: np.ndarray
    t_dense: np.ndarray
    seg: np.ndarray
    functions: list[tuple[int, str]]
    dwells: list[tuple[int, float]]
    blend: float | None
    arcs: dict[int, GcodeArc] = field(default_factory=dict)


#: the plane's first and second axis and its normal (rs274ngc), by G17, G18, G19
ARC_PLANES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}


@dataclass(frozen=True)
class GcodeArc:
    """A G2/G3 as LinuxCNC runs it (emccanon.cc ARC_FEED, _posemath.c pmCircleInit):
    in the plane's (u, v) the radius runs linearly in the angle from the start's to
    the end's, the axis w and A, B linearly; ``center`` (3,) X Y Z (its w unused)."""

    center: tuple[float, float, float]
    plane: int
    ccw: bool

    def geometry(self, a: np.ndarray, b: np.ndarray) -> tuple[float, float, float, float]:
        """(start angle, sweep [rad], start radius, end radius) from a to b."""
        iu, iv, _ = ARC_PLANES[self.plane]
        cu, cv = self.center[iu], self.center[iv]
        th0 = math.atan2(a[iv] - cv, a[iu] - cu)
        th1 = math.atan2(b[iv] - cv, b[iu] - cu)
        # canon's wrap: a sweep in (0, 2 pi] the arc's way (emccanon.cc:1665-1669)
        sweep = (th1 - th0) % (2 * math.pi) if self.ccw else -((th0 - th1) % (2 * math.pi))
        if sweep == 0.0:
            sweep = 2 * math.pi if self.ccw else -2 * math.pi
        r0 = math.hypot(a[iu] - cu, a[iv] - cv)
        r1 = math.hypot(b[iu] - cu, b[iv] - cv)
        return th0, sweep, r0, r1

    def at(self, a: np.ndarray, b: np.ndarray, f: np.ndarray) -> np.ndarray:
        """The poses (len(f), 5) at the shares ``f`` of the angle from a to b."""
        iu, iv, _ = ARC_PLANES[self.plane]
        th0, sweep, r0, r1 = self.geometry(a, b)
        th = th0 + sweep * f
        r = r0 + (r1 - r0) * f
        out = a[None, :] + (b - a)[None, :] * f[:, None]
        out[:, iu] = self.center[iu] + r * np.cos(th)
        out[:, iv] = self.center[iv] + r * np.sin(th)
        return out

    def distance(self, a: np.ndarray, b: np.ndarray, q: np.ndarray, w_deg: float) -> np.ndarray:
        """How far the poses q (m, 5) are from the arc a → b: at each pose's own
        angle (clipped to the arc), |radial, axial, A B × w_deg| [mm]."""
        iu, iv, _ = ARC_PLANES[self.plane]
        th0, sweep, _, _ = self.geometry(a, b)
        th = np.arctan2(q[:, iv] - self.center[iv], q[:, iu] - self.center[iu])
        d = (th - th0) % (2 * math.pi) if sweep > 0 else -((th0 - th) % (2 * math.pi))
        # angles beyond the arc's ends: the nearer end
        beyond = np.abs(d) > abs(sweep)
        past_end = np.abs(np.abs(d) - abs(sweep)) < 2 * math.pi - np.abs(d)
        f = np.where(beyond, np.where(past_end, 1.0, 0.0), d / sweep)
        p = self.at(a, b, f)
        w = np.array([1.0, 1.0, 1.0, w_deg, w_deg])
        return np.linalg.norm((q - p) * w, axis=1)


def arc_substeps(arc: GcodeArc, a: np.ndarray, b: np.ndarray, substeps: int) -> int:
    """Samples along an arc: at least ``substeps``, and chords of them within 1 nm."""
    _, sweep, r0, r1 = arc.geometry(a, b)
    r = max(r0, r1, 1e-9)
    return max(substeps, math.ceil(abs(sweep) / math.sqrt(8e-6 / r)))


def run_gcode(text: str, substeps: int = 8) -> GcodeRun:
    """Read corrected G-code back (G0 start, G93 G1 X Y Z A B F, G2/G3 with I J K in
    G17/G18/G19, G4 P, functions)."""
    q: list[list[float]] = []
    arcs: dict[int, GcodeArc] = {}
    plane = 17
    t: list[float] = []
    line: list[int] = []
    functions: list[tuple[int, str]] = []
    dwells: list[tuple[int, float]] = []
    blend = None
    cur = 0
    for raw in text.splitlines():
        s = raw.strip()
        m = re.match(r"\(line (\d+)\)", s)
        if m:
            cur = int(m.group(1))
            continue
        if s.startswith("(") or s in ("%", ""):
            continue
        w = dict(re.findall(r"([XYZABFPIJK])(-?\d+\.?\d*)", s))
        planes = re.findall(r"\bG(17|18|19)\b", s)
        if planes:
            plane = int(planes[-1])
        if s.startswith(("G2 ", "G3 ")):
            iu, iv, _ = ARC_PLANES[plane]
            start = q[-1]
            center = list(start[:3])
            for i in (iu, iv):
                center[i] += float(w.get("IJK"[i], 0.0))
            q.append([float(w[a]) for a in "XYZAB"])
            t.append(t[-1] + 60.0 / float(w["F"]))
            line.append(cur)
            arcs[len(q) - 1] = GcodeArc((center[0], center[1], center[2]), plane, s[1] == "3")
        elif s.startswith("G64"):
            blend = float(w["P"])
        elif s.startswith("G0 ") or s.startswith("G1 "):
            q.append([float(w[a]) for a in "XYZAB"])
            t.append((t[-1] + 60.0 / float(w["F"])) if "F" in w else 0.0)
            line.append(cur)
        elif s.startswith("G4 "):
            q.append(q[-1])
            t.append(t[-1] + float(w["P"]))
            line.append(cur)
            if float(w["P"]) > 0.0:  # G4 P0 waits for the motion to end, no time
                dwells.append((len(q) - 1, float(w["P"])))
        elif re.fullmatch(r"(?:[GMTS]-?[\d.]+\s*)+", s) and not s.startswith(
            ("G2", "G9", "G64", "G61", "G17", "G18", "G19")
        ):
            functions.append((len(q) - 1, s))
    qa = np.array(q)
    ta = np.array(t)
    s = np.linspace(0.0, 1.0, substeps + 1)[1:]
    a, b = qa[:-1], qa[1:]
    dense = a[:, None, :] + (b - a)[:, None, :] * s[None, :, None]
    td = ta[:-1, None] + (ta[1:] - ta[:-1])[:, None] * s[None, :]
    seg = np.repeat(np.arange(1, len(qa)), substeps)
    q_dense = np.vstack([qa[:1], dense.reshape(-1, 5)])
    t_dense = np.concatenate([[0.0], td.reshape(-1)])
    seg_dense = np.concatenate([[0], seg])
    if arcs:
        # each arc sampled along its own path (time linear in its angle)
        qs, ts, ks = [q_dense[:1]], [t_dense[:1]], [seg_dense[:1]]
        for k in range(1, len(qa)):
            arc = arcs.get(k)
            if arc is None:
                sl = slice(1 + (k - 1) * substeps, 1 + k * substeps)
                qs.append(q_dense[sl])
                ts.append(t_dense[sl])
                ks.append(seg_dense[sl])
                continue
            n = arc_substeps(arc, qa[k - 1], qa[k], substeps)
            f = np.linspace(0.0, 1.0, n + 1)[1:]
            qs.append(arc.at(qa[k - 1], qa[k], f))
            ts.append(ta[k - 1] + (ta[k] - ta[k - 1]) * f)
            ks.append(np.full(n, k))
        q_dense, t_dense, seg_dense = np.vstack(qs), np.concatenate(ts), np.concatenate(ks)
    return GcodeRun(
        qa,
        ta,
        np.array(line),
        q_dense,
        t_dense,
        seg_dense,
        functions,
        dwells,
        blend,
        arcs,
    )
