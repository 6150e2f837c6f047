"""The forward kinematics' Newton iteration: the numpy reference kernel.

:func:`forward_newton` solves the six constraint equations for x = (c, A, B, γ)
(machine-model.md, "Forward kinematics"), batched over rows:

    f_k = (s_k − g_k)·u_k,   f_{3+k} = |w_k| − L_k,   s_k = c + R b_k,  w_k = s_k − a_k

with R = R_y(B) R_x(A) R_z(γ), Newton's step J s = −f (:func:`fk_system`) until every
component of a step is below ``limit``, then checks the residual. Along a path,
:func:`anchored_starts` starts each row at the offset solved at an anchor row. Every operation is
an element-wise IEEE operation in a fixed order: the 3 × 3 products written out as
left-to-right sums, and the 6 × 6 solve Gaussian elimination with partial pivoting
written out (:func:`solve6`), not BLAS and LAPACK (whose kernels, and so whose last
bits, depend on the processor). ``_fk.pyx`` does the same arithmetic in C, each row's
own (four rows side by side), so the two agree to the bit
(``tests/test_kernel_fk.py``). The sines and cosines are numpy's, as in the IK's
reference (``kernel/ik.py``): several times cheaper than the C library's through
:mod:`math`, and the C library's on the machines the tests run on (``tests/test_kernel_ik.py::
test_numpy_trig_is_the_c_librarys_here``; where that fails, they would go through
:mod:`.libm`).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class FKArrays(NamedTuple):
    """A geometry as the FK's arithmetic takes it, made once per geometry.

    g, u : (3, 3) guide points [mm] and hinge axes, one leg a row
    b : (3, 3) ball joints in the platform frame [mm], one leg a row
    L : (3,) strut lengths [mm]
    """

    g: np.ndarray
    u: np.ndarray
    b: np.ndarray
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


def _pose(m: FKArrays, off: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, ...]:
    """At x (N, 6): cos B, sin B, R (N, 3, 3), R b_k (N, leg, 3), w_k (N, leg, 3),
    |w_k| (N, leg), the six equations f (N, 6) [mm]."""
    ca, sa = np.cos(x[:, 3]), np.sin(x[:, 3])
    cb, sb = np.cos(x[:, 4]), np.sin(x[:, 4])
    R = rotation_cs(ca, sa, cb, sb, np.cos(x[:, 5]), np.sin(x[:, 5]))
    # R b_k: row i of R times b_k, summed left to right
    b = m.b[None, :, None, :]
    Rr = R[:, None, :, :]
    rb = Rr[..., 0] * b[..., 0] + Rr[..., 1] * b[..., 1] + Rr[..., 2] * b[..., 2]
    v = x[:, None, :3] + rb - m.g[None]
    plane = dot3(v, m.u[None])
    w = v - off
    norm_w = np.sqrt(dot3(w, w))
    # length residual scaled to mm: |w| − L behaves like a distance
    f = np.concatenate([plane, norm_w - m.L[None]], axis=1)
    return cb, sb, R, rb, w, norm_w, f


def fk_residual(m: FKArrays, off: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The six FK equations (N, 6) [mm] at x = (c, A, B, γ) (N, 6) [mm, rad], for
    the hinges' offsets a_k − g_k ``off`` (N, leg, 3) [mm]."""
    with np.errstate(invalid="ignore", over="ignore"):
        return _pose(m, off, x)[-1]


