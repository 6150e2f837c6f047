"""Inverse and forward kinematics of the PRS-XY machine (contract: machine-model.md).

Notation (frames as in the contract)
------------------------------------
``q``       : (N, 5) virtual axes [x, y, z, A, B], workpiece frame [mm, mm, mm, deg, deg]
``P``       : (N, 5) motor positions [P1, P2, P3, P5, P6] [mm]
``c``       : (N, 3) platform centre, machine frame [mm]
``gamma``   : (N,)  parasitic spin about the spindle axis [rad]
``R``       : (N, 3, 3) platform orientation, R = Ry(B) · Rx(A) · Rz(γ)

The paper writes the inverse map as P_i = g_i(Q1, Q2, Q7, Q8, Q9) (Eq. 1–2); the
calibrated map g'_i of Eq. 3 is the same function evaluated with the calibrated
geometry.

The inverse kinematics is solved in closed form. The three hinge-plane
constraints and the tool-tip height are linear in c:

    M c = r(γ),   M = [u_1; u_2; u_3; e_z]  (4 × 3)
    r_i(γ) = g_i·u_i − u_i·(R b_i),   r_4(γ) = o_z + z − (R t)_z

and r is affine in (cos γ, sin γ). Four equations in three unknowns are
consistent only when n·r(γ) = 0 for the left null vector n of M, a single
equation K0 + Kc cos γ + Ks sin γ = 0; of its two roots the one nearest γ = 0
is the one a Newton iteration from γ = 0 finds (the contract's definition).
Then c = M⁺ r(γ) exactly. No iteration, no warm start, and vectorised.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import kernel
from .errors import ProfileError
from .kernel import fk as kfk
from .kernel import ik as kik
from .profile import Effects, KinematicParams, Profile, TableParams, nominal_kinematics

#: Travel at which ``effects.guide_bow`` is given [mm].
BOW_REF_MM = kik.BOW_REF_MM


def rot_x(a: np.ndarray) -> np.ndarray:
    """Right-handed rotation matrices about x, shape (..., 3, 3); ``a`` in rad."""
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack(
        [np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2
    )


def rot_y(a: np.ndarray) -> np.ndarray:
    """Right-handed rotation matrices about y, shape (..., 3, 3); ``a`` in rad."""
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack(
        [np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2
    )


def rot_z(a: np.ndarray) -> np.ndarray:
    """Right-handed rotation matrices about z, shape (..., 3, 3); ``a`` in rad."""
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    return np.stack(
        [np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2
    )


def platform_rotation(a: np.ndarray, b: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """R = R_y(B) R_x(A) R_z(γ) (contract), (N, 3, 3); angles in rad.

    The product written out (:func:`_rotation_cs`), one array operation per entry
    instead of three stacked matrices and two products (the FK's Newton builds it
    every step).
    """
    return _rotation_cs(np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(gamma), np.sin(gamma))


def _rotation_cs(
    ca: np.ndarray, sa: np.ndarray, cb: np.ndarray, sb: np.ndarray, cg: np.ndarray, sg: np.ndarray
) -> np.ndarray:
    """R_y(B) R_x(A) R_z(γ) from the angles' cosines and sines, (N, 3, 3): the
    kernel's (:func:`prsxy_post.kernel.fk.rotation_cs`, compiled when built)."""
    return kernel.rotation_cs(ca, sa, cb, sb, cg, sg)


def tool_axis(a_deg: np.ndarray, b_deg: np.ndarray) -> np.ndarray:
    """Tool axis R·(0,0,1) = (cos A sin B, −sin A, cos A cos B), shape (N, 3)."""
    a, b = np.radians(a_deg), np.radians(b_deg)
    return np.stack([np.cos(a) * np.sin(b), -np.sin(a), np.cos(a) * np.cos(b)], -1)


