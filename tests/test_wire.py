"""What crosses between a conversion's processes (prsxy_post.wire): every column
packed and unpacked to the same bits, dtype and shape; a planned chunk's pieces as
the chain reads them, the same bits for every field it reads; and the chain's
points from chunks that crossed the same as from chunks made in its own process,
on a machine with play (the chain reads the plans) and on one without."""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import chain, errormap, simulate, wire, writers
from prsxy_post import profile as profile_mod
from prsxy_post.convert import ConvertJob, _planned_here
from prsxy_post.files import load_profile
from prsxy_post.interpolate import Blocks, TimeLaw
from prsxy_post.points import PointChunk

ROOT = Path(__file__).resolve().parent.parent


def same_bits(a: Any, b: Any) -> bool:
    """Both None, or arrays of one dtype and shape with the same bytes (object
    arrays: the same elements)."""
    if a is None or b is None:
        return a is None and b is None
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype == object:
        return bool(a.tolist() == b.tolist())
    return np.ascontiguousarray(a).tobytes() == np.ascontiguousarray(b).tobytes()


def _crossed(x: Any) -> Any:
    """``x`` through a pickle, as the pipe carries it (protocol 5)."""
    return pickle.loads(pickle.dumps(x, protocol=5))


columns = st.one_of(
    hnp.arrays(
        st.sampled_from([np.float64, np.int64, np.int32, np.int8, np.bool_]),
        st.tuples(st.integers(0, 40)) | st.tuples(st.integers(0, 40), st.integers(1, 5)),
        elements=None,
    ),
    # mostly zero (the sparse form), with −0.0, NaN and the odd large value
    st.lists(st.sampled_from([0.0, 0.0, 0.0, 0.0, -0.0, np.nan, 1.5, -(2.0**60)]), max_size=60).map(
        lambda v: np.array(v, dtype=np.float64)
    ),
    st.lists(st.sampled_from([0, 0, 0, 1, -3, 2**40]), max_size=60).map(
        lambda v: np.array(v, dtype=np.int64)
    ),
)


@settings(max_examples=300, deadline=None)
@given(columns)
def test_a_column_crosses_with_the_same_bits_dtype_and_shape(a: np.ndarray) -> None:
    assert same_bits(wire.unpacked(_crossed(wire.packed(a))), a)


@settings(max_examples=100, deadline=None)
@given(st.lists(st.sampled_from([None, None, None, ("M", 3.0), (("S", 1.0),)]), max_size=40))
def test_an_object_column_crosses_as_its_rows_not_none(values: list[Any]) -> None:
    a = np.empty(len(values), dtype=object)
    a[:] = values
    sent = wire.packed(a)
    assert isinstance(sent, wire.Sparse) and len(sent.at) == sum(v is not None for v in values)
    assert same_bits(wire.unpacked(_crossed(sent)), a)


def test_a_mostly_zero_column_crosses_as_its_rows_not_zero() -> None:
    center = np.zeros((1000, 3))
    center[[5, 700]] = [1.0, -0.0, 2.0], [0.0, 0.0, -0.0]  # −0.0 is not zero here
    sent = wire.packed(center)
    assert isinstance(sent, wire.Sparse) and sent.at.tolist() == [5, 700]
    assert same_bits(wire.unpacked(_crossed(sent)), center)
    busy = np.arange(1000.0)
    assert wire.packed(busy) is busy  # most rows set: as it is


def test_the_machine_functions_arrive_where_none_is_read_only() -> None:
    """A chunk without machine functions gets a column of None that cannot be
    written to (shared between chunks: a write would raise, not spread)."""
    fn = wire.unpacked(_crossed(wire.packed(np.empty(7, dtype=object))))
    assert fn.tolist() == [None] * 7 and not fn.flags.writeable


def _machine_with_play(path: Path) -> str:
    """A profile with real-axis tables with play on its motors, servo lag, an error
    map and two tools: the chain reads the pieces' plans (reversals) and poses."""
    nominal = profile_mod.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text())
    rng = np.random.default_rng(7)
    truth = simulate.random_machine(nominal, rng, axis_errors=True, effects=True, name="play")
    q = rng.uniform([-150, -150, -60, -25, -25], [150, 150, 40, 25, 25], (200, 5))
    emap = errormap.fit(q, 1e-3 * np.sin(q / 50.0), rng=rng, degrees=(2,), lambdas=[1e-4])
    tools = [{"number": 1, "length": 35.0, "diameter": 6.0}]
    path.write_text(profile_mod.dumps(dict(truth.raw, error_map=emap.to_dict(), tools=tools)))
    return str(path)


def _program(path: Path) -> str:
    """Over two pieces of blocks: lines and arcs that turn back (the motors
    reverse), machine functions, dwells and a tool length offset."""
    body = ["G21 G90 G17 G1 F1500", "S12000 M3"]
    for i in range(1, 4700):
        x, y = (i % 40) * 0.25, (i % 9) * 0.5
        if i % 37 == 0:
            body.append(f"G2 X{x:.2f} Y{y:.1f} R10")
        else:
            body.append(f"G1 X{x:.2f} Y{y:.1f} Z{-0.1 * (i % 3):.1f} A{(i % 7) * 0.5:.1f}")
        if i % 900 == 0:
            body += ["G4 P0.2", "M8", "M9"]
        if i == 2000:
            body.append("G43 H1")
    path.write_text("\n".join([*body, "M5", "M2"]) + "\n")
    return str(path)


