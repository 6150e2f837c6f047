"""Machines with realistic real-axis tables, and the motions that test a controller table.

A controller table is right when a motor commanded to p ends at p from either
side. The truth of where the part ends is the contract's play model
(:func:`prsxy_post.axiscomp.play_model`) of the profile's own tables, applied to
the motor positions the controller produces from the table it loaded.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from prsxy_post import axiscomp, simulate
from prsxy_post import profile as profile_mod
from prsxy_post.profile import MOTORS

from .conftest import ROOT

#: how far before the target the final approach starts [mm]
APPROACH_MM = 5.0
#: servo samples per move
SAMPLES = 40


def machine(seed: int, *, varying_backlash: bool = False) -> profile_mod.Profile:
    """The nominal design with random tables with backlash on every motor
    (:func:`prsxy_post.simulate.random_axis_table`). ``varying_backlash``: the
    backlash also changes along the travel (by up to ±40 %), as a worn screw's does."""
    base = profile_mod.loads((ROOT / "profiles" / "prsxy-nominal.toml").read_text(), "nominal")
    rng = np.random.default_rng(seed)
    doc = dict(base.raw)
    tables = [simulate.random_axis_table(m, rng) for m in MOTORS]
    if varying_backlash:
        for t in tables:
            pos = np.array(t["positions"])
            fwd, rev = np.array(t["forward"]), np.array(t["reverse"])
            b = rev - fwd
            k = rng.uniform(0.5, 2.0)
            rev = fwd + b * (1 + 0.4 * np.sin(k * np.pi * (pos - pos[0]) / np.ptp(pos)))
            t["reverse"] = rev.tolist()
    doc["axis_comp"] = tables
    return profile_mod.profile_from_dict(doc, f"random machine {seed}")


def targets(mc: profile_mod.MotorConfig, rng: np.random.Generator, n: int = 120) -> np.ndarray:
    """Targets over the travel, with motor zero and points just around it."""
    lo, hi = mc.min + APPROACH_MM + 1, mc.max - APPROACH_MM - 1
    special = np.array([0.0, 1e-3, -1e-3, 0.37, -0.37, lo, hi])
    return np.concatenate([special, rng.uniform(lo, hi, n)])


def approach(p: float, side: int) -> np.ndarray:
    """Commanded (desired) positions at the servo samples of a motion that ends at
    rest at ``p`` approached from below (``side`` = +1) or above (−1) [mm].

    It comes from the other side first, so the last reversal is part of the motion.
    """
    u = (1 - np.cos(np.pi * np.linspace(0, 1, SAMPLES))) / 2
    a, b = p + side * 2 * APPROACH_MM, p - side * APPROACH_MM
    first = a + (b - a) * u
    second = b + (p - b) * u
    return np.concatenate([first, second[1:], np.full(5, p)])


def residuals(
    prof: profile_mod.Profile,
    motor: int,
    commanded_to_motor: Callable[[np.ndarray], np.ndarray],
    pts: np.ndarray,
) -> np.ndarray:
    """Where the part ends minus the target, for each target from below and above [mm].

    ``commanded_to_motor`` maps the desired positions of one motion (servo samples)
    to the motor positions the controller commands (contract coordinates, mm).
    Returns (len(pts), 2): column 0 from below, column 1 from above.
    """
    truth = axiscomp.tables_by_motor(prof.axis_comp)[motor]
    out = np.empty((len(pts), 2))
    for i, p in enumerate(pts):
        for j, side in enumerate((1, -1)):
            q = commanded_to_motor(approach(float(p), side))
            out[i, j] = axiscomp.play_model(truth, q)[-1] - p
    return out
