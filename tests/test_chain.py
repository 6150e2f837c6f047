"""prsxy_post/chain.py's own helpers (the chain as a whole: test_one_chain.py and
the conversions' tests)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post.chain import _windows_over

_IDX = st.integers(-1, 40)


@settings(max_examples=300, deadline=None)
@given(
    hnp.arrays(np.int64, st.integers(0, 30), elements=_IDX),
    st.data(),
    hnp.arrays(np.int64, st.integers(0, 30), elements=_IDX),
)
def test_windows_over_counts_as_the_pairwise_comparison(
    b: np.ndarray, data: st.DataObject, k: np.ndarray
) -> None:
    """The windows holding each point strictly inside (b < k < e), counted by
    sorting, are the pairwise comparison's count; windows that end before they
    begin, or where they begin, included."""
    e = data.draw(hnp.arrays(np.int64, b.shape, elements=_IDX))
    want = ((b[None, :] < k[:, None]) & (k[:, None] < e[None, :])).sum(axis=1)
    assert np.array_equal(_windows_over(b, e, k), want)
