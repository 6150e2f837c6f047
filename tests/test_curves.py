"""The curve geometry (prsxy_post.curves) against independent references:
LinuxCNC's own NURBS formula (its recursive basis, nurbs_additional_functions.cc,
written out here), the Bézier closed form, finite differences for the
derivatives, adaptive quadrature for the arc length."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from prsxy_post.curves import LENGTH_TOLERANCE, Nurbs


def _knots(n: int, k: int) -> list[int]:
    """knot_vector_creator (nurbs_additional_functions.cc)."""
    return [0 if i < k else (i - k + 1 if i <= n else n - k + 2) for i in range(n + k + 1)]


def _nmix(i: int, k: int, u: float, t: list[int]) -> float:
    """Nmix (nurbs_additional_functions.cc), the Cox-de Boor recursion with
    LinuxCNC's handling of repeated knots."""
    if k == 1:
        return 1.0 if t[i] <= u <= t[i + 1] else 0.0
    a, b = t[i + k - 1] - t[i], t[i + k] - t[i + 1]
    if a == 0 and b != 0:
        return (t[i + k] - u) * _nmix(i + 1, k - 1, u, t) / b
    if b == 0 and a != 0:
        return (u - t[i]) * _nmix(i, k - 1, u, t) / a
    if a == 0 and b == 0:
        return 0.0
    return (u - t[i]) * _nmix(i, k - 1, u, t) / a + (t[i + k] - u) * _nmix(i + 1, k - 1, u, t) / b


def linuxcnc_point(u: float, k: int, pts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """nurbs_point (nurbs_additional_functions.cc)."""
    t = _knots(len(pts) - 1, k)
    den = sum(_nmix(i, k, u, t) * w[i] for i in range(len(pts)))
    return sum(pts[i] * _nmix(i, k, u, t) * w[i] / den for i in range(len(pts)))


CONTROL = st.lists(
    st.tuples(st.floats(-50, 50), st.floats(-50, 50), st.floats(-5, 5), st.floats(0.2, 5.0)),
    min_size=3,
    max_size=9,
)


@settings(max_examples=60, deadline=None)
@given(CONTROL, st.integers(3, 6))
def test_points_are_linuxcncs_nurbs(points: list[tuple[float, ...]], order: int) -> None:
    if len(points) < order:
        order = len(points)
    pts = np.array([p[:3] for p in points])
    w = np.array([p[3] for p in points])
    c = Nurbs.linuxcnc(pts, w, order)
    umax = len(pts) - order + 1
    assert (c.u0, c.u1) == (0.0, umax)
    # LinuxCNC's recursion counts a knot twice inside the domain (closed
    # intervals at k = 1): compare between the knots, where it is the NURBS
    for u in np.linspace(0, umax, 37)[1:-1]:
        if abs(u - round(u)) < 1e-9:
            continue
        np.testing.assert_allclose(c.point(u), linuxcnc_point(u, order, pts, w), atol=1e-9)
    np.testing.assert_allclose(c.point([0.0, umax]), pts[[0, -1]], atol=1e-12)


def test_bezier_is_the_closed_form() -> None:
    p = np.array([[0.0, 0.0, 1.0], [3.0, 7.0, 1.0], [9.0, -2.0, 1.0], [12.0, 4.0, 1.0]])
    c = Nurbs.bezier(p)
    for u in np.linspace(0, 1, 11):
        b = (
            (1 - u) ** 3 * p[0]
            + 3 * u * (1 - u) ** 2 * p[1]
            + 3 * u**2 * (1 - u) * p[2]
            + u**3 * p[3]
        )
        np.testing.assert_allclose(c.point(u), b, atol=1e-12)
    q = Nurbs.bezier(p[:3])
    u = 0.3
    b2 = (1 - u) ** 2 * p[0] + 2 * u * (1 - u) * p[1] + u**2 * p[2]
    np.testing.assert_allclose(q.point(u), b2, atol=1e-12)


def test_derivatives_are_the_slopes_of_the_points() -> None:
    pts = np.array([[0, 0, 0], [10, 0, 1], [10, 10, 2], [20, 10, 0], [20, 0, 1.0]])
    c = Nurbs.linuxcnc(pts, np.array([1, 2, 1, 0.5, 1.0]), 4)
    u = np.linspace(0.05, c.u1 - 0.05, 23)
    h = 1e-5
    p, d1, d2 = c.derivatives(u)
    np.testing.assert_allclose(p, c.point(u), atol=1e-12)
    fd1 = (c.point(u + h) - c.point(u - h)) / (2 * h)
    fd2 = (c.point(u + h) - 2 * c.point(u) + c.point(u - h)) / h**2
    np.testing.assert_allclose(d1, fd1, atol=1e-6)
    np.testing.assert_allclose(d2, fd2, atol=2e-3)


def test_arc_length_to_a_nanometre() -> None:
    pts = np.array([[0, 0, 0], [10, 0, 1], [10, 10, 2], [20, 10, 0], [20, 0, 1.0], [5, -5, 0]])
    c = Nurbs.linuxcnc(pts, np.array([1, 2, 1, 0.5, 1.0, 3.0]), 3)
    knots = sorted(set(c.knots))

    def s_ref(u: float) -> float:
        total = 0.0
        for a, b in itertools.pairwise(knots):
            hi = min(b, u)
            if hi > a:
                total += quad(
                    lambda x: float(c.speed(x)), a, hi, epsabs=1e-12, epsrel=0, limit=200
                )[0]
        return total

    assert c.length == pytest.approx(s_ref(c.u1), abs=1e-10)
    for u in (0.3, 1.0, 2.7, 3.99):
        assert float(c.length_at(u)) == pytest.approx(s_ref(u), abs=1e-10)
    s = np.linspace(0, c.length, 101)
    back = np.array([s_ref(float(u)) for u in c.u_at(s)])
    assert np.max(np.abs(back - s)) <= LENGTH_TOLERANCE


def test_a_circle_as_a_nurbs_has_its_circumference() -> None:
    """A quarter circle is a rational quadratic with weights 1, √2/2, 1: the
    length is π r / 2 and every point is on the circle."""
    r = 7.0
    pts = np.array([[r, 0, 0], [r, r, 0], [0, r, 0.0]])
    c = Nurbs(pts, np.array([1, math.sqrt(0.5), 1]), np.array([0, 0, 0, 1, 1, 1.0]), 2)
    assert c.length == pytest.approx(math.pi * r / 2, abs=1e-10)
    u = c.u_at(np.linspace(0, c.length, 9))
    np.testing.assert_allclose(np.linalg.norm(c.point(u)[:, :2], axis=1), r, atol=1e-12)
    # equal steps of arc length are equal angles
    ang = np.arctan2(c.point(u)[:, 1], c.point(u)[:, 0])
    np.testing.assert_allclose(np.diff(ang), math.pi / 16, atol=1e-9 / r)


def test_bad_curves_are_refused() -> None:
    with pytest.raises(ValueError):
        Nurbs(np.zeros((3, 3)), np.array([1, 0, 1.0]), np.array([0, 0, 0, 1, 1, 1.0]), 2)
    with pytest.raises(ValueError):
        Nurbs(np.zeros((3, 3)), np.ones(3), np.array([0, 0, 1, 1.0]), 2)
