"""What a machine does with motor commands: the forward simulation.

The machine is described by a "truth" profile (its real geometry, table and
real-axis errors). Executing a motion means: each motor's driven part follows
the play model of its real-axis table, then the forward kinematics of the true
geometry gives the tool pose (contract: "Forward kinematics", "Real-axis error").

This module is the reference the tests hold converted programs against, and the
core of the ``simulate`` command.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from . import axiscomp, kinematics
from . import effects as registry
from .profile import MOTORS, Profile


def truth_geometry(truth: Profile) -> kinematics.Geometry:
    return kinematics.Geometry.from_params(
        truth.kinematics, truth.origin, truth.table, truth.effects
    )


def actual_motors(
    truth: Profile, P_cmd: np.ndarray, *, approach: int | None = None, t: np.ndarray | None = None
) -> np.ndarray:
    """Where the driven parts end for commands ``P_cmd`` (N, 5) in time order.

    approach : None for a continuous motion (play model); +1 or −1 for points
        each approached on its own from that side (poses, laser runs).
    t : (N,) time stamps [s] of a continuous motion, for the servo lag.
    """
    tables = axiscomp.profile_tables(truth)
    if approach is None:
        P_cmd = registry.SERVO_LAG.follow(truth, P_cmd, t)
    out = np.array(P_cmd, dtype=float, copy=True)
    for col, m in enumerate(MOTORS):
        table = tables.get(m)
        if table is None:
            continue
        if approach is None:
            out[:, col] = axiscomp.play_model(table, P_cmd[:, col])
        else:
            out[:, col] = axiscomp.approach(table, P_cmd[:, col], approach)
    return out


def execute(
    truth: Profile,
    P_cmd: np.ndarray,
    tool_length: np.ndarray | float | None = None,
    *,
    approach: int | None = None,
    guess: np.ndarray | None = None,
    t: np.ndarray | None = None,
) -> np.ndarray:
    """Tool poses q (N, 5) [mm, deg] the truth machine reaches for motor commands.

    Raises
    ------
    RuntimeError
        If the forward kinematics does not converge (the commands are not a pose
        of this machine); callers pass commands from a converted program.
    """
    geo = truth_geometry(truth)
    P = actual_motors(truth, P_cmd, approach=approach, t=t)
    q, ok = kinematics.forward(geo, P, tool_length, guess=guess)
    if not np.all(ok):
        raise RuntimeError(f"forward kinematics did not converge at {np.sum(~ok)} points")
    return q


def random_axis_table(
    motor: int,
    rng: np.random.Generator,
    *,
    lo: float = -250.0,
    hi: float = 250.0,
    step: float = 10.0,
    backlash: float = 0.004,
    amplitude: float = 0.004,
) -> dict:
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
    return {
        "motor": motor,
        "positions": pos.tolist(),
        "forward": fwd.tolist(),
        "reverse": rev.tolist(),
    }


def random_machine(
    base: Profile,
    rng: np.random.Generator,
    *,
    scale: float = 1.0,
    axis_errors: bool = False,
    effects: bool = False,
    name: str = "random machine",
) -> Profile:
    """A machine whose every contract term differs from ``base`` by a random error.

    Parameters
    ----------
    base : the design (usually the nominal profile)
    rng : random generator
    scale : multiplies each term's prior (its typical error, :mod:`effects`)
    axis_errors : add real-axis tables with backlash for every motor
    effects : add the geometry effects outside the contract's terms (bowed
        guides, curved table axes), each at its prior
    """
    from .profile import kinematics_to_dict, profile_from_dict

    doc = {
        k: v
        for k, v in base.raw.items()
        if k not in ("kinematics", "table", "axis_comp", "error_map")
    }
    kin = kinematics_to_dict(base.kinematics)
    for key in ("tool_length", "tool_offset_x", "tool_offset_y"):
        kin[key] = kin[key] + rng.normal(0, registry.prior(f"kinematics.{key}") * scale)
    for i, leg in enumerate(kin["legs"]):
        for key in leg:
            sigma = registry.prior(f"kinematics.legs[{i + 1}].{key}")
            leg[key] = leg[key] + rng.normal(0, sigma * scale)
    doc["kinematics"] = kin
    doc["table"] = {
        k: getattr(base.table, k) + rng.normal(0, registry.prior(f"table.{k}") * scale)
        for k in ("scale_x", "scale_y", "squareness")
    }
    if axis_errors:
        doc["axis_comp"] = [random_axis_table(m, rng) for m in MOTORS]
    if effects:
        doc["effects"] = {
            fam.effects_keys[0]: rng.normal(0, fam.prior, len(fam.members())).tolist()
            for fam in registry.iter_families("geometry")
            if fam.effects_keys
        }
    doc["machine"] = {"name": name}
    return profile_from_dict(doc, f"<{name}>")


def plant(base: Profile, changes: Sequence[registry.Change], name: str = "planted") -> Profile:
    """``base`` with library effects added, each written at its profile home."""
    from .profile import profile_from_dict

    doc = registry.apply(base.raw, base, changes)
    doc["machine"] = {"name": name}
    return profile_from_dict(doc, f"<{name}>")


def random_effects(
    rng: np.random.Generator,
    n: int,
    *,
    scale: float = 1.0,
    candidates: Sequence[str] | None = None,
) -> list[registry.Change]:
    """``n`` different library members at realistic sizes.

    Every family is equally likely (a member of a family with k members has
    weight 1/k); sizes are drawn by the family (:meth:`effects.Family.random_change`:
    0.5 to 2 times its prior, either sign where a sign means something).
    """
    names = list(candidates if candidates is not None else registry.members())
    weight = np.array([1.0 / len(registry.family(m).members()) for m in names])
    pick = rng.choice(len(names), size=n, replace=False, p=weight / weight.sum())
    return [registry.family(names[k]).random_change(names[k], rng, scale) for k in pick]


# ---------------------------------------------------------------- measurements
#
# What measuring instruments see on the truth machine when it is commanded by a
# profile (the "commanded" one, with everything it holds: geometry, tables,
# error map). These are the forward models behind `simulate`, `calibrate` and
# `diagnose`; the contract's measurement files record their inputs and outputs.


def commanded_geometry(commanded: Profile) -> kinematics.Geometry:
    return kinematics.Geometry.from_params(
        commanded.kinematics, commanded.origin, commanded.table, commanded.effects
    )


def _wanted_motors(commanded: Profile, q: np.ndarray, tool_length: float) -> np.ndarray:
    """The commanding profile's virtual-axis map and IK: where the motors must be."""
    from . import chain, errormap

    emap = errormap.from_profile(commanded)
    qt = chain.correct_virtual(q, emap) if emap is not None else q
    ik = kinematics.inverse(commanded_geometry(commanded), qt, tool_length)
    if not np.all(ik.reachable):
        raise ValueError(f"{int(np.sum(~ik.reachable))} poses out of reach")
    return ik.P.copy()


