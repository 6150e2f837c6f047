"""Where a motor with play reverses, and the window in which it crosses the play.

The real-axis compensation (contract, "Real-axis error") commands lo⁻¹(T) while
a motor moves up and hi⁻¹(T) while it moves down, so at a reversal the command
jumps across the play. A controller moves from one point to the next along a
smooth curve; if the jump were left between two ordinary points, the motor
would cross the play over a whole step, the driven part standing still for all
of it while the path goes on. So the jump gets a window of its own:

- a reversal in motion (the motor's planned velocity changes sign between two
  points): the root t_r of the velocity of the segment's cubic, and two new
  points at t_r ± δ/2. Inside the window the part stands at the extremum while
  the motor crosses; it misses the true path by at most |A| (δ/2)² / 2 for the
  motor's acceleration A at the reversal, so δ = sqrt(8 tol / |A|), at most the
  profile's ``reversal_ms``;
- a reversal at rest (the path stood still at the previous point, the motor
  leaves the other way): one more point at the same pose, δ later, at which the
  motor has crossed; the path waits for it.
"""

from __future__ import annotations

import numpy as np

#: A planned motor velocity below this [mm/s] is no direction (rounding noise).
V_EPS = 1e-6
#: The shortest window [s]: a PVT segment of the controller's own servo cycle.
MIN_WINDOW_S = 0.25e-3
#: Window edges of different motors this close [s] are made one point.
SNAP_S = 0.1e-3


def signs(V: np.ndarray) -> np.ndarray:
    """Direction of each planned velocity: +1, −1, or 0 (standing)."""
    return np.where(V > V_EPS, 1, np.where(V < -V_EPS, -1, 0))


def velocity_root(P0: float, V0: float, P1: float, V1: float, h: float) -> tuple[float, float]:
    """Where the cubic through (P0, V0) and (P1, V1) over time h has zero velocity.

    The Hermite cubic's velocity is a quadratic a s² + b s + c in s = t / h, with
    c = V0, a = 6 (P0 − P1)/h + 3 (V0 + V1), b = −6 (P0 − P1)/h − 4 V0 − 2 V1.

    Returns
    -------
    s : the root in [0, 1] where the velocity changes sign
    accel : the cubic's acceleration there [mm/s²]
    """
    d = (P0 - P1) / h
    a = 6.0 * d + 3.0 * (V0 + V1)
    b = -6.0 * d - 4.0 * V0 - 2.0 * V1
    c = V0
    roots: list[float] = []
    if abs(a) < 1e-12 * (abs(b) + abs(c) + 1e-300):
        if b != 0:
            roots = [-c / b]
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0:
            sq = np.sqrt(disc)
            # the numerically stable pair of roots
            qq = -0.5 * (b + np.copysign(sq, b))
            roots = [qq / a, c / qq] if qq != 0 else [-b / (2 * a)]
    inside = [r for r in roots if -1e-9 <= r <= 1.0 + 1e-9]
    if not inside:
        # the velocities at the ends have opposite signs, so a root exists; only
        # rounding can hide it: take the linear estimate
        s = V0 / (V0 - V1) if V0 != V1 else 0.5
    else:
        # the root where the sign changes from V0's: the first one
        s = min(inside)
    s = float(np.clip(s, 0.0, 1.0))
    return s, float((2.0 * a * s + b) / h)


def window(
    t0: float, t1: float, t_root: float, accel: float, tol: float, longest: float
) -> tuple[float, float]:
    """The crossing window around a reversal at ``t_root`` inside the step [t0, t1]."""
    width = longest if accel == 0 else float(np.sqrt(8.0 * tol / abs(accel)))
    width = min(max(width, MIN_WINDOW_S), longest)
    if width >= t1 - t0:
        return t0, t1
    a = min(max(t_root - 0.5 * width, t0), t1 - width)
    b = a + width
    # no sliver of a step beside the window: a step much shorter than the window
    # makes the rounding of the written positions a large velocity error; the
    # window grows by at most half its width on that side (its error by 2.25 x)
    if a - t0 < 0.5 * width:
        a = t0
    if t1 - b < 0.5 * width:
        b = t1
    return a, b


