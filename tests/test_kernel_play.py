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

import copy
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
ENTRIES: dict[str, Any] = {
    "_play_lo": play.lo,
    "_settle_motors": play.settle_motors,
    "_table_commands": play.table_commands,
    "_motors_sides": play.motors_sides,
}


def _same(got: Any, want: Any) -> bool:
    if isinstance(want, tuple):
        return len(got) == len(want) and all(_same(g, w) for g, w in zip(got, want, strict=True))
    return same_bits(got, want)


#: the arguments each kernel updates in place
IN_PLACE = {"_settle_motors": (6, 7), "_table_commands": (5, 6), "_motors_sides": (14,)}


def _settled(f: Any, args: tuple[Any, ...], attr: str = "_settle_motors") -> tuple[Any, ...]:
    """The answer of ``f`` (one of :data:`IN_PLACE`) on a copy of ``args``, and the
    arguments it updated in place."""
    mine = copy.deepcopy(args)
    got = f(*mine)
    return (*(() if got is None else got), *(mine[i] for i in IN_PLACE[attr]))


#: what the chain calls through the kernel's names, and how often at least while
#: the samples convert (the envelopes alone at the start; the commands through the
#: tables, table_commands, are compensate_sided and slope motor by motor in the
#: reference: the settle's pieces below and the generated inputs test those).
#: carried and creeps run inside windows.motor_reversals on both paths (its
#: recorded and generated inputs: tests/test_kernel_windows.py), and on generated
#: inputs here
RECORDED = {
    "_play_lo": 1,
    "_settle_motors": 2,  # one call a chunk, every motor
    "_table_commands": 2,
    "_motors_sides": 2,
}
#: what the settle calls inside the kernel (recorded from the reference settle on
#: the recorded settles' inputs), and how often at least
INNER = {
    "settle_crossings": 3,
    "follow_stretches": 3,
    "catch_up": 3,
    "lo_inv": 3,
    "hi_inv": 3,
    "compensate_sided": 1,
    "slope": 1,
}


@pytest.mark.parametrize("attr", sorted(RECORDED))
def test_sample_programs_play_model_is_bit_identical(attr: str, tmp_path: Path) -> None:
    _play = compiled("_play")
    calls = record(attr, tmp_path)
    assert len(calls) >= RECORDED[attr]
    for args in calls:
        name = attr.removeprefix("_play_").removeprefix("_")
        if attr in IN_PLACE:
            # the commands (sides) are updated in place: compared with the answers
            got_, want_ = (
                _settled(getattr(_play, name), args, attr),
                _settled(ENTRIES[attr], args, attr),
            )
            assert _same(got_, want_), attr
            continue
        want = ENTRIES[attr](*args)
        got = getattr(_play, name)(*args)
        assert _same(tuple(got) if attr == "_settle_crossings" else got, want), attr


@pytest.fixture(scope="module")
def inner_calls(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[tuple[Any, ...]]]:
    """The calls the reference settle makes of the pieces, on the settles the
    sample programs make."""
    settles = record("_settle_motors", tmp_path_factory.mktemp("settle"))
    calls: dict[str, list[tuple[Any, ...]]] = {k: [] for k in INNER}
    mp = pytest.MonkeyPatch()
    for name in INNER:
        inner = getattr(play, name)

        def spy(*args: Any, _inner: Any = inner, _name: str = name) -> Any:
            calls[_name].append(tuple(copy.deepcopy(a) for a in args))
            return _inner(*args)

        mp.setattr(play, name, spy)
    try:
        for args in settles:
            play.settle_motors(*copy.deepcopy(args))
    finally:
        mp.undo()
    return calls


@pytest.mark.parametrize("name", sorted(INNER))
def test_sample_programs_settle_pieces_are_bit_identical(
    name: str, inner_calls: dict[str, list[tuple[Any, ...]]]
) -> None:
    _play = compiled("_play")
    calls = inner_calls[name]
    assert len(calls) >= INNER[name]
    for args in calls:
        want = getattr(play, name)(*copy.deepcopy(args))
        got = getattr(_play, name)(*copy.deepcopy(args))
        assert _same(tuple(got) if name == "settle_crossings" else got, want), name


