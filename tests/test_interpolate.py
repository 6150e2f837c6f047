"""Coarse interpolation: exact path, speed ≤ F, acceleration limited, stream = one shot."""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import chain, gcode, interpolate
from prsxy_post import profile as profile_mod

from .conftest import ROOT

LIM = interpolate.Limits(rapid_mm_min=6000.0, accel_mm_s2=1000.0, period_s=0.01)


def _plan(text: str) -> tuple[interpolate.Blocks, interpolate.TimeLaw, interpolate.Samples]:
    ms = gcode.interpret(text)
    b = interpolate.blocks_from_motions(ms, LIM)
    vj = interpolate.junction_limits(b, LIM.period_s)
    v = interpolate.forward_pass(b, interpolate.backward_pass(b, vj))
    law = interpolate.time_law(b, v)
    return b, law, interpolate.sample(b, law, LIM.period_s)


def test_block_ends_are_points_and_steps_are_at_most_the_period() -> None:
    b, law, s = _plan("G21 G1 X10 F600\nG1 Y5\nG2 X20 Y5 I5 J0\nG4 P0.05\nG0 X0 Y0\nM2\n")
    ends = s.q[np.nonzero(np.diff(np.append(s.block, -1)))[0]]
    np.testing.assert_allclose(ends, b.end, atol=1e-12)
    assert s.dt.max() <= LIM.period_s + 1e-12
    np.testing.assert_allclose(np.bincount(s.block, weights=s.dt), law.duration)


def test_speed_never_exceeds_feed_and_acceleration_holds() -> None:
    _, law, s = _plan("G21 G1 X30 F1200\nG1 X30.5 Y0.2\nG1 X60 Y0\nG3 X60 Y10 R5\nM2\n")
    v = s.speed
    assert v.max() <= 1200 / 60 + 1e-9
    # between points of one block the speed changes by at most a·dt
    same = s.block[1:] == s.block[:-1]
    dv = np.abs(np.diff(v))[same]
    assert np.all(dv <= LIM.accel_mm_s2 * s.dt[1:][same] + 1e-9)
    # trapezoids: entry and exit speeds reachable within each block
    assert np.all(law.t1 >= -1e-12) and np.all(law.t3 >= -1e-12)


def test_corner_speed_is_what_one_cycle_can_turn() -> None:
    _, law, _ = _plan("G21 G1 X20 F3000\nG1 Y20\nM2\n")
    # 90° corner: the velocity jump 2 v sin 45° is at most a · period
    assert law.v1[0] * 2 * np.sin(np.pi / 4) <= LIM.accel_mm_s2 * LIM.period_s + 1e-9
    assert law.v1[0] > 0


def test_helix_is_exactly_on_its_helix() -> None:
    _, _, s = _plan("G21 G0 X5 Y0 Z0\nG3 X5 Y0 I-5 J0 Z-3 P2 F600\nM2\n")
    arc = s.block == 1
    r = np.hypot(s.q[arc, 0], s.q[arc, 1])
    np.testing.assert_allclose(r, 5.0, atol=1e-12)
    th = np.unwrap(np.arctan2(s.q[arc, 1], s.q[arc, 0]))
    np.testing.assert_allclose(s.q[arc, 2], -3.0 * th / (4 * np.pi), atol=1e-9)


@pytest.mark.parametrize("chunk", [1, 2, 5, 17])
def test_planner_streams_like_one_shot(chunk: int) -> None:
    prof = profile_mod.loads((ROOT / "profiles" / "prsxy-shop.toml").read_text(), "shop")
    ms = gcode.interpret(
        (ROOT / "samples" / "pocket.ngc").read_text(), chain.interpreter_config(prof)
    )
    one = chain.run_chain(ms, prof)
    streamed = chain.run_chain(ms, prof, chunk=chunk)
    assert np.array_equal(one.samples.q, streamed.samples.q)
    assert np.array_equal(one.samples.dt, streamed.samples.dt)
    assert np.array_equal(one.P_cmd, streamed.P_cmd)
