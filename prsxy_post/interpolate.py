"""Coarse interpolation in virtual-axis space.

The interpreted motions become points every ``period`` seconds (at most), in
the five virtual axes q = [x, y, z, A, B] (workpiece frame, mm and degrees):

- straight moves are linear in all five axes; arcs lie exactly on the arc
  (helix linear in the axial coordinate, A and B linear along the arc);
- every block's end point is an interpolation point: a block of duration τ is
  cut into n = ⌈τ / period⌉ equal steps of τ / n ≤ period;
- the speed along the path follows an acceleration-limited trapezoid per block;
  the speed at block junctions is planned with look-ahead (a backward and a
  forward pass) so that it never exceeds the feed F of either block, the
  acceleration limit holds within blocks, and at a corner of angle θ the
  velocity jump 2 v sin(θ/2) is at most a·period (what one interpolation cycle
  can absorb);
- F is mm/min along the XYZ path; a move that only turns A/B is timed in
  degrees (LinuxCNC's rule); rapids use the profile's rapid rates;
- a dwell holds the point for its duration.

The path is exact regardless of the speed plan: points are evaluated on the
programmed geometry.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .gcode import Motion

KIND_RAPID, KIND_FEED, KIND_ARC, KIND_DWELL = 0, 1, 2, 3
_KIND = {"rapid": KIND_RAPID, "feed": KIND_FEED, "arc": KIND_ARC, "dwell": KIND_DWELL}

#: in-plane axes (u, v) and normal w of G17, G18, G19 as LinuxCNC orders them:
#: each is a right-handed triple, so a positive rotation is counter-clockwise
#: seen from the positive end of w.
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}

#: A move shorter than this in XYZ (mm) is a rotary-only move.
LINEAR_EPS_MM = 1e-9
#: A move shorter than this in A/B and XYZ is no move at all.
ANGULAR_EPS_DEG = 1e-9


@dataclass(frozen=True)
class Limits:
    """Speed and acceleration limits for planning (profile ``[limits]``)."""

    rapid_mm_min: float = 10000.0
    rapid_deg_min: float = 3600.0
    accel_mm_s2: float = 2000.0
    accel_deg_s2: float = 3600.0
    period_s: float = 0.010


@dataclass
class Blocks:
    """Motions as arrays, one row per block (zero-length moves removed).

    kind : (n,) int, KIND_*
    start, end : (n, 5) [mm, mm, mm, deg, deg]
    line : (n,) source line
    tool_length : (n,) active G43 offset [mm]
    length : (n,) path length [mm, or deg for rotary-only moves]
    angular : (n,) bool, timed in degrees (rotary-only move)
    vmax : (n,) speed limit [mm/s or deg/s]
    accel : (n,) acceleration limit [mm/s² or deg/s²]
    duration : (n,) dwell time [s] (dwell blocks)
    plane, center, sweep, r0, r1 : arc data (sweep signed, rad)
    t_in, t_out : (n, 3) unit tangents at start and end (XYZ), zero for dwell/rotary
    """

    kind: np.ndarray
    start: np.ndarray
    end: np.ndarray
    line: np.ndarray
    tool_length: np.ndarray
    length: np.ndarray
    angular: np.ndarray
    vmax: np.ndarray
    accel: np.ndarray
    duration: np.ndarray
    plane: np.ndarray
    center: np.ndarray
    sweep: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    theta0: np.ndarray
    t_in: np.ndarray
    t_out: np.ndarray

    def __len__(self) -> int:
        return len(self.kind)

    def take(self, sl: slice | np.ndarray) -> Blocks:
        return Blocks(**{k: getattr(self, k)[sl] for k in self.__dataclass_fields__})


def _arc_geometry(
    start: np.ndarray, end: np.ndarray, center: np.ndarray, plane: np.ndarray, rotation: np.ndarray
) -> dict[str, np.ndarray]:
    """Sweep, radii, start angle, XYZ length and end tangents of arcs (vectorised).

    The sweep follows LinuxCNC's ARC_FEED rotation: sign = direction (+ counter-
    clockwise seen from the positive end of the plane's normal), magnitude =
    turns; an arc whose end angle equals its start angle is a full turn.
    """
    n = len(start)
    iu = np.empty(n, dtype=int)
    iv = np.empty(n, dtype=int)
    iw = np.empty(n, dtype=int)
    for pl, (a, b_, c) in PLANE_AXES.items():
        sel = plane == pl
        iu[sel], iv[sel], iw[sel] = a, b_, c
    r = np.arange(n)
    u0, v0 = start[r, iu] - center[r, iu], start[r, iv] - center[r, iv]
    u1, v1 = end[r, iu] - center[r, iu], end[r, iv] - center[r, iv]
    r0, r1 = np.hypot(u0, v0), np.hypot(u1, v1)
    th0, th1 = np.arctan2(v0, u0), np.arctan2(v1, u1)
    turns = np.abs(rotation)
    ccw = rotation > 0
    d = np.where(ccw, (th1 - th0) % (2 * np.pi), (th0 - th1) % (2 * np.pi))
    d = np.where(d <= 1e-12, 2 * np.pi, d)
    sweep = np.where(ccw, 1.0, -1.0) * (d + 2 * np.pi * (turns - 1))
    dw = end[r, iw] - start[r, iw]
    rm = 0.5 * (r0 + r1)
    length = np.hypot(rm * sweep, dw)
    sgn = np.sign(sweep)
    with np.errstate(invalid="ignore", divide="ignore"):
        k = np.where(length > 0, np.abs(rm * sweep) / length, 0.0)
        kw = np.where(length > 0, dw / length, 0.0)
    t_in = np.zeros((n, 3))
    t_out = np.zeros((n, 3))
    th_e = th0 + sweep
    t_in[r, iu] = -np.sin(th0) * sgn * k
    t_in[r, iv] = np.cos(th0) * sgn * k
    t_in[r, iw] = kw
    t_out[r, iu] = -np.sin(th_e) * sgn * k
    t_out[r, iv] = np.cos(th_e) * sgn * k
    t_out[r, iw] = kw
    return {
        "sweep": sweep,
        "r0": r0,
        "r1": r1,
        "theta0": th0,
        "length": length,
        "rm": rm,
        "t_in": t_in,
        "t_out": t_out,
    }


def blocks_from_motions(motions: Sequence[Motion], limits: Limits) -> Blocks:
    """Turn interpreted motions into planning arrays (vectorised); no-motion moves are dropped.

    Speed limits: F (mm/min) along XYZ, or degrees/min for rotary-only moves;
    the profile's rapid rates for G0; A/B rates and accelerations capped by the
    rotary limits scaled by length/angle; on arcs v ≤ sqrt(a r) (centripetal).
    """
    n = len(motions)
    # one pass over the motions (Motion is a tuple): a column per field
    cols = list(zip(*motions, strict=True)) if n else [()] * len(Motion._fields)
    f = Motion._fields.index
    kind = np.array([_KIND[k] for k in cols[f("kind")]], dtype=int).reshape(n)
    start = np.array(cols[f("start")], dtype=float).reshape(n, 5)
    end = np.array(cols[f("end")], dtype=float).reshape(n, 5)
    line = np.array(cols[f("line")], dtype=int).reshape(n)
    tool_length = np.array(cols[f("tool_length")], dtype=float).reshape(n)
    feed = np.array(cols[f("feed")], dtype=float).reshape(n)
    duration = np.array(cols[f("duration")], dtype=float).reshape(n)
    is_arc = kind == KIND_ARC
    plane = np.zeros(n, dtype=int)
    center = np.zeros((n, 3))
    rotation = np.zeros(n, dtype=int)
    arcs = np.flatnonzero(is_arc).tolist()
    if arcs:
        plane[is_arc] = [cols[f("plane")][i] for i in arcs]
        center[is_arc] = np.array([cols[f("center")][i] for i in arcs], dtype=float)
        rotation[is_arc] = [cols[f("rotation")][i] for i in arcs]

    dxyz = end[:, :3] - start[:, :3]
    lin_len = np.sqrt(np.einsum("ij,ij->i", dxyz, dxyz))
    ang = np.hypot(end[:, 3] - start[:, 3], end[:, 4] - start[:, 4])
    length = lin_len.copy()
    with np.errstate(invalid="ignore", divide="ignore"):
        t_lin = np.where(lin_len[:, None] > LINEAR_EPS_MM, dxyz / lin_len[:, None], 0.0)
    t_in = t_lin.copy()
    t_out = t_lin.copy()
    sweep = np.zeros(n)
    r0 = np.zeros(n)
    r1 = np.zeros(n)
    theta0 = np.zeros(n)
    rm = np.full(n, np.inf)
    if arcs:
        g = _arc_geometry(
            start[is_arc], end[is_arc], center[is_arc], plane[is_arc], rotation[is_arc]
        )
        sweep[is_arc], r0[is_arc], r1[is_arc] = g["sweep"], g["r0"], g["r1"]
        theta0[is_arc], length[is_arc], rm[is_arc] = g["theta0"], g["length"], g["rm"]
        t_in[is_arc], t_out[is_arc] = g["t_in"], g["t_out"]

    dwell = kind == KIND_DWELL
    rapid = kind == KIND_RAPID
    angular = ~dwell & (length <= LINEAR_EPS_MM)
    keep = dwell | ~angular | (ang > ANGULAR_EPS_DEG)
    length = np.where(dwell, 0.0, np.where(angular, ang, length))
    t_in[angular | dwell] = 0.0
    t_out[angular | dwell] = 0.0
    rate_deg = limits.rapid_deg_min / 60.0
    with np.errstate(invalid="ignore", divide="ignore"):
        v_lin = np.where(rapid, limits.rapid_mm_min / 60.0, feed / 60.0)
        v_ang = np.where(rapid, rate_deg, np.minimum(feed / 60.0, rate_deg))
        turning = ang > 0
        scale = np.where(turning, length / np.where(turning, ang, 1.0), np.inf)
        v_lin = np.minimum(v_lin, rate_deg * scale)
        a_lin = np.minimum(limits.accel_mm_s2, limits.accel_deg_s2 * scale)
        v_lin = np.where(is_arc & (rm > 0), np.minimum(v_lin, np.sqrt(a_lin * rm)), v_lin)
    vmax = np.where(dwell, 1.0, np.where(angular, v_ang, v_lin))
    accel = np.where(dwell, 1.0, np.where(angular, limits.accel_deg_s2, a_lin))
    b = Blocks(
        kind=kind,
        start=start,
        end=end,
        line=line,
        tool_length=tool_length,
        length=length,
        angular=angular,
        vmax=vmax,
        accel=accel,
        duration=np.where(dwell, duration, 0.0),
        plane=plane,
        center=center,
        sweep=sweep,
        r0=r0,
        r1=r1,
        theta0=theta0,
        t_in=t_in,
        t_out=t_out,
    )
    return b if keep.all() else b.take(keep)


def junction_limits(b: Blocks, period_s: float) -> np.ndarray:
    """Speed limit at the end of each block (the junction with the next one).

    The velocity vector changes by 2 v sin(θ/2) at a corner of angle θ; bounding
    that by a·period lets one interpolation cycle absorb it. Junctions next to a
    dwell, a rotary-only move or a change of tool length are stops. The last
    block ends at rest.
    """
    n = len(b)
    vj = np.zeros(n)
    if n < 2:
        return vj
    cosang = np.clip(np.einsum("ij,ij->i", b.t_out[:-1], b.t_in[1:]), -1.0, 1.0)
    half = np.sqrt(np.maximum(0.0, (1.0 - cosang) / 2.0))  # sin(θ/2)
    a = np.minimum(b.accel[:-1], b.accel[1:])
    with np.errstate(divide="ignore"):
        corner = np.where(half > 1e-12, a * period_s / (2 * np.maximum(half, 1e-300)), np.inf)
    v = np.minimum(np.minimum(b.vmax[:-1], b.vmax[1:]), corner)
    stop = (
        (b.kind[:-1] == KIND_DWELL)
        | (b.kind[1:] == KIND_DWELL)
        | b.angular[:-1]
        | b.angular[1:]
        | (b.tool_length[:-1] != b.tool_length[1:])
    )
    vj[:-1] = np.where(stop, 0.0, v)
    return vj


def backward_pass(b: Blocks, vj: np.ndarray) -> np.ndarray:
    """v_out[k] ≤ sqrt(v_out[k+1]² + 2 a_{k+1} L_{k+1}): every block can slow down in time.

    A plain loop over Python floats: its arithmetic does not depend on where a
    stream was cut, which keeps streamed output identical to one-shot output.
    """
    n = len(b)
    v = vj.tolist()
    two_al = np.where(b.kind == KIND_DWELL, 0.0, 2.0 * b.accel * b.length).tolist()
    sqrt = math.sqrt
    nxt = v[-1] if n else 0.0
    for k in range(n - 2, -1, -1):
        lim = sqrt(nxt * nxt + two_al[k + 1])
        if v[k] > lim:
            v[k] = lim
        nxt = v[k]
    return np.array(v, dtype=float)


def forward_pass(b: Blocks, v_back: np.ndarray, v_start: float = 0.0) -> np.ndarray:
    """v_out[k] ≤ sqrt(v_out[k−1]² + 2 a_k L_k): every block can speed up in time."""
    v = v_back.tolist()
    two_al = np.where(b.kind == KIND_DWELL, 0.0, 2.0 * b.accel * b.length).tolist()
    sqrt = math.sqrt
    prev = v_start
    for k in range(len(v)):
        lim = sqrt(prev * prev + two_al[k])
        if v[k] > lim:
            v[k] = lim
        prev = v[k]
    return np.array(v, dtype=float)


@dataclass(frozen=True)
class TimeLaw:
    """Trapezoid per block: entry v0, exit v1, peak vp, accel a, phase times."""

    v0: np.ndarray
    v1: np.ndarray
    vp: np.ndarray
    a: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    t3: np.ndarray
    duration: np.ndarray


def time_law(b: Blocks, v_out: np.ndarray, v_start: float = 0.0) -> TimeLaw:
    """Acceleration-limited trapezoids between the planned junction speeds."""
    v0 = np.concatenate([[v_start], v_out[:-1]])
    v1 = v_out.copy()
    dwell = b.kind == KIND_DWELL
    v0[dwell] = 0.0
    v1[dwell] = 0.0
    a = b.accel
    L = b.length
    vp = np.minimum(b.vmax, np.sqrt(np.maximum(a * L + 0.5 * (v0**2 + v1**2), 0.0)))
    vp = np.maximum(vp, np.maximum(v0, v1))
    t1 = (vp - v0) / a
    t3 = (vp - v1) / a
    s1 = (vp**2 - v0**2) / (2 * a)
    s3 = (vp**2 - v1**2) / (2 * a)
    s2 = np.maximum(L - s1 - s3, 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        t2 = np.where(vp > 0, s2 / vp, 0.0)
    dur = t1 + t2 + t3
    dur = np.where(dwell, b.duration, dur)
    t1 = np.where(dwell, 0.0, t1)
    t2 = np.where(dwell, b.duration, t2)
    t3 = np.where(dwell, 0.0, t3)
    return TimeLaw(v0, v1, vp, a, t1, t2, t3, dur)


def _distance(law: TimeLaw, k: np.ndarray, tau: np.ndarray, L: np.ndarray) -> np.ndarray:
    """Path distance s(τ) into block k at local time τ (trapezoid law)."""
    v0, vp, a = law.v0[k], law.vp[k], law.a[k]
    t1, t2, t3 = law.t1[k], law.t2[k], law.t3[k]
    s1 = v0 * t1 + 0.5 * a * t1**2
    s2 = vp * t2
    tc = np.clip(tau, 0.0, None)
    in1 = tc <= t1
    in2 = (~in1) & (tc <= t1 + t2)
    td = np.clip(tc - t1 - t2, 0.0, t3)
    s = np.where(
        in1,
        v0 * tc + 0.5 * a * tc**2,
        np.where(in2, s1 + vp * (tc - t1), s1 + s2 + vp * td - 0.5 * a * td**2),
    )
    return np.minimum(s, L)


def evaluate(b: Blocks, k: np.ndarray, frac: np.ndarray) -> np.ndarray:
    """Points at path fraction ``frac`` ∈ [0, 1] of blocks ``k``, shape (N, 5)."""
    st, en = b.start[k], b.end[k]
    q = st + (en - st) * frac[:, None]
    arc = b.kind[k] == KIND_ARC
    if np.any(arc):
        ka = k[arc]
        fa = frac[arc]
        qa = q[arc]
        th = b.theta0[ka] + b.sweep[ka] * fa
        r = b.r0[ka] + (b.r1[ka] - b.r0[ka]) * fa
        for plane, (iu, iv, _iw) in PLANE_AXES.items():
            sel = b.plane[ka] == plane
            if not np.any(sel):
                continue
            c = b.center[ka[sel]]
            qa[sel, iu] = c[:, iu] + r[sel] * np.cos(th[sel])
            qa[sel, iv] = c[:, iv] + r[sel] * np.sin(th[sel])
        # the exact end point, not cos/sin of an angle that lands a rounding off it
        end_hit = fa >= 1.0
        qa[end_hit] = en[arc][end_hit]
        q[arc] = qa
    return q


@dataclass(frozen=True)
class Samples:
    """Interpolation points.

    q : (N, 5) [mm, mm, mm, deg, deg] workpiece frame
    dt : (N,) [s] time of the segment that ends at each point
    line : (N,) source line of the block the point belongs to
    block : (N,) index of the block
    first : (N,) bool, first point of its block
    tool_length : (N,) active G43 offset [mm]
    speed : (N,) planned path speed at the point [mm/s or deg/s]
    """

    q: np.ndarray
    dt: np.ndarray
    line: np.ndarray
    block: np.ndarray
    first: np.ndarray
    tool_length: np.ndarray
    speed: np.ndarray

    def __len__(self) -> int:
        return len(self.dt)


def steps_per_block(law: TimeLaw, period_s: float) -> np.ndarray:
    """n = ⌈τ / period⌉ (at least 1) equal steps per block."""
    return np.maximum(1, np.ceil(law.duration / period_s - 1e-9)).astype(np.int64)


def sample(b: Blocks, law: TimeLaw, period_s: float) -> Samples:
    """Points at n equal time steps per block, the block's end point last."""
    n = steps_per_block(law, period_s)
    k = np.repeat(np.arange(len(b)), n)
    starts = np.cumsum(n) - n
    j = np.arange(len(k)) - np.repeat(starts, n) + 1  # 1..n within block
    step = law.duration / n
    tau = j * step[k]
    frac = np.ones(len(k))
    moving = b.kind[k] != KIND_DWELL
    last = j == n[k]
    km = k[moving & ~last]
    if km.size:
        s = _distance(law, km, tau[moving & ~last], b.length[km])
        frac[moving & ~last] = s / b.length[km]
    q = evaluate(b, k, frac)
    dwell = ~moving
    q[dwell] = b.end[k[dwell]]
    # speed at the point (for PVT velocities): derivative of the trapezoid law
    v = _speed(law, k, tau)
    v[dwell | last] = np.where(dwell[dwell | last], 0.0, law.v1[k[dwell | last]])
    return Samples(
        q=q,
        dt=step[k],
        line=b.line[k],
        block=k,
        first=j == 1,
        tool_length=b.tool_length[k],
        speed=v,
    )


def _speed(law: TimeLaw, k: np.ndarray, tau: np.ndarray) -> np.ndarray:
    v0, vp, v1, a = law.v0[k], law.vp[k], law.v1[k], law.a[k]
    t1, t2 = law.t1[k], law.t2[k]
    return np.where(
        tau <= t1,
        v0 + a * tau,
        np.where(tau <= t1 + t2, vp, np.maximum(vp - a * (tau - t1 - t2), v1)),
    )