class Insertions:
    """What a chunk of points needs for its reversals (:func:`plan_insertions`).

    stand : row k → duration of a standing point put before it
    mid : row k → times (since the chunk's previous point) of points put inside
        the step that ends at row k
    windows : (k, col, t_a, t_b, new) crossing windows inside steps: the motor is on
        its old side −new up to t_a and on the new side from t_b
    contact : (k, col) → the wanted position at the reversal itself (the extreme),
        where the motor meets the part again at the window's end
    stands : (k, col, new) motors that cross at the standing point before row k
    """

    def __init__(self) -> None:
        self.stand: dict[int, float] = {}
        self.mid: dict[int, list[float]] = {}
        self.windows: list[tuple[int, int, float, float, int]] = []
        self.contact: dict[tuple[int, int], float] = {}
        self.stands: list[tuple[int, int, int]] = []

    def __bool__(self) -> bool:
        return bool(self.stand or self.mid)


def plan_insertions(
    t_end: np.ndarray,
    dt: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    resting: np.ndarray,
    prev: tuple[np.ndarray, np.ndarray, bool] | None,
    cols: list[int],
    side: np.ndarray,
    tol: float,
    longest: float,
) -> Insertions:
    """Find every reversal of the motors ``cols`` in a chunk of points and its window.

    Parameters
    ----------
    t_end : (n,) time of each point since the point before the chunk [s]
    dt : (n,) time of the step that ends at each point [s]
    P, V : (n, 5) wanted motor positions and velocities [mm, mm/s]
    resting : (n,) bool, the path stands at the point (speed 0)
    prev : (P, V, resting) of the point before the chunk, None at the start
    cols : motors (columns) with play
    side : (5,) the side each motor is on before the chunk (+1 up, −1 down)
    tol : path error allowed to a crossing [mm]
    longest : the longest crossing window [s]
    """
    ins = Insertions()
    n = len(dt)
    if prev is None:
        P_all, V_all, rest_all, off = P, V, resting, 0
    else:
        P_all = np.vstack([prev[0][None, :], P])
        V_all = np.vstack([prev[1][None, :], V])
        rest_all = np.concatenate([[prev[2]], resting])
        off = 1
    for col in cols:
        sg = np.where(rest_all, 0, signs(V_all[:, col]))
        # the side a row comes from: the last direction before it, or the carried one
        idx = np.where(sg != 0, np.arange(len(sg)), -1)
        last = np.maximum.accumulate(idx)
        before = np.concatenate([[-1], last[:-1]])
        came = np.where(before >= 0, sg[np.maximum(before, 0)], side[col])
        for r in np.flatnonzero((sg != 0) & (sg != came)).tolist():
            k = r - off
            if k < 0 or k >= n:
                continue
            new = int(sg[r])
            if r == 0 or rest_all[r - 1]:
                ins.stand[k] = max(ins.stand.get(k, 0.0), longest)
                ins.stands.append((k, col, new))
                continue
            if (
                k >= 1
                and r >= 2
                and sg[r - 1] == 0
                and sg[r - 2] == 0
                and abs(float(P_all[r - 1, col] - P_all[r - 2, col])) < 1e-9
            ):
                # the motor stood through the step before while the path moved on: it
                # crosses at that step's end, standing, and leaves from contact
                t1 = float(t_end[k - 1])
                t0 = t1 - float(dt[k - 1])
                ta = t0 if t1 - t0 <= 1.5 * longest else t1 - longest
                ins.windows.append((k - 1, col, ta, t1, new))
                if t0 < ta and ta not in ins.mid.get(k - 1, []):
                    ins.mid.setdefault(k - 1, []).append(ta)
                continue
            h = float(dt[k])
            s, acc = velocity_root(
                float(P_all[r - 1, col]),
                float(V_all[r - 1, col]),
                float(P_all[r, col]),
                float(V_all[r, col]),
                h,
            )
            t1 = float(t_end[k])
            t0 = t1 - h
            ta, tb = window(t0, t1, t0 + s * h, acc, tol, longest)
            # motors reversing together (a path reversing) share their points
            known = [t0, t1, *ins.mid.get(k, [])]
            ta = (
                min(known, key=lambda x: abs(x - ta))
                if min(abs(x - ta) for x in known) < SNAP_S
                else ta
            )
            tb = (
                min(known, key=lambda x: abs(x - tb))
                if min(abs(x - tb) for x in known) < SNAP_S
                else tb
            )
            ins.windows.append((k, col, ta, tb, new))
            p0, v0 = float(P_all[r - 1, col]), float(V_all[r - 1, col])
            p1, v1 = float(P_all[r, col]), float(V_all[r, col])
            ins.contact[(k, col)] = float(
                (2 * s**3 - 3 * s**2 + 1) * p0
                + (s**3 - 2 * s**2 + s) * h * v0
                + (-2 * s**3 + 3 * s**2) * p1
                + (s**3 - s**2) * h * v1
            )
            got = ins.mid.setdefault(k, [])
            for t in (ta, tb):
                if t0 < t < t1 and t not in got:
                    got.append(t)
    for k in list(ins.mid):
        if ins.mid[k]:
            ins.mid[k].sort()
        else:
            del ins.mid[k]
    return ins


