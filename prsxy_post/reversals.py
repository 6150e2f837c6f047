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

import math

import numpy as np

#: A planned motor velocity below this [mm/s] gives no direction: a motor creeping
#: (a table following the head's parasitic motion by nanometres) does not make the
#: part cross its play at every wobble; its drift is watched instead (DRIFT_SHARE).
V_EPS = 1e-3
#: The shortest window [s]: a PVT segment of the controller's own servo cycle.
MIN_WINDOW_S = 0.25e-3
#: A creeping motor (slower than V_EPS) may drift back from where it last moved
#: by this share of the reversal allowance before it crosses its play.
DRIFT_SHARE = 1.0
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
            # the numerically stable pair of roots
            qq = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            roots = [qq / a, c / qq] if qq != 0 else [-b / (2 * a)]
    inside = [r for r in roots if -1e-9 <= r <= 1.0 + 1e-9]
    if not inside:
        # the velocities at the ends have opposite signs, so a root exists; only
        # rounding can hide it: take the linear estimate
        s = V0 / (V0 - V1) if V0 != V1 else 0.5
    else:
        # the root where the sign changes from V0's: the first one
        s = min(inside)
    s = min(max(s, 0.0), 1.0)
    return s, (2.0 * a * s + b) / h


def window(
    t0: float, t1: float, t_root: float, accel: float, tol: float, longest: float
) -> tuple[float, float]:
    """The crossing window around a reversal at ``t_root`` inside the step [t0, t1]."""
    width = longest if accel == 0 else math.sqrt(8.0 * tol / abs(accel))
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


def _creeps(sg: np.ndarray, P: np.ndarray, side: int, ref: float, drift: float) -> np.ndarray:
    """Rows where a creeping motor (no direction) has drifted back by more than
    ``drift`` from where it last moved: each becomes a reversal (the new sign), and
    the drift is measured afresh from there."""
    out = np.zeros(len(sg), dtype=int)
    start = 0
    cur_side, cur_ref = side, ref
    while start < len(sg):
        seg = sg[start:]
        # the direction and wanted position each row comes from
        idx = np.where(seg != 0, np.arange(len(seg)), -1)
        last = np.maximum.accumulate(idx)
        came = np.where(last >= 0, seg[np.maximum(last, 0)], cur_side)
        base = np.where(last >= 0, P[start:][np.maximum(last, 0)], cur_ref)
        back = (seg == 0) & (came * (P[start:] - base) < -drift)
        hits = np.flatnonzero(back)
        if not hits.size:
            break
        r = start + int(hits[0])
        out[r] = -int(came[hits[0]])
        cur_side, cur_ref = out[r], float(P[r])
        start = r + 1
    return out


class Insertions:
    """What a chunk of points needs for its reversals (:func:`plan_insertions`).

    stand : row k → duration of a standing point put before it
    mid : row k → times (since the chunk's previous point) of points put inside
        the step that ends at row k
    windows : (k, col, t_a, t_b, new) crossing windows inside steps: the motor is on
        its old side −new up to t_a and on the new side from t_b
    stands : (k, col, new) motors that cross at the standing point before row k
    """

    def __init__(self) -> None:
        self.stand: dict[int, float] = {}
        self.mid: dict[int, list[float]] = {}
        self.windows: list[tuple[int, int, float, float, int]] = []
        self.stands: list[tuple[int, int, int]] = []

    def __bool__(self) -> bool:
        return bool(self.stand or self.mid)


def _add(
    ins: Insertions, k: int, col: int, ta: float, tb: float, new: int, t0: float, t1: float
) -> None:
    """A crossing window in step k (t0..t1); motors reversing together (a path
    reversing) share their points: an edge within SNAP_S of one already there is it."""
    got = ins.mid.setdefault(k, [])
    edges = []
    for t in (ta, tb):
        near = min([t0, t1, *got], key=lambda x: abs(x - t))
        t = near if abs(near - t) < SNAP_S else t
        edges.append(t)
        if t0 < t < t1 and t not in got:
            got.append(t)
    ins.windows.append((k, col, edges[0], edges[1], new))


