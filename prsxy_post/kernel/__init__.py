"""The kernel: per-point numerical work as functions over arrays.

Each kernel has a numpy reference (``ik.py``, ``text.py``, ``legendre.py``, ``fk.py``,
the planner's ``timelaw.py`` and ``path.py``, the play model's ``play.py``, the
crossing windows' ``windows.py``, the root search's ``roots.py``, the corrected G-code
writer's decisions'
``gwrite.py`` in plain Python floats, its arc search's ``arcs.py``: :data:`TWINS`) and a
compiled twin in Cython
(``_ik.pyx``, ...; built when the package is installed) that gives the same bits.
This module picks one set for the whole program, once, at import:

- ``PRSXY_KERNEL=pure`` in the environment: the numpy reference (CI's pure leg);
- otherwise the compiled kernels when the extension imports, else the reference.

:data:`COMPILED` says which was picked, :data:`NAME` names it (``prsxy-post
--version`` prints it) and :data:`WHY_PURE` says why the reference runs; the command
line warns on stderr when the extension is missing (the library never prints).

The compiled IK covers straight guides; a geometry with bowed guides
(``effects.guide_bow``) runs the reference IK even when compiled (its Newton step sums
with numpy's einsum, whose order C would have to copy).

The kernel imports nothing from the stream, the writers, the profile or the
command line: its inputs are arrays and small frozen records of arrays.
"""

from __future__ import annotations

import importlib
import importlib.util
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from types import ModuleType

import numpy as np

from . import fk, gwrite, ik, legendre, path, play, timelaw, windows

#: The environment variable that selects the reference kernels (value ``pure``).
ENV = "PRSXY_KERNEL"

InverseRows = Callable[[ik.IKArrays, np.ndarray, np.ndarray], np.ndarray]
FixedRows = Callable[..., list[str]]
#: each reference module's compiled twin
TWINS = {
    "ik": "_ik",
    "text": "_text",
    "legendre": "_legendre",
    "fk": "_fk",
    "timelaw": "_timelaw",
    "path": "_path",
    "play": "_play",
    "windows": "_windows",
    "gwrite": "_gwrite",
    "arcs": "_arcs",
    "roots": "_roots",
}


def _load() -> tuple[dict[str, ModuleType], str, str]:
    """(the module that runs for each reference module, name, why the reference
    runs or "")."""
    refs = {n: importlib.import_module(f"{__name__}.{n}") for n in TWINS}
    if os.environ.get(ENV, "").strip().lower() == "pure":
        return refs, "pure numpy (PRSXY_KERNEL=pure)", f"{ENV}=pure"
    try:
        twins = {n: importlib.import_module(f"{__name__}.{t}") for n, t in TWINS.items()}
    except ImportError as e:
        absent = [t for t in TWINS.values() if importlib.util.find_spec(f"{__name__}.{t}") is None]
        why = (
            f"the compiled extension is not built (no {', '.join(absent)} "
            f"in {Path(__file__).parent})"
            if absent
            else f"the compiled extension does not import ({e})"
        )
        return refs, f"pure numpy ({why})", why
    return twins, f"compiled (Cython {twins['ik'].CYTHON})", ""