def fk_system(m: FKArrays, off: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The six FK equations f (N, 6) [mm] at x (N, 6) and their Jacobian
    J = ∂f/∂x (N, 6, 6) [mm/mm, mm/rad].

    ∂s_k/∂c = I; an angle turning about the unit axis e (machine frame) moves R b_k
    by e × R b_k, with e = R_y(B) x̂ = (cos B, 0, −sin B) for A, ŷ for B and R ẑ for
    γ (each factor of R turns about its own axis, carried by the factors to its
    left). The angle columns are the triple products n·(e × R b_k) = e·(R b_k × n),
    n = u_k for the plane equations and w_k / |w_k| for the lengths.
    """
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        cb, sb, R, rb, w, norm_w, f = _pose(m, off, x)
        unit_w = w / norm_w[..., None]
        J = np.empty((len(x), 6, 6))
        J[:, :3, :3] = m.u[None]
        J[:, 3:, :3] = unit_w
        for rows, n in ((slice(0, 3), np.broadcast_to(m.u[None], rb.shape)), (slice(3, 6), unit_w)):
            cr = cross3(rb, n)  # R b_k × n
            c0, c1, c2 = cr[..., 0], cr[..., 1], cr[..., 2]
            J[:, rows, 3] = c0 * cb[:, None] - c2 * sb[:, None]
            J[:, rows, 4] = c1
            J[:, rows, 5] = c0 * R[:, None, 0, 2] + c1 * R[:, None, 1, 2] + c2 * R[:, None, 2, 2]
    return f, J


def solve6(J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """s (N, 6) with J s = r for each row: Gaussian elimination with partial
    pivoting (the first row of the largest magnitude in the column; a NaN is
    never chosen over a number, and a NaN on the diagonal stays), then back
    substitution, each sum left to right. A singular J gives a non-finite s.
    """
    # one contiguous (N,) vector per entry: A[i, j], b[i]
    A = np.ascontiguousarray(np.moveaxis(np.asarray(J, dtype=float), 0, -1))
    b = np.ascontiguousarray(np.asarray(r, dtype=float).T)
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        for k in range(6):
            col = np.abs(A[k:, k])
            p = k + np.argmax(np.where(np.isnan(col), -1.0, col), axis=0)
            p[np.isnan(col[0])] = k
            # rows swapped only where the pivot moves (the same numbers either way)
            sw = np.flatnonzero(p != k)
            if sw.size:
                ps = p[sw]
                top, top_b = A[k][:, sw], b[k, sw]
                A[k][:, sw], b[k, sw] = A[ps, :, sw].T, b[ps, sw]
                A[ps, :, sw], b[ps, sw] = top.T, top_b
            lk = A[k + 1 :, k] / A[k, k]
            A[k + 1 :, k + 1 :] -= lk[:, None, :] * A[k, None, k + 1 :]
            b[k + 1 :] -= lk * b[k]
        s = np.empty_like(b)
        for i in range(5, -1, -1):
            t = b[i]
            for j in range(i + 1, 6):
                t = t - A[i, j] * s[j]
            s[i] = t / A[i, i]
    return np.ascontiguousarray(s.T)


def forward_newton(
    m: FKArrays, off: np.ndarray, x0: np.ndarray, limit: float, max_iter: int, res_tol: float
) -> tuple[np.ndarray, np.ndarray]:
    """Newton's iteration on the six FK equations from x0 (N, 6) [mm, rad].

    Each row steps by s = J⁻¹(−f) (:func:`fk_system`, :func:`solve6`) until every
    component of a step is below ``limit`` (converged: one more step would not
    change it) or a step is not finite (stays where it is, not converged), at most
    ``max_iter`` steps. Converged rows must also leave every equation below
    ``res_tol`` [mm].

    Parameters
    ----------
    m : FKArrays
    off : (N, leg, 3) the hinges' offsets a_k − g_k [mm]
    x0 : (N, 6) start (c [mm], A, B, γ [rad])

    Returns
    -------
    x : (N, 6); converged : (N,) bool
    """
    x = np.array(x0, dtype=float)
    converged = np.zeros(len(x), dtype=bool)
    active = np.arange(len(x))
    for _ in range(max_iter):
        if active.size == 0:
            break
        xa = x[active]
        f, J = fk_system(m, off[active], xa)
        step = solve6(J, -f)
        bad = ~np.all(np.isfinite(step), axis=1)
        step = np.where(bad[:, None], 0.0, step)
        done = np.all(np.abs(step) < limit, axis=1) & ~bad
        x[active] = xa + step
        converged[active[done]] = True
        active = active[~(done | bad)]
    converged &= np.all(np.abs(fk_residual(m, off, x)) < res_tol, axis=1)
    return x, converged


def tool_poses(
    x: np.ndarray, ok: np.ndarray, t: np.ndarray, origin: np.ndarray, D: np.ndarray
) -> np.ndarray:
    """The tool poses q (N, 5) [mm, mm, mm, deg, deg] of FK solutions x (N, 6)
    (c [mm], A, B, γ [rad]); NaN rows where not ``ok`` (N,) (contract "Forward
    kinematics").

    The tip T = c + R t for the tool vectors ``t`` (N, 3) [mm] in the platform frame
    (R = R_y(B) R_x(A) R_z(γ), :func:`rotation_cs`), in the workpiece frame
    w = T − o + D (``origin`` o (3,), the table's displacement ``D`` (N, 3) [mm]),
    A and B in degrees (numpy's ``degrees``: x · (180 / π)). R t is summed as numpy's
    ``einsum("nij,nj->ni")`` sums it here (two accumulators from 0, the first
    taking the products of t's components 0 and 2, the second of 1, then added to
    0): ``0 + ((0 + p0 + p2) + (0 + p1))``, written out so that the order is fixed.
    """
    a, b, g = x[:, 3], x[:, 4], x[:, 5]
    R = rotation_cs(np.cos(a), np.sin(a), np.cos(b), np.sin(b), np.cos(g), np.sin(g))
    p = R * t[:, None, :]
    Rt = 0.0 + (((0.0 + p[..., 0]) + p[..., 2]) + (0.0 + p[..., 1]))
    q = np.empty((len(x), 5))
    q[:, :3] = x[:, :3] + Rt - origin + D
    q[:, 3] = np.degrees(x[:, 3])
    q[:, 4] = np.degrees(x[:, 4])
    q[~np.asarray(ok, dtype=bool)] = np.nan
    return q


def forward_poses(
    m: FKArrays,
    d: np.ndarray,
    P: np.ndarray,
    x0: np.ndarray,
    t: np.ndarray,
    origin: np.ndarray,
    D: np.ndarray,
    limit: float,
    max_iter: int,
    res_tol: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The FK of motor positions on straight guides, whole: the hinges' offsets
    P_k d_k from the motors ``P`` (N, >= 3) [mm] and the guides' directions ``d``
    (3, 3), :func:`forward_newton` from x0, then :func:`tool_poses` of its solutions.

    Returns
    -------
    q : (N, 5) [mm, mm, mm, deg, deg], NaN rows where not converged; converged : (N,)
    """
    off = P[:, :3, None] * d[None]
    x, ok = forward_newton(m, off, x0, limit, max_iter, res_tol)
    return tool_poses(x, ok, t, origin, D), ok


#: The largest offset an anchor hands on, per component of x (c [mm], A, B, γ
#: [rad]): a point moved further from its guess starts from the guess alone. About
#: twelve times the largest offsets of the test machines (0.081 mm, 0.0015 rad: the
#: controller's geometry against the contract's perturbed machine's commands,
#: ``python bench/fk_steps.py samples/five-axis.ngc tests/data/vectors/perturbed.toml``),
#: so that a start is never far from its guess, where Newton could find another of
#: the FK's solutions.
ANCHOR_REACH = (1.0, 1.0, 1.0, 0.02, 0.02, 0.02)


def anchored_starts(
    m: FKArrays,
    off: np.ndarray,
    x0: np.ndarray,
    limit: float,
    max_iter: int,
    res_tol: float,
    every: int,
    phase: int,
    carry: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Starts next to the solutions, for rows along a path whose start x0 misses
    its solution by an offset that changes slowly from row to row.

    The anchors, rows r with (phase + r) mod ``every`` = 0, are solved from x0
    (:func:`forward_newton`); an anchor's offset is δ = x − x0 where it converged
    and every |δ_j| ≤ :data:`ANCHOR_REACH`, 0 where not. Every row starts at x0 + δ
    of the last anchor at or before it; the rows before the call's first anchor at
    x0 + ``carry`` (the last δ of the call before, whose rows came before these:
    zeros at the start of a run; 0 too where beyond the reach). Rows a
    path's point apart start within the change of the offset between them, so
    most need one Newton step instead of three (``bench/fk_steps.py``).

    Parameters
    ----------
    off : (N, leg, 3) the hinges' offsets [mm]; x0 : (N, 6) the starts
    every : rows from one anchor to the next, >= 1
    phase : the index of row 0 in the run, modulo ``every``
    carry : (6,) the offset for the rows before the first anchor

    Returns
    -------
    starts : (N, 6); carry : (6,) the offset of the last anchor (``carry`` if none)
    """
    n = len(x0)
    first = (-phase) % every
    a = np.arange(first, n, every)
    xa, oka = forward_newton(m, off[a], x0[a], limit, max_iter, res_tol)
    delta = np.empty((len(a) + 1, 6))
    delta[0] = carry
    delta[1:] = xa - x0[a]
    near = np.all(np.abs(delta) <= np.asarray(ANCHOR_REACH), axis=1)
    near[1:] &= oka
    delta[~near] = 0.0
    # the anchor at or before each row, 0 (the carry) before the first
    k = (np.arange(n) - first) // every + 1
    return x0 + delta[k], delta[-1].copy()


def forward_poses_anchored(
    m: FKArrays,
    d: np.ndarray,
    P: np.ndarray,
    x0: np.ndarray,
    t: np.ndarray,
    origin: np.ndarray,
    D: np.ndarray,
    limit: float,
    max_iter: int,
    res_tol: float,
    every: int,
    phase: int,
    carry: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`forward_poses` from :func:`anchored_starts` of x0: q (N, 5), converged
    (N,), and the carry for the next call (6,)."""
    off = P[:, :3, None] * d[None]
    starts, carry = anchored_starts(m, off, x0, limit, max_iter, res_tol, every, phase, carry)
    q, ok = forward_poses(m, d, P, starts, t, origin, D, limit, max_iter, res_tol)
    return q, ok, carry
