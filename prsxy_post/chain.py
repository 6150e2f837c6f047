"""The compensation chain of a converted program (contract, "The compensation chain").

    G-code → coarse interpolation (period_ms) → Q' = Q − e(Q) (virtual-axis map,
    paper Eq. 6) → P = IK of the calibrated [kinematics] and [table] (Eq. 3, g')
    → real-axis tables (Eq. 3, E_i) → motor commands

Every point carries, besides where each motor must be, how fast it must move
there: the planned velocity of the path pushed through the chain (the IK's
derivative along the path, the tables' slopes). A controller that runs a cubic
between points (Turbo PMAC PVT) then moves on the programmed path between them
too, not only at them. Where a motor with play reverses, the chain places the
crossing of the play in a window of its own (:mod:`.reversals`).

Every stage can be switched off (:class:`Stages`) for comparisons. The chain is
pure: motions and a profile in, arrays out; it raises located errors (the
G-code line) for anything the machine cannot do.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from . import axiscomp, errormap, kernel, kinematics, reversals
from . import rules as checks
from .errors import LimitError, PrsxyError
from .gcode.rows import ROW_LINE, MotionTable
from .interpolate import (
    Blocks,
    Plan,
    PlanLimits,
    Planner,
    Samples,
    at_times,
    blocks_from_motions,
    junctions,
    next_tangent,
)
from .interpolate.geometry import CURVE_SHARE, REVERSAL_SHARE, path_arrays
from .interpolate.lookahead import KAPPA, REVERSAL_SLOPE, STAND_SLOPE
from .interpolate.pieces import Pieces
from .interpolate.sampling import sample, steps
from .kernel import play
from .points import PointChunk, Written
from .profile import MOTORS, Profile, nominal_kinematics

if TYPE_CHECKING:
    from .gcode import Motion
    from .kernel.path import PathArrays


@dataclass(frozen=True)
class Stages:
    """Which compensation stages run.

    error_map : apply the virtual-axis error map Q' = Q − e(Q) (when the profile has one)
    calibrated : use the profile's [kinematics] and [table]; off: the nominal design
    axis_comp : apply the real-axis tables (when the profile has any)
    """

    error_map: bool = True
    calibrated: bool = True
    axis_comp: bool = True

    def describe(self) -> str:
        on = [n for n in ("error_map", "calibrated", "axis_comp") if getattr(self, n)]
        off = [n for n in ("error_map", "calibrated", "axis_comp") if not getattr(self, n)]
        return (
            "stages on: " + (", ".join(on) or "none") + ("; off: " + ", ".join(off) if off else "")
        )


def limits_of(profile: Profile, segment: str = "cubic") -> PlanLimits:
    """The planner's limits from a profile; ``segment``: how the target controller
    moves between points ("cubic" or "chord", from the output dialect)."""
    lim = profile.limits
    ip = profile.interpolation
    return PlanLimits(
        rapid_mm_min=lim.rapid_mm_min,
        rapid_deg_min=lim.rapid_deg_min,
        accel_mm_s2=lim.max_accel_mm_s2,
        accel_deg_s2=lim.max_accel_deg_s2,
        period_s=profile.period_ms / 1000.0,
        tolerance_mm=ip.path_tolerance_mm,
        tolerance_deg=ip.path_tolerance_arcsec / 3600.0,
        segment=segment,
    )


def ik_geometry(profile: Profile, stages: Stages) -> kinematics.Geometry:
    """The geometry the IK uses: calibrated, or the contract's nominal design."""
    if stages.calibrated:
        return kinematics.Geometry.from_params(
            profile.kinematics, profile.origin, profile.table, profile.effects
        )
    return kinematics.Geometry.from_params(nominal_kinematics(), profile.origin)


#: A fitted virtual-axis error: q (N, 5) → e(q) (N, 5) [mm, deg].
ErrorFunction = Callable[[np.ndarray], np.ndarray]


def check_motions(motions: Sequence[Motion] | MotionTable, profile: Profile) -> list[PrsxyError]:
    """Problems visible in the program itself (its motions, or their table):
    feed above the machine's maximum."""
    return [p.error(profile) for p in checks.feed_problems(profile, motions)]


@dataclass
class ChainResult:
    """Everything the chain computed for a whole program (one PointChunk), and the
    problems found when collecting them."""

    points: PointChunk
    geometry: kinematics.Geometry
    problems: list[PrsxyError] = field(default_factory=list)


@dataclass
class Prepared:
    """A chunk of motions made ready for planning: the part of the chain that needs
    nothing from earlier chunks, so it may run ahead (in another process).

    blocks : planning arrays (:func:`blocks_from_motions`)
    n_motions : motions in the chunk
    first_line : line of the first motion (0 when none)
    problems : what :func:`check_motions` found
    """

    blocks: Blocks
    n_motions: int
    first_line: int
    problems: list[PrsxyError]


def prepare(
    motions: Sequence[Motion] | MotionTable, profile: Profile, limits: PlanLimits
) -> Prepared:
    """Planning arrays and program-level problems of a chunk of motions (or of
    their table, :mod:`.gcode.rows`)."""
    if isinstance(motions, MotionTable):
        first = int(motions.rows[0, ROW_LINE]) if len(motions) else 0
    else:
        first = motions[0].line if motions else 0
    return Prepared(
        blocks_from_motions(motions, limits),
        len(motions),
        first,
        check_motions(motions, profile),
    )


#: the play columns when every motor has play
_ALL_MOTORS = list(range(len(MOTORS)))

#: One-sided step [s] of the directional derivative of the IK along the planned
#: velocity: the IK moves by ~v·1e-6 s (under a µm), where its curvature makes an
#: error of 1e-9 of the velocity and rounding one of 1e-8 mm/s.
VEL_STEP_S = 1e-6
#: The same along the path [mm], for the motors' directions at the blocks' ends.
DIR_STEP_MM = 1e-4


def ik_derivative(
    geo: kinematics.Geometry,
    q: np.ndarray,
    dq: np.ndarray,
    tool: np.ndarray,
    P: np.ndarray,
    step: float,
) -> np.ndarray:
    """(N, 5) the motors' derivative along ``dq`` from poses ``q`` (whose IK is
    ``P``): the IK's one-sided difference over ``step`` (VEL_STEP_S along a
    velocity, DIR_STEP_MM along a tangent)."""
    return kinematics.derivative(geo, q, dq, tool, P, step)


def ik_jacobian(
    geo: kinematics.Geometry,
    q: np.ndarray,
    tool: np.ndarray,
    step: float,
    P: np.ndarray | None = None,
) -> np.ndarray:
    """(N, 5, 5) ∂P_i/∂q_j at poses ``q`` (N, 5) [mm, mm, mm, deg, deg]: the IK's
    one-sided differences over ``step`` along each coordinate, as
    :func:`ik_derivative`, the pose (unless its IK ``P`` is given) and its five
    steps in one IK call."""
    return kinematics.jacobian(geo, q, tool, step, P)


@dataclass
class Planned:
    """A chunk through the planner (:meth:`Planning.plan`), ready for its points.

    problems : the chunk's program-level problems (raised, or collected, first)
    start_line : the first chunk's line, where the start point is given
    plan, steps : the planned blocks and their steps per phase (n, 3)
        (:func:`.interpolate.sampling.steps`; None when nothing is ready: the
        look-ahead holds the blocks); their points are made piece by piece
        (:meth:`Planning.cut`)
    late : problems at the ends of long blocks, reported after the points before
        them are made (an earlier line's problem comes first)
    final : the program's last chunk; moves_nothing: and nothing moved
    seconds : the planner's time on it
    """

    problems: list[PrsxyError]
    start_line: int | None = None
    plan: Plan | None = None
    steps: np.ndarray | None = None
    late: list[PrsxyError] = field(default_factory=list)
    final: bool = False
    moves_nothing: bool = False
    seconds: float = 0.0


@dataclass
class Solved:
    """Points' poses through the virtual-axis map and the IK (:meth:`Planning.solve`).

    q_target, P, V : (n, 5) [mm, mm, mm, deg, deg], [mm], [mm/s] the pose handed to
        the IK, the motors' positions and velocities there (V None when a problem
        stops the program before them)
    reachable : every point reachable
    problems : the poses' problems (tilt, reach), raised (or collected) by the
        points' half as it comes to them
    seconds : the map's and the IK's time on them
    """

    q_target: np.ndarray
    P: np.ndarray
    V: np.ndarray | None
    reachable: bool
    problems: list[PrsxyError]
    seconds: tuple[float, float] = (0.0, 0.0)


#: a piece of the program (:mod:`.interpolate.pieces`): its plan, its points and
#: their poses solved (None: to be solved by the points' half)
Piece = tuple[Plan, Samples, Solved | None]

#: the fields of a piece's blocks that the points' half reads where a motor has
#: play (:meth:`Pipeline._reversals` and what it calls: :func:`at_times`'s poses,
#: :func:`next_tangent` and the corners' tangents, the speed limits of
#: :meth:`Pipeline._edge_speed`); without play it reads none. A process that
#: planned the piece sends only these (:mod:`prsxy_post.wire`)
BLOCKS_READ = (
    "kind",
    "start",
    "end",
    "length",
    "plane",
    "center",
    "sweep",
    "r0",
    "r1",
    "theta0",
    "curve",
    "dq_in",
    "dq_out",
    "vmax",
)
#: the fields of a piece's time law that the points' half reads where a motor has
#: play (:func:`at_times`), as :data:`BLOCKS_READ`
LAW_READ = ("v0", "v1", "vp", "a1", "a3", "t1", "t2", "t3")


