"""The C library's scalar math functions over arrays, for bit-identical kernels.

numpy dispatches some float64 functions to its own vector code where the processor
allows (on AVX-512 machines ``np.arccos``, ``np.arctan2`` and ``np.hypot`` differ from
the C library's in the last bit for 8–9 % of arguments, measured in
``tests/test_kernel_ik.py``), so results made with them would depend on the
processor, and a compiled kernel calling the C library could not match them. The
reference kernels call these functions through :mod:`math` instead, which calls the
C library (``acos``, ``atan2``), exactly as the compiled kernels do.
"""

from __future__ import annotations

import math

import numpy as np


def acos(x: np.ndarray) -> np.ndarray:
    """acos of each element (C library); NaN outside [−1, 1] and for NaN."""
    x = np.asarray(x, dtype=float)
    out = np.full(x.shape, np.nan)
    ok = np.abs(x) <= 1.0  # math.acos raises outside its domain; C's acos gives NaN
    out[ok] = np.fromiter(map(math.acos, x[ok].tolist()), float, int(np.count_nonzero(ok)))
    return out


def atan2(y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """atan2(y, x) of each pair of elements (C library), the shape of ``y``."""
    y, x = np.broadcast_arrays(np.asarray(y, dtype=float), np.asarray(x, dtype=float))
    return np.fromiter(
        map(math.atan2, y.ravel().tolist(), x.ravel().tolist()), float, y.size
    ).reshape(y.shape)