def pose_commands(commanded: Profile, q: np.ndarray, tool_length: float = 0.0) -> np.ndarray:
    """Motor commands for static poses, each approached with every motor moving +.

    The commanding profile's chain: Q' = Q − e(Q), its IK, then for each motor the
    command p with lo(p) = wanted (the part ends at lo when approached from below).
    """
    P = _wanted_motors(commanded, q, tool_length)
    tables = axiscomp.profile_tables(commanded)
    for col, m in enumerate(MOTORS):
        if m in tables:
            P[:, col] = tables[m].lo_inv(P[:, col])
    return P


def motion_commands(
    commanded: Profile, q: np.ndarray, tool_length: float = 0.0, t: np.ndarray | None = None
) -> np.ndarray:
    """Motor commands for a continuous motion through poses q at times t (time order)."""
    P = _wanted_motors(commanded, q, tool_length)
    tables = axiscomp.profile_tables(commanded)
    for col, m in enumerate(MOTORS):
        if m in tables:
            P[:, col] = axiscomp.compensate(tables[m], P[:, col])
    return registry.SERVO_LAG.lead(commanded, P, t)


def measure_poses(
    truth: Profile,
    commanded: Profile,
    q: np.ndarray,
    rng: np.random.Generator,
    noise_um: float = 1.0,
    noise_deg: float = 0.0003,
) -> np.ndarray:
    """Measured tip and axis (N, 5) [mm, deg] at commanded poses q (N, 5)."""
    P = pose_commands(commanded, q)
    meas = execute(truth, P, approach=+1)
    meas[:, :3] += rng.normal(0, noise_um * 1e-3, (len(q), 3))
    meas[:, 3:] += rng.normal(0, noise_deg, (len(q), 2))
    return meas


def measure_ballbar(
    truth: Profile,
    commanded: Profile,
    q: np.ndarray,
    t: np.ndarray,
    pivot: np.ndarray,
    length: float,
    rng: np.random.Generator,
    noise_um: float = 0.5,
) -> np.ndarray:
    """Ballbar reading dev_um (N,) along a commanded motion q (N, 5) at times t."""
    P = motion_commands(commanded, q, t=t)
    tip = execute(truth, P, t=t)[:, :3]
    dev = (np.linalg.norm(tip - pivot, axis=1) - length) * 1000.0
    return dev + rng.normal(0, noise_um, len(dev))


