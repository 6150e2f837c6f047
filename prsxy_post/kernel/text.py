"""Rows of fixed-point text for whole chunks at once: the numpy reference kernel.

``_text.pyx`` writes the same bytes row by row in C (``tests/test_kernel_text.py``);
both print what Python's ``"%.{d}f"`` prints (``tests/test_writers_numbers.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: integer digits the vectorised formatter writes; larger values take Python's %
_INT_DIGITS = 9


def format_fixed_rows(columns: Sequence[tuple[str, np.ndarray, int]], end: str = "\n") -> list[str]:
    """Rows of text, ``prefix value prefix value ...``, each value in fixed point.

    The same text as ``"%s%.{d}f" % (prefix, value)`` per column, built for all
    rows at once: digits as bytes in an (N, width) array, unused places dropped.
    Python formats a value itself only where the scaled value lies within 1e-6
    of a rounding tie (there the binary value decides, as in Python), and every
    value when one is too large for :data:`_INT_DIGITS` (or for exact integers).

    Parameters
    ----------
    columns : (prefix, values (N,), decimals) per column
    end : text after each row (kept on the returned rows)
    """
    n = len(columns[0][1]) if columns else 0
    if n == 0:
        return []
    parts: list[np.ndarray] = []
    for prefix, values, d in columns:
        if prefix:
            parts.append(np.tile(np.frombuffer(prefix.encode("ascii"), np.uint8), (n, 1)))
        v = np.asarray(values, dtype=float)
        if not np.all(np.abs(v) < min(10.0**_INT_DIGITS, 2.0**52 / 10.0**d)):
            text = "".join(
                "".join(
                    f"{p}{x:.{dd}f}"
                    for p, x, dd in zip(
                        [c[0] for c in columns], row, [c[2] for c in columns], strict=True
                    )
                )
                + end
                for row in np.column_stack([c[1] for c in columns]).tolist()
            )
            return text.splitlines(keepends=True)
        t = np.abs(v) * 10.0**d
        k = np.rint(t).astype(np.int64)
        tie = np.flatnonzero(np.abs(t - np.floor(t) - 0.5) < 1e-6)
        if tie.size:
            k[tie] = [int(f"{abs(x):.{d}f}".replace(".", "")) for x in v[tie].tolist()]
        width = max(len(str(int(k.max()))), d + 1)  # at least the units digit
        digits = np.empty((width, n), np.uint8)
        # int32 division is several times faster than int64 where the values fit
        x = k.astype(np.int32) if width < 10 else k
        for j in range(width - 1, -1, -1):
            q = x // 10
            digits[j] = x - q * 10
            x = q
        int_w = width - d
        chars = (digits + np.uint8(48)).T
        # leading zeros of the integer part go, the units digit stays
        chars[:, : int_w - 1] *= np.maximum.accumulate(digits[: int_w - 1], axis=0).T != 0
        sign = np.where(np.signbit(v), ord("-"), 0).astype(np.uint8)
        block = np.zeros((n, width + 2), np.uint8)
        block[:, 0] = sign
        block[:, 1 : int_w + 1] = chars[:, :int_w]
        if d:
            block[:, int_w + 1] = ord(".")
            block[:, int_w + 2 :] = chars[:, int_w:]
        parts.append(block)
    parts.append(np.tile(np.frombuffer(end.encode("ascii"), np.uint8), (n, 1)))
    flat = np.hstack(parts).ravel()
    return np.compress(flat != 0, flat).tobytes().decode("ascii").splitlines(keepends=True)