def test_sample_programs_follow_their_parts_through_turning_points(
    inner_calls: dict[str, list[tuple[Any, ...]]],
) -> None:
    """The recorded follows are not all straight: in some steps the command's cubic
    turns back (the turning points, evaluated with numpy's power in both)."""
    calls = inner_calls["follow_stretches"]
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


def _motion(rng: np.random.Generator, n: int) -> play.Motion:
    P_ideal = np.cumsum(rng.normal(0, 0.02, n))
    s_path = np.cumsum(np.where(rng.random(n) < 0.1, 0.0, rng.uniform(0, 0.3, n)))
    return play.Motion(
        P_ideal,
        rng.normal(0, 5, n),
        np.diff(P_ideal, prepend=0.0),
        np.abs(rng.normal(0, 10, n)),
        np.where(rng.random(n) < 0.05, 0.0, rng.uniform(0.001, 0.01, n)),
        s_path,
        rng.choice([-1.0, 1.0], n),
    )


@settings(max_examples=150, deadline=None)
@given(tables(), st.integers(0, 2**32 - 1), st.integers(4, 80), st.booleans())
def test_generated_settles_are_bit_identical(
    table: axiscomp.MotorTable, seed: int, n: int, cubic: bool
) -> None:
    """Chains of crossings (each window inside the gap the one before leaves),
    parts off by up to a few µm, behind and ahead, with and without periodic
    terms: the commands, the part and the carried offset, to the bit."""
    _play = compiled("_play")
    args = _settle_case(table.flat, seed, n, cubic)
    if args is not None:
        assert _same(tuple(_play.settle_crossings(*args)), tuple(play.settle_crossings(*args)))


def _settle_case(t: play.PlayTable, seed: int, n: int, cubic: bool) -> tuple[Any, ...] | None:
    """settle_crossings' arguments: up to four crossings in n points, commands off
    their wanted positions by up to mm (None: no crossing drawn)."""
    rng = np.random.default_rng(seed)
    mo = _motion(rng, n)
    mid = 0.5 * (t.breaks[0] + t.breaks[-1])
    mo = mo._replace(P_ideal=mo.P_ideal + mid)
    k = min(n + 1, 2 * int(rng.integers(1, 5)))
    cuts = np.sort(rng.choice(np.arange(-1, n), size=k, replace=False))
    e = cuts[1::2]
    b = cuts[0::2][: len(e)]
    if not len(e):
        return None
    short = np.abs(rng.normal(0, 1e-7, len(e)))
    P = mo.P_ideal + rng.normal(0, 2e-3, n)
    V = mo.V_ideal + rng.normal(0, 0.1, n)
    before = (mid + rng.normal(0, 1e-3), mid + rng.normal(0, 1e-3), float(rng.normal(0, 5)))
    return (t, mo, before, e, b, short, P, V, cubic, float(rng.choice([5e-5, 5e-3])), 2.0)


def test_generated_settles_reckon_crossings_again(monkeypatch: pytest.MonkeyPatch) -> None:
    """The generated settles take offsets into later crossings (the rounds of
    _reckon_again run), and agree to the bit there too."""
    _play = compiled("_play")
    rounds = 0
    inner = play._reckon_again

    def count(*args: Any) -> Any:
        nonlocal rounds
        rounds += 1
        return inner(*args)

    monkeypatch.setattr(play, "_reckon_again", count)
    t = axiscomp.MotorTable.from_comp(
        AxisComp(1, np.array([-50.0, 0.0, 50.0]), np.zeros(3), np.array([0.004, 0.002, 0.004]))
    ).flat
    for seed in range(40):
        args = _settle_case(t, seed, 60, seed % 2 == 0)
        if args is not None:
            assert _same(tuple(_play.settle_crossings(*args)), tuple(play.settle_crossings(*args)))
    assert rounds > 10