_RUN, NAME, WHY_PURE = _load()
# the selected functions, each a module attribute (the differential tests record
# the calls the conversions make by replacing one)
_inverse_rows = _RUN["ik"].inverse_rows
_platform_cols = _RUN["ik"].platform_cols
_motion_rows = _RUN["ik"].motion_rows
_derivative_rows = _RUN["ik"].derivative_rows
_end_slopes = _RUN["ik"].end_slopes
_jacobian_rows = _RUN["ik"].jacobian_rows
_correct_virtual = _RUN["legendre"].correct_virtual
_fixed_rows = _RUN["text"].format_fixed_rows
_pvt_segment = _RUN["text"].pvt_segment_text
_map_rows = _RUN["legendre"].map_rows
_fk_mod = _RUN["fk"]
_trapezoids = _RUN["timelaw"].trapezoids
_along = _RUN["timelaw"].along
_phase_times = _RUN["timelaw"].phase_times
_backward_pass = _RUN["timelaw"].backward_pass
_forward_pass = _RUN["timelaw"].forward_pass
_play_stops = _RUN["timelaw"].play_stops
_set_offs = _RUN["timelaw"].set_offs
_junction_speeds = _RUN["timelaw"].junction_speeds
_poses = _RUN["path"].poses
_velocities = _RUN["path"].velocities
_play_kernel = _RUN["play"]
#: True when the compiled kernels run.
COMPILED: bool = not WHY_PURE
#: True when the reference runs because the extension is missing (not asked for).
MISSING: bool = bool(WHY_PURE) and not WHY_PURE.startswith(ENV)


def inverse_rows(m: ik.IKArrays, q: np.ndarray, tz: np.ndarray) -> np.ndarray:
    """Motor positions (N, 5) [mm] for poses ``q`` (N, 5) and tool heights ``tz``
    (N,): :func:`ik.inverse_rows`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _inverse_rows(m, q, tz)
    return out


def motion_rows(
    m: ik.IKArrays, q: np.ndarray, qdot: np.ndarray, tz: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """The IK (N, 5) [mm] of poses ``q`` (N, 5) and its velocity (N, 5) along
    ``qdot`` (N, 5), one pass: :func:`ik.motion_rows`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _motion_rows(m, q, qdot, tz, step)
    return out


def derivative_rows(
    m: ik.IKArrays, q: np.ndarray, dq: np.ndarray, tz: np.ndarray, P: np.ndarray, step: float
) -> np.ndarray:
    """The IK's one-sided difference (N, 5) along ``dq`` from poses ``q`` whose IK
    is ``P``: :func:`ik.derivative_rows`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _derivative_rows(m, q, dq, tz, P, step)
    return out


def end_slopes(
    m: ik.IKArrays,
    start: np.ndarray,
    end: np.ndarray,
    dq_in: np.ndarray,
    dq_out: np.ndarray,
    tz: np.ndarray,
    step: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The motors' dP/ds (n, 5) at blocks' starts along ``dq_in`` and at their ends
    back along ``dq_out``: :func:`ik.end_slopes`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _end_slopes(m, start, end, dq_in, dq_out, tz, step)
    return out


def jacobian_rows(
    m: ik.IKArrays, q: np.ndarray, tz: np.ndarray, step: float, P: np.ndarray | None = None
) -> np.ndarray:
    """∂P/∂q (N, 5, 5) by the IK's one-sided differences: :func:`ik.jacobian_rows`,
    compiled when :data:`COMPILED`."""
    out: np.ndarray = _jacobian_rows(m, q, tz, step, P)
    return out


def platform_cols(m: ik.IKArrays, q: np.ndarray, tz: np.ndarray) -> ik.PlatformCols:
    """Step 1 of the IK, the platform's spin and centre for poses ``q`` (N, 5):
    :func:`ik.platform_cols`, compiled when :data:`COMPILED`."""
    out: ik.PlatformCols = _platform_cols(m, q, tz)
    return out


def format_fixed_rows(columns: Sequence[tuple[str, np.ndarray, int]], end: str = "\n") -> list[str]:
    """Rows of fixed-point text: :func:`text.format_fixed_rows`, compiled when
    :data:`COMPILED`."""
    out: list[str] = _fixed_rows(columns, end)
    return out


def pvt_segment_text(
    columns: Sequence[tuple[str, np.ndarray, int]],
    line: np.ndarray,
    new_line: np.ndarray,
    quanta: np.ndarray,
    new_time: np.ndarray,
    other_rows: np.ndarray,
    other_text: Sequence[str],
) -> str:
    """A PVT program's points as one text: :func:`text.pvt_segment_text`, compiled
    when :data:`COMPILED`."""
    out: str = _pvt_segment(columns, line, new_line, quanta, new_time, other_rows, other_text)
    return out


def rotation_cs(
    ca: np.ndarray, sa: np.ndarray, cb: np.ndarray, sb: np.ndarray, cg: np.ndarray, sg: np.ndarray
) -> np.ndarray:
    """R_y(B) R_x(A) R_z(γ) (N, 3, 3) from the angles' cosines and sines:
    :func:`fk.rotation_cs`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _fk_mod.rotation_cs(ca, sa, cb, sb, cg, sg)
    return out


