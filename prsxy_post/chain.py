"""The compensation chain of a converted program (contract, "The compensation chain").

    G-code → coarse interpolation (period_ms) → Q' = Q − e(Q) (virtual-axis map,
    paper Eq. 6) → P = IK of the calibrated [kinematics] and [table] (Eq. 3, g')
    → real-axis tables (Eq. 3, E_i) → motor commands

Every stage can be switched off (:class:`Stages`) for comparisons. The chain is
pure: motions and a profile in, arrays out; it raises located errors (the
G-code line) for anything the machine cannot do.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from . import axiscomp, kinematics
from .errors import LimitError, PrsxyError, ReachError
from .interpolate import Blocks, Limits, Samples, TimeLaw, interpolate
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
        return "stages on: " + (", ".join(on) or "none") + (
            "; off: " + ", ".join(off) if off else "")


@dataclass
class ChainResult:
    """Everything the chain computed, point by point.

    samples : interpolation points (q is the programmed path)
    q_target : (N, 5) the pose handed to the IK, after the virtual-axis map
    P_ideal : (N, 5) IK motor positions (what the motors must reach)
    P_cmd : (N, 5) motor commands after the real-axis tables
    """

    samples: Samples
    blocks: Blocks
    law: TimeLaw
    q_target: np.ndarray
    P_ideal: np.ndarray
    P_cmd: np.ndarray
    geometry: kinematics.Geometry
    problems: list[PrsxyError] = field(default_factory=list)


def interpreter_config(profile: Profile, start: Sequence[float] | None = None
                       ) -> InterpreterConfig:
    """The G-code interpreter's settings from a profile (offsets, tools, G28/G30, start)."""
    from .gcode import InterpreterConfig, ToolEntry

    st = tuple(float(x) for x in (profile.start if start is None else start))
    return InterpreterConfig(
        work_offsets=dict(profile.work_offsets),
        g28_position=tuple(profile.g28),  # type: ignore[arg-type]
        g30_position=tuple(profile.g30),  # type: ignore[arg-type]
        tool_table={n: ToolEntry(length=ln, diameter=d) for n, (ln, d) in profile.tools.items()},
        start=st,  # type: ignore[arg-type]
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
        return kinematics.Geometry.from_params(profile.kinematics, profile.origin, profile.table,
                                              profile.effects)
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
            out.append(LimitError(f"feed F{m.feed:g} mm/min is above the machine's maximum",
                                  line=m.line, expected=f"at most {fmax:g} mm/min "
                                  "(limits.max_feed_mm_min)"))
    return out


def _first_per_line(bad: np.ndarray, lines: np.ndarray) -> list[int]:
    """Indices of the first bad point of each distinct line, in order."""
    idx = np.nonzero(bad)[0]
    if idx.size == 0:
        return []
    _, first = np.unique(lines[idx], return_index=True)
    return sorted(idx[first].tolist())


def check_points(profile: Profile, samples: Samples, ik: kinematics.IKResult,
                 P_cmd: np.ndarray) -> list[PrsxyError]:
    """Reach, tilt and travel problems, one per G-code line and kind."""
    out: list[PrsxyError] = []
    q = samples.q
    max_tilt = profile.limits["max_tilt_deg"]
    cos_tilt = np.cos(np.radians(q[:, 3])) * np.cos(np.radians(q[:, 4]))
    tilt = np.degrees(np.arccos(np.clip(cos_tilt, -1.0, 1.0)))
    for i in _first_per_line(tilt > max_tilt + 1e-9, samples.line):
        out.append(LimitError(
            f"tool axis tilted {tilt[i]:.3f}° at A{q[i, 3]:.4f} B{q[i, 4]:.4f}",
            line=int(samples.line[i]), expected=f"at most {max_tilt:g}° (limits.max_tilt_deg)"))
    for i in _first_per_line(~ik.reachable, samples.line):
        out.append(ReachError(
            "pose out of the machine's reach at X{:.4f} Y{:.4f} Z{:.4f} A{:.4f} B{:.4f}".format(
                *q[i]),
            line=int(samples.line[i]),
            expected="a pose the struts can reach (see the profile's [kinematics])"))
    ok = ik.reachable
    for col, m in enumerate(MOTOR_ORDER):
        mc = profile.motor(m)
        p = P_cmd[:, col]
        bad = ok & ((p < mc.min - 1e-9) | (p > mc.max + 1e-9))
        for i in _first_per_line(bad, samples.line):
            out.append(ReachError(
                f"motor {m} ({mc.axis}) commanded to {p[i]:.4f} mm, beyond its travel",
                line=int(samples.line[i]),
                expected=f"{mc.min:g} to {mc.max:g} mm (motors[{m}].min/max)"))
    return out


def run_chain(motions: Sequence[Motion], profile: Profile, stages: Stages = Stages(),
              error_map: ErrorMap | None = None, *, start: Sequence[float] | None = None,
              collect: bool = False) -> ChainResult:
    """Interpolate, correct, solve and compensate a program.

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

    Raises
    ------
    LimitError, ReachError
        Naming the G-code line (unless ``collect``).
    """
    problems = check_motions(motions, profile)
    if problems and not collect:
        raise problems[0]
    b, law, s = interpolate(motions, limits_of(profile))
    st = np.asarray(profile.start if start is None else start, dtype=float)
    if len(s) == 0:
        raise LimitError("the program moves nothing",
                         expected="at least one move (G0, G1, G2, G3) or dwell")
    # Point 0 is the start pose: the program's first block starts from it.
    first_line = int(s.line[0])
    q0 = st[None, :]
    samples = Samples(
        q=np.vstack([q0, s.q]), dt=np.concatenate([[0.0], s.dt]),
        line=np.concatenate([[first_line], s.line]), block=np.concatenate([[-1], s.block]),
        first=np.concatenate([[False], s.first]),
        tool_length=np.concatenate([[s.tool_length[0]], s.tool_length]),
        speed=np.concatenate([[0.0], s.speed]),
    )
    q_target = samples.q
    if stages.error_map and error_map is not None:
        q_target = correct_virtual(samples.q, error_map)
    geo = geometry_of(profile, stages)
    ik = kinematics.inverse(geo, q_target, samples.tool_length)
    P_ideal = ik.P
    P_cmd = P_ideal.copy()
    if stages.axis_comp and np.all(ik.reachable):
        tables = axiscomp.profile_tables(profile)
        for col, m in enumerate(MOTOR_ORDER):
            if m in tables:
                P_cmd[:, col] = axiscomp.compensate(tables[m], P_ideal[:, col])
        if any(profile.effects.servo_lag_ms):
            from .simulate import lagged

            P_cmd = lagged(profile, P_cmd, np.cumsum(samples.dt), +1.0)
    problems += check_points(profile, samples, ik, P_cmd)
    if problems and not collect:
        raise sorted(problems, key=lambda e: e.line or 0)[0]
    return ChainResult(samples, b, law, q_target, P_ideal, P_cmd, geo, problems)


def correct_virtual(q: np.ndarray, error_map: ErrorMap, iterations: int = 3) -> np.ndarray:
    """Q' with Q' + e(Q') = Q, by fixed-point iteration from Q' = Q − e(Q) (Eq. 6).

    The paper's Q' = Q − e(Q) evaluates the error at the programmed pose; the
    machine, commanded Q', errs by e(Q'), so iterating Q'_{k+1} = Q − e(Q'_k)
    lands the tip closer. e is smooth and small (µm over mm), so the iteration
    contracts quickly; ``iterations`` = 1 is the paper's formula.
    """
    qp = q - error_map(q)
    for _ in range(iterations - 1):
        qp = q - error_map(qp)
    return qp