def _settle_motors_case(
    tabs: list[play.PlayTable], seed: int, n: int, cubic: bool
) -> tuple[Any, ...]:
    """settle_motors' arguments: motors 0 and 2 of three (one table each) with up to
    four crossings each in n points (interleaved by their ends, as the chain sorts
    them), offsets carried from the chunk before or none; steps of no duration at
    about 5 % of the points, never a window's last."""
    rng = np.random.default_rng(seed)
    cols = np.array([0, 2])
    mids = [0.5 * (t.breaks[0] + t.breaks[-1]) for t in tabs]
    P_ideal = (
        np.cumsum(rng.normal(0, 0.02, (3, n)), axis=1) + np.array([mids[0], 0, mids[1]])[:, None]
    )
    s_path = np.cumsum(np.where(rng.random(n) < 0.1, 0.0, rng.uniform(0, 0.3, n)))
    dt = np.where(rng.random(n) < 0.05, 0.0, rng.uniform(0.001, 0.01, n))
    rows = []
    for col in cols:
        k = min(n + 1, 2 * int(rng.integers(0, 5)))
        cuts = np.sort(rng.choice(np.arange(-1, n), size=k, replace=False))
        for b, e in zip(cuts[0::2], cuts[1::2], strict=False):
            rows.append((e, b, col))
            # a crossing takes time: its window's last step has a duration, as the
            # chain's windows do (steps of no duration occur elsewhere)
            dt[e] = dt[e] or 0.001
    ch = play.Chunk(
        P_ideal,
        rng.normal(0, 5, (3, n)),
        rng.choice([-1.0, 1.0], (3, n)),
        np.abs(rng.normal(0, 10, n)),
        dt,
        s_path,
        np.cumsum(dt),
        P_ideal[:, 0] + rng.normal(0, 0.01, 3),
    )
    x = np.array(rows, dtype=int).reshape(-1, 3)
    x = x[np.lexsort((x[:, 2], x[:, 1], x[:, 0]))]
    contacts = play.Contacts(x[:, 0], x[:, 1], x[:, 2], np.abs(rng.normal(0, 1e-7, len(x))))
    before = np.column_stack(
        [mids + rng.normal(0, 1e-3, 2), mids + rng.normal(0, 1e-3, 2), rng.normal(0, 5, 2)]
    )
    carried_off = rng.normal(0, 2e-4, 2) * (rng.random(2) < 0.5)
    P = P_ideal + rng.normal(0, 2e-3, (3, n))
    V = ch.V_ideal + rng.normal(0, 0.1, (3, n))
    share = float(rng.choice([5e-5, 5e-3]))
    return (tuple(tabs), cols, ch, before, carried_off, contacts, P, V, cubic, share, 2.0)


@settings(max_examples=150, deadline=None)
@given(tables(), tables(), st.integers(0, 2**32 - 1), st.integers(1, 60), st.booleans())
def test_generated_settle_motors_are_bit_identical(
    t0: axiscomp.MotorTable, t2: axiscomp.MotorTable, seed: int, n: int, cubic: bool
) -> None:
    """Two motors through a chunk in one call: offsets carried in from the chunk
    before, chains of crossings, none at all (the part followed through the
    whole chunk), straight lines' windows put on their chords: the commands
    (updated in place), the parts and the offsets carried on, to the bit."""
    _play = compiled("_play")
    args = _settle_motors_case([t0.flat, t2.flat], seed, n, cubic)
    got, want = _settled(_play.settle_motors, args), _settled(play.settle_motors, args)
    assert _same(got, want)
    # the motor without play is left as it was
    assert same_bits(got[2][1], args[6][1]) and same_bits(got[3][1], args[7][1])


