"""Blocks: the interpreted motions as planning arrays, and their exact geometry.

A block is one programmed move, arc, dwell or machine function. Its path is a
curve q(s) in the five virtual axes q = [x, y, z, A, B] (workpiece frame, mm and
degrees), parametrised by the path length s ∈ [0, L]:

- straight moves are linear in all five axes, s is the XYZ length (or the A/B
  angle for a move that only turns the tool: LinuxCNC times those in degrees);
- arcs and helices lie exactly on the programmed arc (radius linear in s from the
  start radius to the end radius, as LinuxCNC's spiral tolerance allows, the axial
  coordinate and A/B linear in s);
- curves (G5, G5.1, G5.2 splines and NURBS) lie exactly on the curve
  (:class:`prsxy_post.curves.Nurbs`, walked by arc length), A/B linear in s;
- dwells and machine functions are stops of a given duration (zero for functions).

:func:`evaluate` gives q(s) and the tangent dq/ds anywhere on a block; the planner
multiplies the tangent by the planned speed to get the velocity the controller is
told at each point.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import ClassVar, NamedTuple

import numpy as np

from .. import kernel
from ..gcode import EXACT_STOP, Motion
from ..gcode import rows as gcode_rows
from ..gcode.rows import (
    KIND_ARC,
    KIND_CURVE,
    KIND_DWELL,
    KIND_FUNCTION,
    KIND_RAPID,
    MotionTable,
)
from ..gcode.rows import (
    KIND_FEED as KIND_FEED,  # (the interpolate package names it)
)
from ..kernel.path import PathArrays
from ..points import Columns

_KIND = gcode_rows.KIND
#: points of a curve where its curvature is looked at, per knot span
CURVATURE_SAMPLES = 64

#: in-plane axes (u, v) and normal w of G17, G18, G19 as LinuxCNC orders them:
#: each is a right-handed triple, so a positive rotation is counter-clockwise
#: seen from the positive end of w.
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}

#: A move shorter than this in XYZ (mm) is a rotary-only move.
LINEAR_EPS_MM = 1e-9
#: A move shorter than this in A/B and XYZ is no move at all.
ANGULAR_EPS_DEG = 1e-9

#: Share of the acceleration an arc may use along its path (LinuxCNC's
#: trajectory planner uses the same split): the rest, sqrt(1 − 0.5²) ≈ 0.87 of
#: it, holds the tool on the arc, so that the vector sum stays within the limit.
ARC_TANGENTIAL_SHARE = 0.5


class PlanLimits(NamedTuple):
    """What the planner must respect (profile ``[limits]`` and ``[interpolation]``).

    rapid_mm_min, rapid_deg_min : G0 speeds along XYZ, and of A/B-only moves
    accel_mm_s2, accel_deg_s2 : path and A/B acceleration limits
    period_s : longest interpolation step
    tolerance_mm, tolerance_deg : how far the motion the controller executes between
        points may leave the programmed path (the G64 P tolerance when the program
        sets none), in XYZ and in A/B
    segment : how the controller moves between points: "cubic" (a PVT cubic through
        positions and velocities, Turbo PMAC) or "chord" (a straight line in its
        Cartesian space, a G-code controller); it sets how dense points must be on
        curves
    """

    rapid_mm_min: float = 10000.0
    rapid_deg_min: float = 3600.0
    accel_mm_s2: float = 2000.0
    accel_deg_s2: float = 3600.0
    period_s: float = 0.010
    tolerance_mm: float = 0.0005
    tolerance_deg: float = 0.5 / 3600.0
    segment: str = "cubic"

    @property
    def min_phase_s(self) -> float:
        """Shortest phase of constant acceleration inside a block (see timelaw)."""
        return self.period_s / 4.0


#: How the tolerance is shared between what makes the executed motion leave the
#: path: blending corners, the cubic (or chord) between points on curved paths,
#: crossing a motor's play at a reversal; the rest is kept for the rounding of the
#: written numbers and the kinematics' curvature.
CORNER_SHARE = 0.5
CURVE_SHARE = 0.2
REVERSAL_SHARE = 0.1
#: How far the cubic's speed may stray from the plan's on a curve (a share of it).
SPEED_SHARE = 5e-4


class Blocks(Columns):
    """Motions as arrays, one row per block (zero-length moves removed).

    kind : (n,) int, KIND_*
    start, end : (n, 5) [mm, mm, mm, deg, deg]
    line : (n,) source line
    tool_length : (n,) active G43 offset [mm]
    length : (n,) path length L [mm, or deg for rotary-only moves]
    angular : (n,) bool, timed in degrees (rotary-only move)
    vmax : (n,) speed limit [mm/s or deg/s]
    accel : (n,) acceleration limit along the path [mm/s² or deg/s²]
    duration : (n,) dwell time [s] (dwell blocks)
    plane, center, sweep, r0, r1, theta0 : arc data (sweep signed, rad)
    dq_in, dq_out : (n, 5) tangents dq/ds at the start and the end [mm/mm, deg/mm]
        (zero for dwells and functions)
    dP_in, dP_out : (n, 5) the motors' dP/ds at the start and the end [mm/mm], for the
        motors with play where the planner is told them (else zero:
        :meth:`~prsxy_post.chain.Planning.plan`); a junction where one reverses may
        be a stop (:func:`.lookahead.junction_limits`)
    cross_in : (n,) bool, a motor with play that stood at the block before sets off
        at this block's start against the way it last moved: it crosses its play
        at the junction (told with ``dP_in``)
    tol : (n,) corner tolerance at the block's end [mm] for the blend with the next
        block; 0: exact path (G61), :data:`EXACT_STOP`: stop (G61.1)
    tol_deg : (n,) the same for A/B [deg]
    curv_r : (n,) smallest radius of curvature of the path [mm] (inf on lines)
    fn : (n,) object, the machine-function words of function blocks, else None
    curve : (n,) object, the :class:`~prsxy_post.curves.Nurbs` of curve blocks, else None
    split_after : (n,) int8, a split program's part ends at rest after this block:
        1 at a stop the program makes, 2 at a stop put there for the split

    A :class:`~prsxy_post.points.Columns` record (rows taken, records joined field
    by field).
    """

    #: the fields, in the order the constructor takes them
    FIELDS: ClassVar[tuple[str, ...]] = (
        "kind",
        "start",
        "end",
        "line",
        "tool_length",
        "length",
        "angular",
        "vmax",
        "accel",
        "duration",
        "plane",
        "center",
        "sweep",
        "r0",
        "r1",
        "theta0",
        "dq_in",
        "dq_out",
        "dP_in",
        "dP_out",
        "cross_in",
        "tol",
        "tol_deg",
        "curv_r",
        "fn",
        "curve",
        "split_after",
    )

    def __init__(
        self,
        kind: np.ndarray,
        start: np.ndarray,
        end: np.ndarray,
        line: np.ndarray,
        tool_length: np.ndarray,
        length: np.ndarray,
        angular: np.ndarray,
        vmax: np.ndarray,
        accel: np.ndarray,
        duration: np.ndarray,
        plane: np.ndarray,
        center: np.ndarray,
        sweep: np.ndarray,
        r0: np.ndarray,
        r1: np.ndarray,
        theta0: np.ndarray,
        dq_in: np.ndarray,
        dq_out: np.ndarray,
        dP_in: np.ndarray,
        dP_out: np.ndarray,
        cross_in: np.ndarray,
        tol: np.ndarray,
        tol_deg: np.ndarray,
        curv_r: np.ndarray,
        fn: np.ndarray,
        curve: np.ndarray,
        split_after: np.ndarray,
    ) -> None:
        self.kind = kind
        self.start = start
        self.end = end
        self.line = line
        self.tool_length = tool_length
        self.length = length
        self.angular = angular
        self.vmax = vmax
        self.accel = accel
        self.duration = duration
        self.plane = plane
        self.center = center
        self.sweep = sweep
        self.r0 = r0
        self.r1 = r1
        self.theta0 = theta0
        self.dq_in = dq_in
        self.dq_out = dq_out
        self.dP_in = dP_in
        self.dP_out = dP_out
        self.cross_in = cross_in
        self.tol = tol
        self.tol_deg = tol_deg
        self.curv_r = curv_r
        self.fn = fn
        self.curve = curve
        self.split_after = split_after

    def __len__(self) -> int:
        return len(self.kind)

    @staticmethod
    def concat(parts: Sequence[Blocks]) -> Blocks:
        return Blocks(**Blocks.joined(parts))

    @property
    def stops(self) -> np.ndarray:
        """(n,) bool: blocks the path stands still in (dwells, machine functions)."""
        return (self.kind == KIND_DWELL) | (self.kind == KIND_FUNCTION)


def _arc_geometry(
    start: np.ndarray, end: np.ndarray, center: np.ndarray, plane: np.ndarray, rotation: np.ndarray
) -> dict[str, np.ndarray]:
    """Sweep, radii, start angle and XYZ length of arcs (vectorised).

    The sweep follows LinuxCNC's ARC_FEED rotation: sign = direction (+ counter-
    clockwise seen from the positive end of the plane's normal), magnitude =
    turns; an arc whose end angle equals its start angle is a full turn.
    """
    n = len(start)
    iu, iv, iw = _plane_axes(plane)
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
    return {"sweep": sweep, "r0": r0, "r1": r1, "theta0": th0, "length": length}


def _plane_axes(plane: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    iu = np.zeros(len(plane), dtype=int)
    iv = np.ones(len(plane), dtype=int)
    iw = np.full(len(plane), 2, dtype=int)
    for pl, (a, b_, c) in PLANE_AXES.items():
        sel = plane == pl
        iu[sel], iv[sel], iw[sel] = a, b_, c
    return iu, iv, iw


def blocks_from_motions(motions: Sequence[Motion] | MotionTable, limits: PlanLimits) -> Blocks:
    """Turn interpreted motions (or their table, :mod:`prsxy_post.gcode.rows`) into
    planning arrays (vectorised); no-motion moves are dropped.

    Speed limits: F (mm/min) along XYZ, or degrees/min for rotary-only moves;
    the profile's rapid rates for G0; A/B rates and accelerations capped by the
    rotary limits scaled by length/angle. On arcs, the tangential acceleration is
    :data:`ARC_TANGENTIAL_SHARE` of the limit and the speed keeps the centripetal
    acceleration v²/r within the rest.
    """
    m = motion_columns(motions)
    n = len(m.kind)
    e = _extents(m)
    length, angular, keep, vmax, accel = _speed_limits(m, e, limits)
    tol, tol_deg = _tolerances(m.path_tol, limits)
    b = Blocks(
        kind=m.kind,
        start=m.start,
        end=m.end,
        line=m.line,
        tool_length=m.tool_length,
        length=length,
        angular=angular,
        vmax=vmax,
        accel=accel,
        duration=np.where(m.kind == KIND_DWELL, m.duration, 0.0),
        plane=m.plane,
        center=m.center,
        sweep=e.sweep,
        r0=e.r0,
        r1=e.r1,
        theta0=e.theta0,
        dq_in=np.zeros((n, 5)),
        dq_out=np.zeros((n, 5)),
        dP_in=np.zeros((n, 5)),
        dP_out=np.zeros((n, 5)),
        cross_in=np.zeros(n, dtype=bool),
        tol=tol,
        tol_deg=tol_deg,
        curv_r=e.curv_r,
        fn=m.fn,
        curve=m.curve,
        split_after=np.zeros(n, dtype=np.int8),
    )
    if not keep.all():  # row numbers: Columns.take gathers them with np.take
        b = b.take(np.flatnonzero(keep))
    moving = ~b.stops
    k = np.flatnonzero(moving)
    if len(k) == len(b) and len(k):  # every block moves: the tangents are the columns
        b.dq_in = pose_at(b, k, np.zeros(len(k)))[1]
        b.dq_out = pose_at(b, k, b.length)[1]
    elif len(k):
        _, b.dq_in[k] = pose_at(b, k, np.zeros(len(k)))
        _, b.dq_out[k] = pose_at(b, k, b.length[k])
    return b


class _MotionColumns(NamedTuple):
    """The interpreted motions' fields as arrays, one row per motion (n of them).

    kind : (n,) int, KIND_*
    start, end : (n, 5) [mm, mm, mm, deg, deg]
    line : (n,) source line
    tool_length : (n,) active G43 offset [mm]
    feed : (n,) F [mm/min, or deg/min]
    duration : (n,) dwell time [s]
    path_tol : (n,) the program's G64 P tolerance [mm], NaN where it sets none
    fn, curve : (n,) object, machine-function words and curves (None elsewhere)
    plane, center, rotation : (n,), (n, 3), (n,) arc data (zero elsewhere)
    """

    kind: np.ndarray
    start: np.ndarray
    end: np.ndarray
    line: np.ndarray
    tool_length: np.ndarray
    feed: np.ndarray
    duration: np.ndarray
    path_tol: np.ndarray
    fn: np.ndarray
    curve: np.ndarray
    plane: np.ndarray
    center: np.ndarray
    rotation: np.ndarray


def _poses(col: Sequence[Sequence[float]]) -> np.ndarray:
    """(n, 5) the poses of a column of them (each five numbers: gcode.Pose)."""
    # one flat pass: twice as fast as numpy finding the nested tuples' shape
    return np.fromiter(itertools.chain.from_iterable(col), float, 5 * len(col)).reshape(-1, 5)


def motion_columns(motions: Sequence[Motion] | MotionTable) -> _MotionColumns:
    """The fields of motions, or of their table, as columns (:class:`_MotionColumns`)."""
    if isinstance(motions, MotionTable):
        return _table_columns(motions)
    return _motion_columns(motions)


def _table_columns(t: MotionTable) -> _MotionColumns:
    """:func:`_motion_columns` of a table (the same arrays)."""
    r = t.rows
    n = len(r)
    fn = np.empty(n, dtype=object)
    curve = np.empty(n, dtype=object)
    for i, m in t.objects:
        if m.kind == "function":
            fn[i] = m.words
        else:
            curve[i] = m.curve
    return _MotionColumns(
        kind=r[:, gcode_rows.ROW_KIND].astype(int),
        start=np.ascontiguousarray(r[:, gcode_rows.ROW_START]),
        end=np.ascontiguousarray(r[:, gcode_rows.ROW_END]),
        line=r[:, gcode_rows.ROW_LINE].astype(int),
        tool_length=r[:, gcode_rows.ROW_TOOL_LENGTH].copy(),
        feed=r[:, gcode_rows.ROW_FEED].copy(),
        duration=r[:, gcode_rows.ROW_DURATION].copy(),
        path_tol=r[:, gcode_rows.ROW_PATH_TOL].copy(),
        fn=fn,
        curve=curve,
        plane=r[:, gcode_rows.ROW_PLANE].astype(int),
        center=np.ascontiguousarray(r[:, gcode_rows.ROW_CENTER]),
        rotation=r[:, gcode_rows.ROW_ROTATION].astype(int),
    )


def _motion_columns(motions: Sequence[Motion]) -> _MotionColumns:
    """The motions' fields as columns (:class:`_MotionColumns`)."""
    n = len(motions)
    # one pass over the motions (Motion is a tuple): a column per field
    cols = list(zip(*motions, strict=True)) if n else [()] * len(Motion._fields)
    f = Motion._fields.index
    kind = np.array([_KIND[k] for k in cols[f("kind")]], dtype=int).reshape(n)
    path_tol = np.array(
        [math.nan if t is None else t for t in cols[f("path_tol")]], dtype=float
    ).reshape(n)
    fn = np.empty(n, dtype=object)
    is_fn = kind == KIND_FUNCTION
    if np.any(is_fn):
        words = cols[f("words")]
        for i in np.flatnonzero(is_fn).tolist():
            fn[i] = words[i]
    curve = np.empty(n, dtype=object)
    curves = np.flatnonzero(kind == KIND_CURVE).tolist()
    if curves:
        col = cols[f("curve")]
        for i in curves:
            curve[i] = col[i]
    is_arc = kind == KIND_ARC
    plane = np.zeros(n, dtype=int)
    center = np.zeros((n, 3))
    rotation = np.zeros(n, dtype=int)
    arcs = np.flatnonzero(is_arc).tolist()
    if arcs:
        planes, centers, rotations = cols[f("plane")], cols[f("center")], cols[f("rotation")]
        plane[is_arc] = [planes[i] for i in arcs]
        center[is_arc] = np.array([centers[i] for i in arcs], dtype=float)
        rotation[is_arc] = [rotations[i] for i in arcs]
    return _MotionColumns(
        kind=kind,
        start=_poses(cols[f("start")]),
        end=_poses(cols[f("end")]),
        line=np.fromiter(cols[f("line")], int, n),
        tool_length=np.fromiter(cols[f("tool_length")], float, n),
        feed=np.fromiter(cols[f("feed")], float, n),
        duration=np.fromiter(cols[f("duration")], float, n),
        path_tol=path_tol,
        fn=fn,
        curve=curve,
        plane=plane,
        center=center,
        rotation=rotation,
    )


