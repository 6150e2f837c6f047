"""The command with and without its allocator setting (prsxy_post.allocator), in turns.

Usage::

    python bench/allocator.py --format gcode --runs 6
    python bench/allocator.py --lines 2000000 --runs 2
    python bench/allocator.py --program x.ngc --profile p.toml

Each round runs ``prsxy-post convert`` twice on the same program, as a user runs it:
once as it is (the command fixes glibc's mmap and trim thresholds,
:func:`prsxy_post.allocator.keep_freed_memory`), once with ``GLIBC_TUNABLES`` set
empty in its environment, which leaves glibc's own moving thresholds (the command
keeps a malloc setting the user made, and an empty one changes nothing in glibc).
The two take turns, so that a machine getting slower or faster weighs on both.
Printed per run and on average: wall time, CPU of the command's processes (user +
system) and their page faults (minor: a page the kernel had to map and zero).
Peak memory: ``bench/chunk_memory.py`` run once as it is and once with
``GLIBC_TUNABLES=`` in its environment (its child sets the allocator as the command
does).
"""

from __future__ import annotations

import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench

SETTINGS = {"fixed": {}, "glibc": {"GLIBC_TUNABLES": ""}}


def run_command(program: str, prof: str, fmt: str, out: str, env: dict[str, str]) -> tuple:
    """One command: (wall s, CPU s, minor page faults) of it and its processes."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(
        bench.convert_command(program, prof, out, fmt), check=True, cwd=bench.ROOT, env=env
    )
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    return wall, cpu, r1.ru_minflt - r0.ru_minflt


def main() -> None:
    args = bench.program_parser(__doc__.split("\n")[0]).parse_args()
    results: dict[str, list[tuple]] = {k: [] for k in SETTINGS}
    with tempfile.TemporaryDirectory() as d:
        program, prof = bench.program_and_profile(args, Path(d))
        out = str(Path(d) / "out")
        base = bench.user_env()
        base.pop("GLIBC_TUNABLES", None)
        for _ in range(args.runs):
            for name, extra in SETTINGS.items():
                results[name].append(run_command(program, prof, args.format, out, base | extra))
    print(f"{args.format}, {Path(program).name}, {os.cpu_count()} cores: wall s, CPU s, faults")
    for name, rows in results.items():
        each = ", ".join(f"{w:.2f} s {c:.2f} s {f:,}" for w, c, f in rows)
        mean = [sum(r[i] for r in rows) / len(rows) for i in range(3)]
        print(f"{name:6s} mean {mean[0]:.3f} s, CPU {mean[1]:.3f} s, {mean[2]:,.0f} faults")
        print(f"       runs: {each}")


if __name__ == "__main__":
    main()
