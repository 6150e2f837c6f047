"""What a machine does with motor commands: the forward simulation.

The machine is described by a "truth" profile (its real geometry, table and
real-axis errors). Executing a motion means: each motor's driven part follows
the play model of its real-axis table, then the forward kinematics of the true
geometry gives the tool pose (contract: "Forward kinematics", "Real-axis error").

This module is the reference the tests hold converted programs against, and the
core of the ``simulate`` command.
"""

from __future__ import annotations

import numpy as np

from . import axiscomp, kinematics
from .profile import MOTORS as MOTOR_ORDER
from .profile import Profile


def truth_geometry(truth: Profile) -> kinematics.Geometry:
    return kinematics.Geometry.from_params(truth.kinematics, truth.origin, truth.table,
                                              truth.effects)


def actual_motors(truth: Profile, P_cmd: np.ndarray, *, approach: int | None = None
                  ) -> np.ndarray:
    """Where the driven parts end for commands ``P_cmd`` (N, 5) in time order.

    approach : None for a continuous motion (play model); +1 or −1 for points
        each approached on its own from that side (poses, laser runs).
    """
    tables = axiscomp.tables_by_motor(truth.axis_comp)
    out = np.array(P_cmd, dtype=float, copy=True)
    for col, m in enumerate(MOTOR_ORDER):
        t = tables.get(m)
        if t is None:
            continue
        if approach is None:
            out[:, col] = axiscomp.play_model(t, P_cmd[:, col])
        else:
            out[:, col] = axiscomp.approach(t, P_cmd[:, col], approach)
    return out


def execute(truth: Profile, P_cmd: np.ndarray, tool_length: np.ndarray | float | None = None,
            *, approach: int | None = None, guess: np.ndarray | None = None) -> np.ndarray:
    """Tool poses q (N, 5) [mm, deg] the truth machine reaches for motor commands.

    Raises
    ------
    RuntimeError
        If the forward kinematics does not converge (the commands are not a pose
        of this machine); callers pass commands from a converted program.
    """
    geo = truth_geometry(truth)
    P = actual_motors(truth, P_cmd, approach=approach)
    q, ok = kinematics.forward(geo, P, tool_length, guess=guess)
    if not np.all(ok):
        raise RuntimeError(f"forward kinematics did not converge at {np.sum(~ok)} points")
    return q


#: Typical manufacturing errors (1 σ) of each contract term, for random machines.
ERROR_SIGMA = {
    "guide_radius": 0.05, "guide_angle": 0.02, "guide_height": 0.05, "strut_length": 0.05,
    "platform_radius": 0.05, "platform_angle": 0.02, "guide_tilt_x": 0.01,
    "guide_tilt_y": 0.01, "hinge_twist": 0.03, "platform_z": 0.04,
    "tool_length": 0.04, "tool_offset_x": 0.02, "tool_offset_y": 0.02,
    "scale_x": 4e-5, "scale_y": 4e-5, "squareness": 1e-4,
}


def random_axis_table(motor: int, rng: np.random.Generator, *, lo: float = -250.0,
                      hi: float = 250.0, step: float = 10.0, backlash: float = 0.004,
                      amplitude: float = 0.004) -> dict:
    """A smooth positioning error with backlash, as a contract [[axis_comp]] entry."""
    pos = np.arange(lo, hi + step / 2, step)
    x = (pos - lo) / (hi - lo)
    k = np.arange(1, 4)
    a = rng.normal(0, amplitude / 2, 3)
    ph = rng.uniform(0, 2 * np.pi, 3)
    smooth = (a[None, :] * np.sin(np.pi * k[None, :] * x[:, None] + ph[None, :])).sum(axis=1)
    smooth += rng.normal(0, amplitude / 4) * x
    bl = abs(rng.normal(backlash, backlash / 4))
    fwd = smooth - bl / 2
    rev = smooth + bl / 2
    return {"motor": motor, "positions": pos.tolist(), "forward": fwd.tolist(),
            "reverse": rev.tolist()}


def random_machine(base: Profile, rng: np.random.Generator, *, scale: float = 1.0,
                   axis_errors: bool = False, effects: bool = False,
                   name: str = "random machine") -> Profile:
    """A machine whose every contract term differs from ``base`` by a random error.

    Parameters
    ----------
    base : the design (usually the nominal profile)
    rng : random generator
    scale : multiplies :data:`ERROR_SIGMA`
    axis_errors : add real-axis tables with backlash for every motor
    effects : add effects outside the contract's terms (bowed guides, curved
        table axes) that only the virtual-axis error map can take up
    """
    from .profile import kinematics_to_dict, profile_from_dict

    doc = {k: v for k, v in base.raw.items() if k not in ("kinematics", "table", "axis_comp",
                                                            "error_map")}
    kin = kinematics_to_dict(base.kinematics)
    for key in ("tool_length", "tool_offset_x", "tool_offset_y"):
        kin[key] = kin[key] + rng.normal(0, ERROR_SIGMA[key] * scale)
    for leg in kin["legs"]:
        for key in leg:
            leg[key] = leg[key] + rng.normal(0, ERROR_SIGMA[key] * scale)
    doc["kinematics"] = kin
    doc["table"] = {k: getattr(base.table, k) + rng.normal(0, ERROR_SIGMA[k] * scale)
                    for k in ("scale_x", "scale_y", "squareness")}
    if axis_errors:
        doc["axis_comp"] = [random_axis_table(m, rng) for m in MOTOR_ORDER]
    if effects:
        doc["effects"] = {"guide_bow": rng.normal(0, 0.01, 3).tolist(),
                          "table_straightness": rng.normal(0, 0.05, 2).tolist()}
    doc["machine"] = {"name": name}
    return profile_from_dict(doc, f"<{name}>")
