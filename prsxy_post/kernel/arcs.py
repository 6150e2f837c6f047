"""The arc search of corrected G-code: runs of written points one G2/G3 replaces.

The reference (numpy over each candidate run, the C library's ``atan2`` through
:mod:`math`) of the compiled twin ``_arcs.pyx``, which gives the same bits. The
writer (``writers.arcs``, ``writers.linuxcnc`` rule 5) calls :func:`find_arcs` once a
chunk, and the G-code kernel (``gwrite.refit``; its twin the twin's)
:func:`refit_arcs` where it needs an arc from a later start; the geometry (the arc
LinuxCNC runs from the written words, the fit, the search) is described in
``writers/arcs.py``.

The fit, per plane (G17: X Y, axis Z; G18: Z X, axis Y; G19: Y Z, axis X): the
center lies on the perpendicular bisector of start and end, m + t n; t minimises
the algebraic residuals |p − c|² − |s − c|² of the points between,
t = Σ a b / Σ b² with a = |p − m|² − |s − m|², b = 2 n·(p − m) (sums left to right,
as a C loop adds: ``np.cumsum``'s last element, not ``np.dot``, whose BLAS kernel
picks its own order); the center is rounded as it is written (numpy's round:
rint(x 10^d) / 10^d) and every point judged against the arc with it. Radii are
sqrt(u² + v²), not ``np.hypot`` (numpy's vector hypot differs from the C library's
in the last bit on AVX-512 machines; sqrt is correctly rounded everywhere); angles
are the C library's atan2, their steps wrapped into [−π, π) with numpy's floor
remainder and summed left to right.

Rows returned: ``arc_i (M, 4) int64`` start, end (point indices), plane (17, 18,
19), ccw (1: G3, 0: G2); ``arc_f (M, 6)`` the center as written X Y Z [mm] (its w
the start's), LinuxCNC's length [mm], the largest distance of a replaced point from
the arc [mm], the smaller of the radii at the start and the end [mm]. Inputs are
finite.
"""

from __future__ import annotations

import math

import numpy as np

from . import libm

#: the plane's first and second axis and its normal (rs274ngc's order), by G17/G18/G19
PLANES: dict[int, tuple[int, int, int]] = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
#: the fewest points an arc replaces (its end included): below it a chord or two do
MIN_POINTS = 4
#: the largest sweep of one arc [rad]: the center comes from the chord's bisector,
#: ill-conditioned as the ends close in on a full turn
MAX_SWEEP = 1.5 * math.pi
#: half the window over which a point is looked at for a bend: an arc is looked
#: for only where the points 2 x this apart stray from their chord by more than the
#: tolerance (elsewhere the chords are long)
WINDOW = 4

#: one fitted arc: (ccw, (center x, y, z, length, error, radius))
Fit = tuple[bool, tuple[float, float, float, float, float, float]]


def _sum(x: np.ndarray) -> float:
    """The sum of x left to right (a C loop's order)."""
    return float(np.cumsum(x)[-1]) if len(x) else 0.0


def _round(x: float, decimals: int) -> float:
    """numpy's round of a float64 to ``decimals`` ≥ 0 decimals: rint(x 10^d) / 10^d."""
    p = 10.0**decimals
    return float(np.rint(x * p)) / p


