"""Numbers as controllers read them: fixed-point text for whole chunks at once."""

from __future__ import annotations

import numpy as np

from .. import kernel


def round_clean(x: np.ndarray, decimals: int) -> np.ndarray:
    """Round and clear negative zeros so equal values print equal bytes.

    The zeros are cleared in the rounded array itself (``-0.0 + 0.0`` is ``0.0``):
    a second array of a chunk's size is fresh pages, dearer than the sum."""
    out: np.ndarray = np.round(np.asarray(x, dtype=float), decimals)
    out += 0.0
    return out


#: Rows of fixed-point text, ``prefix value prefix value ...``, the same text as
#: ``"%s%.{d}f" % (prefix, value)`` per column: the kernel's
#: (:func:`prsxy_post.kernel.text.format_fixed_rows`, compiled when built).
format_fixed_rows = kernel.format_fixed_rows

#: A PVT program's points as one text, rows with the line comments and PVT times
#: before them (:func:`prsxy_post.kernel.text.pvt_segment_text`, compiled when built).
pvt_segment_text = kernel.pvt_segment_text
