"""prsxy_post/chain.py's own helpers (the chain as a whole: test_one_chain.py and
the conversions' tests)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import chain, gcode, kinematics, program, simulate
from prsxy_post.chain import _windows_over
from prsxy_post.profile import Profile

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


DIRECTIONS_PROGRAM = """G21 G90 G17 G94
G0 X10 Y5 Z5 A0 B0
G1 Z0 F800
G1 X20 Y8 A2 B-3
G2 X30 Y8 I5 J0
G4 P0.5
G1 X25 Y-4 Z-1 B4
M3 S1000
G1 X40 Y-4 A-5
G1 A0 B0
G1 X41 Z2
M2
"""


@pytest.mark.parametrize("cols", [[0, 1, 2, 3, 4], [1, 3]], ids=["every motor", "two"])
def test_directions_are_the_ik_difference_along_each_moving_blocks_tangents(
    nominal: Profile, cols: list[int]
) -> None:
    """Planning._directions' dP/ds at each moving block's start and end is
    ik_derivative's one-sided difference over DIR_STEP_MM along the block's
    tangent into it (backwards from the end), to the bit, for the motors with
    play only; nothing at stops (a dwell, a machine function)."""
    truth = simulate.random_machine(nominal, np.random.default_rng(3), axis_errors=True)
    planning = chain.Planning(truth)
    planning.play_cols = cols
    planning.way = np.ones(len(cols))
    planning.stood = np.ones(len(cols), dtype=bool)
    motions = gcode.interpret(DIRECTIONS_PROGRAM, program.interpreter_config(truth))
    b = chain.prepare(motions, truth, planning.limits).blocks
    planning._directions(b)
    k = np.flatnonzero(~b.stops)
    assert 0 < len(k) < len(b)
    geo, step, tool = planning.geo, chain.DIR_STEP_MM, b.tool_length[k]

    def ik(q: np.ndarray) -> np.ndarray:
        return kinematics.inverse(geo, q, tool).P

    d_in = chain.ik_derivative(geo, b.start[k], b.dq_in[k], tool, ik(b.start[k]), step)
    d_out = -chain.ik_derivative(geo, b.end[k], -b.dq_out[k], tool, ik(b.end[k]), step)
    others = [c for c in range(5) if c not in cols]
    for got, want in ((b.dP_in, d_in), (b.dP_out, d_out)):
        assert np.array_equal(got[k][:, cols], want[:, cols])
        assert not np.any(got[k][:, others]) and not np.any(got[b.stops])
        assert np.any(got[k][:, cols])


@st.composite
def _new_points(draw: st.DrawFn) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    n = draw(st.integers(0, 12))
    e = draw(st.integers(0, 15))
    step = draw(hnp.arrays(int, e, elements=st.integers(0, n)))
    when = draw(
        hnp.arrays(
            float, e, elements=st.sampled_from([0.0, -0.0, 0.5, 1.0, np.nan]) | st.floats(0, 2)
        )
    )
    before = draw(hnp.arrays(bool, e))
    return n, step, when, before


@settings(max_examples=300, deadline=None)
@given(_new_points())
def test_merge_places_orders_new_points_as_one_sort_of_all(
    case: tuple[int, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """The new points go by step, a standing point first, then by time (ties,
    NaN and ±0.0 as one stable lexsort of them all would leave them), each
    after the chunk's points of the steps before its own; every chunk row keeps
    its order."""
    n, step, when, before = case
    order, at, src = chain._merge_places(n, step, when, before)
    assert np.array_equal(order, np.lexsort((when, np.where(before, 0, 1), step)))
    # merged: the chunk's rows 0..n-1 and the new ones; a chunk row's place is
    # after every new point of its own step and the steps before
    kept = np.ones(n + len(step), dtype=bool)
    kept[at] = False
    assert np.array_equal(src[kept], np.arange(n))
    rows = np.arange(n)
    assert np.array_equal(
        np.flatnonzero(kept), rows + np.searchsorted(np.sort(step), rows, "right")
    )
