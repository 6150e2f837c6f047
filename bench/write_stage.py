"""The write stage alone: CPU of a dialect's writer on a program's recorded points.

Usage::

    python bench/write_stage.py /tmp/p/50k.ngc /tmp/p/bench.toml --format pmac
    python bench/write_stage.py prog.ngc profile.toml --format gcode --repeat 5

It converts the program once (in this process, no writer process) and keeps the
chain's point chunks as the writer was fed them; then it feeds them again to a new
writer ``--repeat`` times (begin, every chunk, finish) and prints the best CPU time
(``time.process_time``) of the writer alone, and, for a Cartesian dialect, of the
forward kinematics it runs on the points (``writers.cartesian.WrittenPoints``).
``convert``'s own ``write`` timing is wall time and includes waiting for a loaded
machine; this is the CPU the writer itself costs. PRSXY_KERNEL=pure times the
reference kernels.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

from prsxy_post import kernel, kinematics, sinks, writers
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.files import load_profile
from prsxy_post.writers.cartesian import WrittenPoints


def record(program: str, profile: str, fmt: str) -> list[Any]:
    """The point chunks the writer is fed while the program converts."""
    chunks: list[Any] = []
    feed = sinks.WriterHere.feed

    def spy(self: sinks.WriterHere, chunk: Any) -> None:
        chunks.append(chunk)
        feed(self, chunk)

    sinks.WriterHere.feed = spy  # type: ignore[method-assign]
    try:
        with tempfile.TemporaryDirectory() as tmp:
            out = str(Path(tmp) / f"out.{fmt}")
            convert_file(ConvertJob(program, profile, fmt, out, parallel=False))
    finally:
        sinks.WriterHere.feed = feed  # type: ignore[method-assign]
    return chunks


def best_cpu(fn: Any, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.process_time()
        fn()
        best = min(best, time.process_time() - t)
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("program")
    ap.add_argument("profile")
    ap.add_argument("--format", default="pmac", choices=sorted(writers.DIALECTS))
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    chunks = record(a.program, a.profile, a.format)
    prof = load_profile(a.profile)
    prov = writers.Provenance(a.program, "", prof.name, a.profile, "", "bench")

    def write() -> None:
        w = writers.writer_for(prof, a.format, prov)
        w.begin()
        for c in chunks:
            w.feed(c)
        w.finish()

    points = sum(len(c) for c in chunks)
    print(f"kernel: {kernel.NAME}; {len(chunks)} chunks, {points} points")
    t = best_cpu(write, a.repeat)
    print(f"write stage ({a.format}): {t:.3f} s CPU, best of {a.repeat}")
    if writers.dialect(a.format).space == "pose":
        cgeo = kinematics.controller_geometry(prof)

        def fk() -> None:
            written = WrittenPoints(cgeo)
            for c in chunks:
                written(c)

        t = best_cpu(fk, a.repeat)
        print(f"  of which the forward kinematics (WrittenPoints): {t:.3f} s CPU")


if __name__ == "__main__":
    main()
