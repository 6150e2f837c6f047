"""The library without the command line: what a shop's script does, in a fresh
interpreter that never imports click.

Two scripts: the README's "Python API" example, run as printed, and a shorter one
whose results are held against the command line's (golden files, check) and
against the machine a campaign was simulated on (calibrate, diagnose).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from .conftest import ROOT

GOLDEN = ROOT / "tests" / "golden"


def _python(code: str, cwd: Path) -> str:
    """Run code in a new interpreter (the package from this work tree) and return
    its standard output; the code must leave click unimported."""
    code += (
        "\nimport sys\nassert not [m for m in sys.modules if m.split('.')[0] == 'click'], 'click'\n"
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run(
        [sys.executable, "-c", code], cwd=cwd, env=env, capture_output=True, text=True
    )
    assert r.returncode == 0, r.stderr
    return r.stdout


def _workdir(tmp_path: Path) -> Path:
    for name in ("profiles", "samples"):
        (tmp_path / name).symlink_to(ROOT / name)
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    return tmp_path


def test_readme_example_runs_as_printed(tmp_path: Path) -> None:
    readme = (ROOT / "README.md").read_text()
    section = readme.split("## Python API", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S)
    assert code, "no python block in the README's Python API section"
    out = _python(code.group(1), _workdir(tmp_path))
    assert "converted ['pocket.pmc']" in out
    assert "far.ngc:1: motor 5 (X) commanded beyond its travel" in out
    assert (tmp_path / "pocket.pmc").read_text().startswith("; prsxy-post")
    cal = (tmp_path / "calibrated.toml").read_text()
    shop = (ROOT / "profiles" / "prsxy-shop.toml").read_text()
    assert re.findall(r"#.*", cal) == re.findall(r"#.*", shop)  # the shop's comments
    assert len(list(tmp_path.glob("*.comp"))) == 5  # a LinuxCNC file per motor


SCRIPT = textwrap.dedent(
    """
    import json
    import numpy as np
    from prsxy_post import calibrate, check, diagnose, experiments, measure, simulate
    from prsxy_post.convert import ConvertJob, convert_file
    from prsxy_post.files import load_profile
    from prsxy_post.profile import profile_from_dict

    out = {}
    # convert, as the golden file was made by the command
    convert_file(ConvertJob("samples/pocket.ngc", "profiles/prsxy-shop.toml", "pmac", "p.pmc",
                            options="--format pmac"))
    # check
    shop = load_profile("profiles/prsxy-shop.toml")
    rep = check.check_text("G21 G1 X310 F3000\\nG1 X0\\nM2\\n", shop)
    out["check"] = [(p.kind, p.line, p.value) for p in rep.problems]

    # a machine with errors, measured while commanded with the nominal profile
    nominal = load_profile("profiles/prsxy-nominal.toml")
    truth = simulate.random_machine(nominal, np.random.default_rng(3))
    files = experiments.measurement_files(truth, nominal, np.random.default_rng(4),
                                          radii=[50.0], tilts=[], planes=["XY"], n_poses=200,
                                          axis_runs=False)
    data = [measure.read_measurement(t, n) for n, t in sorted(files.items())]
    poses = [d for d in data if isinstance(d, measure.PoseData)]
    runs = [d for d in data if isinstance(d, measure.BallbarRun)]

    # calibrate: stage 2 from today's library functions
    theta, _, _, report = calibrate.stage_kinematics(nominal, nominal, [], poses, runs)
    cal = profile_from_dict(calibrate.apply_theta(nominal.raw, theta))
    out["rms"] = [report.rms_before["pose_tip"], report.rms_after["pose_tip"]]
    # where the truth machine puts the tool at fresh poses, commanded with each
    # profile (no noise): the forward simulation is the reference
    q = experiments.pose_grid(np.random.default_rng(5), 100, xy=100.0)
    for name, prof in (("nominal", nominal), ("calibrated", cal)):
        tip = simulate.measure_poses(truth, prof, q, np.random.default_rng(6), 0.0, 0.0)
        out[name] = float(np.max(np.linalg.norm(tip[:, :3] - q[:, :3], axis=1)))

    # diagnose: the nominal profile misses something; the calibrated one less
    d = diagnose.Data.build(nominal, poses, runs, [])
    before = diagnose.diagnose(nominal, d)
    after = diagnose.diagnose(cal, d)
    out["diagnose"] = [before.rms_before_um, after.rms_before_um, after.rms_after_um]
    print(json.dumps(out))
    """
)


@pytest.mark.slow
def test_convert_check_calibrate_diagnose_without_the_cli(tmp_path: Path) -> None:
    out = json.loads(_python(SCRIPT, _workdir(tmp_path)).splitlines()[-1])
    # convert gives the command's output byte for byte (same relative paths, so
    # the same header)
    assert (tmp_path / "p.pmc").read_text() == (GOLDEN / "pocket.prsxy-shop.pmac").read_text()
    # check: X310 is the worst point of line 1 and the first of line 2
    assert out["check"][0] == ["travel", 1, 310.0]
    assert [c[1] for c in out["check"]] == [1, 2]
    # calibrate brings the pose residual down to the 1 µm noise, and the truth
    # machine commanded with the calibrated profile puts the tool where it should
    before, after = out["rms"]
    assert before > 20e-3 and after < 2e-3
    assert out["nominal"] > 0.05 and out["calibrated"] < 0.005, out
    # diagnose sees the nominal model's gap and less of it in the calibrated one
    gap_nominal, gap_cal, _ = out["diagnose"]
    assert gap_cal < 0.2 * gap_nominal
