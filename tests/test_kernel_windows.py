"""The compiled crossing windows against their numpy reference: the same bits.

Recorded inputs (every call the sample programs make while the golden files are
converted: windows about reversals in motion, dips and settings-off, with the
reach the tip's speed allows) and generated ones (hypothesis: roots anywhere in
their steps, accelerations of any size, none or −0.0, reach none (inf), tiny or
wide on either side, steps shorter than a servo cycle, cubics and chords).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import reversals
from prsxy_post.kernel import windows

from .kernel_cases import compiled, record, same_bits


def test_sample_programs_windows_are_bit_identical(tmp_path: Path) -> None:
    _windows = compiled("_windows")
    calls = record("_crossing_windows", tmp_path)
    # every motor's reversals in motion, dips and settings-off a chunk: mostly
    # none, some windows in the five-axis samples
    assert len(calls) >= 20
    assert sum(len(args[0]) for args in calls) >= 3
    for args in calls:
        want = windows.crossing_windows(*args)
        got = _windows.crossing_windows(*args)
        assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])


_reach = st.one_of(st.just(np.inf), st.floats(0.0, 2e-3), st.floats(0.0, 1.0), st.just(0.0))


@st.composite
def _cases(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    n = draw(st.integers(0, 12))
    rows = []
    for _ in range(n):
        t0 = draw(st.floats(0.0, 10.0))
        h = draw(st.one_of(st.floats(1e-5, 5e-4), st.floats(5e-4, 0.05)))
        s = draw(st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1.0, 0.5])))
        acc = draw(
            st.one_of(
                st.floats(-1e5, 1e5, allow_nan=False),
                st.sampled_from([0.0, -0.0, 1e-12, -3.0]),
            )
        )
        rows.append((t0, t0 + h, t0 + s * h, acc, draw(_reach), draw(_reach)))
    arr = np.array(rows, dtype=float).reshape(n, 6)
    return tuple(np.ascontiguousarray(arr[:, j]) for j in range(6))


@settings(max_examples=400, deadline=None)
@given(
    case=_cases(),
    tol=st.sampled_from([5e-5, 1e-6, 1e-3]),
    longest=st.sampled_from([1e-3, 2e-3, 0.25e-3]),
    chords=st.booleans(),
)
def test_generated_windows_are_bit_identical(
    case: tuple[np.ndarray, ...], tol: float, longest: float, chords: bool
) -> None:
    _windows = compiled("_windows")
    args = (*case, tol, longest, chords, reversals.MIN_WINDOW_S)
    want = windows.crossing_windows(*args)
    got = _windows.crossing_windows(*args)
    assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])
    # inside the step, or the step itself
    t0, t1 = case[0], case[1]
    assert np.all((t0 <= want[0]) & (want[0] <= want[1]) & (want[1] <= t1))


def test_a_window_with_no_acceleration_is_half_the_longest_each_side() -> None:
    """At A = 0 the tolerance allows any stand: the window is the longest, evenly
    about its root (compiled and reference alike)."""
    args = (
        np.array([0.0]), np.array([0.01]), np.array([0.005]), np.array([0.0]),
        np.array([np.inf]), np.array([np.inf]), 5e-5, 1e-3, False, reversals.MIN_WINDOW_S,
    )  # fmt: skip
    for mod in (windows, compiled("_windows")):
        a, b = mod.crossing_windows(*args)
        assert a[0] == pytest.approx(0.0045) and b[0] == pytest.approx(0.0055)
