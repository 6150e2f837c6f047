"""Arcs among written points: runs of corrected points LinuxCNC can run as one G2/G3.

Corrected G-code writes a point every interpolation period, or a chord where the
points lie within ``tolerance_mm`` of it (:mod:`.linuxcnc`). On a circle those chords
are short (0.09 mm on R10 within 0.1 µm), and LinuxCNC runs a line in no less than
1.02 servo cycles (``TP_MIN_SEGMENT_CYCLES``): arcs at F10000 ran 1.34-1.49 x the
plan. Where the corrected points still lie on a circle (a helix: a circle and a
straight motion along its axis) within the tolerance, one G2/G3 replaces them.

The arc LinuxCNC runs from the written words (``emccanon.cc`` ARC_FEED, its
source at Debian's 2.9.0~pre1 commit f1270d6ed7, lines 1482-1830): the start is the
last written point, the end and the center (I J K, offsets from the start) are the
written numbers; in the plane's coordinates (u, v) and its axis w, the radius runs
linearly in the angle from |start − center| to |end − center| (``spiral``,
emccanon.cc:1700-1704; ``pmCircleInit``, _posemath.c:1818-1825), w linearly in the
angle, and A and B linearly along the move (``pmCartLineInit`` for ``abc`` in
``pmCircle9Init``, tc.c:725). A run is taken as such an arc where every point it
replaces lies within ``tol_mm`` of it (its radius and its w at the point's own
angle: an upper bound of the distance to the spiral) and its A and B within
``tol_deg`` of the line from the start's to the end's.

The fit, per plane (G17: X Y, axis Z; G18: Z X, axis Y; G19: Y Z, axis X, as
rs274ngc names the first and second axes): the center lies on the perpendicular
bisector of start and end, m + t n, so the written arc passes through both; t
minimises the algebraic residuals |p − c|² − |s − c|² of the points between (a
closed-form least squares in one unknown, t = Σ a b / Σ b², a = |p − m|² − |s − m|²,
b = 2 n·(p − m)), and every point is then verified against the arc with the center
rounded as it is written. Runs grow while the fit holds (doubling, then bisection)
and split where it fails.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

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


@dataclass(frozen=True)
class Arc:
    """One G2/G3: from the written point ``start`` to the point ``end`` (indices).

    plane : 17, 18 or 19; ccw : G3 (counterclockwise in the plane's (u, v)), else G2
    center : (3,) [mm] the center as written (X Y Z; its w is the start's)
    length : [mm] the X Y Z length LinuxCNC reckons (emccanon.cc:1754-1762)
    error_mm : the largest distance of a replaced point from the arc [mm]
    radius : the smaller of its radii at the start and the end [mm]
    """

    start: int
    end: int
    plane: int
    ccw: bool
    center: tuple[float, float, float]
    length: float
    error_mm: float
    #: the smaller of the start's and the end's radius in the plane [mm]
    radius: float


def fit_arc(q: np.ndarray, plane: int, tol_mm: float, tol_deg: float, decimals: int) -> Arc | None:
    """The arc from q[0] to q[-1] through the points between, or None.

    q : (m, 5) [mm, mm, mm, deg, deg] written points, m ≥ 3; the arc starts at
    q[0] (written before it) and ends at q[-1]. ``decimals``: the written center's
    rounding (I J K are offsets from the written start). None where a point lies
    farther than ``tol_mm`` from the arc, its A or B farther than ``tol_deg`` from
    the line between the ends' (A and B run linearly along the move), the angles
    do not advance one way, the sweep exceeds :data:`MAX_SWEEP`, or the points lie
    on the chord (no circle to fit).
    """
    iu, iv, iw = PLANES[plane]
    s, e = q[0], q[-1]
    su, sv, eu, ev = s[iu], s[iv], e[iu], e[iv]
    cu, cv = eu - su, ev - sv
    chord = math.hypot(cu, cv)
    if chord <= 0.0 or len(q) < 3:
        return None
    nu, nv = -cv / chord, cu / chord
    mu, mv = 0.5 * (su + eu), 0.5 * (sv + ev)
    xu, xv = q[1:-1, iu] - mu, q[1:-1, iv] - mv
    a = xu * xu + xv * xv - 0.25 * chord * chord
    b = 2.0 * (nu * xu + nv * xv)
    bb = float(np.dot(b, b))
    if bb <= 0.0:
        return None
    t = float(np.dot(a, b)) / bb
    # the center as written: offsets from the (written) start, rounded
    off_u = round(mu + t * nu - su, decimals)
    off_v = round(mv + t * nv - sv, decimals)
    ccu, ccv = float(su + off_u), float(sv + off_v)
    pu, pv = q[:, iu] - ccu, q[:, iv] - ccv
    rho = np.hypot(pu, pv)
    r0, r1 = float(rho[0]), float(rho[-1])
    # a radius beyond both ends' by more than the tolerance fails whatever the angles
    if float(rho.max()) > max(r0, r1) + tol_mm or float(rho.min()) < min(r0, r1) - tol_mm:
        return None
    # the angles, unwrapped along the points (each step within ±pi)
    steps = np.diff(np.arctan2(pv, pu))
    steps = (steps + math.pi) % (2.0 * math.pi) - math.pi
    if not (np.all(steps > 0.0) or np.all(steps < 0.0)):
        return None
    phi = np.concatenate(([0.0], np.cumsum(steps)))
    sweep = float(phi[-1])
    if abs(sweep) > MAX_SWEEP:
        return None
    f = phi / sweep
    radial = rho - (r0 + (r1 - r0) * f)
    axial = q[:, iw] - (s[iw] + (e[iw] - s[iw]) * f)
    err = float(np.sqrt(radial * radial + axial * axial).max())
    if not err <= tol_mm:
        return None
    ab = q[:, 3:5] - (s[3:5] + (e[3:5] - s[3:5]) * f[:, None])
    if not float(np.abs(ab).max()) <= tol_deg:
        return None
    center = [0.0, 0.0, 0.0]
    center[iu], center[iv], center[iw] = ccu, ccv, float(s[iw])
    # LinuxCNC's length: the spiral's by the smaller radius and the radial change,
    # with the axial motion (emccanon.cc:1754-1762)
    spiral = math.hypot(min(r0, r1) * abs(sweep), r1 - r0)
    length = math.hypot(spiral, float(e[iw] - s[iw]))
    return Arc(
        0,
        len(q) - 1,
        plane,
        sweep > 0.0,
        (center[0], center[1], center[2]),
        length,
        err,
        min(r0, r1),
    )


def _best_fit(
    q: np.ndarray, tol_mm: float, tol_deg: float, decimals: int, planes: tuple[int, ...]
) -> Arc | None:
    """The arc through q in whichever of ``planes`` fits it best, or None."""
    best: Arc | None = None
    for plane in planes:
        arc = fit_arc(q, plane, tol_mm, tol_deg, decimals)
        if arc is not None and (best is None or arc.error_mm < best.error_mm):
            best = arc
    return best


def _bends(q: np.ndarray, tol_mm: float) -> np.ndarray:
    """(n,) bool: points where the chord of the points ``WINDOW`` before and after
    strays from the point by more than ``tol_mm`` in X Y Z (a bend chords serve
    badly)."""
    n = len(q)
    out = np.zeros(n, dtype=bool)
    w = WINDOW
    if n < 2 * w + 1:
        return out
    a, p, b = q[: n - 2 * w, :3], q[w : n - w, :3], q[2 * w :, :3]
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    u = np.einsum("ij,ij->i", p - a, d) / np.where(dd > 0.0, dd, 1.0)
    off = np.linalg.norm(p - (a + u[:, None] * d), axis=1)
    out[w : n - w] = (off > tol_mm) & (dd > 0.0)
    return out


def _keeps(rate: np.ndarray, lead: np.ndarray, lead_tol: float, dip_share: float) -> bool:
    """Whether one line may carry these pieces' timing: the rates (of the pieces
    after the start) do not dip and rise again by more than ``dip_share`` (the line
    is timed at its fastest piece), and what the real-axis tables add to a motor
    (``lead``, the start's first) moves by no more than ``lead_tol``."""
    if float(np.abs(lead[1:] - lead[0]).max(initial=0.0)) > lead_tol:
        return False
    peak = np.maximum.accumulate(rate)
    dipped = np.flatnonzero(rate < peak * (1.0 - dip_share))
    if len(dipped) == 0:
        return True
    tail = rate[dipped[0] :]
    return bool(np.all(tail <= np.minimum.accumulate(tail) * (1.0 + dip_share)))


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
    tilt_span: float = math.inf,
) -> list[Arc]:
    """The arcs among the points q, each from a point to a later one.

    q : (n, 5) written points [mm, mm, mm, deg, deg]
    free : (n,) bool, points a line may pass over (no block end, stop, dwell or
        function: those the writer writes as they are)
    ends : (n,) bool, points an arc may end and start at besides the free ones (a
        block's end in motion: an arc that ends short of it leaves a short line
        between two arcs, which LinuxCNC joins slowly); no arc starts at the other
        points that are not free (a stop)
    rate : (n,) each point's piece rate (its length over its time)
    lead : (n, 5) what the real-axis tables add to each motor [mm]: a line carries
        one timing, so an arc never spans a move of it beyond ``tol_mm``
    tilt_span : the most A or B may change over one arc [deg] (a writer that holds
        the tilt splits an arc where it changes: an arc that turns it further is
        no arc there)
    Every point after an arc's start up to the one before its end is free; the
    arcs do not overlap; each replaces at least :data:`MIN_POINTS` points and
    strays from its chord by more than ``tol_mm`` (elsewhere one line does).
    Greedy from the start of each run of free points with a bend (or the last
    arc's end): the run grows by doubling while an arc fits
    (:func:`fit_arc`, every plane) and the rates and the tables allow one line,
    then by bisection to the longest that fits.
    """
    n = len(q)
    out: list[Arc] = []
    if n < MIN_POINTS + 1:
        return out
    bends = _bends(q, tol_mm) & free
    # each run of free points: its first and last index, for each of its points
    edge = np.flatnonzero(np.diff(np.r_[False, free, False].astype(np.int8)))
    first_free = np.full(n, -1)
    last_free = np.full(n, -1)
    for a, b in zip(edge[::2], edge[1::2], strict=True):
        first_free[a:b], last_free[a:b] = a, b - 1
    i0 = 0
    for c in np.flatnonzero(bends):
        if int(c) < i0:
            continue
        # from the point before the run where a line may end there in motion (a
        # block's end), else from its first point: after a stop LinuxCNC runs the
        # first line in G61 (.linuxcnc), and that is one piece, not the arc
        before = int(first_free[c]) - 1
        start = max(before if before >= 0 and ends[before] else before + 1, i0)
        if start >= n - 1 or not free[start + 1]:
            continue
        hi = int(last_free[start + 1])
        if hi + 1 < n and ends[hi + 1]:
            hi += 1

        planes: tuple[int, ...] = tuple(PLANES)

        def fits(e: int, s: int = start) -> Arc | None:
            if not _keeps(rate[s + 1 : e + 1], lead[s : e + 1], tol_mm, dip_share):
                return None
            ab = q[s : e + 1, 3:5]
            if float((ab.max(axis=0) - ab.min(axis=0)).max()) > tilt_span:
                return None
            return _best_fit(q[s : e + 1], tol_mm, tol_deg, decimals, planes)  # noqa: B023

        good: tuple[int, Arc] | None = None
        step = MIN_POINTS
        e = start + step
        bad = hi + 1
        while e <= hi:
            arc = fits(e)
            if arc is None:
                bad = e
                break
            good = (e, arc)
            planes = (arc.plane,)  # the run grows in the plane it started in
            step *= 2
            e = start + step
        if good is None:
            # no arc from here: the next bend tries a start a few points later
            i0 = start + MIN_POINTS
            continue
        lo = good[0]
        hi_try = min(bad, hi + 1)
        while hi_try - lo > 1:
            mid = (lo + hi_try) // 2
            arc = fits(mid)
            if arc is None:
                hi_try = mid
            else:
                lo, good = mid, (mid, arc)
        end, arc = good
        seg = q[start : end + 1, :3]
        d = seg[-1] - seg[0]
        dd = float(d @ d)
        u = np.clip((seg - seg[0]) @ d / dd, 0.0, 1.0) if dd > 0.0 else np.zeros(len(seg))
        sag = float(np.linalg.norm(seg - (seg[0] + u[:, None] * d), axis=1).max())
        if sag <= tol_mm:
            i0 = end  # one chord does
            continue
        out.append(replace(arc, start=start, end=end))
        i0 = end
    return out


def refit_arcs(
    q: np.ndarray,
    arc: Arc,
    start: int,
    tol_mm: float,
    tol_deg: float,
    decimals: int,
    end: int | None = None,
) -> list[Arc]:
    """The points of ``arc`` from ``start`` to ``end`` (its own end by default) as
    arcs in its plane: the longest that fits from ``start``, then from its end on
    (doubling, then bisection); a point no arc of 2 or more fits from is left to
    a line. Where the ends move, the circle through them moves too, and one arc
    may no longer fit the points its parent did."""
    end = arc.end if end is None else end
    out: list[Arc] = []
    s = start
    while end - s >= 2:
        good: Arc | None = None
        e, bad = s + 2, end + 1
        while e <= end:
            a = fit_arc(q[s : e + 1], arc.plane, tol_mm, tol_deg, decimals)
            if a is None:
                bad = e
                break
            good = replace(a, start=s, end=e)
            e = s + 2 * (e - s)
        if good is None:
            s += 1
            continue
        lo, hi = good.end, min(bad, end + 1)
        while hi - lo > 1:
            mid = (lo + hi) // 2
            a = fit_arc(q[s : mid + 1], arc.plane, tol_mm, tol_deg, decimals)
            if a is None:
                hi = mid
            else:
                lo, good = mid, replace(a, start=s, end=mid)
        out.append(good)
        s = good.end
    return out


#: the center's words by plane: offsets along the plane's first and second axis
CENTER_WORDS = {17: ("I", "J"), 18: ("K", "I"), 19: ("J", "K")}


def arc_words(arc: Arc, start: list[float], decimals: int) -> tuple[str, str]:
    """The motion word (G2 or G3) and the center's words (" I.. J.." in G17,
    " K.. I.." in G18, " J.. K.." in G19: offsets from the written ``start``) of
    ``arc``, with ``decimals`` decimals."""
    iu, iv, _ = PLANES[arc.plane]
    wu, wv = CENTER_WORDS[arc.plane]
    ou = round(arc.center[iu] - start[iu], decimals) + 0.0
    ov = round(arc.center[iv] - start[iv], decimals) + 0.0
    return ("G3" if arc.ccw else "G2"), f" {wu}{ou:.{decimals}f} {wv}{ov:.{decimals}f}"
