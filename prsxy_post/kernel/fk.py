"""The forward kinematics' per-row arithmetic: the numpy reference kernel.

The batched Newton of :func:`prsxy_post.kinematics.forward_platform` solves the six
constraint equations for (c, A, B, γ) (machine-model.md, "Forward kinematics"):

    f_k = (s_k − g_k)·u_k,   f_{3+k} = |w_k| − L_k,   s_k = c + R b_k,  w_k = s_k − a_k

and their Jacobian (:func:`prsxy_post.kinematics._fk_system`). What the kinematics
hands to numpy stays there, on both paths: the sines and cosines (numpy's vector
math), the 3 × 3 products (numpy's matmul, which calls BLAS) and the 6 × 6 solve
(LAPACK). What is left, the element-wise arithmetic between them, is here, each
operation in the order the kinematics always did it: ``_fk.pyx`` is the same
arithmetic in C, so the two agree to the bit (``tests/test_kernel_fk.py``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class FKArrays(NamedTuple):
    """A geometry as the FK's arithmetic takes it, made once per geometry.

    g, u, d : (3, 3) guide points [mm], hinge axes and guide directions, one leg
        a row
    L : (3,) strut lengths [mm]
    """

    g: np.ndarray
    u: np.ndarray
    d: np.ndarray
    L: np.ndarray


def rotation_cs(
    ca: np.ndarray, sa: np.ndarray, cb: np.ndarray, sb: np.ndarray, cg: np.ndarray, sg: np.ndarray
) -> np.ndarray:
    """R = R_y(B) R_x(A) R_z(γ) from the angles' cosines and sines, (N, 3, 3)."""
    R = np.empty((*np.shape(ca), 3, 3))
    R[..., 0, 0] = cb * cg + sb * sa * sg
    R[..., 0, 1] = sb * sa * cg - cb * sg
    R[..., 0, 2] = sb * ca
    R[..., 1, 0] = ca * sg
    R[..., 1, 1] = ca * cg
    R[..., 1, 2] = -sa
    R[..., 2, 0] = cb * sa * sg - sb * cg
    R[..., 2, 1] = sb * sg + cb * sa * cg
    R[..., 2, 2] = cb * ca
    return R


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a × b over the last axis, written out (np.cross is slow on small shapes)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a · b over the last axis, written out (a reduction over 3 is slow)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def fk_equations(
    m: FKArrays, c: np.ndarray, rb: np.ndarray, p3: np.ndarray, off: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The six FK equations at the platform centre ``c`` (N, 3), with R b_k ``rb``
    (N, leg, 3), for the head's motors ``p3`` (N, 3) [mm]: the hinges' offsets
    a_k − g_k are P_k d_k (straight guides), or ``off`` (N, leg, 3) where given.

    Returns
    -------
    w : (N, leg, 3) w_k = s_k − a_k;  norm_w : (N, leg) |w_k|;  f : (N, 6) [mm]
    """
    v = c[:, None, :] + rb - m.g[None]
    plane = dot3(v, m.u)
    w = v - (p3[:, :, None] * m.d[None] if off is None else off)
    norm_w = np.sqrt(dot3(w, w))
    # Length residual scaled to mm: |w| − L behaves like a distance.
    f = np.concatenate([plane, norm_w - m.L[None]], axis=1)
    return w, norm_w, f


def fk_jacobian_parts(
    m: FKArrays,
    R: np.ndarray,
    rb: np.ndarray,
    w: np.ndarray,
    norm_w: np.ndarray,
    cb: np.ndarray,
    sb: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The Jacobian's columns of c, and the factors of its angle columns.

    The rotation axes of A, B, γ (rows) are (cos B, 0, −sin B), ŷ and R ẑ; the
    angle columns are the triple products n·(e × R b_k) = e·(R b_k × n) with
    n = u_k for the plane equations and w_k / |w_k| for the lengths.

    Returns
    -------
    J : (N, 6, 6) with J[:, :, :3] filled (u_k; w_k / |w_k|)
    cross_u, cross_w : (N, leg, 3) R b_k × u_k, R b_k × w_k / |w_k|
    axes_t : (N, 3, 3) the axes as columns: J[:, :3, 3:] = cross_u @ axes_t,
        J[:, 3:, 3:] = cross_w @ axes_t
    """
    n = len(R)
    axes = np.empty((n, 3, 3))  # rotation axes of A, B, γ (rows)
    axes[:, 0, 0] = cb
    axes[:, 0, 1] = 0.0
    axes[:, 0, 2] = -sb
    axes[:, 1] = (0.0, 1.0, 0.0)
    axes[:, 2] = R[:, :, 2]
    unit_w = w / norm_w[..., None]
    J = np.empty((n, 6, 6))
    J[:, :3, :3] = m.u[None]
    J[:, 3:, :3] = unit_w
    return (
        J,
        cross3(rb, np.broadcast_to(m.u, rb.shape)),
        cross3(rb, unit_w),
        axes.transpose(0, 2, 1),
    )


def newton_step(
    x: np.ndarray, step: np.ndarray, limit: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One batched Newton update: rows whose step is not finite stay (bad); the
    others move by it and are done when every component of the step is below
    ``limit``.

    Returns
    -------
    x + step (N, 6);  done, bad : (N,) bool
    """
    bad = ~np.all(np.isfinite(step), axis=1)
    step = np.where(bad[:, None], 0.0, step)
    done = (np.max(np.abs(step), axis=1) < limit) & ~bad
    return x + step, done, bad
