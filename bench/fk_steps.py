"""The forward kinematics of corrected G-code: Newton's steps on a program's points.

Usage::

    python bench/fk_steps.py /tmp/p/50k.ngc /tmp/p/bench.toml

It converts the program to G-code once (``write_stage.record``), then solves each
point's motor commands back to the tool pose in the controller's geometry, chunk
after chunk as the writer is fed them, twice: from the IK pose of the chain's
target alone (``kinematics.fk_start``), and from it moved by the anchors' offsets
as the writer does (``writers.cartesian.WrittenPoints``, ``kernel.fk.anchored_starts``,
an anchor every ``kinematics.FK_ANCHOR_EVERY`` points). For each it prints how many
Newton steps the points take, and the steps the compiled kernel runs a point (it
steps four rows side by side until the slowest of them stops; the anchors' own
solves counted); then how many poses the anchored starts moved, by how much, and
how many of the written values (7 decimals) changed; and the largest offset of a
solution from its guess alone (what ``kernel.fk.ANCHOR_REACH`` bounds).
"""

from __future__ import annotations

import argparse

import numpy as np
from write_stage import record  # bench/ (the script's directory)

from prsxy_post import kernel, kinematics
from prsxy_post.files import load_profile
from prsxy_post.kernel import fk
from prsxy_post.writers.numbers import round_clean

DEC = 7  # the written decimals of X Y Z A B
LANES = 4  # rows the compiled Newton steps side by side (_fk.pyx)


def steps(m: fk.FKArrays, off: np.ndarray, x0: np.ndarray) -> np.ndarray:
    """(N,) the Newton steps each row takes from x0 until it stops converged."""
    took = np.full(len(x0), -1)
    for k in range(1, kinematics.FK_MAX_ITER + 1):
        _, ok = kernel.forward_newton(m, off, x0, kinematics.FK_STEP, k, kinematics.FK_RESIDUAL)
        took[(took < 0) & ok] = k
        if np.all(took > 0):
            break
    return took


def lane_steps(took: np.ndarray) -> int:
    """Steps the compiled kernel runs for rows taking ``took``: LANES at a time."""
    pad = np.concatenate([took, np.zeros(-len(took) % LANES, dtype=took.dtype)])
    return int(LANES * pad.reshape(-1, LANES).max(axis=1).sum())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program")
    ap.add_argument("profile")
    a = ap.parse_args()
    chunks = record(a.program, a.profile, "gcode")
    geo = kinematics.controller_geometry(load_profile(a.profile))
    m, every = geo.fk_arrays, kinematics.FK_ANCHOR_EVERY
    lim, it, res = kinematics.FK_STEP, kinematics.FK_MAX_ITER, kinematics.FK_RESIDUAL
    cold: list[np.ndarray] = []
    warm: list[np.ndarray] = []
    lanes = {"cold": 0, "anchored": 0}
    moved, biggest, changed, values, done = 0, 0.0, 0, 0, 0
    carry = np.zeros(6)
    offset = np.zeros(6)  # the largest |solution - guess| per component
    for c in chunks:
        x0 = kinematics.fk_start(geo, c.q_target)
        off = geo.hinge_offset(c.P_cmd[:, :3])
        starts, carry = fk.anchored_starts(m, off, x0, lim, it, res, every, done % every, carry)
        anchors = np.arange((-done) % every, len(x0), every)
        done += len(x0)
        cold.append(steps(m, off, x0))
        warm.append(steps(m, off, starts))
        lanes["cold"] += lane_steps(cold[-1])
        lanes["anchored"] += lane_steps(warm[-1]) + lane_steps(steps(m, off[anchors], x0[anchors]))
        t = np.broadcast_to(geo.tool, (len(c), 3)).copy()
        D = kinematics.table_displacement(geo, c.P_cmd[:, 3], c.P_cmd[:, 4])
        solved = [kernel.forward_newton(m, off, s, lim, it, res) for s in (x0, starts)]
        q = [kernel.tool_poses(x, ok, t, geo.origin, D) for x, ok in solved]
        offset = np.maximum(offset, np.max(np.abs(solved[0][0] - x0), axis=0, initial=0.0))
        moved += int(np.sum(np.any(q[0] != q[1], axis=1)))
        biggest = max(biggest, float(np.max(np.abs(q[0] - q[1]), initial=0.0)))
        changed += int(np.sum(round_clean(q[0], DEC) != round_clean(q[1], DEC)))
        values += q[0].size
    print(f"kernel: {kernel.NAME}; {done} points; an anchor every {every}")
    for name, took in (("cold", cold), ("anchored", warm)):
        k, n = np.unique(np.concatenate(took), return_counts=True)
        hist = dict(zip(k.tolist(), n.tolist(), strict=True))
        print(
            f"{name}: Newton steps (steps: points) {hist}; "
            f"{lanes[name] / done:.3f} steps a point in the compiled kernel's lanes"
        )
    print(
        f"poses the anchored starts moved: {moved} of {done}, by at most {biggest:.2e} "
        f"(mm, deg); written values ({DEC} decimals) changed: {changed} of {values}"
    )
    print(
        f"largest offset of a solution from its guess alone: centre {offset[:3].max():.3f} mm, "
        f"angles {offset[3:].max():.4f} rad (fk.ANCHOR_REACH: {fk.ANCHOR_REACH})"
    )


if __name__ == "__main__":
    main()
