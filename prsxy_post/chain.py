"""The compensation chain of a converted program (contract, "The compensation chain").

    G-code → coarse interpolation (period_ms) → Q' = Q − e(Q) (virtual-axis map,
    paper Eq. 6) → P = IK of the calibrated [kinematics] and [table] (Eq. 3, g')
    → real-axis tables (Eq. 3, E_i) → motor commands

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

from . import axiscomp, kinematics
from .errors import LimitError, PrsxyError, ReachError
from .interpolate import (
    KIND_DWELL,
    Blocks,
    Limits,
    Samples,
    TimeLaw,
    backward_pass,
    blocks_from_motions,
    forward_pass,
    junction_limits,
    sample,
    steps_per_block,
    time_law,
)
from .profile import MOTORS, Profile, nominal_kinematics

if TYPE_CHECKING:
    from .gcode import InterpreterConfig, Motion

#: Name of each motor column of P, in order.
MOTOR_ORDER = MOTORS


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


@dataclass
class ChainResult:
    """Everything the chain computed, point by point.

    samples : interpolation points (q is the programmed path)
    q_target : (N, 5) the pose handed to the IK, after the virtual-axis map
    P_ideal : (N, 5) IK motor positions (what the motors must reach)
    P_cmd : (N, 5) motor commands after the real-axis tables
    """

    samples: Samples
    q_target: np.ndarray
    P_ideal: np.ndarray
    P_cmd: np.ndarray
    geometry: kinematics.Geometry
    problems: list[PrsxyError] = field(default_factory=list)
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))


def interpreter_config(
    profile: Profile,
    start: Sequence[float] | None = None,
    on_message: Callable[[str, int, str, str], None] | None = None,
) -> InterpreterConfig:
    """The G-code interpreter's settings from a profile (offsets, tools, G28/G30,
    start, [gcode] subroutine path relative to the profile's folder, loop limit,
    user M codes); ``on_message`` receives the program's (MSG/DEBUG/PRINT)."""
    import os

    from .gcode import InterpreterConfig, ToolEntry

    st = tuple(float(x) for x in (profile.start if start is None else start))
    g = profile.gcode
    src = profile.source
    here = os.path.dirname(os.path.abspath(src)) if os.path.isfile(src) else "."
    return InterpreterConfig(
        work_offsets=dict(profile.work_offsets),
        g28_position=tuple(profile.g28),
        g30_position=tuple(profile.g30),
        tool_table={n: ToolEntry(length=ln, diameter=d) for n, (ln, d) in profile.tools.items()},
        start=st,
        subroutine_path=tuple(os.path.join(here, d) for d in g.get("subroutine_path", [])),
        max_loop_passes=int(g.get("max_loop_passes", 10_000_000)),
        user_m_codes=frozenset(g.get("user_m_codes", [])),
        on_message=on_message,
    )


def limits_of(profile: Profile) -> Limits:
    lim = profile.limits
    return Limits(
        rapid_mm_min=lim["rapid_mm_min"],
        rapid_deg_min=lim["rapid_deg_min"],
        accel_mm_s2=lim["max_accel_mm_s2"],
        accel_deg_s2=lim["max_accel_deg_s2"],
        period_s=profile.period_ms / 1000.0,
    )


def geometry_of(profile: Profile, stages: Stages) -> kinematics.Geometry:
    """The geometry the IK uses: calibrated, or the contract's nominal design."""
    if stages.calibrated:
        return kinematics.Geometry.from_params(
            profile.kinematics, profile.origin, profile.table, profile.effects
        )
    return kinematics.Geometry.from_params(nominal_kinematics(), profile.origin)


def controller_geometry(profile: Profile) -> kinematics.Geometry:
    """[controller_kinematics] (default: the nominal design) with an ideal table."""
    kp = profile.controller_kinematics or nominal_kinematics()
    return kinematics.Geometry.from_params(kp, profile.origin)


ErrorMap = Callable[[np.ndarray], np.ndarray]