def test_generated_settle_motors_move_points_onto_chords() -> None:
    """Straight lines: the settle of every motor puts points inside windows on the
    window's chord (play.across, with V the chord's rate), the same in both."""
    _play = compiled("_play")
    t = axiscomp.MotorTable.from_comp(
        AxisComp(1, np.array([-50.0, 0.0, 50.0]), np.zeros(3), np.array([0.004, 0.002, 0.004]))
    ).flat
    moved = 0
    for seed in range(30):
        args = _settle_motors_case([t, t], seed, 40, False)
        got, want = _settled(_play.settle_motors, args), _settled(play.settle_motors, args)
        assert _same(got, want)
        x = args[5]
        inner = x.e - x.b - 1 > 0
        for e, b, col in zip(x.e[inner], x.b[inner], x.col[inner], strict=True):
            if b < 0:
                continue
            P, V, tt = got[2][col], got[3][col], args[2].t
            # one rate, and the points on the line from the window's first command
            on = np.allclose(P[b + 1 : e], P[b] + V[b + 1 : e] * (tt[b + 1 : e] - tt[b]), 0, 1e-9)
            moved += int(np.all(V[b + 1 : e] == V[b + 1]) and on)
    assert moved > 10


@settings(max_examples=100, deadline=None)
@given(tables(), st.integers(0, 2**32 - 1), st.integers(1, 60))
def test_generated_catch_up_commands_are_bit_identical(
    table: axiscomp.MotorTable, seed: int, n: int
) -> None:
    _play = compiled("_play")
    t = table.flat
    rng = np.random.default_rng(seed)
    mo = _motion(rng, n)
    start = np.array(sorted(set(rng.integers(-1, n, 3).tolist())), dtype=int)
    stop = np.append(start[1:], n)
    off0 = rng.normal(0, 1e-3, len(start))
    P, V = mo.P_ideal.copy(), mo.V_ideal.copy()
    P2, V2 = P.copy(), V.copy()
    want = play.catch_up_commands(t, mo, off0, start, stop, P, V, 5e-3, 2.0)
    got = _play.catch_up_commands(t, mo, off0, start, stop, P2, V2, 5e-3, 2.0)
    assert same_bits(got[0], want[0]) and same_bits(np.array(got[1]), np.array(want[1]))
    assert same_bits(P2, P) and same_bits(V2, V)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 40), st.integers(0, 2**32 - 1), st.booleans())
def test_generated_carried_sides_are_identical(n: int, seed: int, columns: bool) -> None:
    """Directions carried through standing rows: one motor (ints, the side an int)
    or several (floats, a side each), the same values and types in both."""
    _play = compiled("_play")
    rng = np.random.default_rng(seed)
    if columns:
        sg = np.where(rng.random((n, 3)) < 0.5, 0.0, np.sign(rng.normal(size=(n, 3))))
        side: Any = rng.choice([-1.0, 1.0], 3)
    else:
        sg = rng.integers(-1, 2, n) * (rng.random(n) < 0.5)
        side = int(rng.choice([-1, 1]))
    got, want = _play.carried(sg, side), play.carried(sg, side)
    assert got.dtype == want.dtype and got.shape == want.shape
    assert np.array_equal(got, want)


@settings(max_examples=300, deadline=None)
@given(
    st.integers(0, 60),
    st.integers(0, 2**32 - 1),
    st.sampled_from([-1, 1]),
    st.one_of(st.just(math.nan), st.floats(-50, 50)),
    st.sampled_from([1e-4, 1e-3, 5e-3]),
)
def test_generated_creeps_are_bit_identical(
    n: int, seed: int, side: int, ref: float, drift: float
) -> None:
    """Motors creeping (no direction) between rows with one, drifting back by more
    and less than the allowance: the same reversals and the same reach, to the bit."""
    _play = compiled("_play")
    rng = np.random.default_rng(seed)
    sg = rng.choice([-1, 0, 0, 0, 1], n)
    P = np.cumsum(rng.normal(0, 1e-3, n)) + rng.normal(0, 10)
    got, want = _play.creeps(sg, P, side, ref, drift), play.creeps(sg, P, side, ref, drift)
    assert np.array_equal(got[0], want[0]) and got[0].dtype == want[0].dtype
    assert same_bits(np.array(got[1]), np.array(want[1]))


