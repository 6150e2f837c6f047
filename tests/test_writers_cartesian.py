"""The Cartesian dialects' shared step (prsxy_post/writers/cartesian.py): the G93
feed words made for a whole chunk are the text Python's own formatting gives; the
written poses turn back into the motor commands through the controller's IK."""

from __future__ import annotations

import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import kinematics
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.kernel import fk
from prsxy_post.points import PointChunk
from prsxy_post.writers.cartesian import WrittenPoints, feed_words

from .conftest import ROOT

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


@pytest.mark.parametrize(
    ("prof", "moved"),
    [("profiles/prsxy-shop.toml", 0.0), ("tests/data/vectors/perturbed.toml", 1e-3)],
    ids=["prsxy-shop", "perturbed"],
)
def test_written_points_give_back_the_motor_commands(
    prof: str, moved: float, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The poses the writer is given (FK of the controller's geometry at the
    compensated motor commands, warm-started at the chain's pose) turn back into
    those commands through the controller's IK to 1e-9 mm, fifty times below the
    written decimals' rounding (5e-8 mm at 7 decimals): the compensation survives
    the controller's own kinematics. Every point of a five-axis sample program,
    with the shop profile and with a perturbed machine, whose geometry the
    controller's (the nominal design) misses."""
    seen: list[tuple[np.ndarray, np.ndarray, np.ndarray, kinematics.Geometry]] = []
    call = WrittenPoints.__call__

    def spy(self: WrittenPoints, chunk: PointChunk) -> np.ndarray:
        q = call(self, chunk)
        seen.append((q, chunk.P_cmd.copy(), chunk.q_target.copy(), self.cgeo))
        return q

    monkeypatch.setattr(WrittenPoints, "__call__", spy)
    out = tmp_path / "out.ngc"
    convert_file(
        ConvertJob(str(ROOT / "samples" / "five-axis.ngc"), str(ROOT / prof), "gcode", str(out))
    )
    assert sum(len(q) for q, *_ in seen) > 1000
    for q, P_cmd, _, cgeo in seen:
        P = kinematics.inverse(cgeo, q).P
        assert np.max(np.abs(P - P_cmd)) < 1e-9
    # with a geometry the nominal design misses, the FK is not its warm start: the
    # written poses are away from the chain's by the calibration in the commands
    if moved:
        assert max(np.max(np.abs(q - q_t)) for q, _, q_t, _ in seen) > moved


@pytest.fixture(scope="module")
def five_axis_points(tmp_path_factory: pytest.TempPathFactory) -> tuple[Any, PointChunk]:
    """The controller's geometry and every point the G-code writer is fed while
    the five-axis sample converts for the perturbed machine (whose geometry the
    controller's misses), joined into one run."""
    chunks: list[PointChunk] = []
    cgeo: list[kinematics.Geometry] = []
    call = WrittenPoints.__call__

    def spy(self: WrittenPoints, chunk: PointChunk) -> np.ndarray:
        chunks.append(chunk)
        cgeo.append(self.cgeo)
        return call(self, chunk)

    mp = pytest.MonkeyPatch()
    mp.setattr(WrittenPoints, "__call__", spy)
    out = tmp_path_factory.mktemp("cartesian") / "out.ngc"
    prof = str(ROOT / "tests" / "data" / "vectors" / "perturbed.toml")
    try:
        convert_file(ConvertJob(str(ROOT / "samples" / "five-axis.ngc"), prof, "gcode", str(out)))
    finally:
        mp.undo()
    return cgeo[0], PointChunk.concat(chunks)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.integers(1, 5000), min_size=1, max_size=8))
def test_written_points_do_not_depend_on_where_the_chunks_are_cut(
    five_axis_points: tuple[Any, PointChunk], cuts: list[int]
) -> None:
    """The anchored FK counts its anchors from the program's first point and
    carries an anchor's offset into the next chunk: the points fed in one run or
    cut anywhere give the same poses, to the bit. And they are the FK's solutions
    started from the chain's pose alone (``kinematics.forward``), within 1e-12 (mm,
    deg), rounding apart."""
    cgeo, pts = five_axis_points
    n = len(pts)
    whole = WrittenPoints(cgeo)(pts)
    edges = sorted({0, n, *(c % n for c in np.cumsum(cuts))})
    wp = WrittenPoints(cgeo)
    parts = [wp(pts.take(slice(a, b))) for a, b in itertools.pairwise(edges)]
    assert np.array_equal(np.concatenate(parts), whole)
    cold, ok = kinematics.forward(cgeo, pts.P_cmd, guess=kinematics.fk_start(cgeo, pts.q_target))
    assert ok.all() and np.max(np.abs(whole - cold)) < 1e-12


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1.0, 0.999, 1.001, 300.0]))
def test_an_offset_within_reach_leads_to_the_guess_alone_solution_and_none_beyond(
    five_axis_points: tuple[Any, PointChunk], seed: int, scale: float
) -> None:
    """Offsets carried into a chunk (random, up to ``ANCHOR_REACH`` times ``scale`` in
    each component, on the chunk's first points, before its first anchor) lose no
    point and lead Newton to the solution from the chain's pose alone, within 1e-12
    (mm, deg). Beyond the reach the offset is not handed on: a carry of 300 (mm,
    rad) handed on could lead Newton to another of the FK's solutions."""
    cgeo, pts = five_axis_points
    part = pts.take(slice(5, 200))
    guess = kinematics.fk_start(cgeo, part.q_target)
    reach = np.asarray(fk.ANCHOR_REACH)
    carry = scale * reach * np.random.default_rng(seed).choice([-1.0, 1.0], 6)
    every = kinematics.FK_ANCHOR_EVERY
    q, ok, _ = kinematics.forward_anchored(cgeo, part.P_cmd, guess, every, 5, carry)
    cold, cold_ok = kinematics.forward(cgeo, part.P_cmd, guess=guess)
    assert ok.all() and cold_ok.all()
    assert np.max(np.abs(q - cold)) < 1e-12
