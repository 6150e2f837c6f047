"""Measurement campaigns on a simulated machine: ballbar runs, pose grids, laser runs.

Each run is a real program: the ballbar circles are G-code (``simulate.ballbar_gcode``)
interpreted, interpolated and commanded by the same chain ``convert`` uses, every
stage of the commanding profile on (``simulate.program_commands``), and executed by
the truth machine. The results are the
contract's measurement files, ready for ``calibrate``, ``diagnose`` and ``ballbar``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from . import gcode, measure, program, simulate
from .profile import MOTORS, Profile


def ballbar_run(
    truth: Profile,
    commanded: Profile,
    rng: np.random.Generator,
    *,
    radius: float,
    plane: str = "XY",
    ccw: bool = True,
    tilt: float = 0.0,
    feed: float = 1000.0,
    pivot: Sequence[float] = (0.0, 0.0, 0.0),
    noise_um: float = 0.5,
    name: str | None = None,
) -> measure.BallbarRun:
    """One ballbar run: the circle program, commanded, executed and read by the ballbar."""
    text = simulate.ballbar_gcode(
        radius, plane=plane, ccw=ccw, tilt_deg=tilt, feed=feed, pivot=(pivot[0], pivot[1], pivot[2])
    )
    motions = gcode.interpret(text, program.interpreter_config(commanded), "<ballbar>")
    first_cut = next(i for i, m in enumerate(motions) if m.kind not in ("rapid", "function"))
    circle = [m for m in motions[first_cut:] if m.kind != "function"]
    start = np.array(circle[0].start, dtype=float)
    # commanded as convert commands it: every stage of the commanding profile on
    res = simulate.program_commands(commanded, circle, start=start.tolist())
    q = res.points.q
    t = res.points.t
    piv = np.asarray(pivot, dtype=float)
    dev = simulate.ballbar_reading(truth, res.points.P_cmd, t, piv, radius, rng, noise_um)
    direction = "ccw" if ccw else "cw"
    label = name or (
        f"{plane.lower()} r{radius:g} {direction}"
        if not tilt
        else f"cone {tilt:g} r{radius:g} {direction}"
    )
    return measure.BallbarRun(
        source=f"{label}.csv",
        name=label,
        pivot=piv,
        length=float(radius),
        t=t,
        commanded=q,
        dev_um=dev,
        rows=np.arange(len(t)) + 1,
        meta={},
    )


def pose_grid(
    rng: np.random.Generator,
    n: int,
    *,
    xy: float = 150.0,
    z: tuple[float, float] = (-60.0, 40.0),
    tilt: float = 25.0,
) -> np.ndarray:
    """n poses spread over the workspace (Latin-hypercube-like stratified draws)."""
    cols = []
    for lo, hi in ((-xy, xy), (-xy, xy), z, (-tilt, tilt), (-tilt, tilt)):
        u = (rng.permutation(n) + rng.random(n)) / n
        cols.append(lo + (hi - lo) * u)
    return np.column_stack(cols)


def measurement_files(
    truth: Profile,
    commanded: Profile,
    rng: np.random.Generator,
    *,
    radii: Sequence[float] = (50.0, 100.0),
    tilts: Sequence[float] = (5, 15),
    planes: Sequence[str] = ("XY", "XZ", "YZ"),
    n_poses: int = 300,
    feed: float = 1000.0,
    noise_um: float = 0.5,
    pose_noise_um: float = 1.0,
    laser_noise_um: float = 0.3,
    axis_runs: bool = True,
    commanded_with: measure.CommandedWith | None = None,
) -> dict[str, str]:
    """Every file of a measurement campaign, as {file name: text}.

    ``commanded_with``: the fingerprint of the commanding profile's file, written
    into every file as ``# commanded_with:`` (measure's module docstring).
    """
    files: dict[str, str] = {}
    runs: list[measure.BallbarRun] = []
    for r in radii:
        for ccw in (True, False):
            if "XY" in planes:
                runs.append(
                    ballbar_run(
                        truth, commanded, rng, radius=r, ccw=ccw, feed=feed, noise_um=noise_um
                    )
                )
            for t in tilts:
                runs.append(
                    ballbar_run(
                        truth,
                        commanded,
                        rng,
                        radius=r,
                        ccw=ccw,
                        tilt=t,
                        feed=feed,
                        noise_um=noise_um,
                    )
                )
    for plane in planes:
        if plane == "XY":
            continue
        r = min(radii)
        for ccw in (True, False):
            runs.append(
                ballbar_run(
                    truth,
                    commanded,
                    rng,
                    radius=r,
                    plane=plane,
                    ccw=ccw,
                    feed=feed,
                    noise_um=noise_um,
                )
            )
    for run in runs:
        name = "ballbar-" + run.name.replace(" ", "-") + ".csv"
        files[name] = measure.format_ballbar(replace(run, commanded_with=commanded_with))
    if n_poses:
        q = pose_grid(rng, n_poses)
        meas = simulate.measure_poses(truth, commanded, q, rng, pose_noise_um)
        files["poses.csv"] = measure.format_poses(
            measure.PoseData(
                source="poses.csv",
                commanded=q,
                tip=meas[:, :3],
                axis=meas[:, 3:],
                rows=np.arange(n_poses) + 1,
                meta={},
                commanded_with=commanded_with,
            )
        )
    if axis_runs:
        rows = []
        for m in MOTORS:
            mc = truth.motor(m)
            lo, hi = max(mc.min, -200.0), min(mc.max, 200.0)
            targets = np.round(np.linspace(lo, hi, 21), 4)
            rows.append(simulate.measure_axis(truth, m, targets, 5, rng, laser_noise_um))
        a = np.vstack(rows)
        files["axis.csv"] = measure.format_axis(
            measure.AxisData(
                source="axis.csv",
                motor=a[:, 0].astype(int),
                target=a[:, 1],
                measured=a[:, 2],
                direction=a[:, 3].astype(int),
                run=a[:, 4].astype(int),
                rows=np.arange(len(a)) + 1,
                meta={},
                commanded_with=commanded_with,
            )
        )
    return files