def check_motions(motions: Sequence[Motion], profile: Profile) -> list[PrsxyError]:
    """Problems visible in the program itself: feed above the machine's maximum."""
    out: list[PrsxyError] = []
    fmax = profile.limits["max_feed_mm_min"]
    for m in motions:
        if m.kind in ("feed", "arc") and m.feed > fmax:
            out.append(
                LimitError(
                    f"feed F{m.feed:g} mm/min is above the machine's maximum",
                    line=m.line,
                    expected=f"at most {fmax:g} mm/min (limits.max_feed_mm_min)",
                )
            )
    return out


def _first_per_line(bad: np.ndarray, lines: np.ndarray) -> list[int]:
    """Indices of the first bad point of each distinct line, in order."""
    idx = np.nonzero(bad)[0]
    if idx.size == 0:
        return []
    _, first = np.unique(lines[idx], return_index=True)
    return sorted(idx[first].tolist())


@dataclass
class PointChunk:
    """A run of consecutive interpolation points with everything the chain computed.

    t : (n,) time at each point [s] from the program start
    Other fields as in :class:`ChainResult` (``samples`` split into arrays).
    """

    q: np.ndarray
    dt: np.ndarray
    t: np.ndarray
    line: np.ndarray
    first: np.ndarray
    tool_length: np.ndarray
    speed: np.ndarray
    q_target: np.ndarray
    P_ideal: np.ndarray
    P_cmd: np.ndarray

    def __len__(self) -> int:
        return len(self.dt)

    def take(self, sl: slice) -> PointChunk:
        return PointChunk(**{k: getattr(self, k)[sl] for k in self.__dataclass_fields__})

    @staticmethod
    def concat(chunks: Sequence[PointChunk]) -> PointChunk:
        return PointChunk(
            **{
                k: np.concatenate([getattr(c, k) for c in chunks])
                for k in PointChunk.__dataclass_fields__
            }
        )


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


def prepare(motions: Sequence[Motion], profile: Profile, limits: Limits | None = None) -> Prepared:
    """Planning arrays and program-level problems of a chunk of motions."""
    # machine functions are carried by the writers (issue "controller truth", in
    # progress); the planner does not see them yet
    moves = [m for m in motions if m.kind != "function"]
    return Prepared(
        blocks_from_motions(moves, limits or limits_of(profile)),
        len(motions),
        motions[0].line if motions else 0,
        check_motions(motions, profile),
    )


class Planner:
    """Look-ahead speed planning over a stream of blocks, in bounded memory.

    Blocks wait until the path after them is long enough to stop from any speed
    (1.5 · v_max² / 2a) or a forced stop follows; then their junction speeds
    cannot change with anything further in the program, and they are committed.
    The result is the same, bit for bit, as planning the whole program at once.
    """

    def __init__(self, limits: Limits) -> None:
        self.limits = limits
        self.pending: Blocks | None = None
        self.v_start = 0.0

    def push(self, new: Blocks, final: bool = False) -> tuple[Blocks, TimeLaw] | None:
        if self.pending is None or len(self.pending) == 0:
            b = new
        elif len(new) == 0:
            b = self.pending
        else:
            b = Blocks(
                **{
                    k: np.concatenate([getattr(self.pending, k), getattr(new, k)])
                    for k in Blocks.__dataclass_fields__
                }
            )
        n = len(b)
        if n == 0:
            self.pending = b
            return None
        vj = junction_limits(b, self.limits.period_s)
        v_back = backward_pass(b, vj)
        if final:
            c = n - 1
        else:
            moving = b.kind != KIND_DWELL
            length = np.where(moving & ~b.angular, b.length, 0.0)
            remaining = np.cumsum(length[::-1])[::-1]  # remaining[k]: blocks k..n-1
            after = np.concatenate([remaining[1:], [0.0]])
            lin = ~b.angular & moving
            vmax = float(np.max(b.vmax[lin])) if np.any(lin) else 0.0
            amin = float(np.min(b.accel[lin])) if np.any(lin) else 1.0
            need = 1.5 * vmax * vmax / (2.0 * amin)
            ok = np.nonzero(after >= need)[0]
            c = int(ok[-1]) if ok.size else -1
            stops = np.nonzero(vj[:-1] == 0.0)[0]
            if stops.size:
                c = max(c, int(stops[-1]))
        if c < 0:
            self.pending = b
            return None
        done = b.take(slice(0, c + 1))
        v_out = forward_pass(done, v_back[: c + 1], self.v_start)
        law = time_law(done, v_out, self.v_start)
        self.v_start = float(v_out[-1])
        self.pending = b.take(slice(c + 1, n))
        return done, law


