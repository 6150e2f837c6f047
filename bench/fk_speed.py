"""The corrected G-code writer's forward kinematics alone, side by side with another tree.

Usage::

    python bench/fk_speed.py /tmp/p/50k.ngc /tmp/p/bench.toml --runs 9
    python bench/fk_speed.py prog.ngc profile.toml --against /path/to/other/tree

It converts the program to G-code once (``write_stage.record``) and keeps the
arguments the writer gives ``kernel.forward_poses_anchored`` for every chunk
(``writers.cartesian.WrittenPoints``: the controller's geometry, started at the IK
pose of the chain's target moved by the anchors' offsets). Each run, in a fresh
interpreter, times (CPU, ``time.process_time``) ``forward_poses_anchored`` on all of
them with the package of this tree
and, with ``--against``, of the other one (its directory holding ``prsxy_post``,
compiled in place), run for run, so both meet the same load on a shared machine; it
prints each tree's median and least CPU and whether both gave the same bits.
"""

from __future__ import annotations

import argparse
import os
import pickle
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from write_stage import record  # bench/ (the script's directory)

from prsxy_post import kernel, kinematics
from prsxy_post.files import load_profile
from prsxy_post.writers.cartesian import WrittenPoints

ROOT = Path(__file__).resolve().parent.parent

#: run in the child: forward_poses_anchored on the recorded arguments; CPU and a digest
CHILD = """
import hashlib, pickle, sys, time
from prsxy_post import kernel
calls = pickle.load(open(sys.argv[1], "rb"))
t = time.process_time()
out = [kernel.forward_poses_anchored(*a) for a in calls]
cpu = time.process_time() - t
h = hashlib.sha256()
for q, ok, carry in out:
    h.update(q.tobytes())
    h.update(ok.tobytes())
    h.update(carry.tobytes())
print(cpu, h.hexdigest(), kernel.NAME)
"""


def arguments(program: str, prof_path: str) -> list[tuple[object, ...]]:
    """``forward_poses_anchored``'s arguments for every chunk, as the G-code writer
    makes them."""
    chunks = record(program, prof_path, "gcode")
    written = WrittenPoints(kinematics.controller_geometry(load_profile(prof_path)))
    calls: list[tuple[object, ...]] = []
    real = kernel.forward_poses_anchored

    def keep(*a: object) -> object:
        calls.append(tuple(x.copy() if isinstance(x, np.ndarray) else x for x in a))
        return real(*a)  # type: ignore[arg-type]

    kernel.forward_poses_anchored = keep  # type: ignore[assignment]
    try:
        for c in chunks:
            written(c)
    finally:
        kernel.forward_poses_anchored = real
    return calls


def run(tree: Path, path: str) -> tuple[float, str]:
    """One timing by the package under ``tree``: CPU [s] and the outputs' digest."""
    env = dict(os.environ, PYTHONPATH=str(tree), PYTHONDONTWRITEBYTECODE="1")
    res = subprocess.run(
        [sys.executable, "-c", CHILD, path],
        env=env,
        capture_output=True,
        text=True,
        cwd=tempfile.gettempdir(),
        check=True,
    )
    cpu, digest, _ = res.stdout.split(maxsplit=2)
    return float(cpu), digest


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program")
    ap.add_argument("profile")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--against", type=Path, action="append", default=[])
    a = ap.parse_args()
    calls = arguments(a.program, a.profile)
    rows = sum(len(c[2]) for c in calls)  # type: ignore[arg-type]
    print(f"kernel: {kernel.NAME}; {len(calls)} calls, {rows} rows")
    trees = [ROOT, *a.against]
    cpu: dict[Path, list[float]] = {t: [] for t in trees}
    digests: dict[Path, set[str]] = {t: set() for t in trees}
    with tempfile.NamedTemporaryFile(suffix=".pkl") as f:
        pickle.dump(calls, f)
        f.flush()
        for _ in range(a.runs):
            for t in trees:
                c, d = run(t, f.name)
                cpu[t].append(c)
                digests[t].add(d)
    for t in trees:
        med, least = statistics.median(cpu[t]), min(cpu[t])
        print(f"{t}: median {med:.4f} s CPU, least {least:.4f} ({a.runs} runs)")
    same = len(set().union(*digests.values())) == 1
    print("outputs: the same bits" if same else "outputs: DIFFERENT")


if __name__ == "__main__":
    main()