@dataclass
class Ready:
    """A planned chunk in the pieces the points' half makes its points from, in the
    order it takes them (:meth:`Planning.cut`); what :class:`Planned` says, with
    ``earlier``: the pieces made before its ``problems`` are raised, and
    ``pieces``: those made after the start point, before ``late``."""

    problems: list[PrsxyError]
    earlier: list[Piece] = field(default_factory=list)
    start_line: int | None = None
    pieces: list[Piece] = field(default_factory=list)
    late: list[PrsxyError] = field(default_factory=list)
    final: bool = False
    moves_nothing: bool = False
    seconds: float = 0.0


class Planning:
    """The planner's half of the chain: look-ahead, time law, where split parts
    end, the work guard, the points' times and poses, the pieces the points are
    made from and the poses through the map and the IK (:meth:`cut`). It carries
    no state that the points' half changes, so it may run in another process
    (the conversion runs it in the interpreter's) with the same result.

    Parameters as :class:`Pipeline`'s (the start pose is the points' half's).
    """

    def __init__(
        self,
        profile: Profile,
        stages: Stages = Stages(),
        error_map: ErrorFunction | None = None,
        *,
        collect: bool = False,
        segment: str = "cubic",
        max_part_points: int = 0,
    ) -> None:
        self.profile = profile
        self.error_map = error_map if stages.error_map else None
        self.collect = collect
        self.limits = limits_of(profile, segment)
        self.planner = Planner(self.limits)
        self.geo = ik_geometry(profile, stages)
        # the motors with play, whose directions at the junctions the look-ahead is
        # told: where one reverses at a corner it crosses its play at rest. Taken at
        # speed, its part would stand through the crossing while the others move on,
        # in a PVT cubic and in LinuxCNC's straight line alike (1.07 x F60 as
        # corrected G-code: test_controller_truth's found programs)
        tables = axiscomp.profile_tables(profile) if stages.axis_comp else {}
        self.play_cols = [
            col for col, m in enumerate(MOTORS) if m in tables and tables[m].max_play > 1e-12
        ]
        # the way each motor with play last moved, and whether it stood at the last
        # moving block's end (_directions)
        self.way = np.ones(len(self.play_cols))
        self.stood = np.ones(len(self.play_cols), dtype=bool)
        self.max_part = max_part_points
        self.window: Blocks | None = None  # blocks held to choose where a part ends
        self.part_used = 1  # the start point belongs to the first part
        self.started = False
        self.any_motion = False
        #: the points' half reads the pieces' plans (:data:`BLOCKS_READ`): a motor
        #: has play (:meth:`Pipeline._reversals`)
        self.plan_read = bool(self.play_cols)
        # the work guard's counters: the points and time planned so far
        self.n_planned = 0
        self.t_planned = 0.0
        # the planner's runs, cut again where the output does not depend on them
        self.pieces = Pieces()

    def plan(self, prepared: Prepared, final: bool = False) -> Planned:
        """Plan a prepared chunk (the last one with ``final``)."""
        t0 = time.process_time()
        out = Planned(prepared.problems, final=final)
        if prepared.problems and not self.collect:
            return out  # its first problem stops the program before anything of it
        b = prepared.blocks
        if not self.started:
            out.start_line = int(b.line[0]) if len(b) else prepared.first_line
            self.started = True
            self.n_planned += 1
        if self.play_cols:
            self._directions(b)
        if self.max_part:
            b = self._parts(b, final)
        plan = self.planner.push(b, final)
        if plan is not None:
            done = plan.blocks
            if np.any(~done.stops):
                self.any_motion = True
            # before any point is made: a long move to an unreachable place is an
            # error at its line, and a block of a billion points is never tried
            phases = steps(done, plan.law, self.limits)
            n_steps = phases[:, 0] + phases[:, 1] + phases[:, 2]  # (a sum over rows of 3)
            long = np.flatnonzero(n_steps > 256)
            if long.size:
                out.late = self._end_problems(done.take(long))
                if out.late and not self.collect:
                    # the blocks before the first long one that cannot be done are
                    # made and checked first: an earlier line's problem comes first
                    worst_line = min(e.line or 0 for e in out.late)
                    cut = int(long[np.flatnonzero(done.line[long] == worst_line)[0]])
                    plan = plan.head(cut)
                    n_steps, phases = n_steps[:cut], phases[:cut]
            self._guard(plan, n_steps)
            out.plan, out.steps = plan, phases
        out.moves_nothing = final and not self.any_motion
        out.seconds = time.process_time() - t0
        return out

    def cut(self, planned: Planned, solve: bool = False) -> Ready:
        """A planned chunk in whole pieces (:mod:`.interpolate.pieces`; the rest held
        for the next) and their points, in the order :meth:`Pipeline.feed_ready`
        makes their points; with ``solve``, their poses solved too (:meth:`solve`).
        A piece's points are made from its plan once it is whole: each block's
        points depend on the block alone (and the tangent after it), so they are
        the points of the runs it joins, without the runs' points made and joined."""
        out = Ready(
            planned.problems,
            start_line=planned.start_line,
            late=planned.late,
            final=planned.final,
            moves_nothing=planned.moves_nothing,
            seconds=planned.seconds,
        )

        def solved(pieces: list[tuple[Plan, np.ndarray]]) -> list[Piece]:
            made = []
            for plan, n_steps in pieces:
                t0 = time.process_time()
                s = sample(plan, self.limits, n_steps)
                out.seconds += time.process_time() - t0
                made.append(
                    (plan, s, self.solve(s.q, s.qdot, s.tool_length, s.line) if solve else None)
                )
            return made

        if planned.problems:  # the points of earlier lines, and their problems, first
            out.earlier = solved(self.pieces.take(final=True))  # type: ignore[arg-type]
        if planned.plan is not None and planned.steps is not None:
            self.pieces.add(planned.plan, planned.steps)
        final = planned.final or bool(planned.late)
        out.pieces = solved(self.pieces.take(final=final))  # type: ignore[arg-type]
        return out

    def solve(self, q: np.ndarray, qdot: np.ndarray, tool: np.ndarray, line: np.ndarray) -> Solved:
        """Virtual-axis map, IK and the IK's velocity for points ``q`` (n, 5) moving
        at ``qdot`` (n, 5) with tool lengths ``tool`` (n,), at G-code lines ``line``
        (n,); their problems returned, not raised."""
        t0 = time.process_time()
        q_t = correct_virtual(q, self.error_map) if self.error_map is not None else q
        t1 = time.process_time()
        # the IK and its velocity (ik_derivative over VEL_STEP_S where a point
        # moves) in one pass. e(Q) changes by µm over mm: its share of the velocity
        # (1e-4 of it) moves the cubic by far less than the rounding of the
        # written numbers
        P, V = kinematics.motion(self.geo, q_t, qdot, tool, VEL_STEP_S)
        pose = [
            *checks.tilt_problems(self.profile, q, line),
            *checks.reach_problems(self.geo, q_t, tool, P, line),
        ]
        problems = [p.error(self.profile) for p in pose]
        with np.errstate(over="ignore", invalid="ignore"):
            # a finite sum: every position finite (a NaN or inf would not be)
            reachable = bool(np.isfinite(P.sum()) or np.isfinite(P).all())
        if problems and not self.collect:  # the first stops the program here
            return Solved(q_t, P, None, reachable, problems)
        return Solved(q_t, P, V, reachable, problems, (t1 - t0, time.process_time() - t1))

    def _directions(self, b: Blocks) -> None:
        """The motors with play: dP/ds at each moving block's ends (the IK's
        difference over DIR_STEP_MM along its tangents), into ``b.dP_in`` and
        ``b.dP_out`` for the look-ahead; and ``b.cross_in``, where one that stood at
        the end of the moving block before (under STAND_SLOPE) sets off, faster than
        a creep at the block's speed limit, against the way it last moved by more
        than REVERSAL_SLOPE (its side, carried across chunks in ``self.way``: a
        creep does not set it, as the points' half watches a creep's drift instead;
        at the start, up, the contract's approach from below)."""
        k = np.flatnonzero(~b.stops)
        n = len(k)
        if not n:
            return
        # each moving block's start and end (whole columns where every block moves:
        # a CAM program's chunks; the same rows gathered where not), the IK there
        # and along the tangents in one pass of the kernel
        every = n == len(b)
        m = self.geo.ik_arrays
        if every:
            tz = kernel.ik.tool_z(m, n, b.tool_length)
            d_in, d_out = kernel.end_slopes(m, b.start, b.end, b.dq_in, b.dq_out, tz, DIR_STEP_MM)
        else:
            tz = kernel.ik.tool_z(m, n, b.tool_length[k])
            d_in, d_out = kernel.end_slopes(
                m,
                np.take(b.start, k, axis=0),
                np.take(b.end, k, axis=0),
                np.take(b.dq_in, k, axis=0),
                np.take(b.dq_out, k, axis=0),
                tz,
                DIR_STEP_MM,
            )
        cols = self.play_cols
        if cols != _ALL_MOTORS:
            d_in, d_out = d_in[:, cols], d_out[:, cols]
        if every and cols == _ALL_MOTORS:
            b.dP_in, b.dP_out = d_in, d_out  # the kernel's own arrays, (n, 5) as theirs
        else:
            b.dP_in[k[:, None], cols] = d_in
            b.dP_out[k[:, None], cols] = d_out
        # the way each motor last moved clearly, carried across chunks: where one
        # that stood sets off against it (the points' half takes a direction from
        # V_EPS on)
        crosses, self.way, self.stood = kernel.set_offs(
            d_in,
            d_out,
            b.vmax if every else b.vmax[k],
            self.way,
            self.stood,
            REVERSAL_SLOPE,
            STAND_SLOPE,
            reversals.V_EPS,
        )
        b.cross_in[k] = crosses

    def _parts(self, new: Blocks, final: bool) -> Blocks:
        """Where a split program's parts end: at rest after a block, the last place
        before the part could hold more than ``max_part_points`` points, judged by
        an upper bound of each block's points that no plan can exceed
        (:func:`.interpolate.geometry.point_bound`). The last stop the program
        makes anyway before that place, or else a stop put at the last block end
        (its junction becomes a G61.1 exact stop). Blocks wait here until that
        place is known; their number is bounded by the part size."""
        from .interpolate.geometry import point_bound

        w = new if self.window is None else Blocks.concat([self.window, new])
        out: list[Blocks] = []
        budget = self.max_part
        while len(w):
            cum = self.part_used + np.cumsum(point_bound(w, self.limits))
            over = np.flatnonzero(cum > budget)
            if over.size == 0:
                break
            j = int(over[0])
            if j == 0:
                raise LimitError(
                    f"this block alone can make more than {budget} points, more than a part "
                    "may hold",
                    line=int(w.line[0]),
                    expected="a larger output.pmac.max_points_per_program, or a shorter block",
                )
            nxt_stop = np.concatenate([w.stops[1:], [False]])
            rest = w.stops | nxt_stop | (w.tol == -1.0)
            cand = np.flatnonzero(rest[:j])
            k = int(cand[-1]) if cand.size else j - 1
            w.split_after[k] = 1 if cand.size else 2
            w.tol[k] = -1.0  # the part ends at rest: an exact stop (G61.1) if not one
            w.tol_deg[k] = -1.0
            out.append(w.take(slice(0, k + 1)))
            w = w.take(slice(k + 1, len(w)))
            self.part_used = 0
        if final:
            out.append(w)
            self.window = None
        else:
            self.window = w
        if not out:
            return w.take(slice(0, 0))
        return Blocks.concat(out)

    def _end_problems(self, b: Blocks) -> list[PrsxyError]:
        """Reach and travel at the end points of long blocks, before interpolating them:
        a move to X1e9 is an error at its line, not a billion points. (Short blocks are
        checked point by point, as every block is; the ends are judged before the
        real-axis tables, which move a command by micrometres.)"""
        ends = b.end
        q_t = correct_virtual(ends, self.error_map) if self.error_map is not None else ends
        ik = kinematics.inverse(self.geo, q_t, b.tool_length)
        found = [
            *checks.tilt_problems(self.profile, ends, b.line),
            *checks.reach_problems(self.geo, q_t, b.tool_length, ik.P, b.line),
            *checks.travel_problems(self.profile, ik.P, b.line),
        ]
        return [p.error(self.profile) for p in found]

    def _guard(self, plan: Plan, n_steps: np.ndarray) -> None:
        """Refuse absurd work: more points or machining time than the profile allows,
        judged from the plan before its points are made (the few points and
        standing times a motor's crossing of its play adds are not counted)."""
        lim = self.profile.limits
        n_after = self.n_planned + np.cumsum(n_steps)
        t_after = self.t_planned + np.cumsum(plan.law.duration)
        over = np.nonzero((n_after > lim.max_points) | (t_after > lim.max_time_s))[0]
        if over.size:
            k = int(over[0])
            raise LimitError(
                f"the program would interpolate to more than {int(lim.max_points)} points or "
                f"run longer than {lim.max_time_s:g} s (reached here)",
                line=int(plan.blocks.line[k]),
                expected="a shorter program, or larger limits.max_points / limits.max_time_s",
            )
        self.n_planned += int(n_steps.sum())
        self.t_planned += float(plan.law.duration.sum())


