"""Curves a program asks for (G5, G5.1, G5.2/G5.3): NURBS, evaluated exactly.

A :class:`Nurbs` is the curve C(u) of degree p with control points P_i (the
workpiece frame, mm), weights w_i and knots t_0 ≤ … ≤ t_{n+p}:

    C(u) = Σ N_{i,p}(u) w_i P_i / Σ N_{i,p}(u) w_i,     u ∈ [t_p, t_n]

(N the B-spline basis). G5 (a cubic) and G5.1 (a quadratic) are Bézier curves,
single spans of degree 3 and 2; G5.2 builds LinuxCNC's NURBS of order L
(degree L − 1) with its open uniform integer knot vector
(``nurbs_additional_functions.cc``: knot_vector_creator). Evaluation is
vectorised over arrays of u: the homogeneous curve A(u) = Σ N w P, W(u) = Σ N w
is a polynomial B-spline (:class:`scipy.interpolate.BSpline`), and

    C = A / W,   C' = (A' − W' C) / W,   C'' = (A'' − 2 W' C' − W'' C) / W.

The arc length s(u) = ∫ |C'| du is integrated by Gauss–Legendre quadrature on a
table of sub-intervals of each knot span, refined until two orders agree to
1e-12 mm; :meth:`Nurbs.u_at` inverts it by Newton's method (with bisection as a
guard), to 1e-9 mm of arc length. The planner walks the curve by arc length;
A and B (which G5 cannot move) go linearly from the motion's start to its end.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from scipy.interpolate import BSpline

#: arc-length accuracy of :meth:`Nurbs.u_at` [mm]
LENGTH_TOLERANCE = 1e-9


@functools.cache
def _gauss(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights of order ``n`` on [-1, 1] (made on first
    use: numpy.polynomial costs 2 ms of every command's start-up otherwise)."""
    from numpy.polynomial.legendre import leggauss

    x, w = leggauss(n)
    return x, w


