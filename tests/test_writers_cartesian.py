"""The Cartesian dialects' shared step (prsxy_post/writers/cartesian.py): the G93
feed words made for a whole chunk are the text Python's own formatting gives."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post.writers.cartesian import feed_words

TIMES = st.one_of(
    st.floats(1e-4, 10.0),
    # 60 / t on a rounding tie of the third decimal, and beside it
    st.integers(1, 10**7).map(lambda i: 60.0 / ((i + 0.5) / 1e3)),
    st.sampled_from([0.01, 0.0025, 1e-12, 5e-324, 1e300, 0.0, -0.0, -0.01, math.inf, math.nan]),
)


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.integers(0, 30), elements=TIMES))
def test_feed_words_are_pythons_text(dt: np.ndarray) -> None:
    """Every positive, finite segment time has its word, ``f"F{60.0 / t:.3f}"``
    (also where 60 / t overflows to inf); zero, negative and non-finite times
    have none (the writer formats those itself, as before)."""
    words = feed_words(dt)
    want = {t: f"F{60.0 / t:.3f}" for t in dt.tolist() if 0.0 < t < math.inf}
    assert words == want
