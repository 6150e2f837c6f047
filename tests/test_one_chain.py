"""One compensation chain: the simulator commands a program as ``convert`` writes it.

The simulated measurement runs (``experiments.ballbar_run``) and a program the
simulator commands (``simulate.program_commands``) must give the truth machine the
motor positions the written Turbo PMAC program gives the controller, read back
from the file ``convert`` wrote: the same virtual-axis map, IK, real-axis tables
with the crossings of their play, and one servo lead (``chain.servo_lead``). The
map in that file is the contract's, Q' = Q − e(Q), judged on the G-code's lines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from prsxy_post import calibrate, chain, errormap, experiments, gcode, kinematics, program, simulate
from prsxy_post import profile as profile_mod
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.diagnose.model import Data

from .conftest import ROOT
from .test_tracking import read_pmac

#: motor positions are written with 7 decimals ([output.pmac] decimals' default):
#: a written number is within half its last digit of the chain's, and a little
#: more for the float printing of an exact half
WRITTEN_MM = 0.5e-7 * (1 + 1e-6)


def _commanding(path: Path, play: bool) -> Path:
    """A calibrated profile with every stage that shapes a command: contract errors,
    real-axis tables (with backlash on every motor when ``play``, else one curve for
    both directions), bowed guides, servo lag on every motor and an error map."""
    nominal = profile_mod.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    rng = np.random.default_rng(11)
    machine = simulate.random_machine(nominal, rng, axis_errors=True, effects=True, name="all")
    q = np.column_stack(
        [
            rng.uniform(-150, 150, (200, 2)),
            rng.uniform(-60, 40, 200),
            rng.uniform(-25, 25, (200, 2)),
        ]
    )
    err = rng.normal(0, 1e-3, q.shape) + 1e-3 * np.sin(q / 50.0)
    emap = errormap.fit(q, err, rng=rng, degrees=(2,), lambdas=[1e-4])
    effects = dict(machine.raw.get("effects", {}), servo_lag_ms=[0.4, 0.1, 0.3, 0.8, 0.5])
    tables = machine.raw["axis_comp"]
    if not play:
        tables = [dict(t, reverse=t["forward"]) for t in tables]
    doc = dict(machine.raw, effects=effects, error_map=emap.to_dict(), axis_comp=tables)
    path.write_text(profile_mod.dumps(doc))
    return path


@pytest.fixture(scope="module", params=[True, False], ids=["play", "no-play"])
def commanding(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _commanding(tmp_path_factory.mktemp("one-chain") / "commanding.toml", request.param)


def _written(
    tmp: Path, text: str, profile_path: Path, start: tuple[float, ...] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor positions (N, 5), segment times [s] and source lines of every point of
    the PMAC program ``convert`` writes (:func:`read_pmac`)."""
    src = tmp / "program.ngc"
    src.write_text(text)
    out = tmp / "program.pmc"
    convert_file(
        ConvertJob(
            program=str(src),
            profile_path=str(profile_path),
            fmt="pmac",
            output=str(out),
            parallel=False,
            start=start,
        )
    )
    return read_pmac(out.read_text())


def _rows(dwell: np.ndarray, dt: np.ndarray) -> np.ndarray:
    """The chain's points that are written as a point: all but the machine functions
    (a point at rest taking no time); the first is the RAPID start."""
    rows = ~(dwell & (dt == 0))
    rows[0] = True
    return rows


@pytest.mark.parametrize("sample", ["five-axis.ngc", "pocket.ngc"])
def test_simulate_commands_a_program_as_convert_writes_it(
    tmp_path: Path, commanding: Path, sample: str
) -> None:
    text = (ROOT / "samples" / sample).read_text()
    prof = profile_mod.loads(commanding.read_text(), str(commanding))
    motions = gcode.interpret(text, program.interpreter_config(prof), sample)
    pts = simulate.program_commands(prof, motions).points
    P_sim = pts.P_cmd[_rows(pts.dwell, pts.dt)]
    P_file = _written(tmp_path, text, commanding)[0]
    assert P_file.shape == P_sim.shape
    assert np.max(np.abs(P_file - P_sim)) <= WRITTEN_MM
    # the stages acted: the commands are not the plain IK of the poses
    assert np.max(np.abs(pts.P_cmd - pts.P_ideal)) > 1e-3


CIRCLES = pytest.mark.parametrize(
    "circle",
    [
        {"radius": 50.0},
        {"radius": 20.0, "tilt": 5.0, "ccw": False},
        {"radius": 50.0, "plane": "XZ", "ccw": False},
    ],
    ids=["xy", "cone", "xz"],
)


