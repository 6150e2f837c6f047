"""The closed-form inverse kinematics over arrays: the numpy reference kernel.

The equations are those of :mod:`prsxy_post.kinematics` (machine-model.md, "Inverse
kinematics"; the paper's g'_i, Eq. 3): the platform's spin γ from
K0 + Kc cos γ + Ks sin γ = 0 (the root nearest 0), its centre c = M⁺ r(γ), then

    P_i = d_i·v_i + sqrt((d_i·v_i)² − |v_i|² + L_i²),  v_i = c + R b_i − g_i
    D = o + (x, y, ·) − T,  P6 = D_y / (1 + s_y),  P5 = (D_x − σ P6) / (1 + s_x)

Every operation is written per component, in an order a loop over rows can keep:
``_ik.pyx`` is the same arithmetic in C, operation for operation, so the two agree
to the bit (``tests/test_kernel_ik.py``). The transcendental functions are the C
library's on both sides (:mod:`.libm`; sin and cos are numpy's, which call the C
library's, checked by the same tests), ρ = sqrt(Kc² + Ks²) instead of ``hypot``
(whose numpy and C versions differ). Rows with no solution hold NaN.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import libm

#: Travel at which a guide's bow is given [mm] (``effects.guide_bow``).
BOW_REF_MM = 100.0


class IKArrays(NamedTuple):
    """A geometry flattened into what the IK needs, made once per geometry.

    u, b, g, d : (3, 3) hinge axes, ball joints (platform frame), guide points,
        guide directions, one leg a row [mm]
    L2 : (3,) squared strut lengths [mm²]
    gu : (3,) g_i · u_i [mm]
    nul : (4,) left null vector n of M = [u_1; u_2; u_3; e_z]
    Mp : (3, 4) M⁺, the pseudo-inverse of M
    origin : (3,) [mm];  tool : (3,) tool tip, platform frame, no G43 [mm]
    scale_x, scale_y, squareness : the table's errors
    straightness : (k_x, k_y) [mm/m²] or None;  bow : (3,) [mm] or None
    radial : (3, 3) the guides' radial directions (where they bow)
    """

    u: np.ndarray
    b: np.ndarray
    g: np.ndarray
    d: np.ndarray
    L2: np.ndarray
    gu: np.ndarray
    nul: np.ndarray
    Mp: np.ndarray
    origin: np.ndarray
    tool: np.ndarray
    scale_x: float
    scale_y: float
    squareness: float
    straightness: np.ndarray | None
    bow: np.ndarray | None
    radial: np.ndarray


def tool_z(m: IKArrays, n: int, tool_length_offset: np.ndarray | float | None) -> np.ndarray:
    """(n,) the tool tip's z in the platform frame, less the G43 length [mm]."""
    tz = np.full(n, m.tool[2])
    if tool_length_offset is not None:
        tz -= tool_length_offset
    return tz


class PlatformCols(NamedTuple):
    """The platform solution in columns (N,) each: cosines and sines of A, B and γ,
    γ [rad] and the centre c (N, 3) [mm]."""

    ca: np.ndarray
    sa: np.ndarray
    cb: np.ndarray
    sb: np.ndarray
    cg: np.ndarray
    sg: np.ndarray
    gamma: np.ndarray
    c: np.ndarray


