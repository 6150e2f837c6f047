"""The compiled crossings (windows, steps' roots and turning points) against
their numpy reference: the same bits.

Recorded inputs (every call the sample programs make while the golden files are
converted: windows about reversals in motion, dips and settings-off, with the
reach the tip's speed allows; the roots of the steps where motors turn) and
generated ones (hypothesis: roots anywhere in their steps, accelerations of any
size, none or −0.0, reach none (inf), tiny or wide on either side, steps shorter
than a servo cycle, cubics and chords; steps' cubics from rest, with equal end
velocities, straight, nearly straight, turning twice, either way or none). The
windows in motion of corrected G-code and the room beside their steps are recorded
from the samples' G-code conversions on the contract's test machine (every motor
with play) and generated with the room drawn beside each step.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import kernel, reversals
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.kernel import windows

from .conftest import ROOT
from .kernel_cases import compiled, record, record_many, same_bits


def _same_pair(got: tuple[np.ndarray, np.ndarray], want: tuple[np.ndarray, np.ndarray]) -> bool:
    return same_bits(got[0], want[0]) and same_bits(got[1], want[1])


#: how often at least the samples' conversions call them, and on how many rows
#: in all (roots: the reversals in motion, once a motor with play and chunk, few
#: steps). dip_roots runs inside the reference's motor_dips and fused into the
#: twin's motor_reversals: generated inputs test it
#: (test_generated_roots_are_bit_identical); the reference's motor_turns and
#: motor_dips run inside its motor_reversals
#: (test_sample_programs_motor_reversals_are_bit_identical)
ROOT_CALLS = {"_velocity_roots": (5, 3)}


@pytest.mark.parametrize("attr", sorted(ROOT_CALLS))
def test_sample_programs_roots_are_bit_identical(attr: str, tmp_path: Path) -> None:
    _windows = compiled("_windows")
    calls = record(attr, tmp_path)
    assert len(calls) >= ROOT_CALLS[attr][0]
    assert sum(len(args[0]) for args in calls) >= ROOT_CALLS[attr][1]
    name = attr.removeprefix("_")
    for args in calls:
        got, want = getattr(_windows, name)(*args), getattr(windows, name)(*args)
        assert len(got) == len(want) and all(
            same_bits(g, w) for g, w in zip(got, want, strict=True)
        )


def _same_reversals(got: windows.Reversals, want: windows.Reversals) -> bool:
    return all(
        same_bits(g, w) and g.dtype == w.dtype and g.shape == w.shape
        for g, w in zip(got, want, strict=True)
    )


def test_sample_programs_motor_reversals_are_bit_identical(tmp_path: Path) -> None:
    """Every motor's reversals, kinds, dips and settings-off back, one call a chunk
    (every row of every motor with play), compiled against the reference; and
    against the reference's pieces motor by motor (motor_turns)."""
    _windows = compiled("_windows")
    calls = record("_motor_reversals", tmp_path)
    assert len(calls) >= 2
    assert sum(args[0].shape[1] * len(args[3]) for args in calls) >= 100
    kinds: set[int] = set()
    for args in calls:
        got = _windows.motor_reversals(*args)
        assert _same_reversals(got, windows.motor_reversals(*args))
        V, P, rest, cols, side, ref, drift, off, eps, _h, _tol = args
        for i, col in enumerate(cols.tolist()):
            turns = windows.motor_turns(
                V[col], P[col], rest, int(side[col]), ref[col], drift, off, eps
            )
            at = slice(got.turns[i], got.turns[i + 1])
            assert same_bits(turns[2], got.r[at]) and same_bits(turns[3], got.kind[at])
            kinds |= set(turns[3].tolist())
    assert len(kinds) >= 2


_vel = st.one_of(
    st.floats(-50.0, 50.0), st.sampled_from([0.0, -0.0, 1e-9, -2.5]), st.floats(-1e-6, 1e-6)
)


