"""The compiled time law against its numpy reference: the same bits.

Recorded inputs (every batch of blocks the planner times, every batch of points it
places on them and every look-ahead pass while the sample programs convert, as the
golden files are made) and generated ones (hypothesis: blocks from a hair to metres
long, speeds from rest to above their limits, so the bisections for the peak and for
a cruise too short both run, dwells, and local times before, inside and after each
block).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post.kernel import timelaw

from .kernel_cases import compiled, record_many, same_bits

LAW_FIELDS = ("v0", "v1", "vp", "a1", "a3", "t1", "t2", "t3", "duration")


def _same_law(got: timelaw.TimeLaw, want: timelaw.TimeLaw) -> bool:
    return all(same_bits(getattr(got, f), getattr(want, f)) for f in LAW_FIELDS)


@pytest.fixture(scope="module")
def recorded(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[Any, ...]]]:
    compiled("_timelaw")
    attrs = [
        "_trapezoids",
        "_along",
        "_phase_times",
        "_backward_pass",
        "_forward_pass",
        "_play_stops",
        "_set_offs",
        "_junction_speeds",
    ]
    return record_many(attrs, tmp_path_factory.mktemp("timelaw"))


def test_sample_programs_trapezoids_are_bit_identical(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    _tl = compiled("_timelaw")
    calls = recorded["_trapezoids"]
    assert len(calls) >= 7  # a plan at least per run
    blocks = bisected = 0
    for args in calls:
        want = timelaw.trapezoids(*args)
        assert _same_law(_tl.trapezoids(*args), want), f"{len(args[0])} blocks differ"
        blocks += len(args[0])
        v0, v1, _, _, vmax, stop = args[:6]
        # the blocks whose speed limit leaves no room: their peak was bisected
        bisected += int(np.count_nonzero((want.vp < np.maximum(vmax, np.maximum(v0, v1))) & ~stop))
    assert blocks > 100  # 130 in the samples
    assert bisected > 10  # 29


def test_sample_programs_points_are_bit_identical(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    _tl = compiled("_timelaw")
    calls = recorded["_along"]
    assert len(calls) >= 7
    points = 0
    for law, k, tau in calls:
        want = timelaw.along(law, k, tau)
        got = _tl.along(law, k, tau)
        assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])
        points += len(k)
    assert points > 10_000


def _same_times(got: tuple[np.ndarray, ...], want: tuple[np.ndarray, ...]) -> bool:
    blk, tau, step, last = got
    return (
        blk.dtype == want[0].dtype
        and np.array_equal(blk, want[0])
        and same_bits(tau, want[1])
        and same_bits(step, want[2])
        and last.dtype == bool
        and np.array_equal(last, want[3])
    )


def test_sample_programs_point_times_are_bit_identical(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    _tl = compiled("_timelaw")
    calls = recorded["_phase_times"]
    assert len(calls) >= 7
    for law, counts in calls:
        assert _same_times(_tl.phase_times(law, counts), timelaw.phase_times(law, counts))
    assert sum(int(c.sum()) for _, c in calls) > 10_000


def test_sample_programs_passes_are_bit_identical(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    _tl = compiled("_timelaw")
    assert len(recorded["_backward_pass"]) >= 7 and len(recorded["_forward_pass"]) >= 7
    for args in recorded["_backward_pass"]:
        assert same_bits(_tl.backward_pass(*args), timelaw.backward_pass(*args))
    for args in recorded["_forward_pass"]:
        assert same_bits(_tl.forward_pass(*args), timelaw.forward_pass(*args))


def test_sample_programs_play_stops_are_the_same(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    _tl = compiled("_timelaw")
    calls = recorded["_play_stops"]
    assert len(calls) >= 7
    stops = 0
    for args in calls:
        want = timelaw.play_stops(*args)
        assert np.array_equal(_tl.play_stops(*args), want)
        stops += int(np.count_nonzero(want))
    assert stops > 0


#: one block: L [mm], a [mm/s²], vmax [mm/s], v0 and v1 as shares of vmax (above 1:
#: faster than its limit, as an arc's entry may be), a stop, its duration [s]
BLOCK = st.tuples(
    st.one_of(st.floats(1e-7, 1e-2), st.floats(1e-2, 2000.0), st.just(0.0)),
    st.floats(1.0, 20_000.0),
    st.floats(1e-3, 600.0),
    st.one_of(st.just(0.0), st.floats(1e-6, 1.2)),
    st.one_of(st.just(0.0), st.floats(1e-6, 1.2)),
    st.integers(0, 5).map(lambda i: i == 0),
    st.floats(0.0, 5.0),
)


def _blocks(rows: list[tuple[float, ...]]) -> tuple[np.ndarray, ...]:
    L, a, vmax, f0, f1, stop, dur = (np.array(c) for c in zip(*rows, strict=True))
    stop = stop.astype(bool)
    v0 = np.where(stop, 0.0, f0 * vmax)
    v1 = np.where(stop, 0.0, f1 * vmax)
    return v0, v1, np.where(stop, 0.0, L), a, vmax, stop, np.where(stop, dur, 0.0)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(BLOCK, min_size=1, max_size=30),
    st.sampled_from([0.0025, 0.001, 0.0]),
    st.lists(st.floats(-0.1, 1.1), min_size=1, max_size=40),
)
def test_generated_blocks_are_bit_identical(
    rows: list[tuple[float, ...]], min_phase: float, shares: list[float]
) -> None:
    _tl = compiled("_timelaw")
    args = _blocks(rows)
    want = timelaw.trapezoids(*args, min_phase)
    assert _same_law(_tl.trapezoids(*args, min_phase), want)
    # points anywhere in the blocks (and a little before and after them)
    k = np.arange(len(shares)) % len(rows)
    tau = np.array(shares) * want.duration[k]
    tau[:: max(1, len(tau) // 3)] = want.t1[k[:: max(1, len(tau) // 3)]]  # phase ends
    got_s, got_v = _tl.along(want, k, tau)
    want_s, want_v = timelaw.along(want, k, tau)
    assert same_bits(got_s, want_s) and same_bits(got_v, want_v)
    # each phase cut into 0 to 5 steps (a dwell: one), some blocks of no points
    counts = np.array([[len(r) % 3, (i * 7) % 6, i % 2] for i, r in enumerate(rows)], np.int64)
    counts[args[5]] = [0, 1, 0]
    got_t = _tl.phase_times(want, counts)
    assert _same_times(got_t, timelaw.phase_times(want, counts))


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(0.0, 500.0), st.floats(1.0, 20_000.0), st.floats(0.0, 600.0)),
        min_size=0,
        max_size=40,
    ),
    st.floats(0.0, 600.0),
)
def test_generated_passes_are_bit_identical(rows: list[tuple[float, ...]], v_start: float) -> None:
    _tl = compiled("_timelaw")
    cols = (
        [np.array(c, dtype=float) for c in zip(*rows, strict=True)] if rows else [np.zeros(0)] * 3
    )
    L, a, vj = cols
    back = timelaw.backward_pass(L, a, vj)
    assert same_bits(_tl.backward_pass(L, a, vj), back)
    assert same_bits(
        _tl.forward_pass(L, a, back, v_start), timelaw.forward_pass(L, a, back, v_start)
    )


def test_the_passes_bound_every_speed_change() -> None:
    """v² changes by at most 2 a L over every block, both ways, in both kernels."""
    _tl = compiled("_timelaw")
    rng = np.random.default_rng(3)
    L, a, vj = rng.uniform(0, 5, 500), rng.uniform(100, 3000, 500), rng.uniform(0, 300, 500)
    vj[-1] = 0.0
    for k in (timelaw, _tl):
        v = k.forward_pass(L, a, k.backward_pass(L, a, vj), 0.0)
        prev = np.concatenate([[0.0], v[:-1]])
        assert np.all(np.abs(v**2 - prev**2) <= 2 * a * L * (1 + 1e-12) + 1e-9)
        assert np.all(v <= vj)


def test_a_block_too_short_for_its_limit_peaks_within_it() -> None:
    """A 1 mm block from rest to rest at 2000 mm/s²: its peak is bisected to
    sqrt(a L) (the triangle), not the 500 mm/s limit, in both kernels; and a dwell
    stands for its duration."""
    _tl = compiled("_timelaw")
    args = (
        np.array([0.0, 0.0]),
        np.array([0.0, 0.0]),
        np.array([1.0, 0.0]),
        np.array([2000.0, 1.0]),
        np.array([500.0, 1.0]),
        np.array([False, True]),
        np.array([0.0, 1.5]),
    )
    for k in (timelaw, _tl):
        law = k.trapezoids(*args, 0.0025)
        assert math.isclose(law.vp[0], math.sqrt(2000.0), rel_tol=1e-12)
        assert law.t2[0] == 0.0 and law.t1[0] == law.t3[0]
        assert (law.t1[1], law.t2[1], law.t3[1], law.duration[1]) == (0.0, 1.5, 0.0, 1.5)
    assert _same_law(_tl.trapezoids(*args, 0.0025), timelaw.trapezoids(*args, 0.0025))


def test_compiled_time_law_refuses_ragged_inputs() -> None:
    _tl = compiled("_timelaw")
    one, two = np.ones(1), np.ones(2)
    with pytest.raises(ValueError, match="one row per block"):
        _tl.trapezoids(one, one, two, one, one, np.zeros(1, bool), one, 0.0025)
    law = timelaw.trapezoids(one, one, one, one, one, np.zeros(1, bool), one, 0.0025)
    with pytest.raises(IndexError, match="out of range"):
        _tl.along(law, np.array([1]), np.zeros(1))


def test_a_cruise_too_short_is_lengthened_or_dropped() -> None:
    """0.06 mm from rest to rest at 10 mm/s and 2000 mm/s²: phases of 5 ms (s = 0.025
    mm each) leave a 1 ms cruise, short of the 2.5 ms a phase must last; the peak is
    bisected down until the cruise lasts min_phase (or there is none), in both
    kernels, to the bit."""
    _tl = compiled("_timelaw")
    z = np.zeros(1)
    args = (z, z, np.array([0.06]), np.array([2000.0]), np.array([10.0]), np.zeros(1, bool), z)
    for k in (timelaw, _tl):
        law = k.trapezoids(*args, 0.0025)
        assert law.vp[0] < 10.0
        assert law.t2[0] == 0.0 or law.t2[0] >= 0.0025 * (1 - 1e-9)
        assert min(law.t1[0], law.t3[0]) >= 0.0025
    assert _same_law(_tl.trapezoids(*args, 0.0025), timelaw.trapezoids(*args, 0.0025))


#: a motor's dP/ds [mm/mm]: standing, creeping, moving either way
SLOPE = st.one_of(
    st.sampled_from([0.0, -0.0, 1e-7, -1e-7, 1e-3, -1e-3, 2e-3, -2e-3]),
    st.floats(-2.0, 2.0),
)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.lists(SLOPE, min_size=5, max_size=5),
            st.lists(SLOPE, min_size=5, max_size=5),
            st.lists(st.floats(-1.0, 1.0), min_size=5, max_size=5),
            st.lists(st.floats(-1.0, 1.0), min_size=5, max_size=5),
            st.booleans(),
        ),
        min_size=1,
        max_size=20,
    )
)
def test_generated_play_stops_are_the_same(rows: list[tuple[Any, ...]]) -> None:
    _tl = compiled("_timelaw")
    P_out, P_in, t_out, t_in, cross = (np.array(c) for c in zip(*rows, strict=True))
    args = (t_out, t_in, P_out, P_in, cross, 3, 1e-3, 1e-6, (1.0 + 1e-4) ** 2)
    assert np.array_equal(_tl.play_stops(*args), timelaw.play_stops(*args))


def _same_set_offs(args: tuple[Any, ...]) -> None:
    """set_offs compiled and reference: the same crossings, ways (to the bit) and
    standing; the inputs left as they were."""
    _tl = compiled("_timelaw")
    way, stood = args[3].copy(), args[4].copy()
    got, want = _tl.set_offs(*args), timelaw.set_offs(*args)
    assert np.array_equal(got[0], want[0]) and got[0].dtype == want[0].dtype == bool
    assert same_bits(got[1], want[1])
    assert np.array_equal(got[2], want[2]) and got[2].dtype == bool
    assert same_bits(args[3], way) and np.array_equal(args[4], stood)


def test_sample_programs_set_offs_are_the_same(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    calls = recorded["_set_offs"]
    assert calls  # the perturbed profile's motors have play
    for args in calls:
        _same_set_offs(args)


@settings(max_examples=300, deadline=None)
@given(
    st.integers(1, 5),
    st.lists(
        st.tuples(
            st.lists(SLOPE, min_size=5, max_size=5),
            st.lists(SLOPE, min_size=5, max_size=5),
            st.sampled_from([0.0, 1e-3, 0.25, 5.0, 100.0]),
        ),
        min_size=1,
        max_size=20,
    ),
    st.lists(st.sampled_from([1.0, -1.0, 0.0]), min_size=5, max_size=5),
    st.lists(st.booleans(), min_size=5, max_size=5),
)
def test_generated_set_offs_are_the_same(
    k: int, rows: list[tuple[Any, ...]], way: list[float], stood: list[bool]
) -> None:
    """Motors standing, creeping, moving either way at blocks' starts and ends,
    speed limits from rest to fast, any way and standing before the first block."""
    d_in, d_out, vmax = (np.array(c) for c in zip(*rows, strict=True))
    args = (
        d_in[:, :k],
        d_out[:, :k],
        vmax,
        np.array(way[:k]),
        np.array(stood[:k]),
        1e-3,
        1e-6,
        5e-4,
    )
    _same_set_offs(args)


def test_a_motor_that_stood_setting_off_against_its_way_crosses() -> None:
    """A motor that last moved up (way +1), stood at the block before's end, and
    sets off down at 0.01 mm/mm on a block of 1 mm/s crosses there; the same
    setting off up, or not having stood, or creeping off (1e-4 mm/mm at 1 mm/s:
    1e-4 mm/s, under v_eps 5e-4 mm/s) does not; its way and standing after the
    last block go on to the next chunk."""
    for kern in (compiled("_timelaw"), timelaw):
        d_out = np.array([[0.0], [0.5]])

        def cross(start: float, stood: bool, kern: Any = kern, d_out: Any = d_out) -> bool:
            d_in = np.array([[start], [0.0]])
            got = kern.set_offs(
                d_in, d_out, np.ones(2), np.ones(1), np.array([stood]), 1e-3, 1e-6, 5e-4
            )
            return bool(got[0][0])

        assert cross(-0.01, True)
        assert not cross(0.01, True) and not cross(-0.01, False) and not cross(-1e-4, True)
        got = kern.set_offs(
            np.array([[-0.01]]),
            np.array([[2e-7]]),
            np.ones(1),
            np.ones(1),
            np.array([False]),
            1e-3,
            1e-6,
            5e-4,
        )
        assert got[1].tolist() == [-1.0] and got[2].tolist() == [True]


def test_a_head_motor_reversing_is_a_stop() -> None:
    """Motor 2 (a head motor) moves up at 0.5 mm/mm into the junction and down at
    0.4 out of it: the junction is a stop; the same with the slopes the same way is
    not. The path turns back along x, and table motor X with it: a stop only where
    a head motor sets off there (its standing does not speed the tip up)."""
    _tl = compiled("_timelaw")
    t = np.array([[1.0, 0.0, 0.0, 0.0, 0.0], [-1.0, 0.0, 0.0, 0.0, 0.0]])
    P_out = np.zeros((2, 5))
    P_in = np.zeros((2, 5))

    def stop(kern: Any, p_out: list[float], p_in: list[float]) -> bool:
        P_out[0], P_in[1] = p_out, p_in
        args = (t, t, P_out, P_in, np.zeros(2, bool), 3, 1e-3, 1e-6, (1.0 + 1e-4) ** 2)
        return bool(kern.play_stops(*args)[0])

    for kern in (timelaw, _tl):
        assert stop(kern, [0, 0.5, 0, 0, 0], [0, -0.4, 0, 0, 0])
        assert not stop(kern, [0, 0.5, 0, 0, 0], [0, 0.4, 0, 0, 0])
        assert not stop(kern, [0, 0.3, 0, 0.5, 0], [0, 0.3, 0, -0.4, 0])
        assert stop(kern, [0, 0.0, 0, 0.5, 0], [0, 0.3, 0, -0.4, 0])


def _same_junctions(args: tuple[Any, ...]) -> None:
    """junction_speeds compiled and reference: the same speeds to the bit, the
    same corners."""
    _tl = compiled("_timelaw")
    got, want = _tl.junction_speeds(*args), timelaw.junction_speeds(*args)
    assert same_bits(got[0], want[0]) and np.array_equal(got[1], want[1])


def test_sample_programs_junction_speeds_are_bit_identical(
    recorded: dict[str, list[tuple[Any, ...]]],
) -> None:
    calls = recorded["_junction_speeds"]
    assert len(calls) >= 7  # a plan at least per run
    junctions = stops = corners = 0
    for args in calls:
        _same_junctions(args)
        vj, corner = timelaw.junction_speeds(*args)
        junctions += len(vj) - 1
        stops += int(np.count_nonzero(vj[:-1] == 0.0))
        corners += int(np.count_nonzero(corner))
    # the samples' junctions: stops, corners taken at speed and tangent ones
    assert junctions > 100 and stops > 5 and corners > 10


_UNIT = st.sampled_from([1.0, -1.0, 0.0, -0.0, 0.6, 0.8, 1e-10])
_RULES = timelaw.JunctionRules(
    period=1e-3, min_phase=2.5e-3, a_xyz=0.5 * 2000.0, a_ab=0.5 * 3600.0,
    an=math.sqrt(0.75) * 2000.0, tol_gain=27.0 * 0.25, eps=1e-9, exact=-1.0,
)  # fmt: skip


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.lists(_UNIT | st.floats(-1.0, 1.0), min_size=5, max_size=5),
            st.lists(_UNIT | st.floats(-1.0, 1.0), min_size=5, max_size=5),
            st.sampled_from([0.0, 10.0, 50.0, np.inf]) | st.floats(0.0, 200.0),
            st.sampled_from([0.0, 1e-4]) | st.floats(0.0, 50.0),
            st.sampled_from([np.inf, 0.0]) | st.floats(0.0, 5.0),
            st.booleans(),
            st.booleans(),
            st.sampled_from([0.0, 10.0]),
            st.sampled_from([0.01, -1.0, 0.0]),
            st.sampled_from([np.inf, 0.5, 30.0, np.nan]),
            st.booleans(),
        ),
        min_size=0,
        max_size=12,
    )
)
def test_generated_junction_speeds_are_bit_identical(rows: list[tuple[Any, ...]]) -> None:
    """Tangents turning any way or not at all (±0.0 among them), speed limits of
    none, zero or any, blocks of no length, curves and lines, dwells, rotary-only
    moves, tool changes, exact stops and play stops."""
    n = len(rows)
    cols = list(zip(*rows, strict=True)) if rows else [[]] * 11
    dq_in = np.array(cols[0], dtype=float).reshape(n, 5)
    dq_out = np.array(cols[1], dtype=float).reshape(n, 5)
    vmax, length, seg = (np.array(cols[j], dtype=float) for j in (2, 3, 4))
    stops, angular = (np.array(cols[j], dtype=bool) for j in (5, 6))
    tool, tol, curv_r = (np.array(cols[j], dtype=float) for j in (7, 8, 9))
    play = np.array(cols[10][1:], dtype=bool)
    dot = np.einsum("ij,ij->i", dq_in[1:, :3], dq_out[:-1, :3])
    args = (dq_in, dq_out, dot, vmax, length, seg, stops, angular, tool, tol, tol, curv_r, play)
    with np.errstate(all="ignore"):
        _same_junctions((*args, _RULES))


def test_compiled_junction_speeds_refuse_ragged_inputs() -> None:
    _tl = compiled("_timelaw")
    n = 4
    one, flags, q = np.ones(n), np.zeros(n, dtype=bool), np.zeros((n, 5))
    args = [q, q, np.zeros(n - 1), one, one, one, flags, flags, one, one, one, one,
            np.zeros(n - 1, dtype=bool), _RULES]  # fmt: skip
    bad = list(args)
    bad[4] = np.ones(n - 1)
    with pytest.raises(
        ValueError, match=r"length must have one value a block \(4, as vmax\), got 3"
    ):
        _tl.junction_speeds(*bad)
    bad = list(args)
    bad[2] = np.zeros(n)
    with pytest.raises(ValueError, match=r"dot and play must have one value a junction \(3\)"):
        _tl.junction_speeds(*bad)