@settings(max_examples=300, deadline=None)
@given(st.integers(1, 50), st.integers(0, 2**32 - 1), st.integers(0, 4), st.integers(0, 3))
def test_generated_motor_sides_are_identical(n: int, seed: int, w: int, s: int) -> None:
    """Windows anywhere in a chunk (one ending before it, at −1; two in one step;
    points after a window in its step), crossings at standing points, creeping
    and resting rows: the same sides, the same type."""
    _play = compiled("_play")
    rng = np.random.default_rng(seed)
    V = rng.normal(0, 1e-3, n) * np.where(rng.random(n) < 0.5, 1.0, 1e4)
    resting = rng.random(n) < 0.2
    e = np.sort(rng.integers(-1, n, w))
    f = np.maximum(e - rng.integers(0, 4, w), 0)
    last_row = np.minimum(e + rng.integers(0, 4, w), n - 1)
    new = rng.choice([-1, 1], w)
    s_first = rng.integers(0, n, s)
    s_new = rng.choice([-1, 1], s)
    side = int(rng.choice([-1, 1]))
    args = (V, resting, f, e, new, last_row, s_first, s_new, side, 5e-4)
    got, want = _play.motor_sides(*args), play.motor_sides(*args)
    assert got.dtype == want.dtype and np.array_equal(got, want)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 40), st.integers(0, 2**32 - 1), st.integers(0, 6), st.integers(0, 4))
def test_generated_motors_sides_are_identical(n: int, seed: int, w: int, s: int) -> None:
    """Motors 0, 2 and 3 of four in one call: each motor's windows a slice of the
    flat arrays (some none), its standing crossings picked by their motor, the
    other motor's row left as it was: the same sides as the reference's
    motor_sides motor by motor."""
    _play = compiled("_play")
    rng = np.random.default_rng(seed)
    cols = np.array([0, 2, 3])
    V = rng.normal(0, 1e-3, (4, n)) * np.where(rng.random((4, n)) < 0.5, 1.0, 1e4)
    resting = rng.random(n) < 0.2
    w_col = np.sort(rng.choice(cols, w)) if n else np.zeros(0, dtype=int)
    e = rng.integers(-1, n, len(w_col))
    e = e[np.lexsort((e, w_col))]
    f = np.maximum(e - rng.integers(0, 4, len(e)), 0)
    last_row = np.minimum(e + rng.integers(0, 4, len(e)), n - 1)
    new = rng.choice([-1, 1], len(e))
    lo, hi = np.searchsorted(w_col, cols, "left"), np.searchsorted(w_col, cols, "right")
    k = s if n else 0
    s_first, s_new, s_col = (
        rng.integers(0, max(n, 1), k),
        rng.choice([-1, 1], k),
        rng.choice(cols, k),
    )
    side = rng.choice([-1, 1], 4)
    out = rng.normal(0, 1, (4, n))
    args = (V, resting, cols, side, f, e, new, last_row, lo, hi, s_first, s_new, s_col, 5e-4, out)
    got = _settled(_play.motors_sides, args, "_motors_sides")[0]
    want = _settled(play.motors_sides, args, "_motors_sides")[0]
    assert got.dtype == want.dtype and np.array_equal(got, want)
    assert same_bits(got[1], out[1])


def test_compiled_motors_sides_refuses_arrays_of_the_wrong_shape() -> None:
    _play = compiled("_play")
    n = 6
    V, out, rest = np.zeros((3, n)), np.zeros((3, n)), np.zeros(n, bool)
    cols, side, e = np.array([0, 2]), np.ones(3, dtype=int), np.array([1, 3])
    lo, hi, none = np.array([0, 1]), np.array([1, 2]), np.zeros(0, dtype=int)
    rows = (e, e, e, e, lo, hi, none, none, none, 5e-4)
    _play.motors_sides(V, rest, cols, side, *rows, out.copy())  # the right shapes pass
    with pytest.raises(ValueError, match=r"out must be a writeable C-ordered float array"):
        _play.motors_sides(V, rest, cols, side, *rows, out.astype(int))
    with pytest.raises(ValueError, match=r"resting must have one value a point.* got 5"):
        _play.motors_sides(V, rest[:-1], cols, side, *rows, out.copy())
    with pytest.raises(ValueError, match=r"new must have one value a window, as e .* got 1"):
        _play.motors_sides(V, rest, cols, side, e, e, e[:1], *rows[3:], out.copy())
    with pytest.raises(ValueError, match=r"lo, hi must cut the windows \(0 to 2\), got 1, 3"):
        _play.motors_sides(V, rest, cols, side, *rows[:5], hi + 1, *rows[6:], out.copy())
    with pytest.raises(ValueError, match=r"s_col must have one value a standing crossing"):
        _play.motors_sides(V, rest, cols, side, *rows[:8], e, 5e-4, out.copy())


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


