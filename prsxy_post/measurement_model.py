"""The measurement model calibration and diagnosis share: what a geometry predicts.

For motor positions P (where the driven parts are) and a geometry θ (contract
terms and the library's geometry effects), the forward kinematics gives the
platform pose x from the constraints F(x, θ, P) = 0 and the tip and tool axis

    y = G(x, θ, P) = (tip x, y, z [mm], A, B [deg]).

Its derivatives come from the implicit-function theorem, ∂x/∂θ = −F_x⁻¹ F_θ, so
one FK solve per evaluation suffices (Eq. 3's g'_i linearised). The calibration's
kinematic stage (:mod:`prsxy_post.calibrate`) and diagnose's model of every
measurement (:mod:`prsxy_post.diagnose.model`) both evaluate it; neither imports
the other for it.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from . import effects as registry
from . import kinematics
from .errors import FitError

#: A geometry for a parameter vector θ.
MakeGeometry = Callable[[np.ndarray], kinematics.Geometry]


def tip_and_axis(geo: kinematics.Geometry, P: np.ndarray, xv: np.ndarray) -> np.ndarray:
    """Tip [mm] and A, B [deg] (N, 5) for motor positions P (N, 5) and platform
    poses xv (N, 6) = (centre [mm], A, B, γ [rad])."""
    R = kinematics.platform_rotation(xv[:, 3], xv[:, 4], xv[:, 5])
    T = xv[:, :3] + np.einsum("nij,j->ni", R, geo.tool)
    w = T - geo.origin + kinematics.table_displacement(geo, P[:, 3], P[:, 4])
    return np.column_stack([w, np.degrees(xv[:, 3]), np.degrees(xv[:, 4])])


def default_steps(names: Sequence[str], theta: np.ndarray) -> np.ndarray:
    """Central-difference steps (the registry's, per member)."""
    return registry.fd_steps(names, theta)


def fk_with_jacobian(
    make_geo: MakeGeometry,
    theta: np.ndarray,
    P: np.ndarray,
    guess: np.ndarray | None = None,
    want_jac: bool = True,
    steps: np.ndarray | None = None,
    motors: bool = False,
) -> tuple[np.ndarray, np.ndarray | None, np.ndarray, np.ndarray | None]:
    """Tip and axis y (N, 5) for motor positions P under geometry θ, with derivatives.

    Implicit differentiation of the FK constraints F(x, θ, P) = 0 (x: platform pose):
    ∂x/∂θ = −F_x⁻¹ F_θ, ∂y/∂θ = G_x ∂x/∂θ + G_θ, and likewise for P.

    ``steps``: central-difference steps of θ (default: the registry's for the
    contract parameters, :data:`prsxy_post.effects.CONTRACT`).

    Returns
    -------
    y : (N, 5) [mm, deg]; J : (N, 5, m) ∂y/∂θ or None; xv : (N, 6) platform poses;
    JP : (N, 5, 5) ∂y/∂P (motor sensitivities) when ``motors``, else None

    Raises
    ------
    FitError
        When the forward kinematics fails at a measured point.
    """
    geo = make_geo(theta)
    xv, ok = kinematics.forward_platform(geo, P, guess)
    if not np.all(ok):
        raise FitError(
            f"forward kinematics failed at {int(np.sum(~ok))} measured points",
            expected="measurements of poses this geometry can reach",
        )
    y = tip_and_axis(geo, P, xv)
    if not want_jac:
        return y, None, xv, None
    Fx = kinematics._fk_system(geo, P, xv)[1]
    Gx = _out_wrt_pose(geo, P, xv)
    h_all = steps if steps is not None else default_steps(list(registry.CONTRACT), theta)
    Ft, Gt = _wrt_theta(make_geo, theta, P, xv, h_all)
    lu = np.linalg.inv(Fx)
    J = np.einsum("nij,njm->nim", Gx, -lu @ Ft) + Gt
    JP = None
    if motors:
        FP, GP = _wrt_motors(geo, P, xv)
        JP = np.einsum("nij,njm->nim", Gx, -lu @ FP) + GP
    return y, J, xv, JP


def _out_wrt_pose(geo: kinematics.Geometry, P: np.ndarray, xv: np.ndarray) -> np.ndarray:
    """G_x (N, 5, 6): the output's change per unit of platform pose."""
    hx = np.array([1e-6, 1e-6, 1e-6, 1e-8, 1e-8, 1e-8])
    Gx = np.empty((len(P), 5, 6))
    for j in range(6):
        xp, xm = xv.copy(), xv.copy()
        xp[:, j] += hx[j]
        xm[:, j] -= hx[j]
        Gx[:, :, j] = (tip_and_axis(geo, P, xp) - tip_and_axis(geo, P, xm)) / (2 * hx[j])
    return Gx


def _wrt_theta(
    make_geo: MakeGeometry, theta: np.ndarray, P: np.ndarray, xv: np.ndarray, h_all: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """F_θ (N, 6, m) and G_θ (N, 5, m) by central differences at the pose xv."""
    n, m = len(P), len(theta)
    Ft = np.empty((n, 6, m))
    Gt = np.empty((n, 5, m))
    for j in range(m):
        h = h_all[j]
        tp, tm = theta.copy(), theta.copy()
        tp[j] += h
        tm[j] -= h
        gp, gm = make_geo(tp), make_geo(tm)
        Ft[:, :, j] = (kinematics._fk_residual(gp, P, xv) - kinematics._fk_residual(gm, P, xv)) / (
            2 * h
        )
        Gt[:, :, j] = (tip_and_axis(gp, P, xv) - tip_and_axis(gm, P, xv)) / (2 * h)
    return Ft, Gt


def _wrt_motors(
    geo: kinematics.Geometry, P: np.ndarray, xv: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """F_P (N, 6, 5) and G_P (N, 5, 5) by central differences at the pose xv."""
    n = len(P)
    FP = np.empty((n, 6, 5))
    GP = np.empty((n, 5, 5))
    for j in range(5):
        Pp, Pm = P.copy(), P.copy()
        Pp[:, j] += 1e-6
        Pm[:, j] -= 1e-6
        FP[:, :, j] = (
            kinematics._fk_residual(geo, Pp, xv) - kinematics._fk_residual(geo, Pm, xv)
        ) / 2e-6
        GP[:, :, j] = (tip_and_axis(geo, Pp, xv) - tip_and_axis(geo, Pm, xv)) / 2e-6
    return FP, GP
