"""The PMAC writer's text kernel alone: CPU a point of ``pvt_segment_text``.

Usage::

    python bench/pvt_text_speed.py /tmp/p/200k.ngc /tmp/p/bench.toml
    python bench/pvt_text_speed.py prog.ngc profile.toml --repeat 7 --save calls.pkl

It converts the program once with PMAC output (in this process) and keeps the
arguments of every ``pvt_segment_text`` call (``--load`` reads them from a file
``--save`` wrote instead); then it runs the selected kernel (compiled, or the
reference under PRSXY_KERNEL=pure) on all of them ``--repeat`` times and prints
the best CPU time (``time.process_time``) in all and a point. ``--rows-only``
clears the line comments and PVT times (the points' rows alone).
"""

from __future__ import annotations

import argparse
import pickle
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from prsxy_post import kernel
from prsxy_post.convert import ConvertJob, convert_file


def record(program: str, profile: str) -> list[tuple[Any, ...]]:
    """The arguments of every ``pvt_segment_text`` call while the program converts."""
    calls: list[tuple[Any, ...]] = []
    inner = kernel._pvt_segment

    def spy(*args: Any) -> str:
        calls.append(args)
        out: str = inner(*args)
        return out

    kernel._pvt_segment = spy
    try:
        with tempfile.TemporaryDirectory() as tmp:
            job = ConvertJob(
                program=program,
                profile_path=profile,
                fmt="pmac",
                output=str(Path(tmp) / "out.pmc"),
                parallel=False,
            )
            convert_file(job)
    finally:
        kernel._pvt_segment = inner
    return calls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program", nargs="?")
    ap.add_argument("profile", nargs="?")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--save", help="write the recorded calls to this file")
    ap.add_argument("--load", help="read the calls from this file instead of converting")
    ap.add_argument("--rows-only", action="store_true", help="no line comments or PVT times")
    a = ap.parse_args()
    if a.load:
        calls = pickle.loads(Path(a.load).read_bytes())
    else:
        calls = record(a.program, a.profile)
    if a.save:
        Path(a.save).write_bytes(pickle.dumps(calls))
    if a.rows_only:
        calls = [
            (c[0], c[1], np.zeros(len(c[1]), bool), c[3], np.zeros(len(c[1]), bool), *c[5:])
            for c in calls
        ]
    fn = kernel._pvt_segment
    points = sum(len(c[1]) for c in calls)
    best = float("inf")
    for _ in range(a.repeat):
        t = time.process_time()
        for c in calls:
            fn(*c)
        best = min(best, time.process_time() - t)
    print(
        f"{'compiled' if kernel.COMPILED else 'pure'}: {len(calls)} calls, {points} points: "
        f"{best:.4f} s CPU, {best / points * 1e9:.1f} ns a point (best of {a.repeat})"
    )


if __name__ == "__main__":
    main()