def _commanded_run(
    prof: profile_mod.Profile, circle: dict, monkeypatch: pytest.MonkeyPatch
) -> tuple[experiments.measure.BallbarRun, np.ndarray]:
    """A simulated ballbar run and the commands the truth machine was given for it
    (seen where the simulator executes them)."""
    given: list[np.ndarray] = []
    execute = simulate.execute

    def spy(truth: profile_mod.Profile, P_cmd: np.ndarray, *args, **kwargs) -> np.ndarray:
        given.append(P_cmd.copy())
        return execute(truth, P_cmd, *args, **kwargs)

    monkeypatch.setattr(simulate, "execute", spy)
    truth = simulate.random_machine(prof, np.random.default_rng(5), axis_errors=True)
    run = experiments.ballbar_run(truth, prof, np.random.default_rng(0), **circle)
    monkeypatch.undo()
    assert len(given) == 1 and len(given[0]) == len(run.t)
    return run, given[0]


@CIRCLES
def test_a_simulated_ballbar_run_is_commanded_as_convert_writes_its_circle(
    tmp_path: Path, commanding: Path, circle: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The commands the truth machine is given in a simulated ballbar run (seen where
    the simulator executes them) are the written program's of the same circle,
    converted from where the run starts (the circle's start, reached by its G0)."""
    prof = profile_mod.loads(commanding.read_text(), str(commanding))
    _, given = _commanded_run(prof, circle, monkeypatch)
    text = simulate.ballbar_gcode(
        circle["radius"],
        plane=circle.get("plane", "XY"),
        ccw=circle.get("ccw", True),
        tilt_deg=circle.get("tilt", 0.0),
    )
    motions = gcode.interpret(text, program.interpreter_config(prof), "circle")
    start = next(m for m in motions if m.kind not in ("rapid", "function")).start
    P_file = _written(tmp_path, text, commanding, tuple(start))[0]
    assert P_file.shape == given.shape
    assert np.max(np.abs(P_file - given)) <= WRITTEN_MM


@CIRCLES
def test_calibrate_and_diagnose_model_a_run_commanded_as_the_simulator_commanded_it(
    commanding: Path, circle: dict, monkeypatch: pytest.MonkeyPatch
) -> None:
    """``calibrate`` and ``diagnose`` have a run's recorded poses and times, not its
    program: the commands they model from them (``simulate.motion_commands``: the
    chain's map, IK, tables on the chain's sides and its servo lead) are the ones
    the simulator gave, within 1.5 µm at a run's first and last steps (where the
    planned velocity turns inside a step) and, with play, a few points of the
    windows in which the chain crosses it (backlash 2 to 7 µm); 99 % of the points
    within 0.5 µm, 90 % within 0.05 nm (the lead of the chain's velocities: a lead
    by central differences of the compensated positions, the simulator's before,
    is 0.13 nm off at 90 % of the xy circle's points)."""
    prof = profile_mod.loads(commanding.read_text(), str(commanding))
    run, given = _commanded_run(prof, circle, monkeypatch)
    modelled = Data.build(prof, [], [run], []).P_run[0]
    off = np.max(np.abs(modelled - given), axis=1)
    play = any(np.any(np.asarray(c.forward) != np.asarray(c.reverse)) for c in prof.axis_comp)
    assert np.percentile(off, 99) < 0.5e-3
    assert np.percentile(off, 90) < 5e-8
    assert np.sum(off > 1e-4) <= (0.015 * len(off) if play else 4)
    assert np.max(off) < (8e-3 if play else 1.5e-3)
    # calibrate's play model of the same commands (every sample kept)
    obs = calibrate.observations(prof, prof.axis_comp, [], [run], ballbar_points=len(run.t))
    reached = calibrate.reached_motors(prof.axis_comp, given, None)
    assert np.percentile(np.max(np.abs(obs.P_bb - reached), axis=1), 99) < 0.5e-3


def test_a_written_program_compensates_with_the_contracts_map_formula(tmp_path: Path) -> None:
    """The contract's compensation is Q' = Q − e(Q) (docs/machine-model.md, the
    paper's Eq. 6), one evaluation of the map at the programmed pose. Read back the
    PMAC program ``convert`` writes for straight moves in G61 (no corner leaves its
    line) on the nominal machine with a steep map (54 µm): each point's written
    motors, through the forward kinematics (Newton on the contract's constraints),
    give Q'; undoing the contract's formula (Q = Q' + e(Q), solved to the bit by
    fixed-point steps) must land on the programmed line. A second fixed-point step
    of the map (Q' = Q − e(Q')) would move these points off it by tens of nm."""
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
    P, _, line = _written(tmp_path, "\n".join([*lines, "M2", ""]), prof_path)

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