def fit(q: np.ndarray, plane: int, tol_mm: float, tol_deg: float, decimals: int) -> Fit | None:
    """The arc from q[0] to q[-1] through the points between in ``plane``, or None.

    q : (m, 5) [mm, mm, mm, deg, deg] written points; the arc starts at q[0]
    (written before it) and ends at q[-1]. None where m < 3, a point lies farther
    than ``tol_mm`` from the arc (its radius against the radius linear in the angle
    between the ends', its w against w linear in the angle), its A or B farther
    than ``tol_deg`` from the line between the ends', the angles do not advance one
    way, the sweep exceeds :data:`MAX_SWEEP`, or the points lie on the chord.
    """
    iu, iv, iw = PLANES[plane]
    m = len(q)
    if m < 3:
        return None
    su, sv, sw = float(q[0, iu]), float(q[0, iv]), float(q[0, iw])
    eu, ev, ew = float(q[-1, iu]), float(q[-1, iv]), float(q[-1, iw])
    cu, cv = eu - su, ev - sv
    chord = math.sqrt(cu * cu + cv * cv)
    if not chord > 0.0:
        return None
    nu, nv = -cv / chord, cu / chord
    mu, mv = 0.5 * (su + eu), 0.5 * (sv + ev)
    xu, xv = q[1:-1, iu] - mu, q[1:-1, iv] - mv
    a = xu * xu + xv * xv - 0.25 * chord * chord
    b = 2.0 * (nu * xu + nv * xv)
    bb = _sum(b * b)
    if not bb > 0.0:
        return None
    t = _sum(a * b) / bb
    # the center as written: offsets from the (written) start, rounded
    ccu = su + _round(mu + t * nu - su, decimals)
    ccv = sv + _round(mv + t * nv - sv, decimals)
    pu, pv = q[:, iu] - ccu, q[:, iv] - ccv
    rho = np.sqrt(pu * pu + pv * pv)
    r0, r1 = float(rho[0]), float(rho[-1])
    r_lo, r_hi = (r1, r0) if r1 < r0 else (r0, r1)
    # a radius beyond both ends' by more than the tolerance fails whatever the angles
    if np.any(rho > r_hi + tol_mm) or np.any(rho < r_lo - tol_mm):
        return None
    # the angles, unwrapped along the points (each step within ±π)
    steps = np.diff(libm.atan2(pv, pu))
    steps = (steps + math.pi) % (2.0 * math.pi) - math.pi
    if not (np.all(steps > 0.0) or np.all(steps < 0.0)):
        return None
    phi = np.concatenate(([0.0], np.cumsum(steps)))
    sweep = float(phi[-1])
    if not abs(sweep) <= MAX_SWEEP:
        return None
    f = phi / sweep
    radial = rho - (r0 + (r1 - r0) * f)
    axial = q[:, iw] - (sw + (ew - sw) * f)
    err = float(np.sqrt(radial * radial + axial * axial).max())
    if not err <= tol_mm:
        return None
    for j in (3, 4):
        s_ab, e_ab = float(q[0, j]), float(q[-1, j])
        if not np.all(np.abs(q[:, j] - (s_ab + (e_ab - s_ab) * f)) <= tol_deg):
            return None
    center = [0.0, 0.0, 0.0]
    center[iu], center[iv], center[iw] = ccu, ccv, sw
    # LinuxCNC's length: the spiral's by the smaller radius and the radial change,
    # with the axial motion (emccanon.cc:1754-1762)
    x, y = r_lo * abs(sweep), r1 - r0
    spiral = math.sqrt(x * x + y * y)
    length = math.sqrt(spiral * spiral + (ew - sw) * (ew - sw))
    return sweep > 0.0, (center[0], center[1], center[2], length, err, r_lo)


def fit_arc(q: np.ndarray, plane: int, tol_mm: float, tol_deg: float, decimals: int) -> np.ndarray:
    """:func:`fit` as a row (7,): ccw (1.0 or 0.0), the center X Y Z, the length,
    the error, the radius; NaN throughout where no arc fits."""
    got = fit(np.asarray(q, dtype=float), plane, tol_mm, tol_deg, decimals)
    if got is None:
        return np.full(7, np.nan)
    return np.array([1.0 if got[0] else 0.0, *got[1]])


def _best(
    q: np.ndarray, tol_mm: float, tol_deg: float, decimals: int, planes: tuple[int, ...]
) -> tuple[int, Fit] | None:
    """The arc through q in whichever of ``planes`` fits it best (the least error,
    the first on a tie), or None."""
    best: tuple[int, Fit] | None = None
    for plane in planes:
        got = fit(q, plane, tol_mm, tol_deg, decimals)
        if got is not None and (best is None or got[1][4] < best[1][1][4]):
            best = (plane, got)
    return best