def sides(
    step: np.ndarray,
    when: np.ndarray,
    standing_before: np.ndarray,
    V: np.ndarray,
    resting: np.ndarray,
    ins: Insertions,
    cols: list[int],
    side: np.ndarray,
) -> np.ndarray:
    """The side (+1, −1) every motor is on at every point of a chunk (new points
    included), and so which of lo⁻¹ and hi⁻¹ commands it: the direction of its
    planned velocity, held while it stands, switched inside a crossing window only
    at the window's end.

    step : (m,) the original row whose step each point belongs to
    when : (m,) time of each point since the point before the chunk [s]
    standing_before : (m,) bool, the point is a standing point put before its row
    V, resting : (m, 5), (m,) planned motor velocities, path at rest
    side : (5,) the side before the chunk
    """
    m = len(step)
    out = np.tile(np.asarray(side, dtype=int), (m, 1))
    for col in cols:
        sg = np.where(resting, 0, signs(V[:, col]))
        for k, c, _ta, tb, new in ins.windows:
            if c == col:
                row = (step == k) & ~standing_before
                # the whole step up to the window's end is on the old side (the
                # velocity may turn a little before the window begins)
                sg = np.where(row & (when < tb), -new, sg)
                # at the window's end the motor has crossed, moving or not
                sg = np.where(row & (when == tb), new, sg)
        for k, c, new in ins.stands:
            if c == col:
                sg = np.where((step == k) & standing_before, new, sg)
        idx = np.where(sg != 0, np.arange(m), -1)
        last = np.maximum.accumulate(idx)
        out[:, col] = np.where(last >= 0, sg[np.maximum(last, 0)], side[col])
    return out


def contact_targets(
    step: np.ndarray,
    when: np.ndarray,
    standing_before: np.ndarray,
    P: np.ndarray,
    ins: Insertions,
) -> np.ndarray:
    """The wanted positions with each crossing window's end moved to the reversal's
    extreme: there the motor meets the part, which stood at that extreme through
    the window, at the planned velocity, and it picks the part up without a jolt
    (the difference to the wanted position, |A| (δ/2)² / 2 at most, is made up
    over the next step)."""
    out = P.copy()
    for k, col, _ta, tb, _new in ins.windows:
        if (k, col) in ins.contact:
            row = np.flatnonzero((step == k) & ~standing_before & (when == tb))
            out[row, col] = ins.contact[(k, col)]
    return out


#: Samples per step when the chain follows its own commands through the play.
EMULATE_SUBSTEPS = 8


def follow(
    table: object,
    y0: float,
    P0: float,
    V0: float,
    P: np.ndarray,
    V: np.ndarray,
    dt: np.ndarray,
) -> np.ndarray:
    """Where a motor's driven part is along the cubics the controller runs through
    commands (P, V) from (P0, V0), starting at y0 (the contract's play model on the
    continuous command); (n, EMULATE_SUBSTEPS) samples, the last of each row at the
    row's point."""
    from .axiscomp import _clamp_scan

    n = len(P)
    s = np.linspace(0.0, 1.0, EMULATE_SUBSTEPS + 1)[1:]
    Pa = np.concatenate([[P0], P[:-1]])
    Va = np.concatenate([[V0], V[:-1]])
    h = dt[:, None]
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    cmd = h00 * Pa[:, None] + h10 * h * Va[:, None] + h01 * P[:, None] + h11 * h * V[:, None]
    flat = cmd.reshape(-1)
    lo = table.lo(flat)  # type: ignore[attr-defined]
    hi = table.hi(flat)  # type: ignore[attr-defined]
    y = _clamp_scan(np.concatenate([[y0], lo]), np.concatenate([[y0], hi]))[1:]
    return y.reshape(n, EMULATE_SUBSTEPS)
