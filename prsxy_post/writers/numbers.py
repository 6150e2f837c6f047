"""Numbers as controllers read them: fixed-point text for whole chunks at once."""

from __future__ import annotations

import numpy as np

from .. import kernel


def round_clean(x: np.ndarray, decimals: int) -> np.ndarray:
    """Round and clear negative zeros so equal values print equal bytes."""
    return np.round(x, decimals) + 0.0


#: Rows of fixed-point text, ``prefix value prefix value ...``, the same text as
#: ``"%s%.{d}f" % (prefix, value)`` per column: the kernel's
#: (:func:`prsxy_post.kernel.text.format_fixed_rows`, compiled when built).
format_fixed_rows = kernel.format_fixed_rows