def test_signed_zeros_clamp_as_numpy_does() -> None:
    """Of −0.0 and 0.0, numpy's maximum and minimum give the second; the twin's
    clamps must too (a first-when-equal clamp gave the other zero)."""
    _play = compiled("_play")
    zeros = np.array([-0.0, 0.0])
    lo = np.tile(zeros, 8)
    hi = np.roll(lo, 1)
    for a, b in ((lo, hi), (hi, lo), (lo, lo), (-np.abs(lo), np.abs(hi))):
        assert same_bits(_play.clamp_scan(a, b), play.clamp_scan(a, b))


def _short(a: np.ndarray) -> np.ndarray:
    return a[:-1].copy()


def test_compiled_play_refuses_arrays_of_the_wrong_length() -> None:
    """The twins run without bounds checks: every public function that takes
    arrays of one length refuses others with a ValueError naming what it
    expected and what it got (before, a short array read past its end)."""
    _play = compiled("_play")
    t = axiscomp.MotorTable.from_comp(
        AxisComp(1, np.array([-50.0, 0.0, 50.0]), np.zeros(3), np.array([0.004, 0.002, 0.004]))
    ).flat
    n = 6
    p, side = np.linspace(-1.0, 1.0, n), np.ones(n)
    with pytest.raises(
        ValueError, match=r"side must have one value a position \(6 values\), got 5"
    ):
        _play.slope(t, p, _short(side))
    with pytest.raises(ValueError, match=r"side must have .* got 5"):
        _play.compensate_sided(t, p, _short(side))
    with pytest.raises(ValueError, match=r"hi must have .* got 5"):
        _play.clamp_scan(p, _short(p))
    sg = np.zeros(n, dtype=int)
    with pytest.raises(ValueError, match=r"P must have one value a row, as sg \(6 values\), got 5"):
        _play.creeps(sg, _short(p), 1, 0.0, 1e-3)
    e = np.array([2])
    with pytest.raises(ValueError, match=r"resting must have .* got 5"):
        _play.motor_sides(p, np.zeros(n - 1, bool), e, e, e, e, e[:0], e[:0], 1, 5e-4)
    with pytest.raises(ValueError, match=r"last_row must have .* \(1 values\), got 0"):
        _play.motor_sides(p, np.zeros(n, bool), e, e, e, e[:0], e[:0], e[:0], 1, 5e-4)
    with pytest.raises(ValueError, match=r"s_new must have .* got 0"):
        _play.motor_sides(p, np.zeros(n, bool), e, e, e, e, e, e[:0], 1, 5e-4)
    s_path = np.cumsum(np.full(n, 0.1))
    with pytest.raises(ValueError, match=r"way must have one value a crossing.* got 0"):
        _play.catch_up(np.ones(1), np.ones(0), e, e, s_path, 5e-5, 2.0)
    with pytest.raises(ValueError, match=r"speed must have one value a point.* got 5"):
        _play.catch_up(np.ones(1), np.ones(1), e, e, s_path, 5e-5, 2.0, (p, p, _short(p)))
    mo = _motion(np.random.default_rng(1), n)
    P, V = mo.P_ideal.copy(), mo.V_ideal.copy()
    for bad in mo._fields:
        short_mo = mo._replace(**{bad: _short(getattr(mo, bad))})
        with pytest.raises(ValueError, match=rf"{bad} must have one value a point"):
            _play.catch_up_commands(t, short_mo, np.ones(1), e, e + 1, P, V, 5e-5, 2.0)
        with pytest.raises(ValueError, match=rf"{bad} must have one value a point"):
            _play.settle_crossings(
                t, short_mo, (0.0, 0.0, 0.0), e, e - 1, np.zeros(1), P, V, True, 5e-5, 2.0
            )
    with pytest.raises(ValueError, match=r"V must have .* got 5"):
        _play.catch_up_commands(t, mo, np.ones(1), e, e + 1, P, _short(V), 5e-5, 2.0)
    with pytest.raises(ValueError, match=r"stop must have one value a crossing.* got 2"):
        _play.catch_up_commands(t, mo, np.ones(1), e, np.array([3, 4]), P, V, 5e-5, 2.0)
    with pytest.raises(ValueError, match=r"shortfall must have one value a crossing.* got 0"):
        _play.settle_crossings(t, mo, (0.0, 0.0, 0.0), e, e - 1, np.zeros(0), P, V, True, 5e-5, 2.0)
    with pytest.raises(ValueError, match=r"V must have one value a point, as P .* got 5"):
        _play.settle_crossings(
            t, mo, (0.0, 0.0, 0.0), e, e - 1, np.zeros(1), P, _short(V), True, 5e-5, 2.0
        )