@st.composite
def _steps(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    n = draw(st.integers(0, 10))
    rows = []
    for _ in range(n):
        h = draw(st.sampled_from([0.01, 0.00977, 2.5e-4]) | st.floats(1e-4, 0.05))
        V0 = draw(_vel)
        V1 = draw(st.one_of(_vel, st.just(V0)))
        P0 = draw(st.floats(-300.0, 300.0))
        # a chord of the cubic's own (straight: (V0 + V1) h / 2), or any
        dP = draw(
            st.one_of(
                st.just(0.5 * (V0 + V1) * h),
                st.floats(-1e-3, 1e-3),
                st.floats(-1.0, 1.0),
                st.just(0.0),
            )
        )
        rows.append((P0, V0, P0 + dP, V1, h, draw(st.sampled_from([1.0, -1.0]))))
    arr = np.array(rows, dtype=float).reshape(n, 6)
    return tuple(np.ascontiguousarray(arr[:, j]) for j in range(6))


@settings(max_examples=400, deadline=None)
@given(case=_steps(), has_new=st.booleans())
def test_generated_roots_are_bit_identical(case: tuple[np.ndarray, ...], has_new: bool) -> None:
    _windows = compiled("_windows")
    P0, V0, P1, V1, h, new = case
    new_i = new.astype(int) if has_new else np.zeros(0, dtype=int)
    args = (P0, V0, P1, V1, h, new_i, has_new)
    want = windows.velocity_roots(*args)
    assert _same_pair(_windows.velocity_roots(*args), want)
    assert np.all((want[0] >= 0) & (want[0] <= 1))
    tp = windows.turning_points(P0, V0, P1, V1, h)
    assert _same_pair(_windows.turning_points(P0, V0, P1, V1, h), tp)
    both = np.isfinite(tp[0])
    assert np.all((tp[0][both] > 0) & (tp[0][both] < tp[1][both]) & (tp[1][both] < 1))
    sg = new.astype(int)
    for tol in (0.0, 1e-6, 5e-5):
        for sets_off in (False, True):
            d_args = (P0, V0, P1, V1, h, sg, tol, sets_off)
            want_d = windows.dip_roots(*d_args)
            got_d = _windows.dip_roots(*d_args)
            assert all(same_bits(g, w) for g, w in zip(got_d, want_d, strict=True))
            assert got_d[0].dtype == bool and int(want_d[0].sum()) == len(want_d[1])


def test_a_cubic_from_rest_turns_at_its_second_root_the_way_it_ends() -> None:
    """A motor at rest (V0 = 0) leaving with its chord against the way it ends the
    step goes back first: its root where it turns to that way is inside the step,
    not s = 0 (compiled and reference alike)."""
    args = (
        np.array([0.0]), np.array([0.0]), np.array([0.47e-3]), np.array([-0.0226]),
        np.array([0.00977]), np.array([-1]), True,
    )  # fmt: skip
    for mod in (windows, compiled("_windows")):
        s, acc = mod.velocity_roots(*args)
        assert 0 < s[0] < 1 and acc[0] < 0


def test_sample_programs_windows_are_bit_identical(tmp_path: Path) -> None:
    _windows = compiled("_windows")
    calls = record("_crossing_windows", tmp_path)
    # every motor's reversals in motion a chunk, and every motor's dips and
    # settings-off together once a chunk: mostly none, some windows in the
    # five-axis samples
    assert len(calls) >= 10
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


def test_compiled_windows_refuse_arrays_of_the_wrong_length() -> None:
    """The twins run without bounds checks: each refuses arrays of another length
    than its first with a ValueError naming what it expected and what it got."""
    _windows = compiled("_windows")
    n = 4
    a = np.linspace(0.0, 1.0, n)
    h = np.full(n, 0.01)
    args = [a, a + 1.0, a + 2.0, -a, h]
    names = ["V0", "P1", "V1", "h"]
    for j, name in enumerate(names, start=1):
        bad = list(args)
        bad[j] = bad[j][:-1]
        msg = rf"{name} must have one value a step \(4 values, as the first\), got 3"
        with pytest.raises(ValueError, match=msg):
            _windows.velocity_roots(*bad, np.ones(n), True)
        with pytest.raises(ValueError, match=msg):
            _windows.turning_points(*bad)
        with pytest.raises(ValueError, match=msg):
            _windows.dip_roots(*bad, np.ones(n), 1e-4, False)
    with pytest.raises(ValueError, match=r"new must have .* got 2"):
        _windows.velocity_roots(*args, np.ones(2), True)
    with pytest.raises(ValueError, match=r"sg must have .* got 5"):
        _windows.dip_roots(*args, np.ones(5), 1e-4, True)
    t0, t1, tr, acc = a, a + 0.01, a + 0.005, np.ones(n)
    inf = np.full(n, np.inf)
    with pytest.raises(
        ValueError, match=r"ra must have one value a window \(4 values, as the first\), got 3"
    ):
        _windows.crossing_windows(t0, t1, tr, acc, inf, inf[:-1], 1e-4, 1e-3, False, 2.5e-4)
    with pytest.raises(ValueError, match=r"t_root must have .* got 3"):
        _windows.crossing_windows(t0, t1, tr[:-1], acc, inf, inf, 1e-4, 1e-3, False, 2.5e-4)


@st.composite
def _motor_rows(draw: st.DrawFn, rows: int | None = None) -> tuple[Any, ...]:
    """A motor's rows as motor_turns takes them: velocities fast, creeping, zero
    or −0.0 either way, positions drifting or standing, rows at rest; with or
    without the point before the chunk (off); ``rows`` of them, or 0 to 40."""
    n = draw(st.integers(0, 40)) if rows is None else rows
    v = st.one_of(
        st.floats(-30.0, 30.0),
        st.sampled_from([0.0, -0.0, 4e-4, -4e-4, 5e-4, -6e-4, 2.0, -2.0]),
        st.floats(-1e-3, 1e-3),
    )
    V = np.array(draw(st.lists(v, min_size=n, max_size=n)), dtype=float)
    steps = draw(
        st.lists(
            st.one_of(st.floats(-1e-2, 1e-2), st.just(0.0), st.floats(-1e-9, 1e-9)),
            min_size=n,
            max_size=n,
        )
    )
    P = 10.0 + np.cumsum(np.array(steps, dtype=float))
    rest = np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)), dtype=bool)
    side = draw(st.sampled_from([1, -1]))
    ref = draw(st.one_of(st.just(np.nan), st.floats(9.9, 10.1)))
    off = draw(st.integers(0, 1)) if n else 0
    return V, P, rest, side, ref, draw(st.sampled_from([5e-5, 1e-7])), off


