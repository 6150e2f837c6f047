"""Synthetic measurement campaigns for tests (no G-code needed): parametric circles
sampled every 10 ms, random poses, laser runs, all measured on a truth machine."""

from __future__ import annotations

import numpy as np

from prsxy_post import kinematics, simulate
from prsxy_post.measure import AxisData, BallbarRun, PoseData
from prsxy_post.profile import MOTORS, Profile


def circle(
    radius: float, tilt: float, sign: int, feed: float = 1000.0
) -> tuple[np.ndarray, np.ndarray]:
    """A full circle about the origin at constant feed, tool tilted outward by ``tilt``."""
    period = 2 * np.pi * radius / (feed / 60.0)
    t = np.arange(0.0, period + 1e-9, 0.01)
    th = sign * 2 * np.pi * t / period
    ax = np.stack(
        [
            np.sin(np.radians(tilt)) * np.cos(th),
            np.sin(np.radians(tilt)) * np.sin(th),
            np.full_like(th, np.cos(np.radians(tilt))),
        ],
        -1,
    )
    a, b = kinematics.angles_from_axis(ax)
    q = np.column_stack([radius * np.cos(th), radius * np.sin(th), np.zeros_like(th), a, b])
    return q, t


def random_poses(rng: np.random.Generator, n: int) -> np.ndarray:
    return np.column_stack(
        [rng.uniform(-150, 150, (n, 2)), rng.uniform(-60, 40, n), rng.uniform(-25, 25, (n, 2))]
    )


def campaign(
    truth: Profile,
    commanded: Profile,
    rng: np.random.Generator,
    *,
    n_poses: int = 200,
    radii: tuple[float, ...] = (50.0, 100.0),
    tilts: tuple[float, ...] = (0.0, 5.0, 15.0),
    axis: bool = False,
    bb_noise: float = 0.5,
    pose_noise: float = 1.0,
) -> tuple[list[PoseData], list[BallbarRun], list[AxisData]]:
    """Poses, ballbar runs and (optionally) laser runs, as the files would read
    (``rows``: the line of each row in a file with one header line)."""
    poses = []
    if n_poses:
        q = random_poses(rng, n_poses)
        m = simulate.measure_poses(truth, commanded, q, rng, pose_noise)
        poses.append(PoseData("poses.csv", q, m[:, :3], m[:, 3:], _rows(len(q))))
    runs = []
    for r in radii:
        for tilt in tilts:
            if tilt and r != max(radii):
                continue
            for sign in (1, -1):
                q, t = circle(r, tilt, sign)
                dev = simulate.measure_ballbar(
                    truth, commanded, q, t, np.zeros(3), r, rng, bb_noise
                )
                name = f"r{r:g} tilt{tilt:g} {'ccw' if sign > 0 else 'cw'}"
                runs.append(
                    BallbarRun(
                        source=name + ".csv",
                        name=name,
                        pivot=np.zeros(3),
                        length=r,
                        t=t,
                        commanded=q,
                        dev_um=dev,
                        rows=_rows(len(t)),
                    )
                )
    laser = []
    if axis:
        rows = np.vstack(
            [simulate.measure_axis(truth, m, np.linspace(-200, 200, 21), 5, rng) for m in MOTORS]
        )
        laser.append(
            AxisData(
                source="axis.csv",
                motor=rows[:, 0].astype(int),
                target=rows[:, 1],
                measured=rows[:, 2],
                direction=rows[:, 3].astype(int),
                run=rows[:, 4].astype(int),
                rows=_rows(len(rows)),
            )
        )
    return poses, runs, laser


def _rows(n: int) -> np.ndarray:
    return np.arange(2, n + 2)
