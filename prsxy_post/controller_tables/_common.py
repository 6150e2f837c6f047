"""What a controller's real-axis table must hold for the contract's play model.

The contract (machine-model.md, "Real-axis error") says where the driven part ends
for a commanded motor position q: at lo(q) = q + min(F, R) when it was approached
moving +, at hi(q) = q + max(F, R) when approached moving −. A controller table
turns the position p a program asks for into a motor command, and does it by
direction of motion. The part ends exactly at p when the command is

    q = lo⁻¹(p) moving +,   q = hi⁻¹(p) moving −,

so the corrections a controller adds to p are

    c_f(p) = lo⁻¹(p) − p,   c_r(p) = hi⁻¹(p) − p          [mm]

and the backlash it must add on a reversal is c_f(p) − c_r(p) ≥ 0. lo and hi
are piecewise linear with kinks at the table breaks b_j, so c_f is piecewise
linear with kinks at lo(b_j) and c_r with kinks at hi(b_j). A controller that
interpolates linearly between its own rows is therefore exact up to the kinks it
misses, and the largest deviation is found by evaluating both piecewise-linear
functions at the union of their kinks (:func:`max_deviation`).
"""

from __future__ import annotations

import numpy as np

from ..axiscomp import MotorTable
from ..profile import AxisComp


def corrections(comp: AxisComp, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corrections a controller adds to the wanted position, by direction.

    Parameters
    ----------
    comp : the motor's ``[[axis_comp]]`` table
    p : (N,) wanted positions [mm, motor coordinates]

    Returns
    -------
    c_f, c_r : (N,) [mm]
        c_f = lo⁻¹(p) − p for an approach moving +, c_r = hi⁻¹(p) − p moving −.
    """
    t = MotorTable.from_comp(comp)
    p = np.asarray(p, dtype=float)
    return t.lo_inv(p) - p, t.hi_inv(p) - p


def kinks(comp: AxisComp) -> np.ndarray:
    """Every position where c_f or c_r changes slope: lo(b_j) and hi(b_j) [mm]."""
    t = MotorTable.from_comp(comp)
    return np.union1d(t.lo(t.breaks), t.hi(t.breaks))


def max_deviation(
    comp: AxisComp,
    travel: tuple[float, float],
    controller: object,
    breakpoints: np.ndarray,
) -> float:
    """Largest |controller correction − exact correction| over the travel [mm].

    ``controller(p) -> (c_f, c_r)`` is piecewise linear with breaks at
    ``breakpoints``; the exact corrections are piecewise linear with breaks at
    :func:`kinks`. The difference of two piecewise-linear functions is largest at
    one of their breaks or at an end of the travel, so evaluating there is exact.
    """
    lo, hi = travel
    pts = np.union1d(np.union1d(kinks(comp), np.asarray(breakpoints, dtype=float)), [lo, hi])
    pts = pts[(pts >= lo) & (pts <= hi)]
    cf, cr = corrections(comp, pts)
    gf, gr = controller(pts)  # type: ignore[operator]
    return float(max(np.max(np.abs(gf - cf)), np.max(np.abs(gr - cr))))


def comp_from_corrections(
    motor: int, nominal: np.ndarray, c_f: np.ndarray, c_r: np.ndarray
) -> AxisComp:
    """The ``[[axis_comp]]`` table whose exact corrections are c_f, c_r at ``nominal``.

    Inverse of :func:`corrections`: the command q = p + c_f(p) ends at lo(q) = p,
    so the forward error at q is F(q) = p − q = −c_f(p) (and R likewise from c_r).
    Those are known at the commands q, which differ from the rows by the
    corrections; the table is written back on the rows ``nominal`` by linear
    interpolation with the end values held (the contract's rule outside a table).
    """
    nominal = np.asarray(nominal, dtype=float)
    q_f = nominal + c_f
    q_r = nominal + c_r
    fwd = np.interp(nominal, q_f, -np.asarray(c_f, dtype=float))
    rev = np.interp(nominal, q_r, -np.asarray(c_r, dtype=float))
    return AxisComp(motor, nominal.copy(), fwd, rev)