class Pipeline:
    """The compensation chain over a stream of motions, chunk by chunk.

    Feed it lists of motions; it returns :class:`PointChunk` s as they become
    final. State carried across chunks: the planner's pending blocks and speed,
    the real-axis compensation state of every motor, the last point (for the
    servo lead), the clock, and the counters of the work guard.
    """

    def __init__(
        self,
        profile: Profile,
        stages: Stages = Stages(),
        error_map: ErrorMap | None = None,
        *,
        start: Sequence[float] | None = None,
        collect: bool = False,
    ) -> None:
        self.profile = profile
        self.stages = stages
        self.error_map = error_map if stages.error_map else None
        self.start = np.asarray(profile.start if start is None else start, dtype=float)
        self.collect = collect
        self.limits = limits_of(profile)
        self.planner = Planner(self.limits)
        self.geo = geometry_of(profile, stages)
        self.tables = axiscomp.profile_tables(profile) if stages.axis_comp else {}
        self.states = {m: axiscomp.PlayState() for m in self.tables}
        self.lag = (
            np.asarray(profile.effects.servo_lag_ms) / 1000.0 if stages.axis_comp else np.zeros(5)
        )
        self.held: PointChunk | None = None  # points waiting for the servo lead
        self.prev: tuple[np.ndarray, float] | None = None  # last released (P, t)
        self.problems: list[PrsxyError] = []
        self.t = 0.0
        self.n_points = 0
        self.started = False
        self.any_motion = False
        #: seconds spent per stage (for the benchmark and profiling)
        self.timings = {"interpolate": 0.0, "error_map": 0.0, "kinematics": 0.0, "axis_tables": 0.0}

    # -- problems
    def _problem(self, errs: list[PrsxyError]) -> None:
        if not errs:
            return
        if not self.collect:
            raise sorted(errs, key=lambda e: e.line or 0)[0]
        self.problems += errs

    def feed(self, motions: Sequence[Motion], final: bool = False) -> list[PointChunk]:
        t0 = time.perf_counter()
        prepared = prepare(motions, self.profile, self.limits)
        self.timings["interpolate"] += time.perf_counter() - t0
        return self.feed_prepared(prepared, final)

    def feed_prepared(self, prepared: Prepared, final: bool = False) -> list[PointChunk]:
        """:meth:`feed` for motions already through :func:`prepare`."""
        t0 = time.perf_counter()
        self._problem(prepared.problems)
        b = prepared.blocks
        out: list[PointChunk] = []
        if not self.started:
            line0 = int(b.line[0]) if len(b) else prepared.first_line
            tl0 = 0.0  # the program starts with no tool length offset in effect
            first = self._points(
                self.start[None, :],
                np.zeros(1),
                np.array([line0]),
                np.array([False]),
                np.array([tl0]),
                np.zeros(1),
            )
            if first is not None:
                out.append(first)
            self.started = True
        res = self.planner.push(b, final)
        if res is not None:
            done, law = res
            if len(done):
                self.any_motion = True
            # before any point is made: a long move to an unreachable place is an
            # error at its line, and a block of a billion points is never tried
            steps = steps_per_block(law, self.limits.period_s)
            long = steps > 256
            if np.any(long):
                self._check_ends(done.take(long))
            self._guard(law, done.line)
            s = sample(done, law, self.limits.period_s)
            self.timings["interpolate"] += time.perf_counter() - t0
            pc = self._points(s.q, s.dt, s.line, s.first, s.tool_length, s.speed)
            if pc is not None:
                out.append(pc)
        if final:
            if not self.any_motion:
                raise LimitError(
                    "the program moves nothing",
                    expected="at least one move (G0, G1, G2, G3) or dwell",
                )
            tail = self._release(final=True)
            if tail is not None:
                out.append(tail)
        return out

    def finish(self) -> list[PointChunk]:
        return self.feed([], final=True)

    def _check_ends(self, b: Blocks) -> None:
        """Reach and travel at the end points of long blocks, before interpolating them:
        a move to X1e9 is an error at its line, not a billion points. (Short blocks are
        checked point by point, as every block is.)"""
        if not len(b):
            return
        ends = b.end
        q_t = correct_virtual(ends, self.error_map) if self.error_map is not None else ends
        ik = kinematics.inverse(self.geo, q_t, b.tool_length)
        errs = check_pose_problems(self.profile, ends, b.line, ik.reachable)
        errs += check_travel(self.profile, ik.P, b.line)
        if errs and not self.collect:
            raise sorted(errs, key=lambda e: e.line or 0)[0]

    def _guard(self, law: TimeLaw, line: np.ndarray) -> None:
        """Refuse absurd work: more points or machining time than the profile allows,
        judged from the time law, before the points are made."""
        lim = self.profile.limits
        steps = steps_per_block(law, self.limits.period_s)
        n_after = self.n_points + np.cumsum(steps)
        t_after = self.t + np.cumsum(law.duration)
        over = np.nonzero((n_after > lim["max_points"]) | (t_after > lim["max_time_s"]))[0]
        if over.size:
            k = int(over[0])
            raise LimitError(
                f"the program would interpolate to more than {int(lim['max_points'])} points or "
                f"run longer than {lim['max_time_s']:g} s (reached here)",
                line=int(line[k]),
                expected="a shorter program, or larger limits.max_points / limits.max_time_s",
            )

    def _points(
        self,
        q: np.ndarray,
        dt: np.ndarray,
        line: np.ndarray,
        first: np.ndarray,
        tool: np.ndarray,
        speed: np.ndarray,
    ) -> PointChunk | None:
        # a running sum continued across chunks (not chunk offset + cumsum), so the
        # clock is the same bit for bit however the program was cut
        t = np.cumsum(np.concatenate([[self.t], dt]))[1:]
        if len(t):
            self.t = float(t[-1])
        self.n_points += len(dt)
        t0 = time.perf_counter()
        q_target = correct_virtual(q, self.error_map) if self.error_map is not None else q
        t1 = time.perf_counter()
        ik = kinematics.inverse(self.geo, q_target, tool)
        self._problem(check_pose_problems(self.profile, q, line, ik.reachable))
        t2 = time.perf_counter()
        P_comp = ik.P.copy()
        if np.all(ik.reachable):
            for col, m in enumerate(MOTOR_ORDER):
                if m in self.tables:
                    P_comp[:, col] = axiscomp.compensate(
                        self.tables[m], ik.P[:, col], self.states[m]
                    )
        self.timings["error_map"] += t1 - t0
        self.timings["kinematics"] += t2 - t1
        self.timings["axis_tables"] += time.perf_counter() - t2
        pc = PointChunk(q, dt, t, line, first, tool, speed, q_target, ik.P, P_comp)
        self.held = pc if self.held is None else PointChunk.concat([self.held, pc])
        return self._release(final=False)

    def _release(self, final: bool) -> PointChunk | None:
        """Points whose servo lead is final.

        The lead c = M + τ v(M) uses the central-difference velocity, so a point
        is final once the next one exists; the last point released is kept as
        the previous point of the next chunk.
        """
        h = self.held
        if h is None or len(h) == 0:
            return None
        lagging = bool(np.any(self.lag))
        k = len(h) if (final or not lagging) else len(h) - 1
        if k <= 0:
            return None
        ready = h.take(slice(0, k))
        if lagging:
            prev = self.prev
            # neighbours of every ready point: the previous one (or itself at the
            # start) and the next one (or itself at the end)
            P_all = np.vstack([prev[0][None, :] if prev else h.P_cmd[:1], h.P_cmd])
            t_all = np.concatenate([[prev[1]] if prev else h.t[:1], h.t])
            if final:
                P_all = np.vstack([P_all, h.P_cmd[-1:]])
                t_all = np.concatenate([t_all, h.t[-1:]])
            span = np.maximum(t_all[2 : k + 2] - t_all[:k], 1e-9)
            v = (P_all[2 : k + 2] - P_all[:k]) / span[:, None]
            if prev is None:
                v[0] = 0.0
            if final:
                v[-1] = 0.0
            self.prev = (h.P_cmd[k - 1].copy(), float(h.t[k - 1]))
            ready.P_cmd = ready.P_cmd + self.lag[None, :] * v
        self.held = None if k == len(h) else h.take(slice(k, len(h)))
        self._problem(check_travel(self.profile, ready.P_cmd, ready.line))
        return ready


