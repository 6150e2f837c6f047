"""The compiled play model against its numpy reference: the same bits.

Recorded inputs (every call of the play kernel the sample programs make, as the
golden files are converted: the envelopes, their inverses and slopes, the sided
compensation, the part followed along the commands' cubics and chords) and
generated ones (hypothesis: tables with crossing forward and reverse errors, one
break, periodic terms; commands with reversals, standing points of no time, empty
stretches). The reference calls the C library's sin and cos through :mod:`math`
(kernel/libm.py), as the compiled twin does.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import axiscomp
from prsxy_post.kernel import libm, play
from prsxy_post.profile import AxisComp

from .kernel_cases import compiled, record, same_bits

#: the kernel's entry points (prsxy_post.kernel's names) and their reference
ENTRIES = {
    "_play_lo": play.lo,
    "_play_hi": play.hi,
    "_play_lo_inv": play.lo_inv,
    "_play_hi_inv": play.hi_inv,
    "_play_slope": play.slope,
    "_compensate_sided": play.compensate_sided,
    "_clamp_scan": play.clamp_scan,
    "_follow_stretches": play.follow_stretches,
    "_catch_up": play.catch_up,
}


def _same(got: Any, want: Any) -> bool:
    if isinstance(want, tuple):
        return len(got) == len(want) and all(_same(g, w) for g, w in zip(got, want, strict=True))
    return same_bits(got, want)


#: what the chain calls, and how often at least while the samples convert (the
#: envelopes alone at the start, the inverses at the crossings' contacts; hi and the
#: scan are inside follow_stretches here: the generated cases below cover them)
RECORDED = {
    "_play_lo": 1,
    "_play_lo_inv": 3,
    "_play_hi_inv": 3,
    "_play_slope": 10,
    "_compensate_sided": 10,
    "_follow_stretches": 10,
    "_catch_up": 3,
}


@pytest.mark.parametrize("attr", sorted(RECORDED))
def test_sample_programs_play_model_is_bit_identical(attr: str, tmp_path: Path) -> None:
    _play = compiled("_play")
    calls = record(attr, tmp_path)
    assert len(calls) >= RECORDED[attr]
    for args in calls:
        want = ENTRIES[attr](*args)
        got = getattr(_play, attr.removeprefix("_play_").removeprefix("_"))(*args)
        if attr == "_catch_up":
            assert got[0].dtype == want[0].dtype
        assert _same(got, want), f"{attr}: compiled and reference differ"


def test_sample_programs_follow_their_parts_through_turning_points(tmp_path: Path) -> None:
    """The recorded follows are not all straight: in some steps the command's cubic
    turns back (the turning points, evaluated with numpy's power in both)."""
    calls = record("_follow_stretches", tmp_path)
    assert sum(len(c[4]) for c in calls) > 1000
    turns = 0
    for _t, _y0, P0, V0, P, V, dt, steps, cubic in calls:
        first = (np.cumsum(steps) - steps)[steps > 0]
        Pa, Va = np.concatenate([[0.0], P[:-1]]), np.concatenate([[0.0], V[:-1]])
        Pa[first], Va[first] = P0[steps > 0], V0[steps > 0]
        # the velocity changes sign inside the step where it does between its ends
        turns += int(np.count_nonzero((Va * V < 0) & (dt > 0))) if cubic else 0
    assert turns > 0


# -- generated tables and commands

ERR = st.floats(-0.01, 0.01)
CYCLIC = st.lists(
    st.tuples(st.floats(1e-5, 3e-3), st.floats(0.5, 50.0), st.floats(-180.0, 180.0)),
    max_size=2,
)


@st.composite
def tables(draw: st.DrawFn) -> axiscomp.MotorTable:
    """A motor's table: 1 to 8 positions, forward and reverse errors that may cross
    (slopes kept above −0.5, as the profile requires), perhaps periodic terms."""
    n = draw(st.integers(1, 8))
    start = draw(st.floats(-300.0, 0.0))
    gaps = draw(st.lists(st.floats(1.0, 80.0), min_size=n - 1, max_size=n - 1))
    pos = start + np.concatenate([[0.0], np.cumsum(gaps)])
    fwd = np.array(draw(st.lists(ERR, min_size=n, max_size=n)))
    rev = np.array(draw(st.lists(ERR, min_size=n, max_size=n)))
    t = axiscomp.MotorTable.from_comp(AxisComp(1, pos, fwd, rev))
    return t.with_cyclic(tuple(draw(CYCLIC)))


@settings(max_examples=150, deadline=None)
@given(tables(), st.integers(0, 2**32 - 1))
def test_generated_envelopes_inverses_and_slopes_are_bit_identical(
    table: axiscomp.MotorTable, seed: int
) -> None:
    _play = compiled("_play")
    t = table.flat
    rng = np.random.default_rng(seed)
    # inside and outside the table, at its breaks and the inverses' ends exactly
    p = np.concatenate(
        [
            rng.uniform(t.breaks[0] - 30, t.breaks[-1] + 30, 200),
            t.breaks,
            t.lo_vals,
            t.hi_vals,
            [np.nan, np.inf, -np.inf, 0.0, -0.0],
        ]
    )
    side = rng.integers(-1, 2, len(p))
    for name in ("lo", "hi", "lo_inv", "hi_inv"):
        assert same_bits(getattr(_play, name)(t, p), getattr(play, name)(t, p)), name
    assert same_bits(_play.slope(t, p, side), play.slope(t, p, side))
    assert same_bits(_play.compensate_sided(t, p, side), play.compensate_sided(t, p, side))
    lo, hi = play.lo(t, p[:-5]), play.hi(t, p[:-5])
    assert same_bits(_play.clamp_scan(lo, hi), play.clamp_scan(lo, hi))


@settings(max_examples=150, deadline=None)
@given(
    tables(),
    st.integers(0, 2**32 - 1),
    st.lists(st.integers(0, 40), min_size=1, max_size=5),
    st.booleans(),
)
def test_generated_follows_are_bit_identical(
    table: axiscomp.MotorTable, seed: int, steps: list[int], cubic: bool
) -> None:
    """Commands with reversals inside steps (velocities that swing the cubics past
    their points), steps of no time, and empty stretches."""
    _play = compiled("_play")
    t = table.flat
    rng = np.random.default_rng(seed)
    k = sum(steps)
    w = len(steps)
    mid = 0.5 * (t.breaks[0] + t.breaks[-1])
    P = mid + np.cumsum(rng.normal(0, 0.05, k))
    V = rng.normal(0, 20, k)
    dt = np.where(rng.random(k) < 0.1, 0.0, rng.uniform(0.001, 0.02, k))
    y0 = mid + rng.normal(0, 0.01, w)
    P0 = mid + rng.normal(0, 0.01, w)
    V0 = rng.normal(0, 20, w)
    st_ = np.array(steps, dtype=int)
    got = _play.follow_stretches(t, y0, P0, V0, P, V, dt, st_, cubic)
    want = play.follow_stretches(t, y0, P0, V0, P, V, dt, st_, cubic)
    assert _same(got, want)


@settings(max_examples=200, deadline=None)
@given(
    st.integers(0, 60),
    st.lists(st.integers(-1, 59), max_size=6, unique=True),
    st.integers(0, 2**32 - 1),
    st.booleans(),
    st.sampled_from([5e-5, 1e-3, 0.5]),
)
def test_generated_catch_ups_are_bit_identical(
    n: int, starts: list[int], seed: int, with_motion: bool, share: float
) -> None:
    """Crossings ending anywhere in a chunk (at the point before it too), offsets
    behind and ahead of their motor's way, paths that stand (equal lengths) and
    run, with and without the motor's motion, slow and fast rates."""
    _play = compiled("_play")
    rng = np.random.default_rng(seed)
    start = np.array(sorted(x for x in starts if x < n), dtype=int)
    m = len(start)
    stop = np.append(start[1:], n).astype(int)
    stop = np.where(rng.random(m) < 0.3, n, stop)  # some go on into the next chunk
    s_path = np.cumsum(np.where(rng.random(n) < 0.2, 0.0, rng.uniform(0, 0.5, n)))
    off0 = rng.normal(0, 1e-4, m) * np.where(rng.random(m) < 0.2, 0.0, 1.0)
    way = rng.choice([-1, 1], m)
    motion = (
        (
            rng.normal(0, 0.01, n),
            rng.normal(0, 5, n),
            np.abs(rng.normal(0, 5, n)) * (rng.random(n) > 0.1),
        )
        if with_motion
        else None
    )
    got = _play.catch_up(off0, way, start, stop, s_path, share, 2.0, motion)
    want = play.catch_up(off0, way, start, stop, s_path, share, 2.0, motion)
    assert _same(got, want)
    assert got[0].dtype == want[0].dtype


def test_the_twin_turns_where_the_reference_does() -> None:
    """A step whose cubic turns twice (leaves, turns back, turns on again): both
    kernels sample both turning points and find the same extremes of the part."""
    _play = compiled("_play")
    t = axiscomp.MotorTable.from_comp(
        AxisComp(1, np.array([-100.0, 100.0]), np.array([0.0, 0.0]), np.array([0.004, 0.004]))
    ).flat
    args = (np.array([0.0]), np.array([0.0]), np.array([30.0]))
    P, V, dt = np.array([0.01]), np.array([30.0]), np.array([0.01])
    got = _play.follow_stretches(t, *args, P, V, dt, np.array([1]))
    want = play.follow_stretches(t, *args, P, V, dt, np.array([1]))
    assert _same(got, want)
    # the cubic goes past 0.01 and back: the part's greatest is above its end
    assert want[2][0] > want[0][0]


@pytest.mark.parametrize("name", ["sin", "cos"])
def test_the_references_trig_is_the_c_librarys(name: str) -> None:
    """libm.sin and libm.cos are math's (the C library's), NaN where C gives NaN."""
    x = np.random.default_rng(3).uniform(-1e3, 1e3, 10_000)
    want = np.fromiter(map(getattr(math, name), x.tolist()), float, x.size)
    assert same_bits(getattr(libm, name)(x), want)
    assert np.isnan(getattr(libm, name)(np.array([np.inf, -np.inf, np.nan]))).all()