def _readies(program: str, prof: str, fmt: str) -> tuple[list[chain.Ready], Any]:
    job = ConvertJob(program, prof, fmt, "-", chunk=700)
    made: list[Any] = []
    counts = {"lines": 0.0, "motions": 0.0, "parse": 0.0}
    readies = list(_planned_here(job, load_profile(prof), counts, None, made.append))
    return readies, made[0]


@pytest.fixture(scope="module")
def with_play(tmp_path_factory: pytest.TempPathFactory) -> tuple[str, str]:
    d = tmp_path_factory.mktemp("wire")
    return _program(d / "job.ngc"), _machine_with_play(d / "play.toml")


def test_a_planned_chunk_crosses_as_the_chain_reads_it(with_play: tuple[str, str]) -> None:
    """Every piece's points (every field), poses solved and the blocks' and time
    law's fields the chain reads arrive with the same bits; the others None."""
    readies, planning = _readies(*with_play, "pmac")
    assert planning.plan_read
    pieces = 0
    for ready in readies:
        back = wire.unpack_ready(_crossed(wire.pack_ready(ready, planning.plan_read)))
        assert (back.final, back.start_line, back.problems) == (
            ready.final,
            ready.start_line,
            ready.problems,
        )
        for (plan, s, solved), (plan2, s2, solved2) in zip(
            ready.earlier + ready.pieces, back.earlier + back.pieces, strict=True
        ):
            pieces += 1
            for f in s.FIELDS:
                assert same_bits(getattr(s2, f), getattr(s, f)), f
            for f in Blocks.FIELDS:
                read = f in (*chain.BLOCKS_READ, "line", "tool_length")
                want = getattr(plan.blocks, f) if read else None
                assert same_bits(getattr(plan2.blocks, f), want), f
            for f in TimeLaw._fields:
                want = getattr(plan.law, f) if f in chain.LAW_READ else None
                assert same_bits(getattr(plan2.law, f), want), f
            assert same_bits(plan2.next_dq_in, plan.next_dq_in)
            assert solved is not None and solved2 is not None
            for f in ("q_target", "P", "V"):
                assert same_bits(getattr(solved2, f), getattr(solved, f)), f
    assert pieces >= 2


def _points(readies: list[chain.Ready], prof: str, fmt: str, crossing: bool) -> PointChunk:
    """The chain's points from ``readies`` (through :mod:`.wire` with
    ``crossing``), made as :func:`convert.convert_file` makes them."""
    profile = load_profile(prof)
    dialect = writers.dialect(fmt)
    settings_ = writers.settings_of(profile, fmt)
    pipe = chain.Pipeline(
        profile,
        chain.Stages(),
        errormap.from_profile(profile),
        segment=dialect.segment,
        max_part_points=dialect.parts(settings_),
        written=dialect.written(settings_),
    )
    out = []
    plan_read = bool(pipe.play_cols)
    for ready in readies:
        if crossing:
            ready = wire.unpack_ready(_crossed(wire.pack_ready(ready, plan_read)))
        out += pipe.feed_ready(ready)
    return PointChunk.concat(out)


@pytest.mark.parametrize("fmt", ["pmac", "gcode"])
@pytest.mark.parametrize("play", [True, False])
def test_the_chains_points_are_the_same_from_chunks_that_crossed(
    with_play: tuple[str, str], fmt: str, play: bool
) -> None:
    """Every field of every point, bit for bit: the chain read nothing that did not
    cross (an unread field arrives None and would fail it)."""
    program, prof = with_play
    if not play:
        prof = str(ROOT / "profiles" / "prsxy-shop.toml")
    readies, planning = _readies(program, prof, fmt)
    assert planning.plan_read == play
    here = _points(readies, prof, fmt, crossing=False)
    crossed = _points(readies, prof, fmt, crossing=True)
    assert len(here) > 9000
    for f in PointChunk.FIELDS:
        assert same_bits(getattr(crossed, f), getattr(here, f)), f


@pytest.mark.parametrize("fmt", ["pmac", "gcode"])
def test_a_writer_is_sent_its_fields_with_the_same_bits(
    with_play: tuple[str, str], fmt: str
) -> None:
    """The fields a writer reads (machine functions among them) arrive with the
    same bits; the others None."""
    from prsxy_post.writers.linuxcnc import GcodeWriter
    from prsxy_post.writers.pmac import PmacWriter

    reads = PmacWriter.reads if fmt == "pmac" else GcodeWriter.reads
    readies, _ = _readies(*with_play, fmt)
    points = _points(readies, with_play[1], fmt, crossing=False)
    back = wire.unpack_points(_crossed(wire.pack_points(points, reads)))
    assert any(f is not None for f in points.fn)
    for f in PointChunk.FIELDS:
        assert same_bits(getattr(back, f), getattr(points, f) if f in reads else None), f
