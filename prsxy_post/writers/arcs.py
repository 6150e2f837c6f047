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

The fit and the search run in the kernel (:mod:`prsxy_post.kernel.arcs`, compiled
as ``_arcs.pyx``), once a chunk, on arrays; this module turns its rows into
:class:`Arc` records and writes an arc's words.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import kernel
from ..kernel.arcs import MAX_SWEEP, MIN_POINTS, PLANES, WINDOW
from .numbers import format_fixed_rows

__all__ = ["MAX_SWEEP", "MIN_POINTS", "PLANES", "WINDOW", "Arc", "ArcTable", "arc_words"]
__all__ += ["arc_lines", "find_arcs", "fit_arc", "refit_arcs"]


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


def _arcs(rows: tuple[np.ndarray, np.ndarray]) -> list[Arc]:
    """The kernel's rows (arc_i (M, 4): start, end, plane, ccw; arc_f (M, 6): the
    center X Y Z, length, error, radius) as records."""
    arc_i, arc_f = rows
    return [
        Arc(s, e, p, bool(c), (f[0], f[1], f[2]), f[3], f[4], f[5])
        for (s, e, p, c), f in zip(arc_i.tolist(), arc_f.tolist(), strict=True)
    ]


def fit_arc(q: np.ndarray, plane: int, tol_mm: float, tol_deg: float, decimals: int) -> Arc | None:
    """The arc from q[0] to q[-1] through the points between, or None.

    q : (m, 5) [mm, mm, mm, deg, deg] written points, m ≥ 3; the arc starts at
    q[0] (written before it) and ends at q[-1]. ``decimals``: the written center's
    rounding (I J K are offsets from the written start). None where a point lies
    farther than ``tol_mm`` from the arc, its A or B farther than ``tol_deg`` from
    the line between the ends' (A and B run linearly along the move), the angles
    do not advance one way, the sweep exceeds :data:`MAX_SWEEP`, or the points lie
    on the chord (no circle to fit). :func:`prsxy_post.kernel.fit_arc`.
    """
    row = kernel.fit_arc(q, plane, tol_mm, tol_deg, decimals)
    if math.isnan(row[0]):
        return None
    f = row.tolist()
    return Arc(0, len(q) - 1, plane, f[0] > 0.0, (f[1], f[2], f[3]), f[4], f[5], f[6])


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
    Greedy from the start of each run of free points with a bend (the points
    :data:`WINDOW` before and after stray from their chord by more than ``tol_mm``)
    or the last arc's end: the run grows by doubling while an arc fits (every
    plane at first, then the plane of the first fit) and the rates (no dip and rise
    by more than ``dip_share``) and the tables allow one line, then by bisection
    to the longest that fits. :func:`prsxy_post.kernel.find_arcs`, one call.
    """
    return _arcs(
        kernel.find_arcs(q, free, ends, rate, lead, tol_mm, tol_deg, decimals, dip_share, tilt_span)
    )


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
    may no longer fit the points its parent did. :func:`prsxy_post.kernel.refit_arcs`.
    """
    end = arc.end if end is None else end
    return _arcs(kernel.refit_arcs(q, arc.plane, start, end, tol_mm, tol_deg, decimals))


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