def test_compiled_settle_motors_refuses_arrays_of_the_wrong_shape() -> None:
    """settle_motors runs on pointers into its rows: commands it cannot update in
    place, rows or columns of other lengths, a motor outside the rows are refused
    with a ValueError saying what was expected."""
    _play = compiled("_play")
    t = axiscomp.MotorTable.from_comp(
        AxisComp(1, np.array([-50.0, 0.0, 50.0]), np.zeros(3), np.array([0.004, 0.002, 0.004]))
    ).flat
    args = list(_settle_motors_case([t, t], 3, 12, True))

    def refused(i: int, value: Any, match: str) -> None:
        bad = copy.deepcopy(args)
        bad[i] = value
        with pytest.raises(ValueError, match=match):
            _play.settle_motors(*bad)

    P, ch, x = args[6], args[2], args[5]
    refused(6, np.asfortranarray(P), r"P must be a writeable C-ordered float array")
    refused(7, args[7].astype(np.float32), r"V must be a writeable C-ordered float array")
    refused(7, args[7][:, :-1].copy(), r"V must have one row a motor .* \(3, 12\), got \(3, 11\)")
    refused(2, ch._replace(side=ch.side[:2]), r"side must have one row a motor")
    refused(2, ch._replace(dt=ch.dt[:-1]), r"dt must have one value a point, as P \(12 values\)")
    refused(2, ch._replace(P_before=ch.P_before[:2]), r"P_before must have one value a motor")
    refused(1, np.array([0, 3]), r"cols must be rows of P \(0 to 2\), got 3")
    refused(0, (t,), r"tables must have one value a motor, as cols \(2 values\), got 1")
    refused(4, np.zeros(1), r"carried_off must have one value a motor")
    refused(5, x._replace(short=x.short[:-1]), r"short must have one value a crossing")
    # no crossing: the reference's e.max() has no answer, the twin says so
    mo = _motion(np.random.default_rng(1), 6)
    none = np.zeros(0, dtype=int)
    with pytest.raises(ValueError, match=r"e must have a crossing at least"):
        _play.settle_crossings(
            t, mo, (0.0, 0.0, 0.0), none, none, np.zeros(0), mo.P_ideal, mo.V_ideal, True, 5e-5, 2.0
        )