def plan_insertions(
    t_end: np.ndarray,
    dt: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    resting: np.ndarray,
    prev: tuple[np.ndarray, np.ndarray, bool] | None,
    cols: list[int],
    side: np.ndarray,
    ref: np.ndarray,
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
    ref : (5,) the wanted position where each motor last moved with a direction;
        updated in place (a creeping motor's drift is measured from it)
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
    drift = DRIFT_SHARE * tol
    te = t_end.tolist()
    dts = dt.tolist()
    rest = rest_all.tolist()
    for col in cols:
        sg = np.where(rest_all, 0, signs(V_all[:, col]))
        crept = _creeps(sg, P_all[:, col], int(side[col]), float(ref[col]), drift)
        sg = np.where(crept != 0, crept, sg)
        # the side a row comes from: the last direction before it, or the carried one
        idx = np.where(sg != 0, np.arange(len(sg)), -1)
        last = np.maximum.accumulate(idx)
        before = np.concatenate([[-1], last[:-1]])
        came = np.where(before >= 0, sg[np.maximum(before, 0)], side[col])
        # the wanted position where each direction was last taken (for the creep)
        moving_rows = np.flatnonzero(sg != 0)
        if moving_rows.size:
            ref[col] = float(P_all[moving_rows[-1], col])
        flips = np.flatnonzero((sg != 0) & (sg != came)).tolist()
        if not flips:
            continue
        Pc = P_all[:, col].tolist()
        Vc = V_all[:, col].tolist()
        sgl = sg.tolist()
        crl = crept.tolist()
        for r in flips:
            k = r - off
            if k < 0 or k >= n:
                continue
            new = sgl[r]
            at_rest = r == 0 or rest[r - 1]
            if crl[r] != 0 and not at_rest:
                # a creeping motor has drifted back past the allowance: it crosses
                # over the end of this step (its speed makes the crossing's error tiny)
                t1 = te[k]
                t0 = t1 - dts[k]
                ta = max(t0, t1 - longest)
                _add(ins, k, col, ta, t1, new, t0, t1)
                continue
            if at_rest:
                ins.stand[k] = max(ins.stand.get(k, 0.0), longest)
                ins.stands.append((k, col, new))
                continue
            if (
                k >= 1
                and r >= 2
                and sgl[r - 1] == 0
                and sgl[r - 2] == 0
                and (abs(Pc[r - 1] - Pc[r - 2]) < 1e-9)
            ):
                # the motor stood through the step before while the path moved on: it
                # crosses at that step's end, standing, and leaves from contact
                t1 = te[k - 1]
                t0 = t1 - dts[k - 1]
                ta = t0 if t1 - t0 <= 1.5 * longest else t1 - longest
                _add(ins, k - 1, col, ta, t1, new, t0, t1)
                continue
            h = dts[k]
            sr, acc = velocity_root(Pc[r - 1], Vc[r - 1], Pc[r], Vc[r], h)
            t1 = te[k]
            t0 = t1 - h
            ta, tb = window(t0, t1, t0 + sr * h, acc, tol, longest)
            _add(ins, k, col, ta, tb, new, t0, t1)
    for k in list(ins.mid):
        if ins.mid[k]:
            ins.mid[k].sort()
        else:
            del ins.mid[k]
    return ins


class Rows:
    """Where each step's points are in a chunk with new points put in (ordered by
    step, standing points first, then by time)."""

    def __init__(self, step: np.ndarray, when: np.ndarray, standing_before: np.ndarray) -> None:
        self.step = step
        n_steps = int(step[-1]) + 1 if len(step) else 0
        ks = np.arange(n_steps)
        self.first = np.searchsorted(step, ks, "left").tolist()
        self.end = np.searchsorted(step, ks, "right").tolist()
        self.before = standing_before.tolist()
        self.when = when.tolist()

    def plain(self, k: int) -> tuple[int, int]:
        """[first, end) of step k's points that are not standing points."""
        a, e = self.first[k], self.end[k]
        while a < e and self.before[a]:
            a += 1
        return a, e

    def standing(self, k: int) -> int:
        """The standing point put before step k's end (−1 if none)."""
        a = self.first[k]
        return a if a < self.end[k] and self.before[a] else -1

    def at(self, k: int, t: float) -> int:
        """The point of step k at time t (its end when t is the step's end)."""
        f, e = self.plain(k)
        for i in range(f, e):
            if self.when[i] == t:
                return i
        return -1


def sides(
    rows: Rows,
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

    rows : the chunk's points (:class:`Rows`)
    V, resting : (m, 5), (m,) planned motor velocities, path at rest
    side : (5,) the side before the chunk
    """
    m = len(rows.step)
    out = np.tile(np.asarray(side, dtype=int), (m, 1))
    for col in cols:
        sg = np.where(resting, 0, signs(V[:, col]))
        for k, c, _ta, tb, new in ins.windows:
            if c == col:
                f, _ = rows.plain(k)
                end = rows.at(k, tb)
                # the whole step up to the window's end is on the old side (the
                # velocity may turn a little before the window begins); at the
                # window's end the motor has crossed, moving or not
                sg[f:end] = -new
                sg[end] = new
        for k, c, new in ins.stands:
            if c == col:
                sg[rows.standing(k)] = new
        idx = np.where(sg != 0, np.arange(m), -1)
        last = np.maximum.accumulate(idx)
        out[:, col] = np.where(last >= 0, sg[np.maximum(last, 0)], side[col])
    return out


def follow(
    table: object,
    y0: float,
    P0: float,
    V0: float,
    P: np.ndarray,
    V: np.ndarray,
    dt: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a motor's driven part is along the cubics the controller runs through
    commands (P, V) from (P0, V0), starting at y0: the contract's play model on the
    continuous command.

    The play model is rate-independent: its result after a monotone stretch of
    commands depends only on where the stretch ends. So the command's cubic in each
    step is taken at its turning points (the roots of its velocity, a quadratic)
    and its end, and the result is exact, with one or three samples a step.

    Returns
    -------
    y_end : (n,) the part at each point
    y_min, y_max : (n,) the least and greatest position of the part within each
        step (its end included)
    """
    from .axiscomp import _clamp_scan

    n = len(P)
    Pa = np.concatenate([[P0], P[:-1]])
    Va = np.concatenate([[V0], V[:-1]])
    h = dt
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(h > 0, (Pa - P) / h, 0.0)
    a = 6.0 * d + 3.0 * (Va + V)
    b = -6.0 * d - 4.0 * Va - 2.0 * V
    c = Va
    disc = b * b - 4.0 * a * c
    with np.errstate(divide="ignore", invalid="ignore"):
        sq = np.sqrt(np.maximum(disc, 0.0))
        r1 = np.where(np.abs(a) > 1e-300, (-b - sq) / (2 * a), np.where(b != 0, -c / b, -1.0))
        r2 = np.where(np.abs(a) > 1e-300, (-b + sq) / (2 * a), -1.0)
    ok1 = (disc >= 0) & (r1 > 0) & (r1 < 1) & (h > 0)
    ok2 = (disc >= 0) & (r2 > 0) & (r2 < 1) & (h > 0) & (np.abs(r2 - r1) > 0)
    s = np.column_stack([np.where(ok1, r1, np.nan), np.where(ok2, r2, np.nan), np.ones(n)])
    s = np.sort(s, axis=1)  # the turning points in time order (NaN last), the end last
    h00 = 2 * s**3 - 3 * s**2 + 1
    h10 = s**3 - 2 * s**2 + s
    h01 = -2 * s**3 + 3 * s**2
    h11 = s**3 - s**2
    cmd = h00 * Pa[:, None] + h10 * (h * Va)[:, None] + h01 * P[:, None] + h11 * (h * V)[:, None]
    keep = ~np.isnan(s)
    flat = cmd[keep]
    row = np.repeat(np.arange(n), keep.sum(axis=1))
    lo = table.lo(flat)  # type: ignore[attr-defined]
    hi = table.hi(flat)  # type: ignore[attr-defined]
    y = _clamp_scan(np.concatenate([[y0], lo]), np.concatenate([[y0], hi]))[1:]
    bounds = np.flatnonzero(np.concatenate([[True], row[1:] != row[:-1]]))
    y_end = y[np.concatenate([bounds[1:] - 1, [len(y) - 1]])]
    return y_end, np.minimum.reduceat(y, bounds), np.maximum.reduceat(y, bounds)