class Pipeline:
    """The compensation chain over a stream of motions, chunk by chunk.

    Feed it prepared chunks of motions (or chunks its :class:`Planning` half
    planned, perhaps in another process: :meth:`feed_planned`); it returns
    :class:`PointChunk` s as they become final. State carried across chunks: the
    planner's (in ``planning``), each motor's side of its play and real-axis
    compensation, the last point (reversals, servo lead) and the clock.

    Parameters
    ----------
    profile : Profile
    stages : Stages
    error_map : the fitted virtual-axis error, applied as Q' = Q − e(Q) when
        ``stages.error_map``
    start : (5,) start pose; default the profile's
    collect : gather every problem in ``problems`` instead of raising the first
    segment : how the target controller moves between points, "cubic" or "chord"
    max_part_points : > 0: the program is split into parts of at most this many
        points, each ending at rest at a block end (:meth:`_parts`)
    written : how the output rounds its numbers (a crossing of a motor's play ends
        short of its part by more than that: :meth:`_crossing_short`)
    """

    def __init__(
        self,
        profile: Profile,
        stages: Stages = Stages(),
        error_map: ErrorFunction | None = None,
        *,
        start: Sequence[float] | None = None,
        collect: bool = False,
        segment: str = "cubic",
        max_part_points: int = 0,
        written: Written = Written(),
    ) -> None:
        self.profile = profile
        self.stages = stages
        self.written = written
        self.error_map = error_map if stages.error_map else None
        self.start = np.asarray(profile.start if start is None else start, dtype=float)
        self.collect = collect
        self.planning = Planning(
            profile,
            stages,
            error_map,
            collect=collect,
            segment=segment,
            max_part_points=max_part_points,
        )
        self.limits = self.planning.limits
        self.geo = self.planning.geo
        self.tables = axiscomp.profile_tables(profile) if stages.axis_comp else {}
        self.table_cols = [
            (col, self.tables[m]) for col, m in enumerate(MOTORS) if m in self.tables
        ]
        self.play_cols = [col for col, t in self.table_cols if t.max_play > 1e-12]
        # the contract: the first point of a motion is approached from below (lo)
        self.side = np.ones(5, dtype=int)
        # where each motor with play last moved with a direction (NaN: not yet)
        self.ref = np.full(5, np.nan)
        # each motor's lag τ (5,) [s] (effects.servo_lag_ms, as effects.SERVO_LAG
        # reads it; read here from the profile's section, so that converting does
        # not load the physics registry, 13 frozen dataclasses of start-up)
        lag_s = np.asarray(profile.effects.servo_lag_ms, dtype=float) / 1000.0
        self.lag = lag_s if stages.axis_comp else np.zeros(5)
        self.reversal_s = profile.interpolation.reversal_ms / 1000.0
        self.reversal_tol = REVERSAL_SHARE * self.limits.tolerance_mm
        # where each motor's driven part is, and the last commands (for _settle)
        self.play_y: dict[int, float] = {}
        # how far each part still is from where it is wanted, after a crossing
        self.catch: dict[int, float] = {}
        # the last point made is a blended corner (_corners): the next
        # chunk's first step gets a point this long [s] after its start
        self.near_next = 0.0
        # the last point's wanted position before a blend moved it (_reversals): the
        # reversals of the next chunk are found from it
        self.last_plain = np.zeros(5)
        self.last_cmd: tuple[np.ndarray, np.ndarray] | None = None
        self.last: PointChunk | None = None  # the last point made (before the lead)
        # points waiting for the servo lead, chunk by chunk (not joined: what is
        # released goes to the writer as the runs it was made in)
        self.held: list[PointChunk] = []
        self.prev_out: PointChunk | None = None  # the last point released
        self.problems: list[PrsxyError] = []
        self.t = 0.0
        self.n_points = 0
        #: CPU seconds spent per stage in this process (for the benchmark and profiling)
        self.timings = {"interpolate": 0.0, "error_map": 0.0, "kinematics": 0.0, "axis_tables": 0.0}

    # -- problems
    def _problem(self, errs: list[PrsxyError]) -> None:
        if not errs:
            return
        if not self.collect:
            raise sorted(errs, key=lambda e: e.line or 0)[0]
        self.problems += errs

    def feed(self, motions: Sequence[Motion], final: bool = False) -> list[PointChunk]:
        t0 = time.process_time()
        prepared = prepare(motions, self.profile, self.planning.limits)
        self.timings["interpolate"] += time.process_time() - t0
        return self.feed_prepared(prepared, final)

    def feed_prepared(self, prepared: Prepared, final: bool = False) -> list[PointChunk]:
        """:meth:`feed` for motions already through :func:`prepare`."""
        return self.feed_planned(self.planning.plan(prepared, final))

    def feed_planned(self, planned: Planned) -> list[PointChunk]:
        """:meth:`feed` for a chunk already through :meth:`Planning.plan`: its
        points, compensated, as they become final."""
        return self.feed_ready(self.planning.cut(planned))

    def feed_ready(self, ready: Ready) -> list[PointChunk]:
        """:meth:`feed` for a chunk already through :meth:`Planning.plan` and
        :meth:`Planning.cut` (here or in another process, whose ``planning`` then
        holds the planner's state): its points, compensated, as they become final."""
        self.timings["interpolate"] += ready.seconds
        out: list[PointChunk] = []
        if ready.problems:  # the points of earlier lines, and their problems, first
            out += self._made(ready.earlier)
            self._problem(ready.problems)
        if ready.start_line is not None:
            out += self._start_point(ready.start_line)
        out += self._made(ready.pieces)
        self._problem(ready.late)
        if ready.final:
            if ready.moves_nothing:
                raise LimitError(
                    "the program moves nothing",
                    expected="at least one move (G0, G1, G2, G3) or dwell",
                )
            out += self._release(final=True)
        return out

    def finish(self) -> list[PointChunk]:
        return self.feed([], final=True)

    def _made(self, pieces: list[Piece]) -> list[PointChunk]:
        """The points of whole pieces (:mod:`.interpolate.pieces`), as they become final."""
        out = []
        for plan, samples, solved in pieces:
            out += self._points(plan, samples, solved)
        return out

    # -- points
    def _start_point(self, line0: int) -> list[PointChunk]:
        z5 = np.zeros((1, 5))
        s = Samples(
            q=self.start[None, :].copy(),
            qdot=z5.copy(),
            dt=np.zeros(1),
            line=np.array([line0]),
            block=np.zeros(1, dtype=int),
            tau=np.zeros(1),
            first=np.array([False]),
            tool_length=np.zeros(1),  # the program starts with no tool length offset
            speed=np.zeros(1),
            dwell=np.array([True]),
            fn=np.empty(1, dtype=object),
            block_end=np.array([True]),
            split=np.zeros(1, dtype=np.int8),
        )
        return self._points(None, s)

    def _solve(
        self, q: np.ndarray, qdot: np.ndarray, tool: np.ndarray, line: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """Virtual-axis map, IK and the IK's velocity for points: (q_target, P, V,
        every point reachable)."""
        return self._solved(self.planning.solve(q, qdot, tool, line))

    def _solved(self, solved: Solved) -> tuple[np.ndarray, np.ndarray, np.ndarray, bool]:
        """:meth:`_solve`'s answer from :meth:`Planning.solve`'s: its problems
        raised (or collected) here, in the points' order."""
        self._problem(solved.problems)
        assert solved.V is not None  # None only with a problem raised above
        self.timings["error_map"] += solved.seconds[0]
        self.timings["kinematics"] += solved.seconds[1]
        return solved.q_target, solved.P, solved.V, solved.reachable

    def _ik_velocity(
        self, q_t: np.ndarray, qdot: np.ndarray, tool: np.ndarray, P: np.ndarray
    ) -> np.ndarray:
        """(N, 5) [mm/s] the motors' velocity moving along ``qdot`` from poses ``q_t``
        (whose IK is ``P``): :func:`ik_derivative` over VEL_STEP_S."""
        return ik_derivative(self.geo, q_t, qdot, tool, P, VEL_STEP_S)

    def _points(
        self, plan: Plan | None, s: Samples, solved: Solved | None = None
    ) -> list[PointChunk]:
        if solved is None:
            solved = self.planning.solve(s.q, s.qdot, s.tool_length, s.line)
        q_t, P, V, reachable = self._solved(solved)
        pc = PointChunk(
            q=s.q,
            qdot=s.qdot,
            dt=s.dt,
            t=np.zeros(len(s)),
            line=s.line,
            first=s.first,
            tool_length=s.tool_length,
            speed=s.speed,
            dwell=s.dwell,
            fn=s.fn,
            block_end=s.block_end,
            split=s.split,
            q_target=q_t,
            P_ideal=P,
            V_ideal=V,
            P_cmd=P,
            V_cmd=V,
        )
        t0 = time.process_time()
        contacts = np.zeros((0, 3), dtype=int)
        plain_last = pc.P_ideal[-1].copy() if len(pc) else self.last_plain
        V_cols: np.ndarray | None = None
        if self.play_cols and reachable:
            pc, side, contacts, V_cols = self._reversals(plan, s, pc)
        else:
            side = np.empty((5, len(pc)))
            side[:] = self.side[:, None]
        # a running sum continued across chunks (not chunk offset + cumsum), so the
        # clock is the same bit for bit however the program was cut
        t = np.cumsum(np.concatenate([[self.t], pc.dt]))[1:]
        pc.t = t
        if len(t):
            self.t = float(t[-1])
        self.n_points += len(pc)
        if reachable and self.table_cols:
            # every motor's columns as contiguous rows (5, n), made in one pass each
            # (a column read alone reads the whole array): the commands are made
            # motor by motor in these rows and turned back once
            # (the sides come as such rows, and the velocities too after _reversals)
            by_motor = (
                np.ascontiguousarray(pc.P_ideal.T, dtype=float),
                np.ascontiguousarray(pc.V_ideal.T, dtype=float) if V_cols is None else V_cols,
                side,
            )
            # a motor without a table is commanded where it must be; where every
            # motor has one, every row is made below
            every = len(self.table_cols) == pc.P_ideal.shape[1]
            P_cmd = np.empty_like(by_motor[0]) if every else by_motor[0].copy()
            V_cmd = np.empty_like(by_motor[1]) if every else by_motor[1].copy()
            # the kernel on the motors' contiguous rows, every motor in one call (what
            # axiscomp.compensate_sided and MotorTable.slope do, without their
            # conversions and reshapes)
            kernel.table_commands(
                tuple(table.flat for _, table in self.table_cols),
                np.array([col for col, _ in self.table_cols], dtype=int),
                *by_motor,
                P_cmd,
                V_cmd,
            )
            if self.play_cols:
                self._settle(pc, by_motor, contacts, P_cmd, V_cmd)
            # the commands' velocities are written in motor space only (a PVT
            # program's V): in pose space they stay the view of the motors' rows
            # they were made in (the same values), not copied into point order
            V_out = V_cmd.T if self.written.space == "pose" else np.ascontiguousarray(V_cmd.T)
            pc.P_cmd, pc.V_cmd = np.ascontiguousarray(P_cmd.T), V_out
        self.timings["axis_tables"] += time.process_time() - t0
        self.last = pc.take(slice(len(pc) - 1, len(pc)))
        self.last_plain = plain_last
        if len(pc):
            self.held.append(pc)
        return self._release(final=False)

    def _reversals(
        self, plan: Plan | None, s: Samples, pc: PointChunk
    ) -> tuple[PointChunk, np.ndarray, np.ndarray, np.ndarray]:
        """Give every reversal of a motor with play its crossing window
        (:mod:`.reversals`), after its corners (:meth:`_corners`). Returns the
        points, the side every motor is on at each (5, n) [a motor a row], the
        crossings (M, 3) ints: the point where each ends, the point where it began,
        the motor's column; in that order; and the points' V_ideal as motor rows
        (5, n) (made once here, for the sides and the tables)."""
        last = self.last
        # the last point as the reversals saw it: a blended corner's before it moved
        # onto its blend (the same positions however the program was cut)
        prev = (
            None if last is None else (self.last_plain, last.V_ideal[0], bool(last.speed[0] == 0))
        )
        self.ref = np.where(np.isnan(self.ref), pc.P_ideal[0], self.ref)
        blends, shift = self._corners(plan, s, pc)
        t_end = np.cumsum(pc.dt)
        resting = pc.speed == 0.0
        found = reversals.find_reversals(
            t_end,
            pc.dt,
            pc.P_ideal,
            pc.V_ideal,
            resting,
            prev,
            self.play_cols,
            self.side,
            self.ref,
            self.reversal_tol,
        )
        # the plan's paths as the path kernel takes them, made once for every
        # look at the plan below (the roots' search asks it several times)
        paths = None if plan is None else path_arrays(plan.blocks)
        velocity = self._path_velocity(plan, s, pc, paths)
        if velocity is not None and found.seen:
            # the roots in motion onto the path: the search asks where to look,
            # the plan and the IK answer (reversals.roots_search)
            st = reversals.roots_search(found)
            while st.phase != reversals.DONE:
                st = reversals.root_answer(st, velocity(*reversals.root_queries(st)))
            found = reversals.with_roots(found, st)
        ins = reversals.place_insertions(
            found,
            self.reversal_tol,
            self.reversal_s,
            self.limits.segment != "cubic",
            # straight lines (corrected G-code) too: a window is one line, symmetric
            # about its root, and within the reach on both sides the tip's speed
            # strays less across it (reversals.chord_windows)
            self._edge_speed(plan, s, pc)(*reversals.edge_queries(found)),
            blends,
            self.near_next,
            # a window reaching over a corner stood on one side of it while the
            # path turned (0.27 µm off a G41.1 corner, test_controller_truth's
            # found programs); only windows of straight lines reach over (PVT's
            # corners found their bends in _corners)
            None if plan is None or self.limits.segment == "cubic" else self._bends(plan, s)[0],
        )
        self.near_next = ins.near_next
        if ins.blended.size:
            # the blended corners' points onto their parabolas (P_cmd is made from
            # P_ideal after this)
            at = ins.blended  # distinct rows
            moved = _gather(shift, np.searchsorted(blends[0], at))
            pc.P_ideal = pc.P_ideal.copy()
            pc.P_ideal[at] = _gather(pc.P_ideal, at) + moved
        n = len(pc)
        step = np.arange(n)
        when = t_end
        before = np.zeros(n, dtype=bool)
        if ins:
            extra, e_step, e_when, e_before, dt = self._new_points(plan, s, pc, t_end, ins, paths)
            places = _merge_places(n, e_step, e_when, e_before)
            pc = self._joined(pc, dt, extra, places)
            step = _merged(step, e_step, places)
            when = _merged(when, e_when, places)
            before = _merged(before, e_before, places)
            resting = pc.speed == 0.0
        rows = reversals.Rows(step, when, before)
        V_cols = np.ascontiguousarray(pc.V_ideal.T, dtype=float)
        side, w_end, s_first = reversals.sides_by_motor(
            rows, V_cols, resting, ins, self.play_cols, self.side
        )
        self.side = side[:, -1].astype(int) if side.shape[1] else self.side
        # where each crossing ends (the motor meets its part) and where it began
        ends = np.concatenate([w_end, s_first])
        begs = np.concatenate([rows.at(ins.w_k, ins.w_ta, ins.w_t0), ends[len(ins.w_tb) :] - 1])
        cols = np.concatenate([ins.w_col, ins.s_col])
        contacts = np.column_stack([ends, begs, cols]).astype(int)
        # by end, then start, then motor: lexsort((cols, begs, ends))'s order as one
        # stable sort of an int key (the points from −1, the motors below the width)
        m, width = len(pc) + 1, pc.P_ideal.shape[1]
        key = ((contacts[:, 0] + 1) * m + (contacts[:, 1] + 1)) * width + contacts[:, 2]
        return pc, side, contacts[np.argsort(key, kind="stable")], V_cols

    def _joined(
        self,
        pc: PointChunk,
        dt: np.ndarray,
        extra: list[PointChunk],
        places: tuple[np.ndarray, np.ndarray, np.ndarray],
    ) -> PointChunk:
        """The chunk's points and the new ones (``extra``, their steps' new ``dt``
        in ``dt``) in time order (:func:`_merge_places`): every field but the clock
        (``_points`` makes it from dt), and not the commands where the tables make
        them again from P_ideal, V_ideal (``_points``)."""
        skip = ("t", "P_cmd", "V_cmd") if self.table_cols else ("t",)
        parts = extra or [pc.take(slice(0, 0))]

        def new_rows(f: str) -> np.ndarray:
            """The new points' field ``f``, all kinds joined."""
            if len(parts) == 1:
                one: np.ndarray = getattr(parts[0], f)
                return one
            return np.concatenate([getattr(p, f) for p in parts])

        fields = {
            f: _merged(getattr(pc, f), new_rows(f), places)
            for f in PointChunk.FIELDS
            if f not in skip and f != "dt"
        }
        fields["dt"] = _merged(dt, new_rows("dt"), places)
        fields["t"] = np.zeros(len(places[2]))
        if self.table_cols:
            fields["P_cmd"], fields["V_cmd"] = fields["P_ideal"], fields["V_ideal"]
        return PointChunk(**fields)

    def _path_velocity(
        self, plan: Plan | None, s: Samples, pc: PointChunk, paths: PathArrays | None = None
    ) -> reversals.Velocity | None:
        """The wanted velocity of motors inside the chunk's steps, from the plan
        (:data:`.reversals.Velocity`): the IK and its velocity at the pose the plan
        has there, as the points' (:meth:`_solve`). The error map's correction is
        taken linear between the step's ends (it changes by µm over mm: its
        curvature over a step is far below the rounding of the written numbers),
        not evaluated again. NaN in a step that begins in another block (its start
        is not in the row's block). None without a plan. ``paths``: the plan's
        ``path_arrays(plan.blocks)``, if made already."""
        if plan is None:
            return None
        # the map's correction at each point and at the point before the chunk
        fix = pc.q - pc.q_target
        fix_before = self.last.q[0] - self.last.q_target[0] if self.last is not None else fix[0]

        def velocity(k: np.ndarray, frac: np.ndarray, cols: np.ndarray) -> np.ndarray:
            tau_k, dt_k = s.tau[k], pc.dt[k]
            tau = tau_k - (1.0 - frac) * dt_k
            inside = tau_k - dt_k >= 0.0
            every = bool(inside.all())
            if not every and not inside.any():
                return np.full(len(k), np.nan)
            if not every:
                k, frac, tau, cols = k[inside], frac[inside], tau[inside], cols[inside]
            q, qdot = at_times(plan, s.block[k], tau, paths)
            e0 = np.where((k >= 1)[:, None], _gather(fix, np.maximum(k - 1, 0)), fix_before)
            q_t = q - (e0 + frac[:, None] * (_gather(fix, k) - e0))
            # the IK and its velocity in one pass of the kernel (the rows of
            # _ik_velocity's difference); a standing row's is P − P there (0, or
            # NaN where the pose is out of reach), as the difference has it
            P, V = kinematics.motion(self.geo, q_t, qdot, s.tool_length[k], VEL_STEP_S)
            row = np.arange(len(k))
            Pc, Vc = P[row, cols], V[row, cols]
            v = np.where(~np.any(qdot != 0.0, axis=1), Pc - Pc, Vc)
            if every:
                return v
            out = np.full(len(inside), np.nan)
            out[inside] = v
            return out

        return velocity

    def _edge_speed(self, plan: Plan | None, s: Samples, pc: PointChunk) -> reversals.EdgeSpeed:
        """How fast a motor may move while its part stands in a crossing window,
        before and after its reversal (:data:`.reversals.EdgeSpeed`).

        The part lacks the motor's motion u, and the tip goes at v t − J u instead
        of v t (v the path's planned speed at the root and t its direction there,
        both linear between the step's ends, J = ∂x/∂P the motor's lever on the
        tip through the forward kinematics: the inverse of the IK's Jacobian
        there). Held within the block's speed limit and CROSSING_SPEED_SHARE of it,
        |v t − J u| ≤ v + r with r = vmax (1 + share) − v, c = 2 v r + r²: on the
        side of the root where the missing motion pushes the tip on (t·J u < 0:
        before the root where (t·J) A > 0, u = A (t − t_root))

            u ≤ c / (v |t·J| + sqrt(v² (t·J)² + |J|² c))

        and on the other, where it holds the tip back,

            u ≤ (v |t·J| + sqrt(v² (t·J)² + |J|² c)) / |J|²

        A motor moving the tip across the path (a table motor at an arc's extreme)
        costs its speed only in the second order."""
        vmax = plan.blocks.vmax[s.block] if plan is not None else pc.speed
        # the path's speed and velocity at the point before the chunk (the first
        # step's start)
        v_before = float(self.last.speed[0]) if self.last is not None else 0.0
        qdot_before = self.last.qdot[0, :3] if self.last is not None else np.zeros(3)

        def levers(k: np.ndarray, cols: np.ndarray) -> np.ndarray:
            """(q, 3) J = ∂x_tip / ∂P_col at rows ``k`` for motors ``cols``: the
            forward Jacobian ∂q/∂P made once a row asked (every motor's and window's
            questions share them: the IK's differences are the cost), only there."""
            rows, which = np.unique(k, return_inverse=True)
            # P_ideal is the IK of q_target here (blends move it only later)
            jac = ik_jacobian(
                self.geo,
                _gather(pc.q_target, rows),
                pc.tool_length[rows],
                DIR_STEP_MM,
                _gather(pc.P_ideal, rows),
            )
            out: np.ndarray = _inverted(jac)[which, :3, cols]
            return out

        def edge_speed(
            k: np.ndarray, frac: np.ndarray, cols: np.ndarray, accel: np.ndarray
        ) -> tuple[np.ndarray, np.ndarray]:
            if not len(k):
                return np.zeros(0), np.zeros(0)
            # J = ∂x_tip / ∂P_col, each row's motor's column, laid out as a column
            # of a (q, 5, 5) array: einsum's sums below take their order from the
            # strides (a contiguous (q, 3) sums otherwise in the last bit)
            buf = np.empty((len(k), 5, 5))
            buf[:, :3, 0] = levers(k, cols)
            lever = buf[:, :3, 0]
            j2 = np.einsum("ij,ij->i", lever, lever)
            v0 = np.where(k >= 1, pc.speed[np.maximum(k - 1, 0)], v_before)
            v = v0 + frac * (pc.speed[k] - v0)
            r = np.maximum(vmax[k] * (1.0 + reversals.CROSSING_SPEED_SHARE) - v, 0.0)
            # the path's direction at the root: its velocity there, linear between
            # the step's ends (on a tight arc the step turns it by tenths of a rad)
            q0 = np.where(
                (k >= 1)[:, None], _gather(pc.qdot, np.maximum(k - 1, 0))[:, :3], qdot_before
            )
            xyz = q0 + frac[:, None] * (_gather(pc.qdot, k)[:, :3] - q0)
            norm = np.linalg.norm(xyz, axis=1)
            # t·J unnormed (signed): its size below, its sign for the side
            dot = np.einsum("ij,ij->i", xyz, lever)
            with np.errstate(divide="ignore", invalid="ignore"):
                # no tangent in xyz (a tilt alone): the worst direction, both sides
                tj = np.where(norm > 0, dot / norm, np.nan)
                worst = np.isnan(tj)
                tj = np.where(worst, np.sqrt(j2), np.abs(tj))
                c = 2.0 * v * r + r * r
                root = v * tj + np.sqrt(v * v * tj * tj + j2 * c)
                on = np.where(c > 0, c / root, 0.0)
                back = np.where(worst, on, root / j2)
                # the side where the tip is pushed on: before the root when the
                # signed t·J and A agree
                ahead = dot * accel > 0
            before = np.where(ahead, on, back)
            after = np.where(ahead, back, on)
            # an unreachable pose (no lever) leaves the tolerance to decide
            return (
                np.where(np.isfinite(before), before, np.inf),
                np.where(np.isfinite(after), after, np.inf),
            )

        return edge_speed

    def _corners(
        self, plan: Plan | None, s: Samples, pc: PointChunk
    ) -> tuple[tuple[np.ndarray, np.ndarray], np.ndarray]:
        """The corners taken at speed where a motor with play stands on one side and
        moves on the other, which a PVT program blends as a parabola over ±τ
        (:func:`.reversals.corners`, with the blend's share of the acceleration,
        lookahead.KAPPA): (rows, tau) for :func:`.reversals.plan_insertions`, and
        (k, 5) how far each corner's point moves onto its blend
        (:func:`.reversals.blend_shift`).

        The decision takes the period for the standing side's step, not the step
        itself: the step past a chunk's last point is not made yet, and the points
        must not depend on where the program was cut into chunks.

        None for straight lines between the points (corrected G-code): a motor
        standing at both ends of a chord stands all along it, and a point near the
        corner only made a short chord whose written digits ran its motion fast
        (a 0.41 ms step at F60, 1 nm of rounding: 1.0015 x F, test_controller_truth's
        found programs)."""
        none = (np.zeros(0, dtype=int), np.zeros(0))
        if plan is None or self.limits.segment != "cubic":
            return none, np.zeros((0, 5))
        J, nxt = self._bends(plan, s)
        if not J.size:
            return none, np.zeros((0, 5))
        # the motors' velocities on the far side: the IK's velocity (as _solve) along
        # the next block's tangent; the near side's is then what the mean leaves
        qdot_out = s.speed[J, None] * nxt
        V_out = self._ik_velocity(
            _gather(pc.q_target, J), qdot_out, s.tool_length[J], _gather(pc.P_ideal, J)
        )
        V_in = 2.0 * _gather(pc.V_ideal, J) - V_out
        period = np.full(len(J), self.limits.period_s)
        accel = KAPPA * self.limits.accel_mm_s2
        blend, tau = reversals.corners(V_in, V_out, self.play_cols, period, accel)
        shift = reversals.blend_shift(
            np.compress(blend, V_in, axis=0), np.compress(blend, V_out, axis=0), tau[blend]
        )
        return (J[blend], tau[blend]), shift

    def _bends(self, plan: Plan, s: Samples) -> tuple[np.ndarray, np.ndarray]:
        """The rows of a chunk's samples where the path turns a corner (a junction
        whose blocks' tangents differ), and the next block's tangent there."""
        J = junctions(s)
        # a tangent junction has one velocity on both sides: no corner
        nxt = next_tangent(plan, s.block[J])
        bent = np.any(nxt != _gather(plan.blocks.dq_out, s.block[J]), axis=1)
        return J[bent], nxt[bent]

    def _settle(
        self,
        pc: PointChunk,
        by_motor: tuple[np.ndarray, np.ndarray, np.ndarray],
        contacts: np.ndarray,
        P_cmd: np.ndarray,
        V_cmd: np.ndarray,
    ) -> None:
        """Follow every motor with play through the cubics (or chords) of its own
        commands (:func:`.reversals.follow`) and end each crossing where the part really
        stands: a corner's blend may have carried it a little past the wanted
        extreme (within the corner tolerance), and a motor that met it at the wanted
        position would then push it with the crossing's speed. Updates the commands
        in place and carries where every part is into the next chunk.

        One pass with the commands as made finds where each part stands in each
        window (a crossing changes nothing before it, and once in contact the part
        follows the command whichever way it got there); the part's position is then
        carried on from the last contact, where it meets the corrected command.

        A part meets its motor off its wanted position (where it stood, behind the
        path by up to the reversal allowance, or ahead of it where the window stood
        longer before its root than after it) and is brought back along the path
        (:func:`.reversals.catch_up`) at a share of the path speed; what is left where
        the motor's next crossing begins goes into that crossing, which is then
        reckoned again from where the part is (the part followed through the
        commands as written, :func:`.kernel.play.follow_stretches`), and what is left
        at the chunk's end goes on in the next. The kernel does it for every motor
        in one call (:func:`.kernel.play.settle_motors`), each over arrays
        (:func:`.kernel.play.settle_crossings`); with straight lines, the points
        inside a window on its chord (:func:`.kernel.play.across`).

        ``by_motor``: the chunk's P_ideal, V_ideal and sides, (5, n) each; the
        commands ``P_cmd``, ``V_cmd`` (5, n) [mm, mm/s] are rows the same way.
        """
        s_path = self._path_run(pc)
        t = np.cumsum(pc.dt)  # since the point before the chunk
        if self.written.space == "motor":
            short = np.full(len(contacts), self.written.digit)
        else:
            # motors often reverse at the same point: the IK's Jacobian once a row
            rows, at = np.unique(contacts[:, 0], return_inverse=True)
            short = self._shorts(
                _gather(pc.q_target, rows), pc.tool_length[rows], at, contacts[:, 2]
            )
        cols = self.play_cols
        # the wanted positions at the point before the chunk (the first point's at
        # the start): each motor's wanted move into the first point
        P_before = self.last.P_ideal[0] if self.last is not None else pc.P_ideal[0]
        ch = play.Chunk(*by_motor, pc.speed, pc.dt, s_path, t, P_before)
        before = np.array([self._part_before(col, P_cmd) for col in cols]).reshape(-1, 3)
        carried = np.array([self.catch.pop(col, 0.0) for col in cols])
        y_end, carry = kernel.settle_motors(
            tuple(self.tables[MOTORS[col]].flat for col in cols),
            np.array(cols, dtype=int),
            ch,
            before,
            carried,
            play.Contacts(contacts[:, 0], contacts[:, 1], contacts[:, 2], short),
            P_cmd,
            V_cmd,
            self.limits.segment == "cubic",
            reversals.CATCH_UP_SHARE,
            reversals.CATCH_UP_HURRY,
        )
        for col, y, c in zip(cols, y_end.tolist(), carry.tolist(), strict=True):
            self.play_y[col] = y
            if not np.isnan(c):
                self.catch[col] = c
        if self.limits.segment != "cubic":
            self._straight_through(pc, contacts, P_cmd, t)
        self.last_cmd = (P_cmd[:, -1].copy(), V_cmd[:, -1].copy())

    def _path_run(self, pc: PointChunk) -> np.ndarray:
        """The path length run by each point since the point before the chunk,
        s_path: (n,) [mm], each step at the slower of its ends' speeds."""
        # path length run by each point since the point before the chunk: the
        # slower end of each step, so that a catch-up never outruns the path
        sp_prev = float(self.last.speed[0]) if self.last is not None else 0.0
        speed = pc.speed
        n = len(speed)
        # in one array, worked in place: the same operations as
        # cumsum(where(dwell, 0, minimum(concat([sp_prev], speed[:-1]), speed) * dt))
        run = np.empty(n)
        if n:
            run[0] = np.minimum(sp_prev, speed[0])
            np.minimum(speed[:-1], speed[1:], out=run[1:])
            np.multiply(run, pc.dt, out=run)
            run[pc.dwell] = 0.0
            np.cumsum(run, out=run)
        return run

    def _part_before(self, col: int, P_cmd: np.ndarray) -> tuple[float, float, float]:
        """Where motor ``col``'s part stands before the chunk [mm], and the
        command's position [mm] and velocity [mm/s] there (``P_cmd`` (5, n))."""
        if self.last_cmd is None:
            table = self.tables[MOTORS[col]]
            # the contract: the first point is approached from below
            y0 = float(table.lo(P_cmd[col, :1])[0])
            return y0, float(P_cmd[col, 0]), 0.0
        prev_P, prev_V = self.last_cmd
        return self.play_y[col], float(prev_P[col]), float(prev_V[col])

    def _straight_through(
        self, pc: PointChunk, contacts: np.ndarray, P_cmd: np.ndarray, t: np.ndarray
    ) -> None:
        """Straight lines between the points (corrected G-code): a planned point
        alone inside a crossing window (one that reaches over its step's end or
        start, :func:`.reversals.chord_windows`) put
        on the straight line from the window's first point to its last, every
        motor, by time, so that the window is one straight line run at one speed.
        Two lines, each averaged what the standing part lacked over it, and the
        one before the root, standing 0.29 ms before it and 0.07 after, ran 0.29 %
        over F (test_controller_truth's found programs). Where the window's chord
        strays from the curve by more than a step's chord may (CURVE_SHARE of the
        tolerance: interpolate.geometry), the point stays on the curve. ``P_cmd``
        (5, n) [mm] the commands, motor by motor; ``t`` (n,) [s] the time since
        the point before the chunk."""
        e, b = contacts[:, 0], contacts[:, 1]
        alone = np.flatnonzero((e - b == 2) & (b >= 0))
        if not alone.size:
            return
        k = b[alone] + 1
        # in no other window, no window's edge, no machine function there
        within = _windows_over(b, e, k)
        # a window's edge: marked once a point (np.isin sorts both every chunk)
        edges = np.zeros(len(pc) + 1, dtype=bool)
        edges[e] = True
        edges[b] = True  # b = −1 (before the chunk) marks the spare last slot
        edge = edges[k]
        plain = np.array([f is None for f in pc.fn[k]], dtype=bool)
        ok = (within == 1) & ~edge & plain & ~pc.dwell[k]
        k, bb, ee = k[ok], b[alone][ok], e[alone][ok]
        frac = ((t[k] - t[bb]) / (t[ee] - t[bb]))[:, None]
        q = pc.q
        stray = q[k] - (q[bb] + frac * (q[ee] - q[bb]))
        near = (np.linalg.norm(stray[:, :3], axis=1) <= CURVE_SHARE * self.limits.tolerance_mm) & (
            np.linalg.norm(stray[:, 3:], axis=1) <= CURVE_SHARE * self.limits.tolerance_deg
        )
        k, bb, ee, frac = k[near], bb[near], ee[near], frac[near]
        P_cmd[:, k] = P_cmd[:, bb] + frac.T * (P_cmd[:, ee] - P_cmd[:, bb])

    def _crossing_short(self, q: np.ndarray, tool: np.ndarray, col: int) -> np.ndarray:
        """How far [mm] short of where motor ``col`` meets its part a crossing
        ending at poses ``q`` (N, 5) [mm, mm, mm, deg, deg] with tool lengths
        ``tool`` (N,) ends: a written digit of the motor's position, or,
        where the pose is written, a digit of each of its coordinates through the
        IK: 10^-d Σ_j |∂P/∂q_j| (q_j in mm and deg, as written), twice the most the
        rounding of the five can move the motor.

        Ended at the contact, the rounding put the command up to that far past it,
        and the motor pushed its part with the crossing's speed in the window's
        last servo cycles, through the head's lever: 1.0013 x F60 from 0.1 nm in
        a PVT program (seven decimals), 1.0025 x F60 from 1 nm in a corrected
        G-code (six) (test_controller_truth's found programs). The part is met
        that much later, at the path's own speed."""
        return self._shorts(q, tool, np.arange(len(q)), np.full(len(q), col))

    def _shorts(
        self, q: np.ndarray, tool: np.ndarray, at: np.ndarray, col: np.ndarray
    ) -> np.ndarray:
        """(M,) [mm] :meth:`_crossing_short` of crossings ending at poses ``q[at]``
        of motors ``col`` (M,): the IK's Jacobian taken once a pose, however many
        motors end a crossing there. A written digit short of the contact: rounded
        past it, the motor would push its part within the window's last servo
        cycles."""
        digit = self.written.digit
        if self.written.space == "motor" or not len(q):
            return np.full(len(at), digit)
        jac = ik_jacobian(self.geo, q, tool, DIR_STEP_MM)
        return digit * np.abs(jac[at, col, :]).sum(axis=1)

    def _standing_points(
        self, pc: PointChunk, ks_stand: np.ndarray, hold: np.ndarray
    ) -> PointChunk:
        """The points where a motor stands before steps ``ks_stand`` for ``hold``
        [s]: each where the point before it is (the chunk's first where the last
        one made is), at rest."""
        c = len(ks_stand)
        at = np.maximum(ks_stand - 1, 0)
        last = self.last
        if ks_stand[0] == 0:
            assert last is not None  # a stand needs a point to stand at

        def where(name: str) -> np.ndarray:
            """Each stands where the point before it is."""
            x: np.ndarray = np.take(getattr(pc, name), at, axis=0)
            if ks_stand[0] == 0:
                x[0] = getattr(last, name)[0]
            return x

        return PointChunk(
            q=where("q"),
            qdot=np.zeros((c, 5)),
            dt=np.array(hold, dtype=float),
            t=where("t"),
            line=pc.line[ks_stand],
            first=np.zeros(c, dtype=bool),
            tool_length=where("tool_length"),
            speed=np.zeros(c),
            dwell=np.ones(c, dtype=bool),
            fn=np.empty(c, dtype=object),
            block_end=np.zeros(c, dtype=bool),
            split=np.zeros(c, dtype=np.int8),
            q_target=where("q_target"),
            P_ideal=where("P_ideal"),
            V_ideal=np.zeros((c, 5)),
            P_cmd=where("P_cmd"),
            V_cmd=np.zeros((c, 5)),
        )

    def _new_points(
        self,
        plan: Plan | None,
        s: Samples,
        pc: PointChunk,
        t_end: np.ndarray,
        ins: reversals.Insertions,
        paths: PathArrays | None = None,
    ) -> tuple[list[PointChunk], np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The standing points and the points inside steps that the reversals need
        (a record of each kind there is, joined with the chunk's points by the
        caller), and the chunk's step times cut at them. ``paths``: the plan's
        ``path_arrays(plan.blocks)``, if made already."""
        parts: list[PointChunk] = []
        e_step: list[np.ndarray] = [np.zeros(0, dtype=int)]
        e_when: list[np.ndarray] = [np.zeros(0)]
        e_before: list[np.ndarray] = [np.zeros(0, dtype=bool)]
        dt = pc.dt.copy()
        if len(ins.stand_k):
            ks_stand = ins.stand_k
            parts.append(self._standing_points(pc, ks_stand, ins.stand_t))
            e_step.append(ks_stand)
            e_when.append(t_end[ks_stand] - pc.dt[ks_stand])
            e_before.append(np.ones(len(ks_stand), dtype=bool))
        if len(ins.mid_k) and plan is not None:
            ks = ins.mid_k
            tt = ins.mid_t
            blk = s.block[ks]
            tau = s.tau[ks] - (t_end[ks] - tt)
            q, qdot = at_times(plan, blk, tau, paths)
            v = np.linalg.norm(qdot[:, :3], axis=1)
            v = np.where(v > 0, v, np.linalg.norm(qdot[:, 3:], axis=1))
            q_t, P, V, _ = self._solve(q, qdot, s.tool_length[ks], s.line[ks])
            m = len(ks)
            # the steps cut at the new points (sorted by step, then time)
            same = np.concatenate([[False], ks[1:] == ks[:-1]])
            before_t = np.where(same, np.concatenate([[0.0], tt[:-1]]), t_end[ks] - pc.dt[ks])
            seg = tt - before_t
            last_in_step = np.concatenate([ks[1:] != ks[:-1], [True]])
            dt[ks[last_in_step]] = t_end[ks[last_in_step]] - tt[last_in_step]
            parts.append(
                PointChunk(
                    q=q,
                    qdot=qdot,
                    dt=seg,
                    t=np.zeros(m),
                    line=s.line[ks],
                    first=np.zeros(m, dtype=bool),
                    tool_length=s.tool_length[ks],
                    speed=v,
                    dwell=np.zeros(m, dtype=bool),
                    fn=np.empty(m, dtype=object),
                    block_end=np.zeros(m, dtype=bool),
                    split=np.zeros(m, dtype=np.int8),
                    q_target=q_t,
                    P_ideal=P,
                    V_ideal=V,
                    P_cmd=P,
                    V_cmd=V,
                )
            )
            e_step.append(ks)
            e_when.append(tt)
            e_before.append(np.zeros(m, dtype=bool))
        return (
            parts,
            np.concatenate(e_step).astype(int),
            np.concatenate(e_when).astype(float),
            np.concatenate(e_before),
            dt,
        )

    def _release(self, final: bool) -> list[PointChunk]:
        """Points whose servo lead is final, as runs of the chunks they were made in
        (the writers' text does not depend on where a run ends: joining them would
        only copy every field).

        A motor that follows its command with a lag τ (τ ṁ + m = c, profile
        ``effects.servo_lag_ms``) reaches M when commanded c = M + τ M', whose
        velocity is M' + τ M''; M'' is taken as the central difference of the
        planned velocities, so a point is final once the next one exists.
        """
        held = self.held
        n = sum(len(h) for h in held)
        lagging = bool(np.any(self.lag))
        k = n if (final or not lagging) else n - 1
        if k <= 0:
            return []
        ready: list[PointChunk] = []
        rest: list[PointChunk] = []
        left = k
        for h in held:
            if left <= 0:
                rest.append(h)
            elif left < len(h):
                ready.append(h.take(slice(0, left)))
                rest.append(h.take(slice(left, len(h))))
            else:
                ready.append(h.take(slice(0, len(h))))
            left -= len(h)
        self.held = rest
        if not lagging:
            for r in ready:
                self._travel(r.P_cmd, r.line)
            return ready
        prev = self.prev_out
        V_all = np.vstack(
            [prev.V_cmd if prev is not None else held[0].V_cmd[:1]] + [h.V_cmd for h in held]
        )
        t_all = np.concatenate(
            [prev.t if prev is not None else held[0].t[:1]] + [h.t for h in held]
        )
        if final:
            V_all = np.vstack([V_all, held[-1].V_cmd[-1:]])
            t_all = np.concatenate([t_all, held[-1].t[-1:]])
        span = t_all[2 : k + 2] - t_all[:k]
        with np.errstate(invalid="ignore", divide="ignore"):
            acc = np.where(span[:, None] > 0, (V_all[2 : k + 2] - V_all[:k]) / span[:, None], 0.0)
        last = ready[-1]
        self.prev_out = last.take(slice(len(last) - 1, len(last)))
        # the commands of the points released (the lead makes them anew), joined
        # to be led and checked as one run
        P_cmd = ready[0].P_cmd if len(ready) == 1 else np.vstack([r.P_cmd for r in ready])
        V_cmd = ready[0].V_cmd if len(ready) == 1 else np.vstack([r.V_cmd for r in ready])
        line = ready[0].line if len(ready) == 1 else np.concatenate([r.line for r in ready])
        speed = ready[0].speed if len(ready) == 1 else np.concatenate([r.speed for r in ready])
        acc[speed == 0.0] = 0.0
        P_led = servo_lead(P_cmd, V_cmd, self.lag)
        V_led = servo_lead(V_cmd, acc, self.lag)
        self._travel(P_led, line)
        at = 0
        for r in ready:
            r.P_cmd, r.V_cmd = P_led[at : at + len(r)], V_led[at : at + len(r)]
            at += len(r)
        return ready

    def _travel(self, P_cmd: np.ndarray, line: np.ndarray) -> None:
        """The motors' commands beyond their travel, raised (or collected)."""
        travel = checks.travel_problems(self.profile, P_cmd, line)
        self._problem([p.error(self.profile) for p in travel])


def _gather(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``a[idx]`` for integer rows ``idx``: np.take along the first axis for a
    table (an (n, 5) array's rows over ten times faster than fancy indexing: the
    same values), plain indexing for a column."""
    out: np.ndarray = np.take(a, idx, axis=0) if a.ndim > 1 else a[idx]
    return out


def _inverted(jac: np.ndarray) -> np.ndarray:
    """(n, 5, 5) the inverses of IK Jacobians ``jac`` (n, 5, 5): the forward
    Jacobians ∂q/∂P; NaN where a Jacobian is not finite (an unreachable pose), the
    pseudo-inverse where one is singular (a long lever: the shortest window, not an
    error)."""
    ok = np.all(np.isfinite(jac), axis=(1, 2))
    # every pose reachable (the rule): no masked copies in and out
    every = bool(np.all(ok))
    if not every and not np.any(ok):
        return np.full(jac.shape, np.nan)
    sub = jac if every else jac[ok]
    try:
        inv = np.linalg.inv(sub)
    except np.linalg.LinAlgError:
        inv = np.linalg.pinv(sub)
    if every:
        out: np.ndarray = inv
        return out
    fwd = np.full(jac.shape, np.nan)
    fwd[ok] = inv
    return fwd


def _merge_places(
    n: int, e_step: np.ndarray, e_when: np.ndarray, e_before: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where ``len(e_step)`` new points go among a chunk's ``n``, in time order: a
    standing point first in its step, then the points inside the step by time, then
    the step's own end point. The chunk's points keep their order, so only the new
    ones are sorted (stably, as one sort of all would place them): the j-th of them
    goes after the j before it and the chunk's points of the steps before its own.
    Returns (the new points' order, their places in the whole, the chunk's row at
    each place: a new point's place is written over after)."""
    # lexsort((e_when, before-first, e_step))'s order, in two stable sorts: by
    # time, then by step and kind as one int key (about a third of its time: the
    # times come in two sorted runs)
    by_time = np.argsort(e_when, kind="stable")
    key = 2 * e_step + np.where(e_before, 0, 1)
    e_order = by_time[np.argsort(key[by_time], kind="stable")]
    at = e_step[e_order] + np.arange(len(e_order))
    kept = np.ones(n + len(at), dtype=bool)
    kept[at] = False
    src = np.maximum(np.cumsum(kept) - 1, 0)
    return e_order, at, src


def _merged(
    own: np.ndarray, new: np.ndarray, places: tuple[np.ndarray, np.ndarray, np.ndarray]
) -> np.ndarray:
    """A chunk's rows ``own`` and the new points' ``new`` in time order
    (:func:`_merge_places`): one gather of the chunk's, the few new ones set."""
    e_order, at, src = places
    out = _gather(own, src)
    put = _gather(new, e_order)
    if out.ndim > 1:
        # a row as one item: numpy sets the rows of an (n, 5) array one number at
        # a time, several times slower (the same bytes)
        row = np.dtype((np.void, out.itemsize * out.shape[1]))
        np.put(out.view(row)[:, 0], at, np.ascontiguousarray(put).view(row)[:, 0])
    else:
        out[at] = put
    return out


def _windows_over(b: np.ndarray, e: np.ndarray, k: np.ndarray) -> np.ndarray:
    """How many windows (b_j, e_j) hold each point k strictly inside, b_j < k < e_j:
    #{b_j < k} − #{b_j < k, e_j ≤ k}, counted by sorting (the windows times the
    points compared pairwise cost more than the rest of ``_straight_through``).
    A window with e_j ≤ b_j holds nothing: it is in the second count wherever it
    is in the first."""
    proper = e > b
    below = np.searchsorted(np.sort(b), k, side="left")
    ended = np.searchsorted(np.sort(e[proper]), k, side="right") + np.searchsorted(
        np.sort(b[~proper]), k, side="left"
    )
    out: np.ndarray = below - ended
    return out


def servo_lead(P: np.ndarray, V: np.ndarray, lag: np.ndarray) -> np.ndarray:
    """Commands (N, 5) that make motors lagging by ``lag`` (5,) [s] reach ``P``:
    c = P + τ V, with V (N, 5) the planned velocity of P.

    A motor that follows its command with a lag τ (τ ṁ + m = c, profile
    ``effects.servo_lag_ms``) is at m = P when commanded c = P + τ P'. The one
    servo-lead formula: :meth:`Pipeline._release` leads the points with it (and their
    velocities, with the accelerations), for ``convert`` and the simulator's
    programs alike; the commands modelled from a recorded path
    (``simulate.motion_commands``) too.
    """
    return P + lag[None, :] * V


def path_sides(P: np.ndarray, V: np.ndarray, rest: np.ndarray, profile: Profile) -> np.ndarray:
    """The side (+1, −1) of its play each motor is on along points of a path, (N, 5),
    as :meth:`Pipeline._reversals` decides it outside its crossing windows: the
    direction of the planned velocity V (:func:`reversals.signs`; none where the
    path rests), a creeping motor's drift back by more than the chain's reversal
    tolerance a reversal, and the last direction carried through the rows without
    one (+1 before the first: the contract's approach from below).

    P, V : (N, 5) wanted motor positions [mm] and velocities [mm/s]; rest : (N,)
    """
    drift = REVERSAL_SHARE * profile.interpolation.path_tolerance_mm
    out = np.ones(P.shape, dtype=int)
    for col in range(P.shape[1] if len(P) else 0):
        sg = np.where(rest, 0, reversals.signs(V[:, col]))
        # measured from where the path starts, as the chain's first chunk does
        crept = kernel.creeps(sg, P[:, col], 1, float(P[0, col]), drift)[0]
        out[:, col] = kernel.carried(np.where(crept != 0, crept, sg), 1)
    return out


def run_chain(
    motions: Sequence[Motion],
    profile: Profile,
    stages: Stages = Stages(),
    error_map: ErrorFunction | None = None,
    *,
    start: Sequence[float] | None = None,
    collect: bool = False,
    chunk: int = 0,
    segment: str = "cubic",
    max_part_points: int = 0,
    written: Written = Written(),
) -> ChainResult:
    """Interpolate, correct, solve and compensate a whole program in memory.

    Parameters
    ----------
    motions : interpreted motions (gcode.iter_motions)
    profile : Profile
    stages : Stages
    error_map : callable q (N, 5) → e(q) (N, 5), optional
        The fitted virtual-axis error; applied as Q' = Q − e(Q) when
        ``stages.error_map``.
    start : (5,) start pose; default the profile's
    collect : bool
        Gather every problem in ``result.problems`` instead of raising the first.
    chunk : feed the pipeline this many motions at a time (0: all at once); the
        result is the same either way.
    segment : how the controller moves between points ("cubic" or "chord")
    max_part_points : > 0: end a part at rest at a block end before every this
        many points (``PointChunk.split``)
    written : how the output rounds its numbers (:class:`Written`)

    Raises
    ------
    LimitError, ReachError
        Naming the G-code line (unless ``collect``).
    """
    pipe = Pipeline(
        profile,
        stages,
        error_map,
        start=start,
        collect=collect,
        segment=segment,
        max_part_points=max_part_points,
        written=written,
    )
    parts: list[PointChunk] = []
    step = chunk if chunk > 0 else max(len(motions), 1)
    for i in range(0, len(motions), step):
        parts += pipe.feed(motions[i : i + step])
    parts += pipe.finish()
    return ChainResult(PointChunk.concat(parts), pipe.geo, pipe.problems)


def correct_virtual(q: np.ndarray, error_map: ErrorFunction, iterations: int = 1) -> np.ndarray:
    """Q' = Q − e(Q), the paper's Eq. 6 and the contract's compensation
    (``docs/machine-model.md``): what every command applies.

    ``iterations`` > 1 repeats Q'_{k+1} = Q − e(Q'_k) toward the fixed point
    Q' + e(Q') = Q (the machine, commanded Q', errs by e(Q')), beyond the
    contract and used by no command: a second step moves Q' by |∂e/∂Q · e|,
    0.13 nm for a map of 2.6 µm and 38 nm for one of 54 µm, where the maps'
    own prediction errors (cross-validated RMS) are 1.1 and 3.2 µm
    (``bench/map_steps.py``).
    """
    if isinstance(error_map, errormap.ErrorMap):
        # the kernel's: every row's steps in one pass (the same numbers)
        return kernel.correct_virtual(error_map.arrays, q, iterations)
    qp = q - error_map(q)
    for _ in range(iterations - 1):
        qp = q - error_map(qp)
    return qp
