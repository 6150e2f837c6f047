"""Real-axis error tables: the contract's play model and its compensation.

For motor m with a table of forward errors F(p) and reverse errors R(p)
(actual − commanded, linear between table points, end values held outside):

    lo(p) = p + min(F(p), R(p)),   hi(p) = p + max(F(p), R(p))

Play model (what the machine does with commands p_0, p_1, ... in time order):

    y_0 = lo(p_0),   y_k = min(max(y_(k−1), lo(p_k)), hi(p_k))

Compensation (the E_i(P_i) term of the paper's Eq. 3): choose commands whose
result is the wanted positions T_k: lo(p_k) = T_k where T rises, hi(p_k) = T_k
where it falls, p_k = p_(k−1) where it stands.

Both are vectorised over a whole chunk of points and can be continued across
chunks with a :class:`PlayState`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import kernel
from .kernel.play import PlayTable, play_table
from .profile import AxisComp, Effects, Profile

#: A wanted position that moves by less than this between two points stands still.
#: Without it, rounding noise of 1e-15 mm in a motor that should stand would be
#: read as reversals, and every one would make the command jump across the play.
STAND_TOL_MM = 1e-9


def cyclic_error(
    p: np.ndarray, terms: tuple[tuple[float, float, float], ...]
) -> np.ndarray | float:
    """Position error [mm] of periodic terms (amplitude mm, period mm, phase deg) at
    motor positions ``p`` [mm]: Σ amplitude · sin(2π p / period + phase)."""
    out: np.ndarray | float = 0.0
    for amp, period, phase in terms:
        out = out + amp * np.sin(2 * np.pi * p / period + np.radians(phase))
    return out


@dataclass(frozen=True)
class MotorTable:
    """lo/hi envelopes of one motor as piecewise-linear functions.

    ``breaks`` are the table positions plus every point where F and R cross
    between two table points, so min/max of the two is exactly linear between
    consecutive breaks.
    """

    motor: int
    breaks: np.ndarray
    lo_err: np.ndarray
    hi_err: np.ndarray
    cyclic: tuple[tuple[float, float, float], ...] = ()  # (amplitude, period, phase deg)

    def with_cyclic(self, terms: tuple[tuple[float, float, float], ...]) -> MotorTable:
        return MotorTable(self.motor, self.breaks, self.lo_err, self.hi_err, terms)

    @classmethod
    def from_comp(cls, comp: AxisComp) -> MotorTable:
        p, f, r = (np.asarray(a, dtype=float) for a in (comp.positions, comp.forward, comp.reverse))
        diff = f - r
        extra = []
        for j in range(len(p) - 1):
            if diff[j] * diff[j + 1] < 0:
                s = diff[j] / (diff[j] - diff[j + 1])
                extra.append(p[j] + s * (p[j + 1] - p[j]))
        breaks = np.union1d(p, np.array(extra)) if extra else p.copy()
        fb = np.interp(breaks, p, f)
        rb = np.interp(breaks, p, r)
        return cls(comp.motor, breaks, np.minimum(fb, rb), np.maximum(fb, rb))

    @cached_property
    def flat(self) -> PlayTable:
        """The table as the kernel takes it (made once)."""
        return play_table(self.breaks, self.lo_err, self.hi_err, self.cyclic)

    def lo(self, p: np.ndarray) -> np.ndarray:
        """Where the part ends when approached moving + (forward error)."""
        p = np.asarray(p, dtype=float)
        return kernel.play_lo(self.flat, p.ravel()).reshape(p.shape)

    def hi(self, p: np.ndarray) -> np.ndarray:
        """Where the part ends when approached moving − (reverse error)."""
        p = np.asarray(p, dtype=float)
        return kernel.play_hi(self.flat, p.ravel()).reshape(p.shape)

    def lo_inv(self, target: np.ndarray) -> np.ndarray:
        """p with lo(p) = target (the periodic terms by fixed-point iteration,
        :func:`.kernel.play.lo_inv`)."""
        t = np.asarray(target, dtype=float)
        return kernel.play_lo_inv(self.flat, t.ravel()).reshape(t.shape)

    def hi_inv(self, target: np.ndarray) -> np.ndarray:
        """p with hi(p) = target."""
        t = np.asarray(target, dtype=float)
        return kernel.play_hi_inv(self.flat, t.ravel()).reshape(t.shape)

    def slope(self, p: np.ndarray, side: np.ndarray) -> np.ndarray:
        """d lo/dp (side > 0) or d hi/dp (side < 0) at p: how fast the driven part
        moves per unit of command, to turn a wanted velocity into a command
        velocity. Piecewise-linear errors: the slope of the interval holding p
        (the one above it at a table point), zero outside the table."""
        p = np.asarray(p, dtype=float)
        sd = np.broadcast_to(np.asarray(side), p.shape)
        return kernel.play_slope(self.flat, p.ravel(), sd.ravel()).reshape(p.shape)

    @property
    def max_play(self) -> float:
        return float(np.max(self.hi_err - self.lo_err))


class PlayState:
    """What the play model and the compensation remember between chunks.

    y : where the driven part is (play model)
    target : last wanted position (compensation)
    command : last command (compensation)
    """

    def __init__(
        self, y: float | None = None, target: float | None = None, command: float | None = None
    ) -> None:
        self.y = y
        self.target = target
        self.command = command


def play_model(
    table: MotorTable | None, p: np.ndarray, state: PlayState | None = None
) -> np.ndarray:
    """Where the driven part ends for commanded positions ``p`` (time order).

    Parameters
    ----------
    table : MotorTable or None (an ideal motor: y = p)
    p : (N,) commanded positions [mm]
    state : PlayState, optional
        Carries the part's position across chunks; updated in place.
    """
    p = np.asarray(p, dtype=float)
    if table is None or len(p) == 0:
        return p.copy()
    lo = table.lo(p)
    hi = table.hi(p)
    if state is not None and state.y is not None:
        lo = np.concatenate([[state.y], lo])
        hi = np.concatenate([[state.y], hi])
        y = kernel.clamp_scan(lo, hi)[1:]
    else:
        y = kernel.clamp_scan(lo, hi)
    if state is not None:
        state.y = float(y[-1])
    return y


def approach(table: MotorTable | None, p: np.ndarray, direction: int) -> np.ndarray:
    """Result of approaching each position on its own from one side (poses, laser runs)."""
    p = np.asarray(p, dtype=float)
    if table is None:
        return p.copy()
    return table.lo(p) if direction > 0 else table.hi(p)


def compensate(
    table: MotorTable | None, target: np.ndarray, state: PlayState | None = None
) -> np.ndarray:
    """Commands whose play-model result is ``target`` (time order).

    Rising wanted position: lo(p_k) = T_k; falling: hi(p_k) = T_k; standing
    (|ΔT| < :data:`STAND_TOL_MM`): p_k = p_(k−1). The first point of a motion is
    approached from below (lo), as the play model starts at lo(p_0).
    """
    target = np.asarray(target, dtype=float)
    if table is None or len(target) == 0:
        return target.copy()
    prev_t = state.target if state is not None else None
    if prev_t is None:
        dT = np.diff(target, prepend=-np.inf)  # first point: rising
    else:
        dT = np.diff(target, prepend=prev_t)
    rising = dT >= STAND_TOL_MM
    falling = dT <= -STAND_TOL_MM
    cmd = np.where(rising, table.lo_inv(target), table.hi_inv(target))
    standing = ~(rising | falling)
    if np.any(standing):
        idx = np.where(standing, -1, np.arange(len(target)))
        idx = np.maximum.accumulate(idx)
        prev_cmd = state.command if state is not None else None
        if prev_cmd is None:
            # Cannot happen for the very first point (it always rises from −∞).
            prev_cmd = float(cmd[0])
        cmd = np.where(idx >= 0, cmd[np.maximum(idx, 0)], prev_cmd)
    if state is not None:
        state.target = float(target[-1])
        state.command = float(cmd[-1])
    return cmd


def compensate_sided(table: MotorTable | None, target: np.ndarray, side: np.ndarray) -> np.ndarray:
    """Commands whose result is ``target`` with the driven part pushed from ``side``
    (+1: the motor moves up, the part sits at lo; −1: down, at hi).

    The chain decides the side from the planned velocity of the motor (a
    continuous motion, whose reversals it places in time), where
    :func:`compensate` decides it from consecutive wanted positions.
    """
    target = np.asarray(target, dtype=float)
    if table is None or len(target) == 0:
        return target.copy()
    return kernel.compensate_sided(table.flat, target, np.asarray(side))


def tables_by_motor(
    comps: tuple[AxisComp, ...], effects: Effects | None = None
) -> dict[int, MotorTable]:
    """MotorTable for every motor with an ``[[axis_comp]]`` entry or a cyclic error."""
    out = {c.motor: MotorTable.from_comp(c) for c in comps}
    if effects is not None:
        for m in {c.motor for c in effects.cyclic}:
            terms = tuple((c.amplitude, c.period, c.phase) for c in effects.cyclic if c.motor == m)
            base = out.get(m) or MotorTable(m, np.array([0.0]), np.zeros(1), np.zeros(1))
            out[m] = base.with_cyclic(terms)
    return out


def profile_tables(profile: Profile) -> dict[int, MotorTable]:
    """Every motor's real-axis error model of a profile (tables and cyclic errors)."""
    return tables_by_motor(profile.axis_comp, profile.effects)
