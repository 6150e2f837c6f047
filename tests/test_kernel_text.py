"""The compiled row text against its numpy reference: the same rows, byte for byte.

Recorded inputs (every chunk of rows the sample programs write, PMAC and G-code, as
the golden files are made) and generated ones (hypothesis: values near rounding
ties, negative zeros, values too large for the integer digits, any decimals).
Both are held against Python's own ``%.{d}f`` in tests/test_writers_numbers.py,
and a PVT program's points (:func:`text.pvt_segment_text`) here against the same
text made row by row with Python's own formatting.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post.kernel import text
from prsxy_post.writers.pmac import pvt_ms_text

from .kernel_cases import compiled, record

FLOATS = st.one_of(
    st.floats(-1e6, 1e6, allow_nan=False),
    st.floats(-1e-3, 1e-3),
    st.integers(-(10**8), 10**8).map(lambda i: (i + 0.5) / 1e4),  # beside ties
    st.sampled_from([0.0, -0.0, 0.5e-5, -0.5e-5, 2.675, 1e9, -1e12, 123456.789015]),
)


def test_sample_programs_rows_are_byte_identical(tmp_path: Path) -> None:
    _text = compiled("_text")
    calls = record("_fixed_rows", tmp_path)
    # a chunk at least per G-code run (PMAC's rows: pvt_segment_text, below)
    assert len(calls) >= 3
    rows = 0
    for columns, end in calls:
        want = text.format_fixed_rows(columns, end)
        assert _text.format_fixed_rows(columns, end) == want
        rows += len(want)
    # the G-code writer formats the lines it writes, not every point: 108 rows over
    # the samples since their arcs are written as G2/G3 (issue 33; 4 002 before),
    # each arc's row among them; the generated rows below cover the formatting
    assert rows > 100


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(np.float64, st.tuples(st.integers(1, 12), st.integers(1, 5)), elements=FLOATS),
    st.lists(st.integers(0, 9), min_size=5, max_size=5),
    st.sampled_from(["\n", "", " ;\n"]),
)
def test_generated_rows_are_byte_identical(
    values: np.ndarray, decimals: list[int], end: str
) -> None:
    _text = compiled("_text")
    cols = [
        (f" {'UVWXY'[i]}" if i else "", values[:, i], decimals[i]) for i in range(values.shape[1])
    ]
    assert _text.format_fixed_rows(cols, end) == text.format_fixed_rows(cols, end)


def test_no_rows_and_no_columns() -> None:
    _text = compiled("_text")
    assert _text.format_fixed_rows([("X", np.zeros(0), 3)]) == []
    assert _text.format_fixed_rows([]) == text.format_fixed_rows([]) == []


def python_segment(
    columns: list[tuple[str, np.ndarray, int]],
    line: np.ndarray,
    new_line: np.ndarray,
    quanta: np.ndarray,
    new_time: np.ndarray,
    other_rows: np.ndarray,
    other_text: list[str],
) -> str:
    """What :func:`text.pvt_segment_text` must write, row by row with Python's own
    formatting: ``; line N``, ``PVT`` with the exact time (pvt_ms_text), the row as
    ``%s%.{d}f`` per column or the row's other text."""
    other = dict(zip(np.asarray(other_rows).tolist(), other_text, strict=True))
    out = []
    for i in range(len(line)):
        if new_line[i]:
            out.append(f"; line {int(line[i])}\n")
        if new_time[i]:
            out.append(f"PVT{pvt_ms_text(int(quanta[i]))}\n")
        if i in other:
            out.append(other[i])
        else:
            out.append("".join(f"{p}{float(v[i]):.{d}f}" for p, v, d in columns) + "\n")
    return "".join(out)


def test_sample_programs_pvt_segments_are_byte_identical(tmp_path: Path) -> None:
    """Every segment of PMAC points the sample programs write: compiled, reference
    and Python's row-by-row text agree."""
    _text = compiled("_text")
    calls = record("_pvt_segment", tmp_path)
    assert len(calls) >= 4  # a segment at least per PMAC run
    rows = times = 0
    for args in calls:
        want = text.pvt_segment_text(*args)
        assert _text.pvt_segment_text(*args) == want
        assert want == python_segment(*args)
        rows += len(args[1])
        times += int(np.count_nonzero(args[4]))
    assert rows > 5_000 and times > 100


