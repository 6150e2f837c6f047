"""The kernel: per-point numerical work as functions over arrays.

Each kernel has a numpy reference (``ik.py``, ``text.py``) and a compiled twin in
Cython (``_ik.pyx``, ``_text.pyx``, built when the package is installed) that gives
the same bits. This module picks one set for the whole program, once, at import:

- ``PRSXY_KERNEL=pure`` in the environment: the numpy reference (CI's pure leg);
- otherwise the compiled kernels when the extension imports, else the reference.

:data:`COMPILED` says which was picked, :data:`NAME` names it (``prsxy-post
--version`` prints it) and :data:`WHY_PURE` says why the reference runs; the command
line warns on stderr when the extension is missing (the library never prints).

The compiled IK covers straight guides; a geometry with bowed guides
(``effects.guide_bow``) runs the reference IK even when compiled (its Newton step sums
with numpy's einsum, whose order C would have to copy).

The kernel imports nothing from the stream, the writers, the profile or the
command line: its inputs are arrays and small frozen records of arrays.
"""

from __future__ import annotations

import importlib.util
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import ik, text

#: The environment variable that selects the reference kernels (value ``pure``).
ENV = "PRSXY_KERNEL"

InverseRows = Callable[[ik.IKArrays, np.ndarray, np.ndarray], np.ndarray]
FixedRows = Callable[..., list[str]]


def _load() -> tuple[Any, Any, str, str]:
    """(inverse_rows, format_fixed_rows, name, why the reference runs or "")."""
    pure = (ik.inverse_rows, text.format_fixed_rows)
    if os.environ.get(ENV, "").strip().lower() == "pure":
        return (*pure, "pure numpy (PRSXY_KERNEL=pure)", f"{ENV}=pure")
    try:
        from . import _ik, _text  # type: ignore[attr-defined]
    except ImportError as e:
        absent = [
            n for n in ("_ik", "_text") if importlib.util.find_spec(f"{__name__}.{n}") is None
        ]
        why = (
            f"the compiled extension is not built (no {', '.join(absent)} "
            f"in {Path(__file__).parent})"
            if absent
            else f"the compiled extension does not import ({e})"
        )
        return (*pure, f"pure numpy ({why})", why)
    return _ik.inverse_rows, _text.format_fixed_rows, f"compiled (Cython {_ik.CYTHON})", ""


_inverse_rows, _fixed_rows, NAME, WHY_PURE = _load()
#: True when the compiled kernels run.
COMPILED: bool = not WHY_PURE
#: True when the reference runs because the extension is missing (not asked for).
MISSING: bool = bool(WHY_PURE) and not WHY_PURE.startswith(ENV)


def inverse_rows(m: ik.IKArrays, q: np.ndarray, tz: np.ndarray) -> np.ndarray:
    """Motor positions (N, 5) [mm] for poses ``q`` (N, 5) and tool heights ``tz``
    (N,): :func:`ik.inverse_rows`, compiled when :data:`COMPILED`."""
    out: np.ndarray = _inverse_rows(m, q, tz)
    return out


def format_fixed_rows(columns: Sequence[tuple[str, np.ndarray, int]], end: str = "\n") -> list[str]:
    """Rows of fixed-point text: :func:`text.format_fixed_rows`, compiled when
    :data:`COMPILED`."""
    out: list[str] = _fixed_rows(columns, end)
    return out
