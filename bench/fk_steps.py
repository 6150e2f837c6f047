"""The forward kinematics of corrected G-code: Newton's steps on a program's points.

Usage::

    python bench/fk_steps.py /tmp/p/50k.ngc /tmp/p/bench.toml

It converts the program to G-code once (``write_stage.record``), then solves each
point's motor commands back to the tool pose as the writer does
(``writers.cartesian.written_points``: the controller's geometry, warm-started at the
IK pose of the chain's target) and prints how many Newton steps the points take, the
size of the last step, and how many of the written values (7 decimals) would change
if the last step were left out (Newton stopped after one step fewer).
"""

from __future__ import annotations

import argparse

import numpy as np
from write_stage import record  # bench/ (the script's directory)

from prsxy_post import kernel, kinematics
from prsxy_post.files import load_profile
from prsxy_post.writers.numbers import round_clean

DEC = 7  # the written decimals of X Y Z A B


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program")
    ap.add_argument("profile")
    a = ap.parse_args()
    chunks = record(a.program, a.profile, "gcode")
    geo = kinematics.controller_geometry(load_profile(a.profile))
    m, lim, res = geo.fk_arrays, kinematics.FK_STEP, kinematics.FK_RESIDUAL
    steps: dict[int, int] = {}
    last, changed, values = [], 0, 0
    for c in chunks:
        x0 = kinematics.platform_guess(kinematics.solve_platform(geo, c.q_target), c.q_target)
        off = geo.hinge_offset(c.P_cmd[:, :3])
        x, ok = kernel.forward_newton(m, off, x0, lim, kinematics.FK_MAX_ITER, res)
        # the steps each row took: the fewest iterations giving the same solution
        took = np.full(len(c), -1)
        for k in range(1, kinematics.FK_MAX_ITER + 1):
            xk, _ = kernel.forward_newton(m, off, x0, lim, k, res)
            took[(took < 0) & np.all(xk == x, axis=1)] = k
            if np.all(took > 0):
                break
        for k, n in zip(*np.unique(took, return_counts=True), strict=True):
            steps[int(k)] = steps.get(int(k), 0) + int(n)
        # one step fewer: the iterate before the last
        k_last = int(took.max())
        fewer, _ = kernel.forward_newton(m, off, x0, lim, k_last - 1, res)
        last.append(np.max(np.abs(x - fewer), axis=1))
        t = np.broadcast_to(geo.tool, (len(c), 3)).copy()
        D = kinematics.table_displacement(geo, c.P_cmd[:, 3], c.P_cmd[:, 4])
        q = round_clean(kernel.tool_poses(x, ok, t, geo.origin, D), DEC)
        q_fewer = round_clean(kernel.tool_poses(fewer, ok, t, geo.origin, D), DEC)
        changed += int(np.sum(q != q_fewer))
        values += q.size
    sizes = np.concatenate(last)
    print(f"kernel: {kernel.NAME}; {len(sizes)} points")
    print("Newton steps taken (steps: points):", dict(sorted(steps.items())))
    lo, med, hi = np.quantile(sizes, [0.0, 0.5, 1.0])
    print(f"the last step: min {lo:.2e}, median {med:.2e}, max {hi:.2e} [mm, rad]")
    print(f"written values ({DEC} decimals) changed without it: {changed} of {values}")


if __name__ == "__main__":
    main()