class _Extents(NamedTuple):
    """How far each motion goes, and how tightly it bends (n rows).

    length : (n,) path length [mm]: XYZ for lines, along the helix for arcs,
        along the curve for curves
    ang : (n,) the A/B angle turned, hypot(ΔA, ΔB) [deg]
    sweep, r0, r1, theta0 : (n,) arc data (:func:`_arc_geometry`; zero elsewhere)
    curv_r : (n,) the tightest radius of curvature [mm] (inf on lines)
    """

    length: np.ndarray
    ang: np.ndarray
    sweep: np.ndarray
    r0: np.ndarray
    r1: np.ndarray
    theta0: np.ndarray
    curv_r: np.ndarray


def _extents(m: _MotionColumns) -> _Extents:
    """The motions' lengths, turns and radii of curvature (:class:`_Extents`)."""
    n = len(m.kind)
    # the arcs by row number: an (n, 5) array's rows taken with np.take, and
    # columns set by number, several times faster than by a boolean mask
    arcs = np.flatnonzero(m.kind == KIND_ARC)
    curves = np.flatnonzero(m.kind == KIND_CURVE).tolist()
    delta = m.end - m.start
    lin_len = np.sqrt(np.einsum("ij,ij->i", delta[:, :3], delta[:, :3]))
    ang = np.hypot(delta[:, 3], delta[:, 4])
    length = lin_len.copy()
    sweep = np.zeros(n)
    r0 = np.zeros(n)
    r1 = np.zeros(n)
    theta0 = np.zeros(n)
    curv_r = np.full(n, np.inf)
    if arcs.size:
        g = _arc_geometry(
            np.take(m.start, arcs, axis=0),
            np.take(m.end, arcs, axis=0),
            np.take(m.center, arcs, axis=0),
            m.plane[arcs],
            m.rotation[arcs],
        )
        sweep[arcs], r0[arcs], r1[arcs] = g["sweep"], g["r0"], g["r1"]
        theta0[arcs], length[arcs] = g["theta0"], g["length"]
        # the tightest radius of curvature of the helix: r (1 + (pitch/r)²) ≥ r
        curv_r[arcs] = np.minimum(r0[arcs], r1[arcs])

    for i in curves:
        length[i] = m.curve[i].length
        curv_r[i] = _least_radius(m.curve[i])
    return _Extents(length, ang, sweep, r0, r1, theta0, curv_r)