@dataclass(frozen=True, eq=False)
class Nurbs:
    """A NURBS curve in the workpiece frame.

    control : (n, 3) control points [mm] (x, y, z)
    weights : (n,) positive weights
    knots : (n + degree + 1,) non-decreasing
    degree : p >= 1
    """

    control: np.ndarray
    weights: np.ndarray
    knots: np.ndarray
    degree: int
    _spline: BSpline = field(init=False, repr=False, compare=False)
    _d1: BSpline = field(init=False, repr=False, compare=False)
    _d2: BSpline | None = field(init=False, repr=False, compare=False)
    _table: tuple[np.ndarray, np.ndarray] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        c = np.asarray(self.control, dtype=float)
        w = np.asarray(self.weights, dtype=float)
        t = np.asarray(self.knots, dtype=float)
        if c.ndim != 2 or c.shape[1] != 3:
            raise ValueError("control points must be (n, 3)")
        if w.shape != (len(c),) or np.any(w <= 0):
            raise ValueError("one positive weight per control point")
        if t.shape != (len(c) + self.degree + 1,) or np.any(np.diff(t) < 0):
            raise ValueError("knots: n + degree + 1, non-decreasing")
        for name, v in (("control", c), ("weights", w), ("knots", t)):
            v.setflags(write=False)
            object.__setattr__(self, name, v)
        # imported here: scipy.interpolate takes 0.4 s to import, and only
        # programs with splines (G5.x) need it
        from scipy.interpolate import BSpline

        hom = np.column_stack([c * w[:, None], w])
        spline = BSpline(t, hom, self.degree, extrapolate=False)
        object.__setattr__(self, "_spline", spline)
        object.__setattr__(self, "_d1", spline.derivative(1))
        object.__setattr__(self, "_d2", spline.derivative(2) if self.degree >= 2 else None)
        object.__setattr__(self, "_table", self._length_table())

    # -- construction
    @classmethod
    def bezier(cls, points: np.ndarray) -> Nurbs:
        """The Bézier curve of control points (k, 3): degree k − 1, one span."""
        pts = np.asarray(points, dtype=float)
        p = len(pts) - 1
        knots = np.r_[np.zeros(p + 1), np.ones(p + 1)]
        return cls(pts, np.ones(len(pts)), knots, p)

    @classmethod
    def linuxcnc(cls, points: np.ndarray, weights: np.ndarray, order: int) -> Nurbs:
        """G5.2: LinuxCNC's knot vector for n + 1 points of order k (degree k − 1):
        k zeros, then 1, 2, … up to n − k + 1, then n − k + 2 repeated k times."""
        pts = np.asarray(points, dtype=float)
        n = len(pts) - 1
        k = order
        knots = [0 if i < k else (i - k + 1 if i <= n else n - k + 2) for i in range(n + k + 1)]
        return cls(pts, np.asarray(weights, dtype=float), np.array(knots, dtype=float), k - 1)

    # -- domain
    @property
    def u0(self) -> float:
        return float(self.knots[self.degree])

    @property
    def u1(self) -> float:
        return float(self.knots[-self.degree - 1])

    @property
    def length(self) -> float:
        """The curve's arc length [mm]."""
        return float(self._table[1][-1])

    # -- evaluation
    def _hom(self, u: np.ndarray, d: int) -> np.ndarray:
        uu = np.clip(np.asarray(u, dtype=float), self.u0, self.u1)
        spline = (self._spline, self._d1, self._d2)[d]
        if spline is None:
            return np.zeros((*uu.shape, 4))
        return np.asarray(spline(uu))

    def point(self, u: np.ndarray | float) -> np.ndarray:
        """C(u): (..., 3) [mm] for u of any shape (clamped to the domain)."""
        h = self._hom(np.asarray(u), 0)
        return h[..., :3] / h[..., 3:4]

    def derivatives(self, u: np.ndarray | float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """C(u), C'(u), C''(u), each (..., 3) [mm, mm per unit u, …]."""
        u = np.asarray(u)
        h0, h1, h2 = self._hom(u, 0), self._hom(u, 1), self._hom(u, 2)
        w0, w1, w2 = h0[..., 3:4], h1[..., 3:4], h2[..., 3:4]
        c = h0[..., :3] / w0
        c1 = (h1[..., :3] - w1 * c) / w0
        c2 = (h2[..., :3] - 2.0 * w1 * c1 - w2 * c) / w0
        return c, c1, c2

    def speed(self, u: np.ndarray | float) -> np.ndarray:
        """|C'(u)| [mm per unit u]."""
        return np.linalg.norm(self.derivatives(u)[1], axis=-1)

    # -- arc length
    def _quad(self, a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
        x, w = _gauss(n)
        mid, half = (a + b) / 2.0, (b - a) / 2.0
        u = mid[..., None] + half[..., None] * x
        return np.sum(self.speed(u) * w, axis=-1) * half

    def _length_table(self) -> tuple[np.ndarray, np.ndarray]:
        """Break points u_j and the arc length s_j from u0 to each."""
        t = self.knots
        spans = [(t[i], t[i + 1]) for i in range(self.degree, len(t) - self.degree - 1)]
        pieces: list[tuple[float, float]] = []
        todo = [(float(a), float(b)) for a, b in spans if b > a]
        while todo:
            a = np.array([p[0] for p in todo])
            b = np.array([p[1] for p in todo])
            coarse = self._quad(a, b, 8)
            fine = self._quad(a, b, 16)
            nxt = []
            for k, (lo, hi) in enumerate(todo):
                if abs(fine[k] - coarse[k]) <= 1e-12 or hi - lo < 1e-9 * (self.u1 - self.u0):
                    pieces.append((lo, hi, float(fine[k])))  # type: ignore[arg-type]
                else:
                    m = (lo + hi) / 2.0
                    nxt += [(lo, m), (m, hi)]
            todo = nxt
        pieces.sort()
        u = np.array([self.u0] + [p[1] for p in pieces])
        s = np.concatenate([[0.0], np.cumsum([p[2] for p in pieces])])  # type: ignore[misc]
        return u, s

    def length_at(self, u: np.ndarray | float) -> np.ndarray:
        """s(u): the arc length from the start to u [mm] (vectorised)."""
        bu, bs = self._table
        uu = np.clip(np.asarray(u, dtype=float), self.u0, self.u1)
        j = np.clip(np.searchsorted(bu, uu, side="right") - 1, 0, len(bu) - 2)
        return bs[j] + self._quad(bu[j], uu, 16)

    def u_at(self, s: np.ndarray | float) -> np.ndarray:
        """u(s): the parameter at arc length s from the start (vectorised), to
        within :data:`LENGTH_TOLERANCE` of arc length."""
        bu, bs = self._table
        ss = np.clip(np.asarray(s, dtype=float), 0.0, bs[-1])
        j = np.clip(np.searchsorted(bs, ss, side="right") - 1, 0, len(bu) - 2)
        lo, hi = bu[j].copy(), bu[j + 1].copy()
        span = np.where(bs[j + 1] > bs[j], bs[j + 1] - bs[j], 1.0)
        u = lo + (hi - lo) * (ss - bs[j]) / span
        for _ in range(60):
            err = self.length_at(u) - ss
            done = np.abs(err) <= LENGTH_TOLERANCE / 4
            if np.all(done):
                break
            hi = np.where(err > 0, u, hi)
            lo = np.where(err < 0, u, lo)
            v = self.speed(u)
            newton = u - err / np.where(v > 0, v, np.inf)
            bad = ~((newton > lo) & (newton < hi)) | (v <= 0)
            u = np.where(done, u, np.where(bad, (lo + hi) / 2.0, newton))
        return u

    def to_json(self) -> dict[str, object]:
        return {
            "degree": self.degree,
            "knots": [round(float(v), 12) for v in self.knots],
            "control": [[round(float(v), 9) + 0.0 for v in p] for p in self.control],
            "weights": [round(float(v), 12) for v in self.weights],
        }