#: PVT times [1/4096 ms]: the machine's range (I42 = 0: below 4096 ms), the
#: integer formatter's limit (2^52) and beyond, negative ones
QUANTA = st.one_of(
    st.integers(0, 2**24 - 1),
    st.integers(-(2**63), 2**63 - 1),
    st.sampled_from([0, 1, 4095, 4096, 4097, 40960, 2**52 - 1, 2**52, -(2**52) + 1, -2048]),
)
LINES = st.one_of(st.integers(0, 10**6), st.sampled_from([-1, 0, -(2**63), 2**63 - 1, 10**18]))


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_generated_pvt_segments_are_byte_identical(data: st.DataObject) -> None:
    _text = compiled("_text")
    m = data.draw(st.integers(0, 12))
    ncol = data.draw(st.integers(1, 4))
    values = data.draw(hnp.arrays(np.float64, (m, ncol), elements=FLOATS))
    decimals = data.draw(st.lists(st.integers(0, 9), min_size=ncol, max_size=ncol))
    cols = [(f" {'UVWXY'[i]}" if i else "X", values[:, i], decimals[i]) for i in range(ncol)]
    line = np.array(data.draw(st.lists(LINES, min_size=m, max_size=m)), dtype=np.int64)
    quanta = np.array(data.draw(st.lists(QUANTA, min_size=m, max_size=m)), dtype=np.int64)
    masks = hnp.arrays(bool, (m,))
    new_line, new_time, other = data.draw(masks), data.draw(masks), data.draw(masks)
    other_rows = np.flatnonzero(other)
    other_text = [
        data.draw(st.sampled_from(["DWELL0\nM3\n", "DWELL12.5000\n", ""])) for _ in other_rows
    ]
    args = (cols, line, new_line, quanta, new_time, other_rows, other_text)
    want = text.pvt_segment_text(*args)
    assert _text.pvt_segment_text(*args) == want
    assert want == python_segment(*args)


@pytest.mark.parametrize("d", range(10))
def test_rows_at_the_limits_of_the_fixed_point_widths(d: int) -> None:
    """Values at the integer formatter's bound (min(10^9, 2^52 / 10^d)), just below
    it (still the integer formatter) and just above (Python's text for the chunk),
    with negative zero, ties and tiny values beside them: compiled, reference and
    Python's %.{d}f agree."""
    _text = compiled("_text")
    lim = min(1e9, 2.0**52 / 10.0**d)
    below = np.nextafter(lim, 0.0)
    for edge in ([below, -below], [lim, -below], [np.nextafter(lim, np.inf)]):
        v = np.array([*edge, -0.0, 0.0, 0.5 / 10.0**d, -2.5 / 10.0**d, 5e-324, 1e-300])
        cols = [("X", v, d), (":", v[::-1].copy(), d)]
        want = text.format_fixed_rows(cols)
        assert _text.format_fixed_rows(cols) == want
        assert want == [f"X{a:.{d}f}:{b:.{d}f}\n" for a, b in zip(v, v[::-1], strict=True)]
        seg = (cols, np.arange(len(v)), v < 0, np.arange(len(v)) * 4095, v >= 0, [], [])
        assert _text.pvt_segment_text(*seg) == text.pvt_segment_text(*seg)
        assert text.pvt_segment_text(*seg) == python_segment(*seg)


@settings(max_examples=300, deadline=None)
@given(st.lists(QUANTA, max_size=20), st.lists(LINES, max_size=20))
def test_pvt_times_and_line_numbers_as_python_writes_them(
    quanta: list[int], lines: list[int]
) -> None:
    """The reference's vectorised PVT times and integers are Python's own text."""
    q = np.array(quanta, dtype=np.int64)
    assert text.pvt_ms_rows(q) == [f"PVT{pvt_ms_text(x)}\n" for x in quanta]
    assert text.int_rows("; line ", np.array(lines, dtype=np.int64)) == [
        f"; line {x}\n" for x in lines
    ]


#: prefixes the compiled kernel copies as one word (up to 8 bytes) or byte by byte
PREFIXES = st.sampled_from(["", "X", " Y", ":", " LONGPREFIX", "#12->A=", "a" * 17])


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_views_long_prefixes_and_many_decimals_are_byte_identical(data: st.DataObject) -> None:
    """Columns read in place (views of a row-major array, steps of any sign), prefixes
    over 8 bytes, decimals 10-22 (the 64-bit fraction path, and beyond 19 the
    reference's own text): compiled and reference agree, rows and segments."""
    _text = compiled("_text")
    m = data.draw(st.integers(1, 10))
    ncol = data.draw(st.integers(1, 6))
    block = data.draw(hnp.arrays(np.float64, (m, ncol), elements=FLOATS))
    if data.draw(st.booleans()):
        block = block[::-1]  # negative steps
    decimals = data.draw(st.lists(st.integers(0, 22), min_size=ncol, max_size=ncol))
    prefixes = data.draw(st.lists(PREFIXES, min_size=ncol, max_size=ncol))
    cols = [(prefixes[i], block[:, i], decimals[i]) for i in range(ncol)]
    assert _text.format_fixed_rows(cols) == text.format_fixed_rows(cols)
    line = np.arange(m, dtype=np.int64) * 7919
    masks = hnp.arrays(bool, (m,))
    quanta = data.draw(hnp.arrays(np.int64, (m,), elements=st.integers(0, 2**24)))
    seg = (cols, line, data.draw(masks), quanta, data.draw(masks), np.zeros(0, np.intp), [])
    assert _text.pvt_segment_text(*seg) == text.pvt_segment_text(*seg)
