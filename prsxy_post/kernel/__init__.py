"""The kernel: per-point numerical work as functions over arrays.

Each kernel has a numpy reference (``ik.py``, ``text.py``; the planner's
``timelaw.py`` and ``path.py``) and a compiled twin in Cython (``_ik.pyx``,
``_text.pyx``, ``_timelaw.pyx``, ``_path.pyx``, built when the package is installed)
that gives the same bits. This module picks one set for the whole program, once, at import:

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

import importlib.util
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import ik, path, text, timelaw

#: The environment variable that selects the reference kernels (value ``pure``).
ENV = "PRSXY_KERNEL"

InverseRows = Callable[[ik.IKArrays, np.ndarray, np.ndarray], np.ndarray]
FixedRows = Callable[..., list[str]]


def _load() -> tuple[Any, Any, str, str]:
    """(inverse_rows, format_fixed_rows, name, why the reference runs or "")."""
    pure = (ik.inverse_rows, text.format_fixed_rows)
    if os.environ.get(ENV, "").strip().lower() == "pure":
        return (*pure, "pure numpy (PRSXY_KERNEL=pure)", f"{ENV}=pure")
    try:
        from . import _ik, _path, _text, _timelaw  # type: ignore[attr-defined]  # noqa: F401
    except ImportError as e:
        absent = [
            n
            for n in ("_ik", "_text", "_path", "_timelaw")
            if importlib.util.find_spec(f"{__name__}.{n}") is None
        ]
        why = (
            f"the compiled extension is not built (no {', '.join(absent)} "
            f"in {Path(__file__).parent})"
            if absent
            else f"the compiled extension does not import ({e})"
        )
        return (*pure, f"pure numpy ({why})", why)
    return _ik.inverse_rows, _text.format_fixed_rows, f"compiled (Cython {_ik.CYTHON})", ""


_inverse_rows, _fixed_rows, NAME, WHY_PURE = _load()
#: True when the compiled kernels run.
COMPILED: bool = not WHY_PURE
#: True when the reference runs because the extension is missing (not asked for).
MISSING: bool = bool(WHY_PURE) and not WHY_PURE.startswith(ENV)

# the planner's kernels: the time law and the poses on lines and arcs (_load has
# imported the compiled ones when COMPILED)
_plan_mods: tuple[Any, Any] = (timelaw, path)
if COMPILED:
    from . import _path, _timelaw  # type: ignore[attr-defined]

    _plan_mods = (_timelaw, _path)
_trapezoids = _plan_mods[0].trapezoids
_along = _plan_mods[0].along
_phase_times = _plan_mods[0].phase_times
_backward_pass = _plan_mods[0].backward_pass
_forward_pass = _plan_mods[0].forward_pass
_play_stops = _plan_mods[0].play_stops
_poses = _plan_mods[1].poses
_velocities = _plan_mods[1].velocities


def inverse_rows(m: ik.IKArrays, q: np.ndarray, tz: np.ndarray) -> np.ndarray:
    """Motor positions (N, 5) [mm] for poses ``q`` (N, 5) and tool heights ``tz``
    (N,): :func:`ik.inverse_rows`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _inverse_rows(m, q, tz)
    return out


def format_fixed_rows(columns: Sequence[tuple[str, np.ndarray, int]], end: str = "\n") -> list[str]:
    """Rows of fixed-point text: :func:`text.format_fixed_rows`, compiled when
    :data:`COMPILED`."""
    out: list[str] = _fixed_rows(columns, end)
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