def fk_system(m: fk.FKArrays, off: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The six FK equations (N, 6) and their Jacobian (N, 6, 6) at x (N, 6):
    :func:`fk.fk_system`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _fk_mod.fk_system(m, off, x)
    return out


def fk_residual(m: fk.FKArrays, off: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The six FK equations (N, 6) at x (N, 6): :func:`fk.fk_residual`, compiled
    when :data:`COMPILED`."""
    out: np.ndarray = _fk_mod.fk_residual(m, off, x)
    return out


def forward_newton(
    m: fk.FKArrays, off: np.ndarray, x0: np.ndarray, limit: float, max_iter: int, res_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """The FK's Newton iteration from x0 (N, 6): the solution and which rows
    converged, :func:`fk.forward_newton`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _fk_mod.forward_newton(
        m, off, x0, limit, max_iter, res_tol
    )
    return out


def tool_poses(
    x: np.ndarray, ok: np.ndarray, t: np.ndarray, origin: np.ndarray, D: np.ndarray
) -> np.ndarray:
    """Tool poses (N, 5) [mm, mm, mm, deg, deg] of FK solutions x (N, 6):
    :func:`fk.tool_poses`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _fk_mod.tool_poses(x, ok, t, origin, D)
    return out


def forward_poses(
    m: fk.FKArrays,
    d: np.ndarray,
    P: np.ndarray,
    x0: np.ndarray,
    t: np.ndarray,
    origin: np.ndarray,
    D: np.ndarray,
    limit: float,
    max_iter: int,
    res_tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The FK of motor positions on straight guides, Newton and tool poses in one
    call: :func:`fk.forward_poses`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _fk_mod.forward_poses(
        m, d, P, x0, t, origin, D, limit, max_iter, res_tol
    )
    return out


def forward_poses_anchored(
    m: fk.FKArrays,
    d: np.ndarray,
    P: np.ndarray,
    x0: np.ndarray,
    t: np.ndarray,
    origin: np.ndarray,
    D: np.ndarray,
    limit: float,
    max_iter: int,
    res_tol: float,
    every: int,
    phase: int,
    carry: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`forward_poses` from starts set by anchors every ``every`` rows (row 0
    the run's ``phase``-th modulo ``every``), the offset ``carry`` (6,) before the
    first: :func:`fk.forward_poses_anchored`, compiled when :data:`COMPILED`;
    returns q, converged and the carry for the run's next call."""
    if every < 1 or phase < 0:
        raise ValueError(f"every must be >= 1 and phase >= 0, not {every} and {phase}")
    out: tuple[np.ndarray, np.ndarray, np.ndarray] = _fk_mod.forward_poses_anchored(
        m, d, P, x0, t, origin, D, limit, max_iter, res_tol, every, phase, carry
    )
    return out


def map_rows(m: legendre.MapArrays, q: np.ndarray) -> np.ndarray:
    """The virtual-axis error e(q) (N, 5) [mm, mm, mm, deg, deg] for poses ``q``
    (N, 5): :func:`legendre.map_rows`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _map_rows(m, q)
    return out


def correct_virtual(m: legendre.MapArrays, q: np.ndarray, iterations: int = 1) -> np.ndarray:
    """Q' = Q − e(Q) (N, 5) for poses ``q`` (N, 5), Eq. 6 (``iterations`` > 1:
    Q' = Q − e(Q') again, ``iterations`` − 1 times):
    :func:`legendre.correct_virtual`, compiled (one pass over the rows) when
    :data:`COMPILED`."""
    out: np.ndarray = _correct_virtual(m, q, iterations)
    return out


def trapezoids(
    v0: np.ndarray,
    v1: np.ndarray,
    length: np.ndarray,
    accel: np.ndarray,
    vmax: np.ndarray,
    stop: np.ndarray,
    duration: np.ndarray,
    min_phase: float,
) -> timelaw.TimeLaw:
    """Each block's trapezoid between its entry and exit speeds:
    :func:`timelaw.trapezoids`, compiled when :data:`COMPILED`."""
    out: timelaw.TimeLaw = _trapezoids(v0, v1, length, accel, vmax, stop, duration, min_phase)
    return out


def along(law: timelaw.TimeLaw, k: np.ndarray, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance and speed at local times ``tau`` of blocks ``k``: :func:`timelaw.along`,
    compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _along(law, k, tau)
    return out


def phase_times(
    law: timelaw.TimeLaw, counts: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The points' blocks, local times, steps and block ends for phases cut into
    ``counts`` steps: :func:`timelaw.phase_times`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] = _phase_times(law, counts)
    return out


def backward_pass(length: np.ndarray, accel: np.ndarray, vj: np.ndarray) -> np.ndarray:
    """The look-ahead's backward pass: :func:`timelaw.backward_pass`, compiled when
    :data:`COMPILED`."""
    out: np.ndarray = _backward_pass(length, accel, vj)
    return out


def forward_pass(
    length: np.ndarray, accel: np.ndarray, v_back: np.ndarray, v_start: float = 0.0
) -> np.ndarray:
    """The look-ahead's forward pass: :func:`timelaw.forward_pass`, compiled when
    :data:`COMPILED`."""
    out: np.ndarray = _forward_pass(length, accel, v_back, v_start)
    return out


def play_stops(
    dq_out: np.ndarray,
    dq_in: np.ndarray,
    dP_out: np.ndarray,
    dP_in: np.ndarray,
    cross_in: np.ndarray,
    head: int,
    reversal_slope: float,
    stand_slope: float,
    gain_max: float,
) -> np.ndarray:
    """The junctions where a motor with play crosses it at rest:
    :func:`timelaw.play_stops`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _play_stops(
        dq_out, dq_in, dP_out, dP_in, cross_in, head, reversal_slope, stand_slope, gain_max
    )
    return out


