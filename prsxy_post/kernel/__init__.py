"""The kernel: per-point numerical work as functions over arrays.

Each kernel has a numpy reference (``ik.py``, ``text.py``, ``play.py``: the
real-axis play model, the crossings' settle and catch-up) and a compiled twin in
Cython (``_ik.pyx``, ``_text.pyx``, ``_play.pyx``, built when the package is
installed) that gives the same bits. This module picks one set for the whole
program, once, at import:

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

from . import ik, play, text

#: The environment variable that selects the reference kernels (value ``pure``).
ENV = "PRSXY_KERNEL"

InverseRows = Callable[[ik.IKArrays, np.ndarray, np.ndarray], np.ndarray]
FixedRows = Callable[..., list[str]]


def _load() -> tuple[Any, Any, Any, str, str]:
    """(inverse_rows, format_fixed_rows, the play model's module, name, why the
    reference runs or "")."""
    pure = (ik.inverse_rows, text.format_fixed_rows, play)
    if os.environ.get(ENV, "").strip().lower() == "pure":
        return (*pure, "pure numpy (PRSXY_KERNEL=pure)", f"{ENV}=pure")
    try:
        from . import _ik, _play, _text  # type: ignore[attr-defined]
    except ImportError as e:
        absent = [
            n
            for n in ("_ik", "_text", "_play")
            if importlib.util.find_spec(f"{__name__}.{n}") is None
        ]
        why = (
            f"the compiled extension is not built (no {', '.join(absent)} "
            f"in {Path(__file__).parent})"
            if absent
            else f"the compiled extension does not import ({e})"
        )
        return (*pure, f"pure numpy ({why})", why)
    return (
        _ik.inverse_rows,
        _text.format_fixed_rows,
        _play,
        f"compiled (Cython {_ik.CYTHON})",
        "",
    )


_inverse_rows, _fixed_rows, _play_kernel, NAME, WHY_PURE = _load()
#: True when the compiled kernels run.
COMPILED: bool = not WHY_PURE
#: True when the reference runs because the extension is missing (not asked for).
MISSING: bool = bool(WHY_PURE) and not WHY_PURE.startswith(ENV)


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