@settings(max_examples=150, deadline=None)
@given(tables(), tables(), st.integers(0, 2**32 - 1), st.integers(0, 80))
def test_generated_table_commands_are_bit_identical(
    t0: axiscomp.MotorTable, t2: axiscomp.MotorTable, seed: int, n: int
) -> None:
    """Motors 0 and 2 of three through their tables in one call (periodic terms or
    none, positions inside and outside the tables, at their breaks, both sides):
    the commands and their rates to the bit, the other motor's rows untouched."""
    _play = compiled("_play")
    rng = np.random.default_rng(seed)
    P_ideal = np.empty((3, n))
    for row, t in ((0, t0.flat), (1, t0.flat), (2, t2.flat)):
        P_ideal[row] = rng.uniform(t.breaks[0] - 5, t.breaks[-1] + 5, n)
        k = rng.random(n) < 0.1
        P_ideal[row, k] = rng.choice(t.breaks, int(k.sum()))
    V_ideal = rng.normal(0, 20, (3, n))
    side = rng.choice([-1.0, 1.0], (3, n))
    P, V = rng.normal(0, 1, (3, n)), rng.normal(0, 1, (3, n))
    args = ((t0.flat, t2.flat), np.array([0, 2]), P_ideal, V_ideal, side, P, V)
    got = _settled(_play.table_commands, args, "_table_commands")
    want = _settled(play.table_commands, args, "_table_commands")
    assert _same(got, want)
    assert same_bits(got[0][1], P[1]) and same_bits(got[1][1], V[1])
    # the rows are the per-motor kernels' (compensate_sided, then V over the slope)
    assert same_bits(got[0][2], _play.compensate_sided(t2.flat, P_ideal[2], side[2]))


def test_compiled_table_commands_refuses_arrays_of_the_wrong_shape() -> None:
    _play = compiled("_play")
    t = axiscomp.MotorTable.from_comp(
        AxisComp(1, np.array([-50.0, 0.0, 50.0]), np.zeros(3), np.array([0.004, 0.002, 0.004]))
    ).flat
    rows = np.zeros((3, 6))
    cols = np.array([0, 2])
    with pytest.raises(ValueError, match=r"P must be a writeable C-ordered float array"):
        _play.table_commands((t, t), cols, rows, rows, rows, rows.T.copy().T, rows.copy())
    with pytest.raises(ValueError, match=r"side must have one row a motor .* got \(3, 5\)"):
        _play.table_commands((t, t), cols, rows, rows, rows[:, :5], rows.copy(), rows.copy())
    with pytest.raises(ValueError, match=r"tables must have one value a motor, as cols"):
        _play.table_commands((t,), cols, rows, rows, rows, rows.copy(), rows.copy())
    with pytest.raises(ValueError, match=r"cols must be rows of P \(0 to 2\), got 5"):
        _play.table_commands((t, t), np.array([0, 5]), rows, rows, rows, rows.copy(), rows.copy())


def test_compiled_sides_refuse_points_outside_the_chunk() -> None:
    """A window or standing crossing at a point the chunk has not: the reference's
    indexing raises IndexError; the twin, which writes without bounds checks,
    must refuse it too (a ValueError) rather than write past its array."""
    _play = compiled("_play")
    n = 6
    V, rest = np.zeros(n), np.zeros(n, bool)
    f, e, new = np.array([0]), np.array([2]), np.array([1])
    none = np.zeros(0, dtype=int)
    cases = [
        (f, e, new, np.array([n + 40]), none, none),  # after its end: past the chunk
        (f, np.array([n]), new, np.array([n]), none, none),  # its end past the chunk
        (f, np.array([-n - 1]), new, np.array([0]), none, none),  # before it
        (f, e, new, np.array([3]), np.array([n + 1]), np.array([1])),  # standing
    ]
    for case in cases:
        with pytest.raises(IndexError):
            play.motor_sides(V, rest, *case, 1, 5e-4)
        with pytest.raises(ValueError, match=r"must be points of the chunk"):
            _play.motor_sides(V, rest, *case, 1, 5e-4)
        fv, ev, nv, lv, sf, sn = case
        out = np.zeros((2, n))
        args = (np.zeros((2, n)), rest, np.array([1]), np.ones(2, dtype=int), fv, ev, nv, lv)
        with pytest.raises(ValueError, match=r"must be points of the chunk"):
            _play.motors_sides(
                *args, np.array([0]), np.array([1]), sf, sn, np.ones(len(sf), int), 5e-4, out
            )
        assert not out.any()  # nothing written before refusing