def junction_speeds(
    dq_in: np.ndarray,
    dq_out: np.ndarray,
    dot: np.ndarray,
    vmax: np.ndarray,
    length: np.ndarray,
    seg: np.ndarray,
    stops: np.ndarray,
    angular: np.ndarray,
    tool_length: np.ndarray,
    tol: np.ndarray,
    tol_deg: np.ndarray,
    curv_r: np.ndarray,
    play: np.ndarray,
    rules: timelaw.JunctionRules,
) -> tuple[np.ndarray, np.ndarray]:
    """The junction speeds (n,) and corners (n + 1,) of n blocks:
    :func:`timelaw.junction_speeds`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _junction_speeds(
        dq_in, dq_out, dot, vmax, length, seg, stops, angular, tool_length, tol, tol_deg,
        curv_r, play, rules,
    )  # fmt: skip
    return out


def set_offs(
    d_in: np.ndarray,
    d_out: np.ndarray,
    vmax: np.ndarray,
    way: np.ndarray,
    stood: np.ndarray,
    reversal_slope: float,
    stand_slope: float,
    v_eps: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a motor with play sets off against the way it last moved, and each
    motor's way and standing after the blocks: :func:`timelaw.set_offs`, compiled
    when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray, np.ndarray] = _set_offs(
        d_in, d_out, vmax, way, stood, reversal_slope, stand_slope, v_eps
    )
    return out


def poses(p: path.PathArrays, k: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses and tangents on lines and arcs: :func:`path.poses`, compiled when
    :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _poses(p, k, s)
    return out


def velocities(
    v: np.ndarray,
    dq: np.ndarray,
    blk: np.ndarray,
    corner: np.ndarray,
    dq_out: np.ndarray,
    dq_next: np.ndarray,
) -> np.ndarray:
    """The points' planned velocities, the mean of both sides at corners:
    :func:`path.velocities`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _velocities(v, dq, blk, corner, dq_out, dq_next)
    return out


