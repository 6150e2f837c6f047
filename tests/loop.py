"""The calibration loop as a shop runs it, for the tests and the bench.

A machine with effects outside the contract is measured while the nominal
profile commands it (the contract's files, read back from their text); the
library calibrates from them; ``diagnose -o`` is run on the result with the
same data; every profile is judged by converting the sample programs, writing
the PMAC program, reading it back and executing it on the machine (play model,
servo, forward kinematics of the true geometry) at its points, each held against
the G-code path of its line.
"""

from __future__ import annotations

import numpy as np

from prsxy_post import (
    calibrate,
    chain,
    diagnose,
    effects,
    errormap,
    experiments,
    gcode,
    measure,
    program,
    simulate,
    writers,
)
from prsxy_post import profile as profile_mod

from .conftest import ROOT
from .test_tracking import path_distance, read_pmac

PROGRAMS = ("pocket.ngc", "five-axis.ngc")
PROV = writers.Provenance("x.ngc", "0" * 64, "p", "p.toml", "0" * 64, "")


def unmodelled_machine(nominal: profile_mod.Profile, seed: int) -> profile_mod.Profile:
    """Random errors in every contract term, real-axis tables with backlash, bowed
    guides and curved table axes (``simulate.random_machine``), and cyclic errors
    on two motors: what the contract's terms and tables alone cannot hold."""
    rng = np.random.default_rng(seed)
    base = simulate.random_machine(
        nominal, rng, axis_errors=True, effects=True, name=f"unmodelled {seed}"
    )
    motors = rng.choice([1, 2, 3, 5, 6], 2, replace=False)
    cyc = [
        effects.Change(
            f"cyclic[{m}]",
            float(rng.uniform(0.002, 0.004)),
            float(rng.choice([4.0, 5.0, 10.0, 16.0])),
            float(rng.uniform(-180, 180)),
        )
        for m in motors
    ]
    return simulate.plant(base, cyc, f"unmodelled {seed}")


def measurements(
    truth: profile_mod.Profile, commanded: profile_mod.Profile, seed: int
) -> tuple[list[measure.PoseData], list[measure.BallbarRun], list[measure.AxisData]]:
    rng = np.random.default_rng(seed)
    files = experiments.measurement_files(truth, commanded, rng, n_poses=400)
    data = [measure.read_measurement(text, name) for name, text in files.items()]
    return (
        [d for d in data if isinstance(d, measure.PoseData)],
        [d for d in data if isinstance(d, measure.BallbarRun)],
        [d for d in data if isinstance(d, measure.AxisData)],
    )


def calibrated(
    nominal: profile_mod.Profile,
    data: tuple[list, list, list],
    stages: tuple[str, ...] = calibrate.STAGES,
) -> profile_mod.Profile:
    poses, runs, axis = data
    cal = calibrate.calibrate(nominal, nominal, poses, runs, axis, stages=stages)
    return profile_mod.profile_from_dict(cal.doc, "calibrated")


def diagnosed(
    current: profile_mod.Profile, commanded: profile_mod.Profile, data: tuple[list, list, list]
) -> tuple[profile_mod.Profile, diagnose.Diagnosis]:
    d = diagnose.diagnose(current, diagnose.Data.build(commanded, *data))
    return profile_mod.profile_from_dict(d.updated, "diagnosed"), d


def trace_error(truth: profile_mod.Profile, prof: profile_mod.Profile, sample: str) -> float:
    """Largest distance [mm] of an executed point of the written PMAC program from
    the G-code path of its line (its block's line, arc or helix; a point of a line
    that does not move, from the point the chain meant there)."""
    text = (ROOT / "samples" / sample).read_text()
    cfg = program.interpreter_config(prof)
    motions = list(gcode.iter_motions(gcode.split_lines(text), cfg, sample))
    d = writers.dialect("pmac")
    settings = writers.settings_of(prof, "pmac")
    res = chain.run_chain(
        motions,
        prof,
        error_map=errormap.from_profile(prof),
        segment=d.segment,
        max_part_points=d.parts(settings),
    )
    w = d.make(prof, settings, PROV)
    parts: dict[int, list[str]] = {}
    for part, piece in [*w.begin(), *w.feed(res.points), *w.finish()]:
        parts.setdefault(part, []).append(piece)
    P, dt, lines = read_pmac("".join(parts[min(parts)]))
    pts = res.points
    rows = ~(pts.dwell & (pts.dt == 0))
    rows[0] = True
    assert len(P) == int(np.sum(rows))
    q = simulate.execute(truth, P, pts.tool_length[rows], t=np.cumsum(dt))
    by_line: dict[int, list[gcode.Motion]] = {}
    for m in motions:
        if m.kind in ("rapid", "feed", "arc") and (m.kind == "arc" or m.start != m.end):
            by_line.setdefault(m.line, []).append(m)
    dist = np.linalg.norm(q[:, :3] - pts.q[rows, :3], axis=1)
    for ln in np.unique(lines):
        sel = lines == ln
        if int(ln) in by_line:
            dist[sel] = np.min([path_distance(m, q[sel])[0] for m in by_line[int(ln)]], axis=0)
    return float(dist.max())
