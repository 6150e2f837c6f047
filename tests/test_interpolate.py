"""Coarse interpolation: exact path, speed ≤ F, acceleration limited, phases as
points, corners within the tolerance, stream = one shot."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import chain, gcode, interpolate, program
from prsxy_post import profile as profile_mod
from prsxy_post.interpolate.geometry import CORNER_SHARE
from prsxy_post.kernel.timelaw import row_norm

from .conftest import ROOT

LIM = interpolate.PlanLimits(rapid_mm_min=6000.0, accel_mm_s2=1000.0, period_s=0.01)


def _plan(text: str, lim: interpolate.PlanLimits = LIM):
    ms = gcode.interpret(text)
    b = interpolate.blocks_from_motions(ms, lim)
    plan = interpolate.Planner(lim).push(b, final=True)
    assert plan is not None
    return plan.blocks, plan.law, interpolate.sample(plan, lim)


def test_block_ends_are_points_and_steps_are_at_most_the_period() -> None:
    b, law, s = _plan("G21 G1 X10 F600\nG1 Y5\nG2 X20 Y5 I5 J0\nG4 P0.05\nG0 X0 Y0\nM2\n")
    ends = s.q[s.block_end]
    np.testing.assert_allclose(ends, b.end, atol=1e-12)
    assert s.dt[~s.dwell].max() <= LIM.period_s + 1e-12
    np.testing.assert_allclose(np.bincount(s.block, weights=s.dt), law.duration)


def test_a_dwell_is_one_point_held_for_its_time() -> None:
    _, _, s = _plan("G21 G1 X10 F600\nG4 P2.5\nG1 X20\nM2\n")
    held = s.dwell & (s.dt > 0)
    assert held.sum() == 1 and s.dt[held][0] == 2.5


def test_phases_of_constant_acceleration_are_points() -> None:
    """Between two points the acceleration of the plan is constant: a point at every
    phase boundary, and no phase shorter than a quarter period unless it is the
    whole block."""
    b, law, s = _plan("G21 G1 X30 F1200\nG1 X30.5 Y0.2\nG1 X60 Y0\nG3 X60 Y10 R5\nM2\n")
    for k in range(len(b)):
        bounds = np.cumsum([law.t1[k], law.t2[k], law.t3[k]])
        taus = s.tau[s.block == k]
        for t_b, t_ph in zip(bounds, (law.t1[k], law.t2[k], law.t3[k]), strict=True):
            if t_ph > 0:
                assert np.min(np.abs(taus - t_b)) < 1e-12
        phases = np.array([law.t1[k], law.t2[k], law.t3[k]])
        present = phases[phases > 0]
        assert np.all(present >= LIM.min_phase_s - 1e-12) or len(present) == 1


def test_speed_never_exceeds_feed_and_acceleration_holds() -> None:
    b, law, s = _plan("G21 G1 X30 F1200\nG1 X30.5 Y0.2\nG1 X60 Y0\nG3 X60 Y10 R5\nM2\n")
    assert s.speed.max() <= 1200 / 60 + 1e-9
    assert np.all(law.a1 <= b.accel + 1e-9) and np.all(law.a3 <= b.accel + 1e-9)
    assert np.all(law.t1 >= 0) and np.all(law.t3 >= 0)


def test_corner_speed_keeps_the_cubic_within_the_tolerance() -> None:
    """A 1° bend of a polyline is taken at speed: the written mean velocity leaves
    each cubic by (4/27) · period · v |Δt| / 2 at most (lookahead's docstring)."""
    turn = np.radians(1.0)
    text = f"G21 G1 X20 F3000\nG1 X{20 + 20 * np.cos(turn):.6f} Y{20 * np.sin(turn):.6f}\nM2\n"
    b, law, _ = _plan(text)
    v = law.v1[0]
    d = np.linalg.norm(b.dq_in[1, :3] - b.dq_out[0, :3])
    assert v > 0
    assert (4 / 27) * LIM.period_s * v * d / 2 <= CORNER_SHARE * LIM.tolerance_mm * (1 + 1e-9)


def test_a_sharp_corner_is_a_stop() -> None:
    _, law, _ = _plan("G21 G1 X20 F3000\nG1 Y20\nG1 X0 Y0\nM2\n")
    assert law.v1[0] == 0 and law.v1[1] == 0


def test_helix_is_exactly_on_its_helix() -> None:
    _, _, s = _plan("G21 G0 X5 Y0 Z0\nG3 X5 Y0 I-5 J0 Z-3 P2 F600\nM2\n")
    arc = s.block == 1
    r = np.hypot(s.q[arc, 0], s.q[arc, 1])
    np.testing.assert_allclose(r, 5.0, atol=1e-12)
    th = np.unwrap(np.arctan2(s.q[arc, 1], s.q[arc, 0]))
    np.testing.assert_allclose(s.q[arc, 2], -3.0 * th / (4 * np.pi), atol=1e-9)


def test_velocity_is_the_tangent_times_the_speed() -> None:
    _, _, s = _plan("G21 G0 X5 Y0 Z0\nG3 X5 Y0 I-5 J0 F600\nM2\n")
    inside = (s.block == 1) & ~s.block_end
    # on a circle about the origin the velocity is perpendicular to the radius
    radial = np.einsum("ij,ij->i", s.q[inside, :2], s.qdot[inside, :2])
    np.testing.assert_allclose(radial, 0.0, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(s.qdot[inside, :3], axis=1), s.speed[inside])


@pytest.mark.parametrize("chunk", [1, 2, 5, 17])
def test_planner_streams_like_one_shot(chunk: int) -> None:
    prof = profile_mod.loads((ROOT / "profiles" / "prsxy-shop.toml").read_text(), "shop")
    ms = gcode.interpret(
        (ROOT / "samples" / "pocket.ngc").read_text(), program.interpreter_config(prof)
    )
    one = chain.run_chain(ms, prof).points
    streamed = chain.run_chain(ms, prof, chunk=chunk).points
    assert np.array_equal(one.q, streamed.q)
    assert np.array_equal(one.dt, streamed.dt)
    assert np.array_equal(one.P_cmd, streamed.P_cmd)
    assert np.array_equal(one.V_cmd, streamed.V_cmd)


def _junction_speeds(text: str, prof: profile_mod.Profile, segment: str) -> dict[int, float]:
    """Planned speed at the end of each moving line's block, through the chain's
    planning (which tells the look-ahead the motors' directions)."""
    planning = chain.Planning(prof, segment=segment)
    motions = list(
        gcode.iter_motions(gcode.split_lines(text), program.interpreter_config(prof), "x")
    )
    planned = planning.plan(chain.prepare(motions, prof, planning.limits), final=True)
    assert planned.plan is not None
    b, law = planned.plan.blocks, planned.plan.law
    return {int(ln): float(v) for ln, v, st in zip(b.line, law.v1, b.stops, strict=True) if not st}


def test_a_head_motor_reversing_at_a_junction_is_a_stop() -> None:
    """Line 3 tilts B, line 4 plunges: head motor V moves up along line 3 and down
    along line 4, and the path bends by 14° in XZ, a corner the tolerance lets
    through at F60. With play in V (a random machine with backlash), a PVT program
    and a corrected G-code stop there so that V crosses its play at rest (taken at
    speed, V's part stood through its crossing while the other motors moved on:
    1.07 x F60 in LinuxCNC's straight line, test_controller_truth's found
    programs); a machine without play takes the corner at speed. Where the head
    sets off from standing as the path goes straight on, a descent (every head
    motor the way it last moved, down from the start) is no stop, but a tilt is:
    one of its motors sets off up against its last way, and its crossing would
    take the place of the head's blend (Blocks.cross_in; 4.6 % over F60 found at
    F300). A tilt after a descent of 1e-3 mm per mm (the head's motors creep down,
    under REVERSAL_SLOPE, and V goes up on) is a stop. A table motor reversing at a
    slight XY corner is no stop, unless the head sets off there, or the table
    cancels the head's motion along its axis."""
    from .test_tracking import truth_machine

    reverses = (
        "G21 G90 G17 G94 G40 G49 G54 G80\nG0 X-20 Y-20 Z0 A0 B0\n"
        "G1 X-15 Y-20 B0.5 F60\nG1 X-14 Y-20 Z-0.25 F60\nM2\n"
    )
    sets_off = (
        "G21 G90 G17 G94 G40 G49 G54 G80\nG0 X-20 Y-20 Z0 A0 B0\n"
        "G1 X-19 Y-20 F60\nG1 X-16 Y-20 {} F60\nM2\n"
    )
    creeps = (
        "G21 G90 G17 G94 G40 G49 G54 G80\nG0 X-20 Y-20 Z0 A0 B0\n"
        "G1 X-16 Y-20 Z-0.0039 F60\nG1 X-11 Y-20 B0.5 F60\nM2\n"
    )
    play = truth_machine("random", 12)
    assert _junction_speeds(creeps, play, "cubic")[3] == 0.0
    assert _junction_speeds(reverses, play, "cubic")[3] == 0.0
    assert _junction_speeds(reverses, play, "chord")[3] == 0.0
    assert _junction_speeds(reverses, truth_machine("random", 12, play=False), "cubic")[3] > 0.9
    assert _junction_speeds(sets_off.format("Z-0.05"), play, "cubic")[3] > 0.9
    assert _junction_speeds(sets_off.format("A0.25"), play, "cubic")[3] == 0.0
    assert (
        _junction_speeds(
            sets_off.format("A0.25"), truth_machine("random", 12, play=False), "cubic"
        )[3]
        > 0.9
    )
    table = "G21 G90 G17 G94 G40 G49 G54 G80\nG0 X-20 Y-20 Z0 A0 B0\nG1 X-19 Y-20.1 F60\n"
    assert _junction_speeds(table + "G1 X-18 Y-20 F60\nM2\n", play, "cubic")[3] > 0.5
    assert _junction_speeds(table + "G1 X-18 Y-20 B0.25 F60\nM2\n", play, "cubic")[3] == 0.0
    # A tilts on through a slight XY corner where table motor Y reverses, cancelling
    # the tilt's motion of the tip along y: its part standing through its crossing
    # would let the tilt reach the tip (lookahead.TABLE_STAND_SHARE); without the
    # tilt the same corner is taken at speed
    corner = (
        "G21 G90 G17 G94 G40 G49 G54 G80\nG0 X-16.0933 Y-19.2578 Z0 A0 B0\n"
        "G1 X-12.2176 Y-18.2682 A{} F60\nG1 X-8.7073 Y-16.3505 A{} F60\nM2\n"
    )
    assert _junction_speeds(corner.format(0.5, 1.0), play, "cubic")[3] == 0.0
    assert _junction_speeds(corner.format(0.5, 1.0), play, "chord")[3] == 0.0
    assert _junction_speeds(corner.format(0, 0), play, "cubic")[3] > 0.5


def test_a_short_block_between_two_stops_rises_and_falls() -> None:
    """A block that starts and ends at rest, so short that its peak's cruise comes
    out a rounding short of min_phase (0.1224 mm at 399 mm/s², vmax 6.65 mm/s: a
    tilt between two junctions where a head motor reverses, bench.py's 2 M-line
    program), was made one phase from v0 to v1, both zero: it took forever. It rises
    and falls within the block and the acceleration limit."""
    from prsxy_post.interpolate.timelaw import distance, time_law

    b = interpolate.blocks_from_motions(gcode.interpret("G21 G1 X1 F2000\nM2\n"), LIM)
    b = b.take(np.flatnonzero(~b.stops))
    b.length[:], b.vmax[:], b.accel[:] = 0.1224000000000025, 6.654608352581903, 399.2765011549142
    law = time_law(b, np.zeros(1), 0.0, LIM.min_phase_s)
    assert np.isfinite(law.duration[0]) and law.vp[0] > 0
    assert law.a1[0] <= b.accel[0] * (1 + 1e-12) and law.a3[0] <= b.accel[0] * (1 + 1e-12)
    end = distance(law, np.zeros(1, dtype=int), law.duration)
    assert end[0] == pytest.approx(b.length[0], rel=1e-12)


@pytest.mark.parametrize("segment", ["cubic", "chord"])
def test_segment_limit_bounds_curves_and_leaves_lines_free(segment: str) -> None:
    """The longest step at speed 1 on a curve of radius r: the cubic's error
    (h v)⁴ / (384 r³) or the chord's (h v)² / (8 r) at CURVE_SHARE of the
    tolerance, the cubic's also its speed error; none on lines (r = inf, NaN).
    Computed over the curves alone, each to the bit of the formula over every
    block."""
    from prsxy_post.interpolate import geometry as g

    rng = np.random.default_rng(5)
    r = np.concatenate([rng.uniform(0, 500, 500), np.full(300, np.inf), [0.0, np.nan, 1e300]])
    rng.shuffle(r)
    b = g.Blocks(**{f: np.zeros(len(r)) for f in g.Blocks.FIELDS})
    b.curv_r = r
    lim = g.PlanLimits(segment=segment)
    tol = g.CURVE_SHARE * lim.tolerance_mm
    with np.errstate(invalid="ignore", over="ignore"):
        if segment == "chord":
            hv = np.sqrt(8.0 * r * tol)
        else:
            speed = r * (125.0 * g.SPEED_SHARE) ** (1 / 3)
            hv = np.minimum((384.0 * tol * r**3) ** 0.25, speed)
    want = np.where(np.isfinite(hv), hv, np.inf)
    got = g.segment_limit(b, lim)
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
    assert np.all(np.isinf(got[~np.isfinite(r)]))
    one = np.flatnonzero(np.isfinite(r) & (r > 1))[0]
    if segment == "chord":  # the chord's sagitta at the step is the share of tol
        assert np.isclose(got[one] ** 2 / (8 * r[one]), tol, rtol=1e-12)


@settings(max_examples=100, deadline=None)
@given(
    hnp.arrays(
        np.float64,
        st.tuples(st.integers(0, 300), st.integers(1, 5)),
        elements=st.floats(-1e150, 1e150) | st.sampled_from([0.0, -0.0, 1e-160]),
    )
)
def test_row_norm_is_numpys_norm_of_each_row_to_the_bit(x: np.ndarray) -> None:
    """The kernel's row_norm (the look-ahead's junctions and bends) sums the
    squares in column order, as numpy's norm(axis=1) does (the junctions' turns
    must keep their bits)."""
    assert row_norm(x).tobytes() == np.linalg.norm(x, axis=1).tobytes()