# the play model (kernel/play.py and its twin _play.pyx), one name each so that a
# test can watch the calls
_play_lo = _play_kernel.lo
_play_hi = _play_kernel.hi
_play_lo_inv = _play_kernel.lo_inv
_play_hi_inv = _play_kernel.hi_inv
_play_slope = _play_kernel.slope
_compensate_sided = _play_kernel.compensate_sided
_clamp_scan = _play_kernel.clamp_scan
_follow_stretches = _play_kernel.follow_stretches


def play_lo(t: play.PlayTable, p: np.ndarray) -> np.ndarray:
    """lo(p) (n,) [mm]: :func:`play.lo`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _play_lo(t, p)
    return out


def play_hi(t: play.PlayTable, p: np.ndarray) -> np.ndarray:
    """hi(p) (n,) [mm]: :func:`play.hi`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _play_hi(t, p)
    return out


def play_lo_inv(t: play.PlayTable, target: np.ndarray) -> np.ndarray:
    """lo⁻¹ (n,) [mm]: :func:`play.lo_inv`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _play_lo_inv(t, target)
    return out


def play_hi_inv(t: play.PlayTable, target: np.ndarray) -> np.ndarray:
    """hi⁻¹ (n,) [mm]: :func:`play.hi_inv`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _play_hi_inv(t, target)
    return out


def play_slope(t: play.PlayTable, p: np.ndarray, side: np.ndarray) -> np.ndarray:
    """d lo/dp or d hi/dp (n,): :func:`play.slope`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _play_slope(t, p, side)
    return out


def compensate_sided(t: play.PlayTable, target: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Commands (n,) [mm]: :func:`play.compensate_sided`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _compensate_sided(t, target, side)
    return out


_table_commands = _play_kernel.table_commands


def table_commands(
    tables: tuple[play.PlayTable, ...],
    cols: np.ndarray,
    P_ideal: np.ndarray,
    V_ideal: np.ndarray,
    side: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
) -> None:
    """Every motor's commands through its table in one call, into the rows of ``P``,
    ``V`` (R, n) (C order, float): :func:`play.table_commands`, compiled when
    :data:`COMPILED`."""
    _table_commands(tables, cols, P_ideal, V_ideal, side, P, V)


def clamp_scan(lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The play model's scan (n,): :func:`play.clamp_scan`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _clamp_scan(lo, hi)
    return out


def follow_stretches(
    t: play.PlayTable,
    y0: np.ndarray,
    P0: np.ndarray,
    V0: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    dt: np.ndarray,
    steps: np.ndarray,
    cubic: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The part along the commands' cubics: :func:`play.follow_stretches`, compiled
    when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray, np.ndarray] = _follow_stretches(
        t, y0, P0, V0, P, V, dt, steps, cubic
    )
    return out


_catch_up = _play_kernel.catch_up


def catch_up(
    off0: np.ndarray,
    way: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    s_path: np.ndarray,
    share: float,
    hurry: float,
    motion: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The offsets taken up after crossings: :func:`play.catch_up`, compiled when
    :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] = _catch_up(
        off0, way, start, stop, s_path, share, hurry, motion
    )
    return out


_catch_up_commands = _play_kernel.catch_up_commands
_settle_crossings = _play_kernel.settle_crossings


def catch_up_commands(
    t: play.PlayTable,
    mo: play.Motion,
    off0: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    share: float,
    hurry: float,
) -> tuple[np.ndarray, float]:
    """The take-up's commands into ``P``, ``V`` (contiguous, in place):
    :func:`play.catch_up_commands`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, float] = _catch_up_commands(t, mo, off0, start, stop, P, V, share, hurry)
    return out


