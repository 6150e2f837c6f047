"""The compiled row text against its numpy reference: the same rows, byte for byte.

Recorded inputs (every chunk of rows the sample programs write, PMAC and G-code, as
the golden files are made) and generated ones (hypothesis: values near rounding
ties, negative zeros, values too large for the integer digits, any decimals).
Both are held against Python's own ``%.{d}f`` in tests/test_writers_numbers.py.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post.kernel import text

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
    assert len(calls) >= 7  # a chunk at least per run
    rows = 0
    for columns, end in calls:
        want = text.format_fixed_rows(columns, end)
        assert _text.format_fixed_rows(columns, end) == want
        rows += len(want)
    assert rows > 5_000


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