def rotate(
    p: PlatformCols, w0: np.ndarray, w1: np.ndarray, w2: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """R w = Ry(B) Rx(A) Rz(γ) w for w in components, each (N,) or (N, k)."""
    cg, sg, ca, sa, cb, sb = p.cg, p.sg, p.ca, p.sa, p.cb, p.sb
    if np.ndim(w0) == 2:
        cg, sg, ca, sa, cb, sb = (v[:, None] for v in (cg, sg, ca, sa, cb, sb))
    x = cg * w0 - sg * w1
    y = sg * w0 + cg * w1
    # then Rx(A), then Ry(B)
    y2 = ca * y - sa * w2
    z2 = sa * y + ca * w2
    return cb * x + sb * z2, y2, -sb * x + cb * z2


def wrap(a: np.ndarray) -> np.ndarray:
    """An angle into [−π, π): numpy's floor remainder (fmod, then the divisor's sign)."""
    return (a + np.pi) % (2 * np.pi) - np.pi


def platform_cols(m: IKArrays, q: np.ndarray, tz: np.ndarray) -> PlatformCols:
    """Step 1 of the IK: spin γ and centre c for poses ``q`` (N, 5) [mm, deg]."""
    a_rad, b_rad = np.radians(q[:, 3]), np.radians(q[:, 4])
    ca, sa, cb, sb = np.cos(a_rad), np.sin(a_rad), np.cos(b_rad), np.sin(b_rad)
    nul, Mp = m.nul, m.Mp
    # u_i · (Rab w) = (Rab^T u_i) · w, Rab = Ry(B) Rx(A) with columns
    # (cb, 0, −sb), (sb sa, ca, cb sa), (sb ca, −sa, cb ca)
    ux, uy, uz = m.u[:, 0], m.u[:, 1], m.u[:, 2]
    cA, sA, cB, sB = ca[:, None], sa[:, None], cb[:, None], sb[:, None]
    uR0 = cB * ux - sB * uz  # (N, 3 legs)
    uR1 = sB * sA * ux + cA * uy + cB * sA * uz
    uR2 = sB * cA * ux - sA * uy + cB * cA * uz
    bx, by, bz = m.b[:, 0], m.b[:, 1], m.b[:, 2]
    # R b = cos γ · Rab (bx, by, 0) + sin γ · Rab (−by, bx, 0) + Rab (0, 0, bz)
    const_legs = m.gu - uR2 * bz
    cos_legs = -(uR0 * bx + uR1 * by)
    sin_legs = -(uR1 * bx - uR0 * by)
    # the row of Rab giving the z component: (−sb, cb sa, cb ca)
    rz0, rz1, rz2 = -sb, cb * sa, cb * ca
    tx, ty = m.tool[0], m.tool[1]
    const_z = m.origin[2] + q[:, 2] - rz2 * tz
    cos_z = -(rz0 * tx + rz1 * ty)
    sin_z = -(rz1 * tx - rz0 * ty)

    # n · r(γ) = K0 + Kc cos γ + Ks sin γ
    def dot_n(legs: np.ndarray, z: np.ndarray) -> np.ndarray:
        return legs[:, 0] * nul[0] + legs[:, 1] * nul[1] + legs[:, 2] * nul[2] + z * nul[3]

    K0, Kc, Ks = dot_n(const_legs, const_z), dot_n(cos_legs, cos_z), dot_n(sin_legs, sin_z)
    rho = np.sqrt(Kc * Kc + Ks * Ks)
    phi = libm.atan2(Ks, Kc)
    with np.errstate(invalid="ignore", divide="ignore"):
        delta = libm.acos(-K0 / rho)  # NaN outside [-1, 1]: no spin satisfies all legs
    g1 = wrap(phi + delta)
    g2 = wrap(phi - delta)
    gamma = np.where(np.abs(g1) <= np.abs(g2), g1, g2)
    cg, sg = np.cos(gamma), np.sin(gamma)
    r_legs = const_legs + cos_legs * cg[:, None] + sin_legs * sg[:, None]
    r_z = const_z + cos_z * cg + sin_z * sg
    c = np.column_stack(
        [r_legs[:, 0] * p[0] + r_legs[:, 1] * p[1] + r_legs[:, 2] * p[2] + r_z * p[3] for p in Mp]
    )  # c = M⁺ r
    return PlatformCols(ca, sa, cb, sb, cg, sg, gamma, c)


def inverse_rows(m: IKArrays, q: np.ndarray, tz: np.ndarray) -> np.ndarray:
    """Motor positions P (N, 5) [mm] for poses ``q`` (N, 5) [mm, mm, mm, deg, deg]
    (workpiece frame) and tool heights ``tz`` (N,) (:func:`tool_z`); NaN rows where
    unreachable (module docstring)."""
    p = platform_cols(m, q, tz)
    # s_i = c + R b_i, v_i = s_i − g_i, all legs at once: (N, 3 legs) per component
    n = q.shape[0]
    b = m.b
    Rb = rotate(
        p,
        np.broadcast_to(b[:, 0], (n, 3)),
        np.broadcast_to(b[:, 1], (n, 3)),
        np.broadcast_to(b[:, 2], (n, 3)),
    )
    v = [p.c[:, j : j + 1] + Rb[j] - m.g[:, j] for j in range(3)]
    dv = v[0] * m.d[:, 0] + v[1] * m.d[:, 1] + v[2] * m.d[:, 2]
    disc = dv**2 - (v[0] ** 2 + v[1] ** 2 + v[2] ** 2) + m.L2
    with np.errstate(invalid="ignore"):
        p_head = dv + np.sqrt(disc)
    if m.bow is not None:
        p_head = bowed_guides(m, np.stack(v, -1), p_head)
    Rt = rotate(p, np.full(n, m.tool[0]), np.full(n, m.tool[1]), tz)
    Dx = m.origin[0] + q[:, 0] - (p.c[:, 0] + Rt[0])
    Dy = m.origin[1] + q[:, 1] - (p.c[:, 1] + Rt[1])
    p5, p6 = table_motors(m, Dx, Dy)
    return np.column_stack([p_head, p5, p6])


def hinge_offset(m: IKArrays, P: np.ndarray) -> np.ndarray:
    """Hinge centre a_i − g_i for motor positions P (N, 3) → (N, 3 legs, 3) [mm]:
    P_i d_i, and a guide bowed radially by b_i (P_i / 100 mm)² (``effects.guide_bow``)."""
    off = P[:, :, None] * m.d[None]
    if m.bow is not None:
        off = off + (m.bow[None, :, None] * (P[:, :, None] / BOW_REF_MM) ** 2 * m.radial[None])
    return off


def bowed_guides(m: IKArrays, v: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Newton on |v_i − a_i(P_i) + g_i|² = L_i² from the straight-guide solution."""
    assert m.bow is not None
    bow = m.bow
    for _ in range(6):
        w = v - hinge_offset(m, p)
        da = m.d[None] + (2 * bow[None, :, None] * p[:, :, None] / BOW_REF_MM**2 * m.radial[None])
        f = np.einsum("nki,nki->nk", w, w) - m.L2[None]
        fp = -2 * np.einsum("nki,nki->nk", w, da)
        with np.errstate(invalid="ignore", divide="ignore"):
            p = p - f / fp
    return p


def table_motors(m: IKArrays, dx: np.ndarray, dy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve the table equation D(P5, P6) = (dx, dy) for the motors [mm]."""
    p6 = dy / (1.0 + m.scale_y)
    p5 = (dx - m.squareness * p6) / (1.0 + m.scale_x)
    if m.straightness is not None:
        kx, ky = m.straightness
        # the bends are µm over hundreds of mm: a few fixed-point steps converge
        for _ in range(4):
            p6 = (dy - kx * (p5 / 1000.0) ** 2) / (1.0 + m.scale_y)
            p5 = (dx - m.squareness * p6 - ky * (p6 / 1000.0) ** 2) / (1.0 + m.scale_x)
    return p5, p6


def derivative_rows(
    m: IKArrays, q: np.ndarray, dq: np.ndarray, tz: np.ndarray, P: np.ndarray, step: float
) -> np.ndarray:
    """(N, 5) the motors' derivative along ``dq`` (N, 5) from poses ``q`` (N, 5)
    whose IK is ``P`` (N, 5): the IK's one-sided difference over ``step``,
    (P(q + step dq) − P) / step."""
    return (inverse_rows(m, q + step * dq, tz) - P) / step


def _row_bits(q: np.ndarray) -> np.ndarray:
    """(N,) each row of ``q`` (N, 5) as one value of its 40 bytes (rows compared
    to the bit in one pass; np.all over rows of 5 is slow)."""
    return np.ascontiguousarray(q).view(np.dtype((np.void, q.itemsize * 5))).reshape(-1)


def end_slopes(
    m: IKArrays,
    start: np.ndarray,
    end: np.ndarray,
    dq_in: np.ndarray,
    dq_out: np.ndarray,
    tz: np.ndarray,
    step: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The motors' dP/ds at the starts and ends of n blocks: (d_in, d_out), (n, 5)
    each [mm/mm].

    d_in = (P(start + h dq_in) − P(start)) / h along the tangent into each block,
    d_out = −((P(end − h dq_out) − P(end)) / h) back along the tangent out of it
    (:func:`derivative_rows` over ``step`` h), for poses ``start``, ``end`` (n, 5)
    with tool heights ``tz`` (n,). A start with the bits of the block before's
    end, and its tool height (a path's every junction), takes that end's IK: the
    IK solves each row alone, so the same row gives the same bits.
    """
    n = len(start)
    P_end = inverse_rows(m, end, tz)
    again = np.zeros(n, dtype=bool)
    if n > 1:
        again[1:] = (_row_bits(start[1:]) == _row_bits(end[:-1])) & (
            tz[1:].view(np.int64) == tz[:-1].view(np.int64)
        )
    P_start = np.empty((n, 5))
    P_start[1:] = P_end[:-1]
    fresh = np.flatnonzero(~again)
    P_start[fresh] = inverse_rows(m, np.take(start, fresh, axis=0), tz[fresh])
    d_in = derivative_rows(m, start, dq_in, tz, P_start, step)
    d_out = -derivative_rows(m, end, -dq_out, tz, P_end, step)
    return d_in, d_out


def motion_rows(
    m: IKArrays, q: np.ndarray, qdot: np.ndarray, tz: np.ndarray, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """The IK P (N, 5) [mm] of poses ``q`` (N, 5) and its velocity V (N, 5) [mm/s]
    along ``qdot`` (N, 5): :func:`derivative_rows` over ``step`` [s] where a row
    moves, 0 where its ``qdot`` is 0."""
    P = inverse_rows(m, q, tz)
    V = np.zeros_like(P)
    moving = np.flatnonzero(np.any(qdot != 0.0, axis=1))
    if moving.size:
        V[moving] = derivative_rows(m, q[moving], qdot[moving], tz[moving], P[moving], step)
    return P, V


def jacobian_rows(
    m: IKArrays, q: np.ndarray, tz: np.ndarray, step: float, P: np.ndarray | None = None
) -> np.ndarray:
    """(N, 5, 5) ∂P_i/∂q_j at poses ``q`` (N, 5): the IK's one-sided differences
    over ``step`` along each coordinate, (P(q + step e_j) − P) / step, from ``P``
    (the IK of ``q``; solved with the steps when None)."""
    n = len(q)
    base = 0 if P is None else 1
    q6 = np.tile(q, (6 - base, 1))
    for j in range(5):
        q6[(j + 1 - base) * n : (j + 2 - base) * n, j] += step
    P6 = inverse_rows(m, q6, np.tile(tz, 6 - base))
    if P is not None:
        P6 = np.concatenate([P, P6])
    return np.stack([(P6[(j + 1) * n : (j + 2) * n] - P6[:n]) / step for j in range(5)], axis=2)