def check_pose_problems(
    profile: Profile, q: np.ndarray, line: np.ndarray, reachable: np.ndarray
) -> list[PrsxyError]:
    """Tilt beyond the limit and poses out of reach, one per G-code line and kind."""
    out: list[PrsxyError] = []
    max_tilt = profile.limits["max_tilt_deg"]
    cos_tilt = np.cos(np.radians(q[:, 3])) * np.cos(np.radians(q[:, 4]))
    tilt = np.degrees(np.arccos(np.clip(cos_tilt, -1.0, 1.0)))
    for i in _first_per_line(tilt > max_tilt + 1e-9, line):
        out.append(
            LimitError(
                f"tool axis tilted {tilt[i]:.3f}° at A{q[i, 3]:.4f} B{q[i, 4]:.4f}",
                line=int(line[i]),
                expected=f"at most {max_tilt:g}° (limits.max_tilt_deg)",
            )
        )
    for i in _first_per_line(~reachable, line):
        out.append(
            ReachError(
                "pose out of the machine's reach at X{:.4f} Y{:.4f} Z{:.4f} A{:.4f} B{:.4f}".format(
                    *q[i]
                ),
                line=int(line[i]),
                expected="a pose the struts can reach (see the profile's [kinematics])",
            )
        )
    return out