def _speed_limits(
    m: _MotionColumns, e: _Extents, limits: PlanLimits
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """How each motion is timed and how fast it may go.

    Returns
    -------
    length : (n,) path length L [mm, or deg for rotary-only moves; 0 for stops]
    angular : (n,) bool, a rotary-only move (timed in degrees)
    keep : (n,) bool, the motion moves (or is a stop): the others are dropped
    vmax : (n,) speed limit [mm/s or deg/s]
    accel : (n,) acceleration limit along the path [mm/s² or deg/s²]
    """
    kind, feed, ang = m.kind, m.feed, e.ang
    is_arc = kind == KIND_ARC
    r0, r1 = e.r0, e.r1
    bends = is_arc | (kind == KIND_CURVE)  # paths with a centripetal acceleration
    stop = (kind == KIND_DWELL) | (kind == KIND_FUNCTION)
    rapid = kind == KIND_RAPID
    angular = ~stop & (e.length <= LINEAR_EPS_MM)
    keep = stop | ~angular | (ang > ANGULAR_EPS_DEG)
    length = np.where(stop, 0.0, np.where(angular, ang, e.length))
    rate_deg = limits.rapid_deg_min / 60.0
    with np.errstate(invalid="ignore", divide="ignore"):
        v_lin = np.where(rapid, limits.rapid_mm_min / 60.0, feed / 60.0)
        v_ang = np.where(rapid, rate_deg, np.minimum(feed / 60.0, rate_deg))
        turning = ang > 0
        scale = np.where(turning, length / np.where(turning, ang, 1.0), np.inf)
        v_lin = np.minimum(v_lin, rate_deg * scale)
        a_lin = np.minimum(limits.accel_mm_s2, limits.accel_deg_s2 * scale)
        a_normal = a_lin * math.sqrt(1.0 - ARC_TANGENTIAL_SHARE**2)
        # a spiral's speed along its XYZ path exceeds ds/dt by up to r_max / r_mean
        spiral = np.where(is_arc, np.maximum(r0, r1) / np.maximum(0.5 * (r0 + r1), 1e-300), 1.0)
        v_lin = np.where(
            bends, np.minimum(v_lin, np.sqrt(a_normal * e.curv_r)) / np.maximum(spiral, 1.0), v_lin
        )
        a_lin = np.where(bends, a_lin * ARC_TANGENTIAL_SHARE, a_lin)
    vmax = np.where(stop, 1.0, np.where(angular, v_ang, v_lin))
    accel = np.where(stop, 1.0, np.where(angular, limits.accel_deg_s2, a_lin))
    return length, angular, keep, vmax, accel


def _tolerances(path_tol: np.ndarray, limits: PlanLimits) -> tuple[np.ndarray, np.ndarray]:
    """Each block's corner tolerance at its end, tol [mm] and tol_deg [deg], (n,)
    each: the program's G64 P where it sets one (``path_tol``, NaN where not), else
    the profile's."""
    tol = np.where(np.isnan(path_tol), limits.tolerance_mm, path_tol)
    tol_deg = np.where(
        np.isnan(path_tol),
        limits.tolerance_deg,
        np.where(
            path_tol == EXACT_STOP,
            EXACT_STOP,
            # a program's G64 P scales the angular tolerance with it
            path_tol * limits.tolerance_deg / limits.tolerance_mm,
        ),
    )
    return tol, tol_deg


def path_arrays(b: Blocks) -> PathArrays:
    """The blocks' lines and arcs as the path kernel takes them
    (:class:`~prsxy_post.kernel.path.PathArrays`)."""
    plane = b.plane
    return PathArrays(
        start=b.start,
        end=b.end,
        length=b.length,
        arc=b.kind == KIND_ARC,
        theta0=b.theta0,
        sweep=b.sweep,
        r0=b.r0,
        r1=b.r1,
        center=b.center,
        iu=_IN_PLANE[0][plane],
        iv=_IN_PLANE[1][plane],
    )


def _in_plane() -> np.ndarray:
    """(2, 20) the in-plane axes (u, v) by plane code (PLANE_AXES; G17's where no
    plane is set: lines), looked up in one pass per batch."""
    out = np.array([[0] * 20, [1] * 20], dtype=np.intp)
    for pl, (u, v, _) in PLANE_AXES.items():
        out[:, pl] = u, v
    return out


_IN_PLANE = _in_plane()


def pose_at(
    b: Blocks, k: np.ndarray, s: np.ndarray, paths: PathArrays | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Pose q(s) and tangent dq/ds at path distance ``s`` into blocks ``k``.

    Lines and arcs: :func:`prsxy_post.kernel.path.poses`; curves here.
    ``paths``: ``path_arrays(b)`` where the caller has it (made here otherwise:
    a pass over every block, where a few points are asked many times a chunk).

    Returns
    -------
    q : (N, 5) [mm, mm, mm, deg, deg]
    dq_ds : (N, 5) [mm/mm, deg/mm] (per degree for rotary-only moves; zero for
        dwells and functions)
    """
    k = np.asarray(k, dtype=np.intp)
    s = np.asarray(s, dtype=float)
    q, dq = kernel.poses(path_arrays(b) if paths is None else paths, k, s)
    on_curve = b.kind[k] == KIND_CURVE
    if np.any(on_curve):
        rows = np.flatnonzero(on_curve)
        L = b.length[k[rows]]
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(L > 0, np.clip(s[rows] / L, 0.0, 1.0), 1.0)
        for kb in np.unique(k[rows]).tolist():
            at = k[rows] == kb
            sel = rows[at]
            c = b.curve[kb]
            u = c.u_at(s[sel])
            _, d1, _ = c.derivatives(u)
            q[sel, :3] = c.point(u)
            norm = np.linalg.norm(d1, axis=1)
            dq[sel, :3] = d1 / np.where(norm > 0, norm, 1.0)[:, None]
            end_hit = frac[at] >= 1.0
            q[sel[end_hit]] = b.end[kb]
    return q, dq


def _least_radius(curve: object) -> float:
    """The tightest radius of curvature of a curve [mm]: 1 / max κ, κ = |C' × C''| / |C'|³,
    looked at on :data:`CURVATURE_SAMPLES` points of every knot span."""
    t = np.unique(curve.knots)  # type: ignore[attr-defined]
    u = np.concatenate([np.linspace(a, b_, CURVATURE_SAMPLES) for a, b_ in itertools.pairwise(t)])
    _, d1, d2 = curve.derivatives(u)  # type: ignore[attr-defined]
    sp = np.linalg.norm(d1, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        kappa = np.linalg.norm(np.cross(d1, d2), axis=1) / sp**3
    kappa = kappa[np.isfinite(kappa)]
    top = float(kappa.max()) if kappa.size else 0.0
    return 1.0 / top if top > 0 else math.inf


def segment_limit(b: Blocks, limits: PlanLimits) -> np.ndarray:
    """Longest time step [s] on each block at speed 1 (divide by the speed).

    Between two points a controller moves along a cubic (PVT) or a chord. On a
    circle of radius r traversed at speed v a Hermite cubic over a step h errs by
    at most h⁴ max|q''''| / 384 = (h v)⁴ / (384 r³), a chord by (h v)² / (8 r);
    keeping that within :data:`CURVE_SHARE` of the tolerance gives h v. The cubic's
    speed errs too, and on tight curves that bounds h v first.
    """
    tol = CURVE_SHARE * limits.tolerance_mm
    out = np.full(len(b), np.inf)
    # lines (r = inf, and NaN) have no limit: the powers run over the curves only
    k = np.flatnonzero(np.isfinite(b.curv_r))
    if not k.size:
        return out
    r = b.curv_r[k]
    with np.errstate(invalid="ignore", over="ignore"):
        if limits.segment == "chord":
            hv = np.sqrt(8.0 * r * tol)
        else:
            # the cubic's velocity errs by up to h^3 max|q''''| / (72 sqrt 3), about
            # (h v)^3 v / (125 r^3): within SPEED_SHARE of the speed on tight curves
            hv = np.minimum((384.0 * tol * r**3) ** 0.25, r * (125.0 * SPEED_SHARE) ** (1 / 3))
    out[k] = np.where(np.isfinite(hv), hv, np.inf)
    return out


def point_bound(b: Blocks, limits: PlanLimits) -> np.ndarray:
    """An upper bound on the points each block can become, whatever the plan.

    The slowest a block can be is from rest to rest: τ ≤ L / v + v / a (v, a: the
    least speed limit and acceleration the look-ahead may give it), plus
    three phases stretched to the shortest phase; its steps are at most
    τ / h + 3 for the shortest step h it can have (the period, or shorter on a
    curve at the block's top speed). A reversal of a motor with play adds at most
    two points, a stop one; a block can reverse each motor at most twice, and an
    arc twice per half turn more.
    """
    # next to a corner a block keeps under cos(45°) of its speed limit at worst and
    # sqrt(1 − κ²) = 0.87 of its acceleration (lookahead)
    v = 0.7 * b.vmax
    a = 0.8 * b.accel
    with np.errstate(divide="ignore", invalid="ignore"):
        tau = np.where(b.stops, 0.0, b.length / v + v / a)
        tau = tau + 3.0 * limits.min_phase_s
        h = np.minimum(limits.period_s, segment_limit(b, limits) / b.vmax)
        steps = np.ceil(tau / h) + 3.0
    turns = np.abs(b.sweep) / np.pi
    reversal = 5 * 2 * (2.0 + 2.0 * np.ceil(turns)) + 1
    return np.where(b.stops, 1, steps + reversal).astype(np.int64)
