"""Rows of fixed-point text for whole chunks at once: the numpy reference kernel.

``_text.pyx`` writes the same bytes row by row in C (``tests/test_kernel_text.py``);
both print what Python's ``"%.{d}f"`` prints (``tests/test_writers_numbers.py``).
:func:`pvt_segment_text` writes a PVT program's points: each row with the line
comment and the PVT time before it where they change, in one call.
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


#: 1 / 4096 ms = 0.000244140625 ms: a quantum's twelve decimals as an integer
QUANTUM_E12 = 244_140_625
#: PVT times [1/4096 ms] the integer formatter takes; beyond, Python's float text
#: (q / 4096 is exact below 2^53)
PVT_MAX_QUANTA = 2**52


def pvt_ms_text(quanta: int) -> str:
    """A PVT time of ``quanta`` / 4096 ms, exactly, as decimal text with at least four
    decimals: 40960 → ``10.0000``, 1000 → ``0.244140625`` (Python's own float text,
    the definition the vectorised :func:`pvt_ms_rows` and the compiled twin follow).

    A whole number of 2^-12 has at most twelve decimals, and its double is exact.
    """
    text = f"{quanta / 4096:.12f}".rstrip("0")
    whole, frac = text.split(".")
    return f"{whole}.{frac:0<4}"


def _digits(x: np.ndarray, width: int) -> np.ndarray:
    """The ``width`` lowest decimal digits of non-negative integers ``x``, (n, width)
    uint8, most significant first."""
    out = np.empty((width, len(x)), np.uint8)
    for j in range(width - 1, -1, -1):
        q = x // 10
        out[j] = x - q * 10
        x = q
    return out.T


def _int_block(x: np.ndarray) -> np.ndarray:
    """Integers as text bytes, (n, width) uint8, unused places 0 (dropped later):
    the same text as ``str(int)``."""
    a = np.abs(x).astype(np.uint64)  # |int64 min| fits in uint64
    width = len(str(int(a.max()))) if len(a) else 1
    d = _digits(a, width)
    chars = d + np.uint8(48)
    # leading zeros go, the units digit stays
    chars[:, :-1] *= np.maximum.accumulate(d[:, :-1], axis=1) != 0
    sign = np.where(x < 0, ord("-"), 0).astype(np.uint8)
    return np.hstack([sign[:, None], chars])


def _rows(blocks: list[np.ndarray]) -> list[str]:
    """Rows of text from byte blocks (zeros dropped); each row ends with a newline."""
    flat = np.hstack(blocks).ravel()
    return np.compress(flat != 0, flat).tobytes().decode("ascii").splitlines(keepends=True)


def pvt_ms_rows(quanta: np.ndarray, prefix: str = "PVT") -> list[str]:
    """``prefix + pvt_ms_text(q) + "\n"`` for every q of ``quanta`` (n,), all at once:
    the whole ms, then the twelve decimals of the quanta left (q mod 4096 times
    0.000244140625), their zeros stripped from the end down to four."""
    q = np.asarray(quanta, dtype=np.int64)
    if q.size == 0:
        return []
    if not np.all((-PVT_MAX_QUANTA < q) & (q < PVT_MAX_QUANTA)):  # np.abs(-2^63) < 0
        return [f"{prefix}{pvt_ms_text(x)}\n" for x in q.tolist()]
    a = np.abs(q)
    whole = _int_block(a >> 12)
    # "-0.5000" for q = -2048: the sign goes with the value, not its whole part
    whole[:, 0] = np.where(q < 0, ord("-"), 0)
    frac = _digits((a & 4095) * QUANTUM_E12, 12)
    # the decimals up to the last non-zero one, and at least four
    keep = np.maximum.accumulate(frac[:, ::-1], axis=1)[:, ::-1] != 0
    keep[:, :4] = True
    n = len(q)
    return _rows(
        [
            np.tile(np.frombuffer(prefix.encode("ascii"), np.uint8), (n, 1)),
            whole,
            np.full((n, 1), ord("."), np.uint8),
            (frac + np.uint8(48)) * keep,
            np.full((n, 1), ord("\n"), np.uint8),
        ]
    )


def int_rows(prefix: str, values: np.ndarray, end: str = "\n") -> list[str]:
    """``f"{prefix}{v}{end}"`` for every integer v of ``values`` (n,), all at once
    (``end`` ends with a newline; no prefix holds one)."""
    v = np.asarray(values, dtype=np.int64)
    if v.size == 0:
        return []
    n = len(v)
    return _rows(
        [
            np.tile(np.frombuffer(prefix.encode("ascii"), np.uint8), (n, 1)),
            _int_block(v),
            np.tile(np.frombuffer(end.encode("ascii"), np.uint8), (n, 1)),
        ]
    )


def pvt_segment_text(
    columns: Sequence[tuple[str, np.ndarray, int]],
    line: np.ndarray,
    new_line: np.ndarray,
    quanta: np.ndarray,
    new_time: np.ndarray,
    other_rows: np.ndarray,
    other_text: Sequence[str],
) -> str:
    """A PVT program's points as one text: per row, ``; line N`` where ``new_line``,
    ``PVT<ms>`` where ``new_time`` (:func:`pvt_ms_text` of its ``quanta``), then the
    row of ``columns`` (:func:`format_fixed_rows`), or, for the rows ``other_rows``
    (ascending), the texts ``other_text`` instead (a dwell, machine functions).

    Parameters
    ----------
    columns : (prefix, values (m,), decimals) per column, as format_fixed_rows
    line : (m,) int, the G-code line of each row
    new_line, new_time : (m,) bool
    quanta : (m,) int, the PVT time [1/4096 ms] before each row where new_time
    other_rows : (k,) int; other_text : k texts
    """
    m = len(line)
    text = np.empty((m, 3), dtype=object)
    text[:] = ""
    at = np.flatnonzero(new_line)
    text[at, 0] = int_rows("; line ", np.asarray(line)[at])
    at = np.flatnonzero(new_time)
    text[at, 1] = pvt_ms_rows(np.asarray(quanta)[at])
    if m:
        text[:, 2] = format_fixed_rows(columns)
    if len(other_rows):
        text[np.asarray(other_rows, dtype=np.intp), 2] = list(other_text)
    return "".join(text.ravel().tolist())