def check_travel(profile: Profile, P_cmd: np.ndarray, line: np.ndarray) -> list[PrsxyError]:
    """Motors commanded beyond their travel, one per G-code line and motor."""
    out: list[PrsxyError] = []
    ok = np.all(np.isfinite(P_cmd), axis=1)
    for col, m in enumerate(MOTOR_ORDER):
        mc = profile.motor(m)
        p = P_cmd[:, col]
        bad = ok & ((p < mc.min - 1e-9) | (p > mc.max + 1e-9))
        for i in _first_per_line(bad, line):
            out.append(
                ReachError(
                    f"motor {m} ({mc.axis}) commanded to {p[i]:.4f} mm, beyond its travel",
                    line=int(line[i]),
                    expected=f"{mc.min:g} to {mc.max:g} mm (motors[{m}].min/max)",
                )
            )
    return out


def run_chain(
    motions: Sequence[Motion],
    profile: Profile,
    stages: Stages = Stages(),
    error_map: ErrorMap | None = None,
    *,
    start: Sequence[float] | None = None,
    collect: bool = False,
    chunk: int = 0,
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

    Raises
    ------
    LimitError, ReachError
        Naming the G-code line (unless ``collect``).
    """
    pipe = Pipeline(profile, stages, error_map, start=start, collect=collect)
    parts: list[PointChunk] = []
    step = chunk if chunk > 0 else max(len(motions), 1)
    for i in range(0, len(motions), step):
        parts += pipe.feed(motions[i : i + step])
    parts += pipe.finish()
    pc = PointChunk.concat(parts)
    samples = Samples(
        q=pc.q,
        dt=pc.dt,
        line=pc.line,
        block=np.zeros(len(pc), dtype=int),
        first=pc.first,
        tool_length=pc.tool_length,
        speed=pc.speed,
    )
    return ChainResult(samples, pc.q_target, pc.P_ideal, pc.P_cmd, pipe.geo, pipe.problems, pc.t)


def correct_virtual(q: np.ndarray, error_map: ErrorMap, iterations: int = 2) -> np.ndarray:
    """Q' with Q' + e(Q') = Q, by fixed-point iteration from Q' = Q − e(Q) (Eq. 6).

    The paper's Q' = Q − e(Q) evaluates the error at the programmed pose; the
    machine, commanded Q', errs by e(Q'), so iterating Q'_{k+1} = Q − e(Q'_k)
    lands the tip closer. e is smooth and small (µm over mm): each step shrinks
    what is left by |∂e/∂Q| ≈ 1e-4, so the second evaluation leaves about
    1e-11 mm (measured on a calibrated map) and a third changes nothing a
    program prints. ``iterations`` = 1 is the paper's formula.
    """
    qp = q - error_map(q)
    for _ in range(iterations - 1):
        qp = q - error_map(qp)
    return qp