def angles_from_axis(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A = asin(−a_y), B = atan2(a_x, a_z) in degrees (contract)."""
    axis = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    return (
        np.degrees(np.arcsin(np.clip(-axis[..., 1], -1.0, 1.0))),
        np.degrees(np.arctan2(axis[..., 0], axis[..., 2])),
    )


@dataclass(frozen=True)
class Geometry:
    """A profile's geometry as arrays, radians, ready for vectorised kinematics.

    Attributes
    ----------
    g : (3, 3) guide points g_i (rows), machine frame [mm]
    d : (3, 3) guide directions d_i
    u : (3, 3) hinge axes u_i
    b : (3, 3) ball joints in the platform frame b_i [mm]
    L : (3,) strut lengths [mm]
    tool : (3,) tool tip in the platform frame t [mm] (without any G43 offset)
    origin : (3,) machine position of the workpiece origin with both table motors at 0
    scale_x, scale_y, squareness : table errors (squareness in rad)
    """

    g: np.ndarray
    d: np.ndarray
    u: np.ndarray
    b: np.ndarray
    L: np.ndarray
    tool: np.ndarray
    origin: np.ndarray
    scale_x: float = 0.0
    scale_y: float = 0.0
    squareness: float = 0.0
    guide_bow: np.ndarray | None = None
    table_straightness: np.ndarray | None = None

    @property
    def radial(self) -> np.ndarray:
        """Unit radial direction of each guide (rows): the direction a guide bows in."""
        r = self.g[:, :2] / np.linalg.norm(self.g[:, :2], axis=1, keepdims=True)
        return np.column_stack([r, np.zeros(3)])

    def hinge_offset(self, P: np.ndarray) -> np.ndarray:
        """Hinge centre a_i − g_i for motor positions P (N, 3) → (N, 3 legs, 3).

        Contract: a_i = g_i + P_i d_i. Extension ``effects.guide_bow`` b_i [mm]:
        a guide bowed in its radial direction by b_i (P_i / 100 mm)².
        """
        off = P[:, :, None] * self.d[None]
        if self.guide_bow is not None:
            off = off + (
                self.guide_bow[None, :, None]
                * (P[:, :, None] / BOW_REF_MM) ** 2
                * self.radial[None]
            )
        return off

    @classmethod
    def from_params(
        cls,
        kp: KinematicParams,
        origin: np.ndarray,
        table: TableParams | None = None,
        effects: Effects | None = None,
    ) -> Geometry:
        """Build the arrays of machine-model.md "Geometry of leg i" from profile values."""
        table = table or TableParams()
        g, d, u, b, L = [], [], [], [], []
        for leg in kp.legs:
            th = np.radians(leg.guide_angle)
            g.append(
                [leg.guide_radius * np.cos(th), leg.guide_radius * np.sin(th), leg.guide_height]
            )
            di = (
                rot_x(np.radians(leg.guide_tilt_x))
                @ rot_y(np.radians(leg.guide_tilt_y))
                @ np.array([0.0, 0.0, 1.0])
            )
            tangent = np.array([-np.sin(th), np.cos(th), 0.0])
            radial = np.array([np.cos(th), np.sin(th), 0.0])
            k = np.radians(leg.hinge_twist)
            v = np.cos(k) * tangent + np.sin(k) * radial
            ui = v - (v @ di) * di
            u.append(ui / np.linalg.norm(ui))
            d.append(di)
            ph = np.radians(leg.platform_angle)
            b.append(
                [leg.platform_radius * np.cos(ph), leg.platform_radius * np.sin(ph), leg.platform_z]
            )
            L.append(leg.strut_length)
        bow = straight = None
        if effects is not None and any(effects.guide_bow):
            bow = np.array(effects.guide_bow, dtype=float)
        if effects is not None and any(effects.table_straightness):
            straight = np.array(effects.table_straightness, dtype=float)
        return cls(
            np.array(g),
            np.array(d),
            np.array(u),
            np.array(b),
            np.array(L),
            np.array([kp.tool_offset_x, kp.tool_offset_y, -kp.tool_length]),
            np.asarray(origin, dtype=float).copy(),
            table.scale_x,
            table.scale_y,
            table.squareness,
            bow,
            straight,
        )

    @cached_property
    def fk_arrays(self) -> kfk.FKArrays:
        """The geometry as the kernel's FK arithmetic takes it (made once)."""
        return kfk.FKArrays(g=self.g, u=self.u, b=self.b, L=self.L)

    # Precomputed linear algebra of the closed-form IK, once per geometry (an SVD
    # and a pseudo-inverse cost 0.2 ms; the arrays are not changed after
    # construction, as a frozen geometry's are not).
    @cached_property
    def _m(self) -> tuple[np.ndarray, np.ndarray]:
        M = np.vstack([self.u, [0.0, 0.0, 1.0]])
        U, _, _ = np.linalg.svd(M)
        return U[:, 3], np.linalg.pinv(M)

    @cached_property
    def ik_arrays(self) -> kik.IKArrays:
        """The geometry as the kernel's IK takes it (made once)."""
        nul, Mp = self._m
        bow = self.guide_bow
        return kik.IKArrays(
            u=self.u,
            b=self.b,
            g=self.g,
            d=self.d,
            L2=self.L**2,
            gu=np.sum(self.g * self.u, axis=1),
            nul=nul,
            Mp=Mp,
            origin=self.origin,
            tool=self.tool,
            scale_x=self.scale_x,
            scale_y=self.scale_y,
            squareness=self.squareness,
            straightness=self.table_straightness,
            bow=bow if bow is not None and np.any(bow) else None,
            radial=self.radial,
        )


@dataclass(frozen=True)
class PlatformPose:
    """Platform centre c (N, 3) [mm], spin gamma (N,) [rad], orientation R (N, 3, 3)."""

    c: np.ndarray
    gamma: np.ndarray
    R: np.ndarray


def _tool_vectors(
    geo: Geometry, n: int, tool_length_offset: np.ndarray | float | None
) -> np.ndarray:
    t = np.broadcast_to(geo.tool, (n, 3)).copy()
    if tool_length_offset is not None:
        t[:, 2] -= tool_length_offset
    return t


def solve_platform(
    geo: Geometry, q: np.ndarray, tool_length_offset: np.ndarray | float | None = None
) -> PlatformPose:
    """Platform centre and spin for tool poses ``q`` (step 1 of the contract's IK).

    Parameters
    ----------
    geo : Geometry
    q : (N, 5) ndarray [mm, mm, mm, deg, deg]
    tool_length_offset : (N,) or float, optional
        G43 length added to the tool (the tip sits that much further along the
        spindle axis, away from the spindle).

    Returns
    -------
    PlatformPose; rows with no solution hold NaN.
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    return _pose(_solve(geo, q, tool_length_offset))


def _solve(
    geo: Geometry, q: np.ndarray, tool_length_offset: np.ndarray | float | None
) -> kik.PlatformCols:
    """The closed-form platform solution (module docstring), in components: the
    kernel's (:func:`prsxy_post.kernel.ik.platform_cols`, compiled when built)."""
    m = geo.ik_arrays
    return kernel.platform_cols(m, q, kik.tool_z(m, q.shape[0], tool_length_offset))


def _pose(p: kik.PlatformCols) -> PlatformPose:
    return PlatformPose(p.c, p.gamma, _rotation_cs(p.ca, p.sa, p.cb, p.sb, p.cg, p.sg))


def strut_discriminant(geo: Geometry, pose: PlatformPose) -> np.ndarray:
    """(d_i·v_i)² − |v_i|² + L_i², shape (N, 3); negative: strut i cannot reach."""
    s = pose.c[:, None, :] + np.einsum("nij,kj->nki", pose.R, geo.b)
    v = s - geo.g[None]
    dv = np.einsum("nki,ki->nk", v, geo.d)
    return dv**2 - np.einsum("nki,nki->nk", v, v) + geo.L[None] ** 2


@dataclass(frozen=True)
class IKResult:
    """Motor positions and what the solution went through.

    P : (N, 5) [P1, P2, P3, P5, P6] mm; NaN where unreachable
    pose : PlatformPose (solved again when asked for: the chain needs only P)
    reachable : (N,) bool
    """

    P: np.ndarray
    reachable: np.ndarray
    _q: np.ndarray
    _tool_z: np.ndarray
    _geo: Geometry

    @cached_property
    def pose(self) -> PlatformPose:
        return _pose(kernel.platform_cols(self._geo.ik_arrays, self._q, self._tool_z))


def inverse(
    geo: Geometry, q: np.ndarray, tool_length_offset: np.ndarray | float | None = None
) -> IKResult:
    """Virtual → real: motor positions for tool poses (contract "Inverse kinematics").

    P_i = d_i·v_i + sqrt((d_i·v_i)² − |v_i|² + L_i²),  v_i = c + R b_i − g_i
    (hinge above the ball joint), and the table equation solved for P5, P6:

        D = o + (x, y, ·) − T,  P6 = D_y / (1 + s_y),  P5 = (D_x − σ P6) / (1 + s_x)

    Computed by the kernel (:func:`prsxy_post.kernel.inverse_rows`: compiled, or its
    numpy reference).

    Parameters
    ----------
    geo : Geometry
    q : (N, 5) ndarray [mm, mm, mm, deg, deg], workpiece frame
    tool_length_offset : (N,) or float, optional  [mm]

    Returns
    -------
    IKResult
    """
    q = np.atleast_2d(np.asarray(q, dtype=float))
    m = geo.ik_arrays
    tz = kik.tool_z(m, q.shape[0], tool_length_offset)
    P = kernel.inverse_rows(m, q, tz)
    reachable = np.all(np.isfinite(P), axis=1)
    # q is kept (a copy: callers reuse their arrays) to solve the pose when asked
    return IKResult(P, reachable, q.copy(), tz, geo)


def motion(
    geo: Geometry, q: np.ndarray, qdot: np.ndarray, tool_length_offset: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """The motors' positions P (N, 5) [mm] at poses ``q`` (N, 5) [mm, mm, mm, deg,
    deg] and their velocities V (N, 5) [mm/s] moving at ``qdot`` (N, 5): the IK's
    one-sided difference over ``step`` [s], (P(q + step q̇) − P) / step, 0 where a
    row stands (``qdot`` 0). Both in one pass of the kernel
    (:func:`prsxy_post.kernel.motion_rows`); the same numbers as :func:`inverse` and
    :func:`derivative`."""
    m = geo.ik_arrays
    tz = kik.tool_z(m, q.shape[0], tool_length_offset)
    return kernel.motion_rows(m, q, qdot, tz, step)


def derivative(
    geo: Geometry,
    q: np.ndarray,
    dq: np.ndarray,
    tool_length_offset: np.ndarray,
    P: np.ndarray,
    step: float,
) -> np.ndarray:
    """(N, 5) dP along ``dq`` (N, 5) at poses ``q`` (N, 5) whose IK is ``P``: the IK's
    one-sided difference (P(q + step dq) − P) / step (the kernel's
    :func:`prsxy_post.kernel.derivative_rows`)."""
    m = geo.ik_arrays
    tz = kik.tool_z(m, q.shape[0], tool_length_offset)
    return kernel.derivative_rows(m, q, dq, tz, P, step)


def jacobian(
    geo: Geometry,
    q: np.ndarray,
    tool_length_offset: np.ndarray,
    step: float,
    P: np.ndarray | None = None,
) -> np.ndarray:
    """(N, 5, 5) ∂P_i/∂q_j at poses ``q`` (N, 5): the IK's one-sided differences
    over ``step`` along each coordinate from ``P`` (the IK of ``q``; solved too when
    None), the kernel's :func:`prsxy_post.kernel.jacobian_rows`."""
    m = geo.ik_arrays
    tz = kik.tool_z(m, q.shape[0], tool_length_offset)
    return kernel.jacobian_rows(m, q, tz, step, P)


def table_displacement(geo: Geometry, p5: np.ndarray, p6: np.ndarray) -> np.ndarray:
    """D = (P5(1 + s_x) + σ P6, P6(1 + s_y), 0), shape (N, 3) (contract "Table").

    Extension ``effects.table_straightness`` (k_x, k_y) [mm/m²]: the X motion
    bends towards +Y by k_x (P5 / 1000)², the Y motion towards +X by k_y (P6 / 1000)².
    """
    p5 = np.asarray(p5, dtype=float)
    p6 = np.asarray(p6, dtype=float)
    dx = p5 * (1.0 + geo.scale_x) + geo.squareness * p6
    dy = p6 * (1.0 + geo.scale_y)
    if geo.table_straightness is not None:
        kx, ky = geo.table_straightness
        dx = dx + ky * (p6 / 1000.0) ** 2
        dy = dy + kx * (p5 / 1000.0) ** 2
    return np.stack([dx, dy, np.zeros_like(p5)], -1)


def table_motors(geo: Geometry, dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve the table equation D(P5, P6) = (dx, dy) for the motors."""
    return kik.table_motors(geo.ik_arrays, dx, dy)


def _fk_residual(geo: Geometry, P: np.ndarray, xv: np.ndarray) -> np.ndarray:
    """Six FK equations for unknowns xv = (c, A, B, γ) [mm, rad], shape (N, 6)."""
    return kernel.fk_residual(geo.fk_arrays, geo.hinge_offset(P[:, :3]), xv)


def _fk_system(geo: Geometry, P: np.ndarray, xv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The six FK equations at xv = (c, A, B, γ) [mm, rad] and their Jacobian.

    With s_k = c + R b_k and R = R_y(B) R_x(A) R_z(γ) (contract), the equations are
    the ball's height over its hinge plane, (s_k − g_k)·u_k, and the strut length,
    |w_k| − L_k with w_k = s_k − a_k; their derivatives are closed forms
    (:func:`prsxy_post.kernel.fk.fk_system`, compiled when built).

    Returns
    -------
    f : (N, 6) [mm]; J : (N, 6, 6) ∂f/∂xv [mm/mm, mm/rad]
    """
    return kernel.fk_system(geo.fk_arrays, geo.hinge_offset(P[:, :3]), xv)


def _fk_guess(geo: Geometry, P: np.ndarray) -> np.ndarray:
    """Start for Newton: the platform parallel to the plane through the hinges."""
    a = geo.g[None] + geo.hinge_offset(P[:, :3])  # hinge centres (N, 3, 3)
    nrm = np.cross(a[:, 1] - a[:, 0], a[:, 2] - a[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm *= np.sign(nrm[:, 2:3])
    A = np.arcsin(np.clip(-nrm[:, 1], -1, 1))
    B = np.arctan2(nrm[:, 0], nrm[:, 2])
    drop = np.sqrt(
        np.maximum(
            geo.L**2
            - (np.linalg.norm(geo.g[:, :2], axis=1) - np.linalg.norm(geo.b[:, :2], axis=1)) ** 2,
            0.0,
        )
    )
    c = a.mean(axis=1) - nrm * drop.mean()
    return np.column_stack([c, A, B, np.zeros(len(P))])


#: the FK's Newton: a step below FK_STEP [mm, rad] in every component ends it (the
#: step at rounding level: one more after it first gets small would not change the
#: result), at most FK_MAX_ITER steps, a residual below FK_RESIDUAL [mm] is a solution
FK_STEP, FK_MAX_ITER, FK_RESIDUAL = 1e-9, 30, 1e-9


def forward_platform(
    geo: Geometry,
    P: np.ndarray,
    guess: np.ndarray | None = None,
    tol: float = FK_STEP / 1e3,
    max_iter: int = FK_MAX_ITER,
) -> tuple[np.ndarray, np.ndarray]:
    """Solve the six constraint equations for (c, A, B, γ) by Newton's method,
    each row on its own: :func:`prsxy_post.kernel.fk.forward_newton` (compiled
    when built), steps below ``tol`` · 1e3, residual below 1e-9 mm.

    Parameters
    ----------
    P : (N, 5) motor positions [mm]
    guess : (N, 6) start (c [mm], A, B, γ [rad]); default: platform parallel to the
        plane of the hinge centres.

    Returns
    -------
    xv : (N, 6) solution; converged : (N,) bool
    """
    P = np.atleast_2d(np.asarray(P, dtype=float))
    xv = _fk_guess(geo, P) if guess is None else np.array(guess, dtype=float)
    # Newton stops when the step is at rounding level (one more step after the
    # step first gets small would not change the result), then checks the residual
    return kernel.forward_newton(
        geo.fk_arrays, geo.hinge_offset(P[:, :3]), xv, tol * 1e3, max_iter, FK_RESIDUAL
    )


def forward(
    geo: Geometry,
    P: np.ndarray,
    tool_length_offset: np.ndarray | float | None = None,
    guess: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Real → virtual (contract "Forward kinematics").

    Returns
    -------
    q : (N, 5) [x, y, z, A, B] workpiece frame [mm, deg]; NaN where not converged
    converged : (N,) bool
    """
    P = np.atleast_2d(np.asarray(P, dtype=float))
    t = _tool_vectors(geo, len(P), tool_length_offset)
    D = table_displacement(geo, P[:, 3], P[:, 4])
    origin = np.asarray(geo.origin, dtype=float)
    if geo.guide_bow is None:
        # straight guides: Newton (as forward_platform's) and the tool poses in one
        # kernel call (prsxy_post.kernel.fk.forward_poses, compiled when built)
        # the kernel reads the start, never writes it: no copy
        x0 = _fk_guess(geo, P) if guess is None else np.asarray(guess, dtype=float)
        return kernel.forward_poses(
            geo.fk_arrays, geo.d, P, x0, t, origin, D, FK_STEP, FK_MAX_ITER, FK_RESIDUAL
        )
    xv, ok = forward_platform(geo, P, guess)
    # tip c + R t, in the workpiece frame, tilts in degrees: the kernel's
    # (prsxy_post.kernel.fk.tool_poses, compiled when built)
    return kernel.tool_poses(xv, ok, t, origin, D), ok


#: Points from one anchor of :func:`forward_anchored` to the next: the FK of the
#: 50 000-line bench program's corrected G-code takes 1.77 Newton steps a point (in
#: the compiled kernel's groups of four, the anchors' own included) instead of 3, its
#: written values the same; 12, 20 and 24 took 1.80, 1.77 and 1.78
#: (``bench/fk_steps.py``).
FK_ANCHOR_EVERY = 16


def forward_anchored(
    geo: Geometry, P: np.ndarray, guess: np.ndarray, every: int, phase: int, carry: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`forward` of a run of points along a path, one call after another: each
    point starts from ``guess`` moved by the offset to its solution found at the
    last anchor point (every ``every``-th of the run, ``phase`` the index of P's
    first row in it; ``carry`` (6,) the offset the run's previous call returned,
    zeros at its start): :func:`prsxy_post.kernel.fk.anchored_starts`. A start
    that misses the solution by as much as the offset changes between neighbouring
    points needs one Newton step where the guess alone needs three. An offset
    beyond :data:`prsxy_post.kernel.fk.ANCHOR_REACH` is not handed on: a start far
    from the guess could lead Newton to another of the FK's solutions.

    Returns
    -------
    q : (N, 5) [mm, mm, mm, deg, deg], NaN where not converged; converged : (N,);
    carry : (6,) for the run's next call
    """
    if geo.guide_bow is not None:
        raise ValueError("anchored FK starts are for straight guides (a controller's geometry)")
    P = np.atleast_2d(np.asarray(P, dtype=float))
    t = _tool_vectors(geo, len(P), None)
    D = table_displacement(geo, P[:, 3], P[:, 4])
    origin = np.asarray(geo.origin, dtype=float)
    return kernel.forward_poses_anchored(
        geo.fk_arrays,
        geo.d,
        P,
        guess,
        t,
        origin,
        D,
        FK_STEP,
        FK_MAX_ITER,
        FK_RESIDUAL,
        every,
        phase,
        carry,
    )


def platform_guess(pose: PlatformPose, q: np.ndarray) -> np.ndarray:
    """An FK start (c, A, B, γ) from an IK solution, for warm-started FK."""
    return np.column_stack([pose.c, np.radians(q[:, 3]), np.radians(q[:, 4]), pose.gamma])


def fk_start(geo: Geometry, q: np.ndarray) -> np.ndarray:
    """(N, 6) the FK start (c [mm], A, B, γ [rad]) at tool poses ``q`` (N, 5) [mm,
    mm, mm, deg, deg] (no tool length offset): :func:`platform_guess` of
    :func:`solve_platform`, the same numbers, without the rotations (the start
    needs only the centre and the spin) and made in one array."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    p = _solve(geo, q, None)
    x0 = np.empty((len(q), 6))
    x0[:, :3] = p.c
    np.radians(q[:, 3], out=x0[:, 3])
    np.radians(q[:, 4], out=x0[:, 4])
    x0[:, 5] = p.gamma
    return x0


def check_reach(prof: Profile) -> None:
    """A profile whose struts cannot reach its start pose is an error naming the leg.

    Part of reading a profile file (:func:`prsxy_post.files.load_profile`): the
    profile package checks the document's keys and values, this its geometry.

    Raises
    ------
    ProfileError
        ``kinematics.legs[i].strut_length`` (or ``controller_kinematics...``) and
        how far the strut falls short across its guide.
    """
    for section, kp in (
        ("kinematics", prof.kinematics),
        ("controller_kinematics", prof.controller_kinematics),
    ):
        if kp is None:
            continue
        geo = (
            Geometry.from_params(kp, prof.origin, prof.table, prof.effects)
            if section == "kinematics"
            else Geometry.from_params(kp, prof.origin)
        )
        q = prof.start[None, :]
        try:
            sol = solve_platform(geo, q)
        except Exception as exc:  # degenerate geometry: no solution at all
            raise ProfileError(
                f"the platform cannot be placed at the start pose ({exc})",
                source=prof.source,
                key=section,
                expected="a 3-PRS geometry close to the nominal design",
            ) from None
        disc = strut_discriminant(geo, sol)
        for i in range(3):
            if not disc[0, i] >= 0:
                short = math.sqrt(-disc[0, i]) if disc[0, i] < 0 else math.nan
                raise ProfileError(
                    f"strut {i + 1} cannot reach the platform at the start pose "
                    f"(it falls short by {short:.3f} mm across the guide)",
                    source=prof.source,
                    key=f"{section}.legs[{i + 1}].strut_length",
                    expected="a strut longer than the hinge-to-ball distance across the guide",
                )


def controller_geometry(profile: Profile) -> Geometry:
    """[controller_kinematics] (default: the nominal design) with an ideal table."""
    kp = profile.controller_kinematics or nominal_kinematics()
    return Geometry.from_params(kp, profile.origin)