@settings(max_examples=300, deadline=None)
@given(case=_motor_rows(), tol=st.sampled_from([0.0, 1e-7, 5e-5]), seed=st.integers(0, 2**16))
def test_generated_motor_turns_and_dips_are_bit_identical(
    case: tuple[Any, ...], tol: float, seed: int
) -> None:
    """A motor's reversals and their kinds, and its dips and settings-off back
    (motor_reversals of the motor alone), compiled against the reference's pieces
    (motor_turns, motor_dips): the same rows, kinds and roots to the bit."""
    _windows = compiled("_windows")
    V, P, rest, side, ref, drift, off = case
    h = np.random.default_rng(seed).choice([0.01, 0.00977, 2.5e-4], len(V) - off)
    got = _windows.motor_reversals(
        V[None, :], P[None, :], rest, np.array([0]), np.array([side]), np.array([ref]),
        drift, off, reversals.V_EPS, h, tol,
    )  # fmt: skip
    want = windows.motor_turns(V, P, rest, side, ref, drift, off, reversals.V_EPS)
    assert all(
        same_bits(np.asarray(g), np.asarray(w))
        for g, w in zip((got.sg[0], got.came[0], got.r, got.kind, got.reach[0]), want, strict=True)
    )
    assert got.kind.dtype == np.int8 and set(got.kind.tolist()) <= {0, 1, 2, 3}
    sg, came = want[0], want[1]
    for part, sets_off in enumerate((False, True)):
        w_d = windows.motor_dips(P, V, h, sg, came, off, tol, sets_off)
        at = slice(got.dips[part], got.dips[part + 1])
        g_d = (got.j[at], got.s1[at], got.s2[at], got.A1[at], got.A2[at])
        assert all(same_bits(g, w) and g.dtype == w.dtype for g, w in zip(g_d, w_d, strict=True))


