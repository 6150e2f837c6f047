"""Where a conversion's CPU goes: compiled kernels, numpy, the Python around them.

Usage::

    python bench/cpu_profile.py                         # 200 000 lines, PMAC
    python bench/cpu_profile.py --format gcode --top 25
    python bench/cpu_profile.py --program x.ngc --profile p.toml

It converts the program (bench.py's generated one unless given) in one process
(``convert_file`` with ``parallel=False``: the same work as the command's three
processes, without the pipes between them; the allocator set as the command sets
it, :mod:`prsxy_post.allocator`) under :mod:`cProfile`, and sorts every function's
own time into:

- **kernels**: the calls into :mod:`prsxy_post.kernel` (the compiled kernels when
  built: Cython's functions are not profiled, so their time is their caller's, the
  kernel module's own wrapper);
- **numpy**: numpy's functions and array methods;
- **I/O**: reading the program, writing the output, syncing it to disk;
- **Python**: the package's own Python lines (the glue between the kernels);
- **other**: the standard library and built-ins (imports made during the
  conversion among them).

Then the largest kernels, and the package's functions ranked by their glue: their
own time and that of the numpy (and other non-package) calls they make, shared out
to the package function that made them (a numpy function called by another numpy
function counts for the package function that called the first). That ranking is
what the next compiled kernel should be chosen from (issue 31).

The profiler costs every Python call some CPU, so the Python and numpy shares are
somewhat larger here than in an unprofiled run, and the total is larger than
``bench/bench.py``'s chain CPU; compare shares, and runs with each other.
"""

from __future__ import annotations

import cProfile
import os
import pstats
import sys
import tempfile
import time
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench

#: a profile entry: (file, line, function)
Key = tuple[str, int, str]

GROUPS = ("kernels", "numpy", "I/O", "Python", "other")
#: built-ins that wait for or move bytes of files and pipes
IO_CALLS = ("write", "read", "readinto", "fdatasync", "fsync", "replace", "writev", "readv")


def group(key: Key) -> str:
    """Which of :data:`GROUPS` a profile entry's own time belongs to."""
    path, _, name = key
    path = path.replace(os.sep, "/")
    if "prsxy_post/kernel/" in path:
        return "kernels"
    if "prsxy_post/" in path:
        return "Python"
    if "/numpy/" in path or "numpy" in name:
        return "numpy"
    if path == "~" and any(f"'{c}'" in name or f".{c}" in name for c in IO_CALLS):
        return "I/O"
    return "other"


def is_package(key: Key) -> bool:
    """The package's own Python (not its kernels)."""
    return group(key) == "Python"


def glue_by_function(stats: dict) -> dict[Key, float]:
    """Each package function's own CPU and that of the numpy and other
    non-package calls it made, directly or through them [s]: a non-package
    entry's time is shared among its callers in proportion to what each called of
    it, up the callers until a package function (kernels and I/O not counted)."""
    out: dict[Key, float] = defaultdict(float)

    def share(key: Key, seconds: float, depth: int) -> None:
        callers = stats[key][4]
        total = sum(v[3] for v in callers.values()) or 1.0
        for caller, v in callers.items():
            part = seconds * v[3] / total
            if is_package(caller):
                out[caller] += part
            elif depth < 8 and caller in stats and group(caller) in ("numpy", "other"):
                share(caller, part, depth + 1)

    for key, (_, _, tt, _, _) in stats.items():
        g = group(key)
        if g == "Python":
            out[key] += tt
        elif g in ("numpy", "other"):
            share(key, tt, 0)
    return out


def profile_conversion(program: str, prof: str, fmt: str) -> tuple[dict, float, int]:
    """The conversion's profile entries, its CPU time [s] and its points."""
    sys.path.insert(0, str(bench.ROOT))
    from prsxy_post import allocator
    from prsxy_post.convert import ConvertJob, convert_file

    allocator.keep_freed_memory()  # as the command (cli.run)

    with tempfile.TemporaryDirectory() as d:
        job = ConvertJob(program, prof, fmt, str(Path(d) / "out"), parallel=False)
        # the profiler's own clock (a Python clock function would cost every call
        # more than most calls take, and weigh on the Python share): wall time, which
        # in one process is its CPU but for the waits on the disk (I/O)
        pr = cProfile.Profile()
        c0 = time.process_time()
        pr.enable()
        st = convert_file(job)
        pr.disable()
        cpu = time.process_time() - c0
    stats = pstats.Stats(pr).stats  # type: ignore[attr-defined]
    return stats, cpu, int(st.points)


def where(key: Key) -> str:
    """A function's name as the table shows it: path inside the package, line."""
    path, line, name = key
    path = path.replace(os.sep, "/")
    short = path.split("prsxy_post/", 1)[1] if "prsxy_post/" in path else path
    return f"{short}:{line} {name}"


def report(stats: dict, cpu: float, points: int, top: int) -> str:
    by_group: dict[str, float] = defaultdict(float)
    for key, (_, _, tt, _, _) in stats.items():
        by_group[group(key)] += tt
    total = sum(by_group.values())
    lines = [
        f"CPU {cpu:.2f} s profiled ({total:.2f} s in its functions by the profiler's "
        f"clock), {points:,} points, {1e6 * cpu / max(points, 1):.2f} µs of CPU a point",
        "",
        "| where | s | share |",
        "|---|---:|---:|",
    ]
    lines += [f"| {g} | {by_group[g]:.3f} | {by_group[g] / total:.0%} |" for g in GROUPS]
    kernels = sorted(
        ((k, v[2], v[1]) for k, v in stats.items() if group(k) == "kernels"), key=lambda r: -r[1]
    )
    lines += [
        "",
        f"The {top} largest kernels (their own time: the compiled call when built):",
        "",
        "| kernel | s | share | calls |",
        "|---|---:|---:|---:|",
    ]
    lines += [f"| `{where(k)}` | {t:.3f} | {t / total:.1%} | {n:,} |" for k, t, n in kernels[:top]]
    glue = glue_by_function(stats)
    lines += [
        "",
        f"The package's {top} largest glues (own Python and the numpy calls made):",
        "",
        "| function | glue s | share | calls |",
        "|---|---:|---:|---:|",
    ]
    for key, s in sorted(glue.items(), key=lambda kv: -kv[1])[:top]:
        lines.append(f"| `{where(key)}` | {s:.3f} | {s / total:.1%} | {stats[key][1]:,} |")
    return "\n".join(lines)


def main() -> None:
    ap = bench.program_parser(__doc__.split("\n")[0])
    ap.add_argument("--top", type=int, default=20, help="how many functions to rank")
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        program, prof = bench.program_and_profile(args, Path(d))
        stats, cpu, points = profile_conversion(program, prof, args.format)
    if args.markdown:
        import mdsection

        print(mdsection.header("Where the CPU goes"))
    print(report(stats, cpu, points, args.top))


if __name__ == "__main__":
    main()