def measure_axis(
    truth: Profile,
    motor: int,
    targets: np.ndarray,
    runs: int,
    rng: np.random.Generator,
    noise_um: float = 0.3,
) -> np.ndarray:
    """Laser runs per ISO 230-2: rows (motor, target, measured, direction, run).

    Each run goes up through the targets then down, no compensation active: the
    part ends at lo(target) approached from below and hi(target) from above.
    """
    tables = axiscomp.profile_tables(truth)
    t = tables.get(motor)
    rows = []
    for run in range(1, runs + 1):
        for direction, seq in ((1, targets), (-1, targets[::-1])):
            reached = axiscomp.approach(t, seq, direction)
            reached = reached + rng.normal(0, noise_um * 1e-3, len(seq))
            rows += [
                (motor, float(a), float(b), direction, run)
                for a, b in zip(seq, reached, strict=True)
            ]
    return np.array(rows, dtype=float)


def ballbar_gcode(
    radius: float,
    *,
    plane: str = "XY",
    ccw: bool = True,
    tilt_deg: float = 0.0,
    feed: float = 1000.0,
    pivot: tuple[float, float, float] = (0.0, 0.0, 0.0),
    chord_tol_mm: float = 2e-5,
) -> str:
    """A ballbar test program: a full circle about the pivot, from and back to rest.

    ``ccw`` runs the way G3 turns in the plane (G17, G18 or G19), counter-clockwise
    seen from the positive end of the plane's normal (+Z, +Y, +X) as RS274/NGC
    defines it; ``ccw=False`` the way G2 turns (``docs/data-formats.md``).

    XY circles without tilt are one G2/G3; tilted ("cone") circles keep the tool
    axis tilted by ``tilt_deg`` away from the pivot all round, which needs A/B to
    follow the angle, so they are written as short G1 moves whose chords stay
    within ``chord_tol_mm`` of the circle (the ballbar would see the polygon).
    """
    px, py, pz = pivot
    d = "G3" if ccw else "G2"
    out = [
        f"(ballbar {plane} r{radius:g} {'ccw' if ccw else 'cw'} tilt {tilt_deg:g})",
        "G21 G90 G94",
    ]
    if plane == "XY" and tilt_deg == 0.0:
        out += [
            "G17",
            f"G0 X{px + radius:.6f} Y{py:.6f} Z{pz:.6f} A0 B0",
            f"{d} X{px + radius:.6f} Y{py:.6f} I{-radius:.6f} J0 F{feed:g}",
        ]
    elif plane == "XY":
        sgn = 1 if ccw else -1
        segments = int(np.ceil(np.pi / np.arccos(1.0 - chord_tol_mm / radius)))
        th = sgn * np.linspace(0, 2 * np.pi, segments + 1)
        ax = np.stack(
            [
                np.sin(np.radians(tilt_deg)) * np.cos(th),
                np.sin(np.radians(tilt_deg)) * np.sin(th),
                np.full_like(th, np.cos(np.radians(tilt_deg))),
            ],
            -1,
        )
        a, b = kinematics.angles_from_axis(ax)
        a, b = np.round(a, 6) + 0.0, np.round(b, 6) + 0.0
        x = px + radius * np.cos(th)
        y = py + radius * np.sin(th)
        out.append(f"G0 X{x[0]:.6f} Y{y[0]:.6f} Z{pz:.6f} A{a[0]:.6f} B{b[0]:.6f}")
        out.append(f"F{feed:g}")
        out += [f"G1 X{x[k]:.6f} Y{y[k]:.6f} A{a[k]:.6f} B{b[k]:.6f}" for k in range(1, len(th))]
    elif plane in ("XZ", "YZ"):
        code, first = ("G18", "X") if plane == "XZ" else ("G19", "Y")
        c0 = px if plane == "XZ" else py
        off = "I" if plane == "XZ" else "J"
        # G18: positive rotation is counter-clockwise seen from +Y (Z towards X)
        out += [
            code,
            f"G0 {first}{c0 + radius:.6f} {'Y' if plane == 'XZ' else 'X'}"
            f"{(py if plane == 'XZ' else px):.6f} Z{pz:.6f} A0 B0",
            f"{d} {first}{c0 + radius:.6f} Z{pz:.6f} {off}{-radius:.6f} K0 F{feed:g}",
        ]
    else:
        raise ValueError(f"unknown ballbar plane {plane!r}")
    out.append("M2")
    return "\n".join(out) + "\n"
