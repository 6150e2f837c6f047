"""Real-axis tables: the contract's play model and compensation."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import axiscomp as AC
from prsxy_post import profile as profile_mod
from prsxy_post import simulate

from .conftest import VECTORS, read_vector_csv


@pytest.fixture(scope="module")
def table5(perturbed: profile_mod.Profile) -> AC.MotorTable:
    return AC.tables_by_motor(perturbed.axis_comp)[5]


def test_play_model_matches_contract_vector(table5: AC.MotorTable) -> None:
    d = read_vector_csv(VECTORS / "play-motor5.csv")
    # the contract's 1e-6 mm (tests/data/vectors/README.md), not numpy's default rtol
    # on top of it (5e-6 mm at 43 mm)
    np.testing.assert_allclose(
        AC.play_model(table5, d["commanded"]), d["actual"], rtol=0, atol=1e-6
    )


def test_compensation_matches_contract_vector(table5: AC.MotorTable) -> None:
    d = read_vector_csv(VECTORS / "compensate-motor5.csv")
    cmd = AC.compensate(table5, d["wanted"])
    np.testing.assert_allclose(cmd, d["command"], rtol=0, atol=1e-6)
    np.testing.assert_allclose(AC.play_model(table5, cmd), d["wanted"], rtol=0, atol=1e-12)


def _play_loop(t: AC.MotorTable, p: np.ndarray) -> np.ndarray:
    """The contract's recursion, literally."""
    y = [float(t.lo(p[:1])[0])]
    for pk in p[1:]:
        y.append(min(max(y[-1], float(t.lo(np.array([pk]))[0])), float(t.hi(np.array([pk]))[0])))
    return np.array(y)


@settings(max_examples=100, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(2, 300))
def test_scan_equals_recursion_and_compensation_inverts_it(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    comp = simulate.random_axis_table(5, rng, backlash=0.01)
    t = AC.MotorTable.from_comp(
        profile_mod.AxisComp(5, *(np.array(comp[k]) for k in ("positions", "forward", "reverse")))
    )
    # a motion with reversals, stops and excursions beyond the table
    wanted = np.cumsum(rng.normal(0, 20, n) * (rng.random(n) > 0.2))
    y = AC.play_model(t, wanted)
    np.testing.assert_allclose(y, _play_loop(t, wanted), atol=1e-12)
    cmd = AC.compensate(t, wanted)
    np.testing.assert_allclose(AC.play_model(t, cmd), wanted, atol=1e-9)
    # chunked with state = one shot, bit for bit
    cut = int(rng.integers(1, n))
    s1, s2 = AC.PlayState(), AC.PlayState()
    cmd2 = np.concatenate([AC.compensate(t, wanted[:cut], s1), AC.compensate(t, wanted[cut:], s1)])
    assert np.array_equal(cmd, cmd2)
    y2 = np.concatenate([AC.play_model(t, cmd[:cut], s2), AC.play_model(t, cmd[cut:], s2)])
    assert np.array_equal(AC.play_model(t, cmd), y2)


def test_reversal_jumps_across_the_play(table5: AC.MotorTable) -> None:
    wanted = np.array([0.0, 1.0, 2.0, 1.0, 0.0])
    cmd = AC.compensate(table5, wanted)
    # going down after going up: the command jumps by the play at the reversal
    play = float(table5.hi(np.array([2.0]))[0] - table5.lo(np.array([2.0]))[0])
    assert play > 0.005
    assert table5.lo(cmd[2:3])[0] == pytest.approx(2.0, abs=1e-12)
    assert table5.hi(cmd[3:4])[0] == pytest.approx(1.0, abs=1e-12)
    assert cmd[2] - cmd[3] > 1.0 + 0.9 * play


def test_small_wobble_moves_result_no_more_than_wobble(table5: AC.MotorTable) -> None:
    p = 10.0 + np.array([0, 1e-4, -1e-4, 1e-4, 0])
    y = AC.play_model(table5, p)
    assert np.ptp(y) <= 2e-4 + 1e-12


def test_standing_target_keeps_command(table5: AC.MotorTable) -> None:
    cmd = AC.compensate(table5, np.array([0.0, 5.0, 5.0, 5.0, 4.0]))
    assert cmd[2] == cmd[1] == cmd[3]
