"""The compiled root search's step against its numpy reference: the same bits.

Recorded inputs (every false-position step the sample programs make while the
golden files are converted: the reversals in motion moved onto the path) and
generated ones (hypothesis: roots anywhere in their brackets, ±0.0 at their
ends, velocities either way, NaN, ±inf, ±0.0, accelerations of any size, none or
NaN, steps of no time, brackets whose ends were moved last or not, roots already
found or left); a velocity exactly at the found threshold. The rules are
:func:`prsxy_post.reversals.root_search`'.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import kernel, reversals
from prsxy_post.kernel import roots

from .kernel_cases import compiled, record, same_bits


def _same(got: tuple[Any, ...], want: tuple[Any, ...]) -> bool:
    """Every returned array the same to the bit, booleans and ints as the
    reference's dtypes."""
    return len(got) == len(want) and all(
        np.asarray(g).dtype == np.asarray(w).dtype and same_bits(g, w)
        for g, w in zip(got, want, strict=True)
    )


def test_sample_programs_root_steps_are_bit_identical(tmp_path: Path) -> None:
    _roots = compiled("_roots")
    calls = record("_seek_step", tmp_path)
    # the reversals in motion whose roots the samples move onto the path
    assert len(calls) >= 2
    assert sum(int(np.count_nonzero(args[2])) for args in calls) >= 5
    for args in calls:
        assert _same(_roots.seek_step(*args), roots.seek_step(*args))


_v = st.one_of(
    st.floats(-50.0, 50.0),
    st.sampled_from([0.0, -0.0, math.nan, math.inf, -math.inf, 1e-12, -1e-12]),
)


@st.composite
def _searches(draw: st.DrawFn) -> tuple[Any, ...]:
    m = draw(st.integers(0, 12))
    names = "x going ok moved new accel h sa va sb vb last".split()
    cols: dict[str, list[Any]] = {k: [] for k in names}
    for _ in range(m):
        sa = draw(st.sampled_from([0.0, -0.0]) | st.floats(0.0, 1.0))
        sb = draw(st.sampled_from([1.0, sa]) | st.floats(0.0, 1.0))
        cols["sa"].append(sa)
        cols["sb"].append(sb)
        cols["x"].append(draw(st.sampled_from([sa, sb, 0.0, -0.0]) | st.floats(0.0, 1.0)))
        cols["va"].append(draw(_v))
        cols["vb"].append(draw(_v))
        cols["going"].append(draw(st.booleans()))
        cols["ok"].append(draw(st.booleans()))
        cols["moved"].append(draw(st.booleans()))
        cols["new"].append(draw(st.sampled_from([1, -1])))
        cols["accel"].append(draw(st.sampled_from([0.0, -0.0, math.nan]) | st.floats(-1e5, 1e5)))
        cols["h"].append(draw(st.sampled_from([0.01, 2.5e-4, 0.0]) | st.floats(1e-4, 0.05)))
        cols["last"].append(draw(st.sampled_from([-1, 0, 1])))
    q = sum(cols["going"])
    v = [draw(_v) for _ in range(q)]
    return (
        np.array(cols["x"], dtype=float),
        np.array(v, dtype=float),
        np.array(cols["going"], dtype=bool),
        np.array(cols["ok"], dtype=bool),
        np.array(cols["moved"], dtype=bool),
        np.array(cols["new"], dtype=int),
        np.array(cols["accel"], dtype=float),
        np.array(cols["h"], dtype=float),
        np.array(cols["sa"], dtype=float),
        np.array(cols["va"], dtype=float),
        np.array(cols["sb"], dtype=float),
        np.array(cols["vb"], dtype=float),
        np.array(cols["last"], dtype=int),
        reversals.ROOT_SLOPE_MARGIN,
        draw(st.sampled_from([reversals.ROOT_TIME_S, 1e-3, 0.0])),
    )


@settings(max_examples=300, deadline=None)
@given(_searches())
def test_generated_root_steps_are_bit_identical(args: tuple[Any, ...]) -> None:
    _roots = compiled("_roots")
    assert _same(_roots.seek_step(*args), roots.seek_step(*args))


def test_root_step_found_at_the_threshold_and_moved_beside_it() -> None:
    """A velocity whose |v| · margin equals the acceleration's share of ROOT_TIME_S
    is found (≤); one a hair above has its bracket's new-way end moved to x and x
    moved by false position (both paths)."""
    accel, h = 100.0, 0.01
    v_found = accel * reversals.ROOT_TIME_S / reversals.ROOT_SLOPE_MARGIN
    for run in (roots.seek_step, kernel.seek_step):
        out = run(
            np.array([0.5, 0.5]), np.array([v_found, 2 * v_found]), np.array([True, True]),
            np.array([True, True]), np.array([False, False]), np.array([1, 1]),
            np.array([accel, accel]), np.array([h, h]), np.zeros(2), np.array([-1.0, -1.0]),
            np.ones(2), np.array([1.0, 1.0]), np.zeros(2, dtype=int),
            reversals.ROOT_SLOPE_MARGIN, reversals.ROOT_TIME_S,
        )  # fmt: skip
        x, going, ok, moved, s_a, v_a, s_b, v_b, last = out
        assert going.tolist() == [False, True] and moved.tolist() == [False, True]
        assert ok.tolist() == [True, True] and s_a.tolist() == [0, 0] and v_a[1] == -1.0
        assert s_b[1] == 0.5 and v_b[1] == 2 * v_found and last.tolist() == [0, 1]
        # the false position between (0, −1) and (0.5, 2 v): just below 0.5
        assert x[1] == pytest.approx(0.5 / (1 + 2 * v_found), rel=1e-12) and x[0] == 0.5


def test_compiled_root_step_refuses_wrong_lengths() -> None:
    _roots = compiled("_roots")
    one, two = np.zeros(1), np.zeros(2)
    b1 = np.array([True])
    with pytest.raises(ValueError, match="h must have one value a root"):
        _roots.seek_step(one, one, b1, b1, b1, np.ones(1), one, two, one, one, one, one,
                         np.zeros(1, dtype=int), 5.0, 1e-6)  # fmt: skip
    with pytest.raises(ValueError, match=r"v must have one value a root going \(1\), got 2"):
        _roots.seek_step(one, two, b1, b1, b1, np.ones(1), one, one, one, one, one, one,
                         np.zeros(1, dtype=int), 5.0, 1e-6)  # fmt: skip
