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


def test_a_written_program_compensates_with_the_contracts_map_formula(tmp_path) -> None:
    """The contract's compensation is Q' = Q − e(Q) (docs/machine-model.md, the
    paper's Eq. 6), one evaluation of the map at the programmed pose. Read back the
    PMAC program ``convert`` writes for straight moves in G61 (no corner leaves its
    line) on the nominal machine with a steep map (54 µm): each point's written
    motors, through the forward kinematics (Newton on the contract's constraints),
    give Q'; undoing the contract's formula (Q = Q' + e(Q), solved to the bit by
    fixed-point steps) must land on the programmed line. A second fixed-point step
    of the map (Q' = Q − e(Q')) would move these points off it by tens of nm."""
    from prsxy_post import errormap
    from prsxy_post import profile as profile_mod
    from prsxy_post.convert import ConvertJob, convert_file

    from .conftest import ROOT
    from .test_tracking import read_pmac

    rng = np.random.default_rng(3)
    lo, hi = np.array([-150, -150, -60, -25, -25.0]), np.array([150, 150, 40, 25, 25.0])
    q_fit = rng.uniform(lo, hi, (300, 5))
    emap = errormap.fit(q_fit, 50e-3 * np.sin(q_fit / 50.0), rng=rng, degrees=(3,), lambdas=[1e-4])
    nominal = (ROOT / "profiles" / "prsxy-nominal.toml").read_text()
    doc = dict(profile_mod.loads(nominal, "nominal").raw, error_map=emap.to_dict())
    prof_path = tmp_path / "mapped.toml"
    prof_path.write_text(profile_mod.dumps(doc))
    ends = [
        (-40.0, -30.0, -10.0, 0.0, 0.0),
        (60.0, 20.0, -25.0, 12.0, -8.0),
        (10.0, 70.0, 0.0, -5.0, 15.0),
    ]
    words = "X{:g} Y{:g} Z{:g} A{:g} B{:g}"
    lines = ["G21 G90 G17 G94 G61", "G0 " + words.format(*ends[0])]
    lines += ["G1 " + words.format(*e) + " F1500" for e in ends[1:]]
    src = tmp_path / "lines.ngc"
    src.write_text("\n".join([*lines, "M2", ""]))
    out = tmp_path / "lines.pmc"
    convert_file(ConvertJob(str(src), str(prof_path), "pmac", str(out), parallel=False))
    P, _, line = read_pmac(out.read_text())

    prof = profile_mod.loads(prof_path.read_text(), str(prof_path))
    q_cmd, ok = kinematics.forward(chain.ik_geometry(prof, chain.Stages()), P, 0.0)
    assert ok.all()
    q = q_cmd.copy()
    for _ in range(30):  # Q = Q' + e(Q): contracts by |∂e/∂Q| ≈ 1e-3 a step
        q = q_cmd + emap(q)
    assert np.abs(q - emap(q) - q_cmd).max() < 1e-12

    e = np.array(ends)
    for k in (1, 2):  # the points of the G1 to ends[k], from ends[k - 1]
        at = line == k + 2
        assert at.sum() > 20
        d = (e[k] - e[k - 1]) / np.linalg.norm(e[k] - e[k - 1])
        rel = q[at] - e[k - 1]
        off = rel - np.outer(rel @ d, d)
        # written to 7 decimals: 0.05 nm a motor, well under a nanometre at the tip
        assert np.abs(off).max() < 1e-6, np.abs(off).max()
    # the test tells the formulas apart: the fixed point's second step moves them
    step = chain.correct_virtual(q, emap, 2) - chain.correct_virtual(q, emap, 1)
    assert np.abs(step).max() > 2e-5