def settle_crossings(
    t: play.PlayTable,
    mo: play.Motion,
    before: tuple[float, float, float],
    e: np.ndarray,
    b: np.ndarray,
    short: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    cubic: bool,
    share: float,
    hurry: float,
) -> play.Settled:
    """A motor's crossings ended where its part stands: :func:`play.settle_crossings`,
    compiled when :data:`COMPILED`."""
    out: play.Settled = _settle_crossings(t, mo, before, e, b, short, P, V, cubic, share, hurry)
    return out


_settle_motors = _play_kernel.settle_motors


def settle_motors(
    tables: tuple[play.PlayTable, ...],
    cols: np.ndarray,
    ch: play.Chunk,
    before: np.ndarray,
    carried_off: np.ndarray,
    x: play.Contacts,
    P: np.ndarray,
    V: np.ndarray,
    cubic: bool,
    share: float,
    hurry: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Every motor with play settled through a chunk in one call, the commands ``P``,
    ``V`` (R, n) (C order, float) updated in place: :func:`play.settle_motors`,
    compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _settle_motors(
        tables, cols, ch, before, carried_off, x, P, V, cubic, share, hurry
    )
    return out


_carried = _play_kernel.carried


def carried(sg: np.ndarray, side: np.ndarray | float) -> np.ndarray:
    """The side carried through rows without a direction: :func:`play.carried`,
    compiled when :data:`COMPILED`."""
    out: np.ndarray = _carried(sg, side)
    return out


_creeps = _play_kernel.creeps


def creeps(
    sg: np.ndarray, P: np.ndarray, side: int, ref: float, drift: float
) -> tuple[np.ndarray, float]:
    """Where a creeping motor drifted back: :func:`play.creeps`, compiled when
    :data:`COMPILED`."""
    out: tuple[np.ndarray, float] = _creeps(sg, P, side, ref, drift)
    return out


_motor_sides = _play_kernel.motor_sides


def motor_sides(
    V: np.ndarray,
    resting: np.ndarray,
    f: np.ndarray,
    e: np.ndarray,
    new: np.ndarray,
    last_row: np.ndarray,
    s_first: np.ndarray,
    s_new: np.ndarray,
    side: int,
    eps: float,
) -> np.ndarray:
    """A motor's side at each point: :func:`play.motor_sides`, compiled when
    :data:`COMPILED`."""
    out: np.ndarray = _motor_sides(V, resting, f, e, new, last_row, s_first, s_new, side, eps)
    return out


_motors_sides = _play_kernel.motors_sides


def motors_sides(
    V: np.ndarray,
    resting: np.ndarray,
    cols: np.ndarray,
    side: np.ndarray,
    f: np.ndarray,
    e: np.ndarray,
    new: np.ndarray,
    last_row: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    s_first: np.ndarray,
    s_new: np.ndarray,
    s_col: np.ndarray,
    eps: float,
    out: np.ndarray,
) -> None:
    """Every motor's side at each point in one call, into the rows ``cols`` of
    ``out`` (R, m) (C order, float): :func:`play.motors_sides`, compiled when
    :data:`COMPILED`."""
    _motors_sides(
        V, resting, cols, side, f, e, new, last_row, lo, hi, s_first, s_new, s_col, eps, out
    )


# the crossings (kernel/windows.py and its twin _windows.pyx)
_crossing_windows = _RUN["windows"].crossing_windows
_chord_windows = _RUN["windows"].chord_windows
_chord_room = _RUN["windows"].chord_room
_velocity_roots = _RUN["windows"].velocity_roots
_turning_points = _RUN["windows"].turning_points
_dip_roots = _RUN["windows"].dip_roots
_corner_blends = _RUN["windows"].corner_blends


def corner_blends(
    V_in: np.ndarray,
    V_out: np.ndarray,
    cols: np.ndarray,
    h: np.ndarray,
    accel: float,
    v_eps: float,
    turn_mm: float,
    blend_min: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The corners a PVT program blends and their τ: :func:`windows.corner_blends`,
    compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _corner_blends(
        V_in, V_out, cols, h, accel, v_eps, turn_mm, blend_min
    )
    return out


_motor_reversals = _RUN["windows"].motor_reversals


def motor_reversals(
    V: np.ndarray,
    P: np.ndarray,
    rest: np.ndarray,
    cols: np.ndarray,
    side: np.ndarray,
    ref: np.ndarray,
    drift: float,
    off: int,
    eps: float,
    h: np.ndarray,
    tol: float,
) -> windows.Reversals:
    """Every motor's reversals and their kinds, its dips and settings-off back in a
    chunk, in one call: :func:`windows.motor_reversals`, compiled when
    :data:`COMPILED`."""
    out: windows.Reversals = _motor_reversals(V, P, rest, cols, side, ref, drift, off, eps, h, tol)
    return out


def dip_roots(
    P0: np.ndarray,
    V0: np.ndarray,
    P1: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    sg: np.ndarray,
    tol: float,
    sets_off: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The steps that dip (n,) bool, and their turning points and accelerations
    there (m,): :func:`windows.dip_roots`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray] = _dip_roots(
        P0, V0, P1, V1, h, sg, tol, sets_off
    )
    return out


def velocity_roots(
    P0: np.ndarray,
    V0: np.ndarray,
    P1: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    new: np.ndarray,
    has_new: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """The first roots of steps' cubics' velocity and the accelerations there (n,):
    :func:`windows.velocity_roots`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _velocity_roots(P0, V0, P1, V1, h, new, has_new)
    return out


def turning_points(
    P0: np.ndarray, V0: np.ndarray, P1: np.ndarray, V1: np.ndarray, h: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Both turning points inside steps (n,), NaN elsewhere:
    :func:`windows.turning_points`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _turning_points(P0, V0, P1, V1, h)
    return out


def crossing_windows(
    t0: np.ndarray,
    t1: np.ndarray,
    t_root: np.ndarray,
    accel: np.ndarray,
    rb: np.ndarray,
    ra: np.ndarray,
    tol: float,
    longest: float,
    chords: bool,
    min_w: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The windows' starts and ends (n,) [s]: :func:`windows.crossing_windows`,
    compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _crossing_windows(
        t0, t1, t_root, accel, rb, ra, tol, longest, chords, min_w
    )
    return out


def chord_windows(
    t0: np.ndarray,
    t1: np.ndarray,
    t_root: np.ndarray,
    accel: np.ndarray,
    rb: np.ndarray,
    ra: np.ndarray,
    tol: float,
    longest: float,
    t_before: np.ndarray,
    t_after: np.ndarray,
    min_w: float,
    snap: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The windows' starts and ends (n,) [s] for straight lines between the
    points: :func:`windows.chord_windows`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _chord_windows(
        t0, t1, t_root, accel, rb, ra, tol, longest, t_before, t_after, min_w, snap
    )
    return out


def chord_room(
    km: np.ndarray,
    t0: np.ndarray,
    t1: np.ndarray,
    dt: np.ndarray,
    resting: np.ndarray,
    busy: np.ndarray,
    bent: np.ndarray,
    min_w: float,
) -> tuple[np.ndarray, np.ndarray]:
    """How far (m,) [s] windows in steps ``km`` may reach before and after them:
    :func:`windows.chord_room`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _chord_room(km, t0, t1, dt, resting, busy, bent, min_w)
    return out


# the corrected G-code writer's decisions (kernel/gwrite.py and its twin _gwrite.pyx)
_gcode_ops = _RUN["gwrite"].gcode_ops


def gcode_ops(
    st: gwrite.GState,
    q: np.ndarray,
    dt: np.ndarray,
    line: np.ndarray,
    speed: np.ndarray,
    block_end: np.ndarray,
    fn: np.ndarray,
    fn_end: np.ndarray,
    dwell: np.ndarray,
    lead: np.ndarray,
    end: bool,
    arc_of: np.ndarray,
    arc_i: np.ndarray,
    arc_f: np.ndarray,
    fit: tuple[float, float, int] | None = None,
) -> gwrite.Ops:
    """A chunk's points decided, one op per output line (``st`` updated in place;
    with ``fit``, its arcs refitted where it stops, ``st.fit_i``, ``st.fit_f``):
    :func:`gwrite.gcode_ops`, compiled when :data:`COMPILED`."""
    gwrite.reserve(st, len(q))
    out: gwrite.Ops = _gcode_ops(
        st, q, dt, line, speed, block_end, fn, fn_end, dwell, lead, end, arc_of, arc_i, arc_f, fit
    )
    return out


# the arc search of corrected G-code (kernel/arcs.py and its twin _arcs.pyx)
_fit_arc = _RUN["arcs"].fit_arc
_find_arcs = _RUN["arcs"].find_arcs
_refit_arcs = _RUN["arcs"].refit_arcs


def fit_arc(q: np.ndarray, plane: int, tol_mm: float, tol_deg: float, decimals: int) -> np.ndarray:
    """The arc from q[0] to q[-1] through the points between, as a row (7,) (NaN:
    none): :func:`arcs.fit_arc`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _fit_arc(q, plane, tol_mm, tol_deg, decimals)
    return out


def find_arcs(
    q: np.ndarray,
    free: np.ndarray,
    ends: np.ndarray,
    rate: np.ndarray,
    lead: np.ndarray,
    tol_mm: float,
    tol_deg: float,
    decimals: int,
    dip_share: float,
    tilt_span: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The arcs among a chunk's written points, as rows (arc_i (M, 4), arc_f (M, 6)):
    :func:`arcs.find_arcs`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _find_arcs(
        q, free, ends, rate, lead, tol_mm, tol_deg, decimals, dip_share, tilt_span
    )
    return out


def refit_arcs(
    q: np.ndarray,
    plane: int,
    start: int,
    end: int,
    tol_mm: float,
    tol_deg: float,
    decimals: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The points q[start : end + 1] as arcs in ``plane``, as rows:
    :func:`arcs.refit_arcs`, compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, np.ndarray] = _refit_arcs(
        q, plane, start, end, tol_mm, tol_deg, decimals
    )
    return out


# the root search (kernel/roots.py and its twin _roots.pyx)
_seek_step = _RUN["roots"].seek_step


def seek_step(
    x: np.ndarray,
    v: np.ndarray,
    going: np.ndarray,
    ok: np.ndarray,
    moved: np.ndarray,
    new: np.ndarray,
    accel: np.ndarray,
    h: np.ndarray,
    s_a: np.ndarray,
    v_a: np.ndarray,
    s_b: np.ndarray,
    v_b: np.ndarray,
    last: np.ndarray,
    margin: float,
    time_s: float,
) -> tuple[np.ndarray, ...]:
    """One false-position step of the reversals' roots: :func:`roots.seek_step`,
    compiled when :data:`COMPILED`."""
    out: tuple[np.ndarray, ...] = _seek_step(
        x, v, going, ok, moved, new, accel, h, s_a, v_a, s_b, v_b, last, margin, time_s
    )
    return out
