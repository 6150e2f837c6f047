"""The virtual-axis error map over arrays: the numpy reference kernel.

The map of the paper's Eq. 4–5 (:mod:`prsxy_post.errormap`) is a sum over distinct
products of Legendre polynomials of the five coordinates, each scaled to [−1, 1] over
the fitted domain and clamped to its edge:

    u_v = clip(2 (q_v − lo_v) / span_v − 1, −1, 1)
    P_0 = 1,  P_1 = u,  P_i = (P_{i−1} u (2i − 1) − P_{i−2} (i − 1)) / i
    e_c(q) = Σ_k C[k, c] Π_v P_{E[k, v]}(u_v)

(the recurrence is numpy's ``legvander``, operation for operation). The compensation
is Q' = Q − e(Q) (Eq. 6, :func:`correct_virtual`). ``_legendre.pyx`` is the same
arithmetic in C, in the same order, so the two agree to the bit
(``tests/test_kernel_legendre.py``).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class MapArrays(NamedTuple):
    """A fitted map flattened into what its evaluation needs, made once per map.

    lo : (5,) the domain's lower corner [mm, mm, mm, deg, deg]
    span : (5,) hi − lo, 1 where the domain is flat
    degree : the highest Legendre degree any product uses (at least 2)
    exps : (K, 5) int64, each distinct product's degree in x, y, z, A, B
    coef : (K, 5) each product's coefficient in e_x, e_y, e_z, e_A, e_B [mm, deg]
    """

    lo: np.ndarray
    span: np.ndarray
    degree: int
    exps: np.ndarray
    coef: np.ndarray


def scaled(m: MapArrays, q: np.ndarray) -> np.ndarray:
    """u (N, 5): the coordinates scaled to [−1, 1] over the domain, clamped."""
    return np.clip(2.0 * (q - m.lo) / m.span - 1.0, -1.0, 1.0)


def legendre_table(u: np.ndarray, degree: int) -> np.ndarray:
    """P_0..P_degree at u (N,), shape (N, degree + 1): numpy's ``legvander``."""
    u = u + 0.0  # as legvander: −0.0 becomes 0.0
    v = np.empty((degree + 1, len(u)))
    v[0] = u * 0 + 1
    if degree > 0:
        v[1] = u
        for i in range(2, degree + 1):
            v[i] = (v[i - 1] * u * (2 * i - 1) - v[i - 2] * (i - 1)) / i
    return np.moveaxis(v, 0, -1)


def map_rows(m: MapArrays, q: np.ndarray) -> np.ndarray:
    """e(q) (N, 5) [mm, mm, mm, deg, deg] for poses q (N, 5)."""
    u = scaled(m, q)
    tables = [legendre_table(u[:, v], m.degree) for v in range(5)]
    out = np.zeros((len(q), 5))
    for k in range(len(m.exps)):
        col: np.ndarray | float = 1.0
        for v in range(5):
            if m.exps[k, v]:
                col = tables[v][:, m.exps[k, v]] * col
        for c in range(5):
            if m.coef[k, c] != 0.0:
                out[:, c] += m.coef[k, c] * col
    return out


def correct_virtual(m: MapArrays, q: np.ndarray, iterations: int = 1) -> np.ndarray:
    """Q' (N, 5) = Q − e(Q) (Eq. 6), then Q' = Q − e(Q') again ``iterations`` − 1
    times (see :func:`prsxy_post.chain.correct_virtual`)."""
    qp = q - map_rows(m, q)
    for _ in range(iterations - 1):
        qp = q - map_rows(m, qp)
    return qp
