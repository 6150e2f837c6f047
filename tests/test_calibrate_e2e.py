"""Issue "measured machine": the whole loop on seeded machines, judged by execution.

A machine with random errors in every contract term, real-axis errors with
backlash and effects outside the profile's terms (bowed guides, curved table axes)
is measured (0.5 µm ballbar, 1 µm poses, 0.3 µm laser) while commanded with the
nominal profile; the three calibration stages build a profile from the files; the
sample programs converted with it are executed by the machine (play model, forward
kinematics) and compared with the programmed path. Not the calibration's own
residual: the forward simulation.
"""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import calibrate, chain, errormap, experiments, gcode, measure, simulate
from prsxy_post import profile as profile_mod

from .conftest import ROOT


def _calibrate(
    nominal: profile_mod.Profile, truth: profile_mod.Profile, seed: int
) -> profile_mod.Profile:
    rng = np.random.default_rng(seed)
    files = experiments.measurement_files(truth, nominal, rng, n_poses=400)
    data = [measure.read_measurement(text, name) for name, text in files.items()]
    poses = [d for d in data if isinstance(d, measure.PoseData)]
    runs = [d for d in data if isinstance(d, measure.BallbarRun)]
    axis = [d for d in data if isinstance(d, measure.AxisData)]
    tables, _ = calibrate.stage_tables(nominal, axis)
    theta, _, obs, _ = calibrate.stage_kinematics(nominal, nominal, tables, poses, runs)
    doc = calibrate.apply_theta(nominal.raw, theta)
    doc["axis_comp"] = [
        {
            "motor": t.motor,
            "positions": t.positions.tolist(),
            "forward": t.forward.tolist(),
            "reverse": t.reverse.tolist(),
        }
        for t in tables
    ]
    cal = profile_mod.profile_from_dict(doc)
    emap, _ = calibrate.stage_error_map(cal, theta, obs, rng, {})
    doc["error_map"] = emap.to_dict()
    return profile_mod.profile_from_dict(doc)


def _trace_error(truth: profile_mod.Profile, prof: profile_mod.Profile, program: str) -> float:
    text = (ROOT / "samples" / program).read_text()
    ms = gcode.interpret(text, chain.interpreter_config(prof))
    res = chain.run_chain(ms, prof, error_map=errormap.from_profile(prof))
    pts = res.points
    qa = simulate.execute(truth, pts.P_cmd, pts.tool_length, t=pts.t)
    return float(np.linalg.norm(qa[:, :3] - pts.q[:, :3], axis=1).max())


@pytest.mark.slow
@pytest.mark.parametrize("seed", [7, 8, 9])
def test_calibrated_profile_traces_within_2_5_um(nominal: profile_mod.Profile, seed: int) -> None:
    truth = simulate.random_machine(
        nominal, np.random.default_rng(seed), axis_errors=True, effects=True, name=f"seeded {seed}"
    )
    cal = _calibrate(nominal, truth, seed)
    for program in ("pocket.ngc", "five-axis.ngc"):
        before = _trace_error(truth, nominal, program)
        after = _trace_error(truth, cal, program)
        assert before > 0.1, f"{program}: nominal off by {before * 1000:.1f} µm only"
        assert after < 2.5e-3, f"{program}: {after * 1000:.3f} µm after calibration"