def _bends(q: np.ndarray, tol_mm: float) -> np.ndarray:
    """(n,) bool: points where the chord of the points :data:`WINDOW` before and
    after strays from the point by more than ``tol_mm`` in X Y Z."""
    n = len(q)
    out = np.zeros(n, dtype=bool)
    w = WINDOW
    if n < 2 * w + 1:
        return out
    a, p, b = q[: n - 2 * w, :3], q[w : n - w, :3], q[2 * w :, :3]
    d = b - a
    x = p - a
    dd = d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1] + d[:, 2] * d[:, 2]
    u = (x[:, 0] * d[:, 0] + x[:, 1] * d[:, 1] + x[:, 2] * d[:, 2]) / np.where(dd > 0.0, dd, 1.0)
    r = p - (a + u[:, None] * d)
    off = np.sqrt(r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1] + r[:, 2] * r[:, 2])
    out[w : n - w] = (off > tol_mm) & (dd > 0.0)
    return out


def _sag(seg: np.ndarray) -> float:
    """The largest distance of the X Y Z points ``seg`` (k, ≥3) from the segment
    between the first and the last."""
    s0 = seg[0, :3]
    d = seg[-1, :3] - s0
    x = seg[:, :3] - s0
    dd = float(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
    if dd > 0.0:
        u = np.clip((x[:, 0] * d[0] + x[:, 1] * d[1] + x[:, 2] * d[2]) / dd, 0.0, 1.0)
    else:
        u = np.zeros(len(seg))
    r = seg[:, :3] - (s0 + u[:, None] * d)
    return float(np.sqrt(r[:, 0] * r[:, 0] + r[:, 1] * r[:, 1] + r[:, 2] * r[:, 2]).max())


def _keeps(rate: np.ndarray, lead: np.ndarray, lead_tol: float, dip_share: float) -> bool:
    """Whether one line may carry these pieces' timing: the rates (of the pieces
    after the start) do not dip and rise again by more than ``dip_share`` (the line
    is timed at its fastest piece), and what the real-axis tables add to a motor
    (``lead``, the start's first) moves by no more than ``lead_tol``."""
    if np.any(np.abs(lead[1:] - lead[0]) > lead_tol):
        return False
    peak = np.maximum.accumulate(rate)
    dipped = np.flatnonzero(rate < peak * (1.0 - dip_share))
    if len(dipped) == 0:
        return True
    tail = rate[dipped[0] :]
    return bool(np.all(tail <= np.minimum.accumulate(tail) * (1.0 + dip_share)))


def _rows(found: list[tuple[int, int, int, Fit]]) -> tuple[np.ndarray, np.ndarray]:
    """(arc_i (M, 4), arc_f (M, 6)) of (start, end, plane, fit) tuples."""
    arc_i = np.array([[s, e, p, 1 if g[0] else 0] for s, e, p, g in found], dtype=np.int64).reshape(
        -1, 4
    )
    arc_f = np.array([g[1] for _, _, _, g in found], dtype=float).reshape(-1, 6)
    return arc_i, arc_f


def _free_runs(free: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each point's run of free points: its first and last index (-1: not free)."""
    n = len(free)
    first = np.full(n, -1, dtype=np.int64)
    last = np.full(n, -1, dtype=np.int64)
    edge = np.flatnonzero(np.diff(np.r_[False, free, False].astype(np.int8)))
    for a, b in zip(edge[::2].tolist(), edge[1::2].tolist(), strict=True):
        first[a:b], last[a:b] = a, b - 1
    return first, last


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
    """The arcs among the written points q (n, 5), each from a point to a later
    one, as rows (module docstring).

    free (n,) bool: points a line may pass over; ends (n,) bool: points an arc may
    end and start at besides the free ones; rate (n,): each point's piece rate;
    lead (n, 5): what the real-axis tables add to each motor [mm]; tilt_span: the
    most A or B may change over one arc [deg] (inf: any). Greedy from the start of
    each run of free points with a bend (or the last arc's end): the run grows by
    doubling while an arc fits (every plane, then the first one's) and the rates
    and the tables allow one line, then by bisection to the longest that fits; an
    arc within ``tol_mm`` of its chord is left to the chord
    (``writers.arcs.find_arcs`` states the rules).
    """
    n = len(q)
    found: list[tuple[int, int, int, Fit]] = []
    if n < MIN_POINTS + 1:
        return _rows(found)
    bends = _bends(q, tol_mm) & free
    first_free, last_free = _free_runs(free)
    i0 = 0
    for c in np.flatnonzero(bends).tolist():
        if c < i0:
            continue
        # from the point before the run where a line may end there in motion (a
        # block's end), else from its first point
        before = int(first_free[c]) - 1
        start = max(before if before >= 0 and ends[before] else before + 1, i0)
        if start >= n - 1 or not free[start + 1]:
            continue
        hi = int(last_free[start + 1])
        if hi + 1 < n and ends[hi + 1]:
            hi += 1
        planes: tuple[int, ...] = tuple(PLANES)

        def fits(e: int, s: int = start) -> tuple[int, Fit] | None:
            if not _keeps(rate[s + 1 : e + 1], lead[s : e + 1], tol_mm, dip_share):
                return None
            ab = q[s : e + 1, 3:5]
            if np.any(ab.max(axis=0) - ab.min(axis=0) > tilt_span):
                return None
            return _best(q[s : e + 1], tol_mm, tol_deg, decimals, planes)  # noqa: B023

        good: tuple[int, tuple[int, Fit]] | None = None
        step = MIN_POINTS
        e = start + step
        bad = hi + 1
        while e <= hi:
            got = fits(e)
            if got is None:
                bad = e
                break
            good = (e, got)
            planes = (got[0],)  # the run grows in the plane it started in
            step *= 2
            e = start + step
        if good is None:
            # no arc from here: the next bend tries a start a few points later
            i0 = start + MIN_POINTS
            continue
        lo, hi_try = good[0], min(bad, hi + 1)
        while hi_try - lo > 1:
            mid = (lo + hi_try) // 2
            got = fits(mid)
            if got is None:
                hi_try = mid
            else:
                lo, good = mid, (mid, got)
        end, (plane, fitted) = good
        if not _sag(q[start : end + 1]) <= tol_mm:
            found.append((start, end, plane, fitted))
        i0 = end
    return _rows(found)


def refit_arcs(
    q: np.ndarray,
    plane: int,
    start: int,
    end: int,
    tol_mm: float,
    tol_deg: float,
    decimals: int,
) -> tuple[np.ndarray, np.ndarray]:
    """The points q[start : end + 1] as arcs in ``plane``, as rows: the longest
    that fits from ``start`` (doubling, then bisection), then from its end on; a
    point no arc of 2 or more fits from is left to a line."""
    found: list[tuple[int, int, int, Fit]] = []
    s = start
    while end - s >= 2:
        good: tuple[int, Fit] | None = None
        e, bad = s + 2, end + 1
        while e <= end:
            got = fit(q[s : e + 1], plane, tol_mm, tol_deg, decimals)
            if got is None:
                bad = e
                break
            good = (e, got)
            e = s + 2 * (e - s)
        if good is None:
            s += 1
            continue
        lo, hi = good[0], min(bad, end + 1)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            got = fit(q[s : mid + 1], plane, tol_mm, tol_deg, decimals)
            if got is None:
                hi = mid
            else:
                lo, good = mid, (mid, got)
        found.append((s, good[0], plane, good[1]))
        s = good[0]
    return _rows(found)
