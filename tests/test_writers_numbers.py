"""Text of the writers: the vectorised fixed-point formatter prints what Python prints."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post.writers.numbers import format_fixed_rows
from prsxy_post.writers.numbers import round_clean as _round

FLOATS = st.one_of(
    st.floats(-1e6, 1e6, allow_nan=False),
    st.floats(-1e-3, 1e-3),
    st.sampled_from([0.0, -0.0, 0.5e-5, -0.5e-5, 1e9, -1e12, 123456.789015]),
)


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(np.float64, st.tuples(st.integers(1, 12), st.integers(1, 4)), elements=FLOATS),
    st.lists(st.integers(0, 8), min_size=4, max_size=4),
)
def test_fixed_rows_are_the_text_python_prints(values: np.ndarray, decimals: list[int]) -> None:
    cols = [
        (f" {'UVWX'[i]}" if i else "U", _round(values[:, i], decimals[i]), decimals[i])
        for i in range(values.shape[1])
    ]
    want = [
        "".join(f"{p}{row[i]:.{d}f}" for i, (p, _, d) in enumerate(cols)) + "\n"
        for row in np.column_stack([c[1] for c in cols]).tolist()
    ]
    assert format_fixed_rows(cols) == want


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.one_of(
            st.floats(-1e5, 1e5, allow_nan=False),
            # just beside rounding ties: the binary value decides, as in Python
            st.integers(-(10**8), 10**8).map(lambda i: (i + 0.5) / 1e4),
            st.sampled_from([-0.0, -1e-9, 0.00005, 1.00005, 2.675]),
        ),
        min_size=1,
        max_size=30,
    ),
    st.integers(0, 6),
)
def test_unrounded_values_print_as_python_prints_them(values: list[float], d: int) -> None:
    got = format_fixed_rows([("PVT", np.array(values), d)])
    assert got == [f"PVT{x:.{d}f}\n" for x in values]


def test_no_rows() -> None:
    assert format_fixed_rows([("X", np.zeros(0), 3)]) == []