@pytest.mark.parametrize("seed", range(4))
def test_dips_at_signed_zeros_and_velocities_against_the_way_are_bit_identical(
    seed: int,
) -> None:
    """The twin's dip pass skips a step before its roots are made where their
    signs rule out two inside it (c = V0 zero, a against c, b's sign bit against
    c): steps at ±0.0 velocities (a motor's way made by its creeps there), chords
    that make b exactly ±0.0, velocities against the way and dips of either way;
    motor_reversals of the motor alone, compiled against the reference."""
    _windows = compiled("_windows")
    rng = np.random.default_rng(seed)
    n = 4000
    # runs of one way, some rows against it; ±0.0 and ±1e-300 stand (their way
    # from the creeps or none)
    way = np.repeat(rng.choice([1.0, -1.0], n // 8 + 1), 8)[:n]
    way[rng.random(n) < 0.05] *= -1.0
    V = way * rng.choice([0.0, 1e-300, 3.0, 1.0, 7.5], n)
    h = rng.choice([0.01, 0.00977, 2.5e-4], n - 1)
    # chords: none, ±0.0, along the mean velocity, short of it (a dip), against it
    k = rng.integers(0, 6, n - 1)
    mean = 0.5 * (V[:-1] + V[1:]) * h
    step = np.select(
        [k == 0, k == 1, k == 2, k == 3, k == 4],
        [np.zeros(n - 1), np.full(n - 1, -0.0), mean, 0.05 * mean, -mean],
        rng.normal(0.0, 0.01, n - 1),
    )
    P = np.concatenate([[0.0], np.cumsum(step)])
    P[1:][k == 1] = P[:-1][k == 1]  # exactly no chord
    rest = rng.random(n) < 0.02
    args = (
        V[None, :], P[None, :], rest, np.array([0]), np.array([1]), np.array([np.nan]),
        1e-6, 1, reversals.V_EPS, h, 1e-6,
    )  # fmt: skip
    got, want = _windows.motor_reversals(*args), windows.motor_reversals(*args)
    assert _same_reversals(got, want)
    # dips, and settings-off back, found
    assert want.dips[1] > want.dips[0] and want.dips[2] > want.dips[1]


@st.composite
def _chunk_rows(draw: st.DrawFn) -> tuple[Any, ...]:
    """motor_reversals' arguments: motors 0 and 2 of three, each drawn as
    :func:`_motor_rows` draws one (its own velocities, positions, side and ref) on
    the chunk's rows at rest, with or without the point before the chunk."""
    one = draw(_motor_rows())
    n, rest, off, drift = len(one[0]), one[2], one[6], one[5]
    V, P, side, ref = np.zeros((3, n)), np.zeros((3, n)), np.ones(3, dtype=int), np.zeros(3)
    V[0], P[0], side[0], ref[0] = one[0], one[1], one[3], one[4]
    other = draw(_motor_rows(n))
    V[2], P[2], side[2], ref[2] = other[0], other[1], other[3], other[4]
    return V, P, rest, np.array([0, 2]), side, ref, drift, off


@settings(max_examples=200, deadline=None)
@given(case=_chunk_rows(), tol=st.sampled_from([0.0, 1e-7, 5e-5]), seed=st.integers(0, 2**16))
def test_generated_motor_reversals_are_bit_identical(
    case: tuple[Any, ...], tol: float, seed: int
) -> None:
    """Two motors' reversals, kinds, dips and settings-off back in one call, compiled
    against the reference (motor_turns and motor_dips motor by motor): the same
    rows, kinds, roots and offsets, to the bit and dtype."""
    _windows = compiled("_windows")
    V, P, rest, cols, side, ref, drift, off = case
    h = np.random.default_rng(seed).choice([0.01, 0.00977, 2.5e-4], V.shape[1] - off)
    args = (V, P, rest, cols, side, ref, drift, off, reversals.V_EPS, h, tol)
    assert _same_reversals(_windows.motor_reversals(*args), windows.motor_reversals(*args))


def test_compiled_motor_rows_refuse_arrays_of_the_wrong_length() -> None:
    _windows = compiled("_windows")
    rest = np.zeros(5, bool)
    V2, P2, cols, side, ref = (
        np.ones((3, 5)),
        np.ones((3, 5)),
        np.array([0, 2]),
        np.ones(3),
        np.zeros(3),
    )
    rows = (rest, cols, side, ref, 1e-4, 1, 5e-4, np.ones(4), 1e-6)
    _windows.motor_reversals(V2, P2, *rows)  # the right shapes pass
    with pytest.raises(ValueError, match=r"V must have one row a motor .* \(3, 5\), got \(3, 4\)"):
        _windows.motor_reversals(V2[:, :4], P2, *rows)
    with pytest.raises(ValueError, match=r"rest must have one value a row, as P .* got 4"):
        _windows.motor_reversals(V2, P2, rest[:-1], *rows[1:])
    with pytest.raises(ValueError, match=r"ref must have one value a motor, as P's rows .* got 2"):
        _windows.motor_reversals(V2, P2, rest, cols, side, ref[:2], *rows[4:])
    with pytest.raises(ValueError, match=r"cols must be rows of P \(0 to 2\), got 3"):
        _windows.motor_reversals(V2, P2, rest, np.array([3]), *rows[2:])
    with pytest.raises(ValueError, match=r"h must have at most 4 values \(one a step\), got 5"):
        _windows.motor_reversals(V2, P2, *rows[:-2], np.ones(5), 1e-6)


def _polyline(n: int) -> str:
    """A tilting polyline at F1500 turning 12° at each point, ten one way then ten
    the other: corners taken at speed."""
    lines = ["G21 G90 G17 G94", "G0 X0 Y0 Z5 A0 B0", "G1 Z0 F600"]
    x = y = ang = 0.0
    for i in range(n):
        ang += math.radians(12 if (i // 10) % 2 else -12)
        x, y = x + 2 * math.cos(ang), y + 2 * math.sin(ang)
        a, b = 3 * math.sin(i / 5), 2 * math.cos(i / 7)
        lines.append(f"G1 X{x:.3f} Y{y:.3f} A{a:.3f} B{b:.3f} F1500")
    return "\n".join([*lines, "M2", ""])


def test_converted_corner_blends_are_bit_identical(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The corners a PVT conversion looks at (a polyline at speed through a
    profile with play; the sample programs have none), compiled against the
    reference: blend and τ to the bit, some corners blended, some not."""
    _windows = compiled("_windows")
    calls: list[tuple[Any, ...]] = []
    inner = kernel._corner_blends

    def spy(*args: Any) -> Any:
        calls.append(copy.deepcopy(args))
        return inner(*args)

    monkeypatch.setattr(kernel, "_corner_blends", spy)
    program = tmp_path / "polyline.ngc"
    program.write_text(_polyline(80))
    prof = str(ROOT / "tests" / "data" / "vectors" / "perturbed.toml")
    convert_file(ConvertJob(str(program), prof, "pmac", str(tmp_path / "out.pmc")))
    assert sum(len(args[3]) for args in calls) >= 20
    blended = corners = 0
    for args in calls:
        want = windows.corner_blends(*args)
        got = _windows.corner_blends(*args)
        assert same_bits(got[0], want[0]) and got[0].dtype == bool
        assert same_bits(got[1], want[1])
        blended += int(want[0].sum())
        corners += len(want[0])
    assert 0 < blended < corners


_corner_v = st.one_of(
    st.floats(-60.0, 60.0),
    st.sampled_from([0.0, -0.0, 4e-4, -6e-4, 1.0, -1.0]),
    st.floats(-1e-3, 1e-3),
)


@settings(max_examples=300, deadline=None)
@given(
    k=st.integers(0, 8),
    data=st.data(),
    cols=st.sampled_from([[0, 1, 2, 3, 4], [2], [0, 3], []]),
    accel=st.sampled_from([250.0, 1e4, 1.0]),
)
def test_generated_corner_blends_are_bit_identical(
    k: int, data: st.DataObject, cols: list[int], accel: float
) -> None:
    """Corners with motors standing on one side, slowing, reversing, creeping,
    −0.0; steps from a servo cycle to 20 ms: blend and τ to the bit."""
    _windows = compiled("_windows")
    V_in = np.array(data.draw(st.lists(_corner_v, min_size=5 * k, max_size=5 * k))).reshape(k, 5)
    V_out = np.array(data.draw(st.lists(_corner_v, min_size=5 * k, max_size=5 * k))).reshape(k, 5)
    if k and data.draw(st.booleans()):
        V_out[:, 1] = V_in[:, 1]  # a motor moving alike on both sides
    h = np.array(data.draw(st.lists(st.floats(2.5e-4, 0.02), min_size=k, max_size=k)))
    args = (V_in, V_out, np.array(cols, dtype=int), h, accel, 5e-4, 1e-6, 1e-3)
    want = windows.corner_blends(*args)
    got = _windows.corner_blends(*args)
    assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])


def test_compiled_corner_blends_refuse_wrong_shapes() -> None:
    _windows = compiled("_windows")
    V = np.zeros((3, 5))
    h = np.full(3, 0.01)
    cols = np.array([0, 1])
    with pytest.raises(
        ValueError, match=r"V_in and V_out must be \(k, 5\), got \(3, 5\) and \(3, 4\)"
    ):
        _windows.corner_blends(V, V[:, :4], cols, h, 250.0, 5e-4, 1e-6, 1e-3)
    with pytest.raises(
        ValueError, match=r"h must have one row a corner, as V_in \(3 values.*got 2"
    ):
        _windows.corner_blends(V, V, cols, h[:2], 250.0, 5e-4, 1e-6, 1e-3)
    with pytest.raises(ValueError, match=r"cols must be motor columns 0 to 4, got 5"):
        _windows.corner_blends(V, V, np.array([5]), h, 250.0, 5e-4, 1e-6, 1e-3)


def test_sample_programs_chord_windows_and_their_room_are_bit_identical(
    tmp_path: Path,
) -> None:
    """The windows in motion of corrected G-code (straight lines between the
    points) and how far each may reach into the steps beside, as the samples'
    G-code conversions ask them on the contract's test machine, every motor with
    play: compiled and reference the same bits."""
    _windows = compiled("_windows")
    runs = [
        (s, "gcode", "tests/data/vectors/perturbed.toml") for s in ("pocket.ngc", "five-axis.ngc")
    ]
    calls = record_many(["_chord_windows", "_chord_room"], tmp_path, runs)
    # every motor with play a chunk
    for attr in ("_chord_windows", "_chord_room"):
        assert len(calls[attr]) >= 10
        assert sum(len(args[0]) for args in calls[attr]) >= 10
    for args in calls["_chord_windows"]:
        assert _same_pair(_windows.chord_windows(*args), windows.chord_windows(*args))
    for args in calls["_chord_room"]:
        assert _same_pair(_windows.chord_room(*args), windows.chord_room(*args))


@st.composite
def _chord_cases(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    """Windows in motion (:func:`_cases`' steps, roots, accelerations and reach)
    and the room beside each step: none, short or long."""
    case = draw(_cases())
    room = st.one_of(st.just(0.0), st.floats(0.0, 5e-4), st.floats(0.0, 0.05))
    n = len(case[0])
    before = case[0] - np.array([draw(room) for _ in range(n)], dtype=float)
    after = case[1] + np.array([draw(room) for _ in range(n)], dtype=float)
    return (*case, before, after)


@settings(max_examples=400, deadline=None)
@given(
    case=_chord_cases(),
    tol=st.sampled_from([5e-5, 1e-6, 1e-3]),
    longest=st.sampled_from([1e-3, 2e-3, 0.25e-3]),
)
def test_generated_chord_windows_are_bit_identical(
    case: tuple[np.ndarray, ...], tol: float, longest: float
) -> None:
    _windows = compiled("_windows")
    args = (*case[:6], tol, longest, *case[6:], reversals.MIN_WINDOW_S, reversals.SNAP_S)
    want = windows.chord_windows(*args)
    assert _same_pair(_windows.chord_windows(*args), want)
    # within the room beside its step, about its root
    t_root, before, after = case[2], case[6], case[7]
    a, b = want
    assert np.all((before <= a) & (a <= b) & (b <= after))
    assert np.all((a <= t_root) & (t_root <= b))


@st.composite
def _rooms(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    """Steps of a chunk (some of no time, some at rest), windows in any of them,
    the steps with other windows and the corner rows, sorted, with −1 and n
    among them (a window's step before the first)."""
    n = draw(st.integers(1, 10))
    dt = np.array(
        draw(st.lists(st.sampled_from([0.0, 1e-4, 2.5e-4, 3e-3]), min_size=n, max_size=n))
    )
    resting = np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)))
    km = np.array(draw(st.lists(st.integers(0, n - 1), max_size=8)), dtype=int)
    t0 = np.arange(len(km), dtype=float) * 0.01
    t1 = t0 + 0.005
    steps = st.lists(st.integers(-1, n), max_size=6)
    busy = np.sort(np.array(draw(steps), dtype=int))
    bent = np.sort(np.array(draw(steps), dtype=int))
    return km, t0, t1, dt, resting, busy, bent


@settings(max_examples=400, deadline=None)
@given(case=_rooms())
def test_generated_chord_room_is_bit_identical(case: tuple[np.ndarray, ...]) -> None:
    _windows = compiled("_windows")
    km, t0, t1, dt, resting, busy, bent = case
    args = (*case, reversals.MIN_WINDOW_S)
    t_before, t_after = windows.chord_room(*args)
    assert _same_pair(_windows.chord_room(*args), (t_before, t_after))
    # room only into a step beside that moves, where no other window or corner is
    prev_free = (
        (km >= 2)
        & ~resting[np.maximum(km - 1, 0)]
        & ~resting[np.maximum(km - 2, 0)]
        & (dt[np.maximum(km - 1, 0)] > 0)
        & ~np.isin(km - 1, busy)
        & ~np.isin(km - 1, bent)
    )
    assert np.all((t_before < t0) <= prev_free)
    assert np.all(t_before <= t0) and np.all(t_after >= t1)


@settings(max_examples=200, deadline=None)
@given(
    x=st.lists(st.integers(-3, 12), max_size=10),
    pool=st.lists(st.integers(-3, 12), max_size=10),
)
def test_in_sorted_is_numpys_isin(x: list[int], pool: list[int]) -> None:
    xs, ps = np.array(x, dtype=int), np.sort(np.array(pool, dtype=int))
    assert np.array_equal(windows.in_sorted(xs, ps), np.isin(xs, ps))


def test_compiled_chord_room_refuses_steps_outside_the_chunk() -> None:
    _windows = compiled("_windows")
    dt, resting, none = np.full(3, 1e-3), np.zeros(3, dtype=bool), np.zeros(0, dtype=int)
    with pytest.raises(ValueError, match=r"km must be steps of dt \(0 to 2\), got 3"):
        _windows.chord_room(np.array([3]), np.zeros(1), np.ones(1), dt, resting, none, none, 2.5e-4)
    with pytest.raises(ValueError, match=r"t1 must have one value a window \(2 values"):
        _windows.chord_room(
            np.array([0, 1]), np.zeros(2), np.ones(1), dt, resting, none, none, 2.5e-4
        )