class ArcTable:
    """A chunk's arcs as the arc kernel gives them (:func:`prsxy_post.kernel.find_arcs`,
    :func:`prsxy_post.kernel.refit_arcs`), kept as arrays: no :class:`Arc` record a
    row, and rows appended where the writer refits, in place.

    ``ai`` (M, 4) int64: start, end, plane, ccw; ``af`` (M, 6): the center X Y Z as
    written [mm], length [mm], error [mm], the least radius [mm]; ``arc_of`` (n,)
    int64: the arc each of the chunk's n points lies on after its start (-1: none).
    The rows the G-code writer's kernel takes (:func:`prsxy_post.kernel.gcode_ops`):
    ``k_i`` (M, 4) start, end, plane, refitted; ``k_f`` (M, 2) length, radius.
    """

    def __init__(self, rows: tuple[np.ndarray, np.ndarray], n: int) -> None:
        ai, af = rows
        cap = 2 * len(ai) + 16
        self.m = 0
        self._ai = np.zeros((cap, 4), dtype=np.int64)
        self._af = np.zeros((cap, 6))
        self._ki = np.zeros((cap, 4), dtype=np.int64)
        self._kf = np.zeros((cap, 2))
        self.arc_of = np.full(n, -1, dtype=np.int64)
        self.add((ai, af), refit=False)

    def add(
        self, rows: tuple[np.ndarray, np.ndarray], refit: bool = True, arc_of: bool = True
    ) -> int:
        """Append the kernel's rows (arc_i, arc_f), each arc named on its points
        after its start in ``arc_of`` (unless not ``arc_of``); the index of the first."""
        ai, af = rows
        first, m = self.m, self.m + len(ai)
        if m > len(self._ai):
            cap = 2 * m
            for name in ("_ai", "_af", "_ki", "_kf"):
                old = getattr(self, name)
                new = np.zeros((cap, old.shape[1]), dtype=old.dtype)
                new[:first] = old[:first]
                setattr(self, name, new)
        self._ai[first:m] = ai
        self._af[first:m] = af
        self._ki[first:m, :3] = ai[:, :3]
        self._ki[first:m, 3] = int(refit)
        self._kf[first:m] = af[:, 3::2]  # length, radius
        self.m = m
        if not arc_of:
            return first
        # each arc's points after its start (the arcs do not overlap)
        if len(ai) < 8:  # a refit's few: slices cost less than the index arrays
            for j, (s, e) in enumerate(ai[:, :2].tolist()):
                self.arc_of[s + 1 : e + 1] = first + j
            return first
        span = ai[:, 1] - ai[:, 0]
        if span.sum():
            at = np.arange(int(span.sum())) - np.repeat(np.cumsum(span) - span, span)
            self.arc_of[at + np.repeat(ai[:, 0] + 1, span)] = np.repeat(
                np.arange(first, m, dtype=np.int64), span
            )
        return first

    @property
    def ai(self) -> np.ndarray:
        return self._ai[: self.m]

    @property
    def af(self) -> np.ndarray:
        return self._af[: self.m]

    @property
    def k_i(self) -> np.ndarray:
        return self._ki[: self.m]

    @property
    def k_f(self) -> np.ndarray:
        return self._kf[: self.m]

    def row(self, a: int) -> tuple[np.ndarray, np.ndarray]:
        """The arc ``a``'s rows (ai (4,), af (6,)), copies."""
        return self._ai[a].copy(), self._af[a].copy()


def arc_lines(
    end: np.ndarray,
    f: np.ndarray,
    start: np.ndarray,
    ai: np.ndarray,
    af: np.ndarray,
    decimals: int,
) -> list[str]:
    """The G2/G3 lines of arcs whose rows are ``ai`` (P, 4), ``af`` (P, 6)
    (:class:`ArcTable`'s), each from the written point ``start`` (P, 5) to ``end``
    (P, 5) (its A B as written) with the inverse time ``f`` (P,): ``G3 X.. Y.. Z..
    A.. B.. I.. J.. F..`` (:func:`arc_words`' motion and center words around the
    end's, F with three decimals), the same text row for row, made for all rows
    at once (:func:`.numbers.format_fixed_rows`). ``%.{d}f`` of a center offset
    prints what :func:`arc_words` prints of it rounded (both the value's exactly
    rounded decimals), but for a negative offset that rounds to zero, which
    :func:`arc_words` writes without its sign."""
    out = np.empty(len(ai), dtype=object)
    plane, ccw = ai[:, 2], ai[:, 3] != 0
    zero = "0." + "0" * decimals if decimals else "0"
    for p, (iu, iv, _) in PLANES.items():
        wu, wv = CENTER_WORDS[p]
        for turn in (False, True):
            at = np.flatnonzero((plane == p) & (ccw == turn))
            if not at.size:
                continue
            e, s, c = end[at], start[at], af[at]
            cols = [("G3 X" if turn else "G2 X", e[:, 0]), (" Y", e[:, 1]), (" Z", e[:, 2])]
            cols += [(" A", e[:, 3]), (" B", e[:, 4])]
            cols += [(f" {wu}", c[:, iu] - s[:, iu]), (f" {wv}", c[:, iv] - s[:, iv])]
            rows = format_fixed_rows([(pre, v, decimals) for pre, v in cols] + [(" F", f[at], 3)])
            for word in (wu, wv):
                neg = f" {word}-{zero} "
                rows = [r.replace(neg, f" {word}{zero} ") if neg in r else r for r in rows]
            out[at] = rows
    lines: list[str] = out.tolist()
    return lines
