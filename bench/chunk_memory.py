"""Chunk size and look-ahead of a conversion: its time and the peak memory of its
processes, setting against setting.

Usage::

    python bench/chunk_memory.py --lines 2000000 --format gcode --runs 3 \\
        --setting 4096:3 --setting 3072:2
    python bench/chunk_memory.py --program x.ngc --profile p.toml --setting 2048:3

Each ``--setting CHUNK:AHEAD`` converts the program with ``ConvertJob.chunk`` =
CHUNK motions and ``convert.AHEAD`` = AHEAD chunks for the output's segment, as
the command runs it (``parallel=True``), in a fresh child process each time (a
process's peak memory is its whole life's). The settings take turns, ``--runs``
rounds of one run each, so that a machine getting slower or faster over the runs
weighs on every setting alike. Printed per setting: each run's wall time [s] and
peak resident memory, main + interpreter + writer = all [MB] (no interpreter
process, 0, and no look-ahead where the output's dialect keeps its interpreter in
the main process: corrected G-code, ``Dialect.interpreter_apart``). The program and
profile are bench.py's unless given (``bench.program_parser``).
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))

import bench


def child(program: str, prof: str, fmt: str, chunk: int, ahead: int, out: str) -> None:
    """Run in a child process: one conversion, its wall time and peak memory as JSON."""
    sys.path.insert(0, str(bench.ROOT))
    from prsxy_post import allocator, convert, writers
    from prsxy_post.runtime import peak_rss_mb

    allocator.keep_freed_memory()  # as the command (cli.run)

    convert.AHEAD[writers.dialect(fmt).segment] = ahead
    t0 = time.perf_counter()
    st = convert.convert_file(
        convert.ConvertJob(program, prof, fmt, out, chunk=chunk, parallel=True)
    )
    wall = time.perf_counter() - t0
    # no interpreter process where the dialect keeps its interpreter here (G-code)
    mb = (peak_rss_mb(), st.helper_peak_rss_mb or 0.0, st.writer_peak_rss_mb or 0.0)
    print(json.dumps({"wall_s": wall, "mb": mb}))


def main() -> None:
    if sys.argv[1:2] == ["--child"]:
        program, prof, fmt, chunk, ahead, out = sys.argv[2:8]
        child(program, prof, fmt, int(chunk), int(ahead), out)
        return
    ap = bench.program_parser(__doc__.split("\n")[0])
    ap.add_argument(
        "--setting",
        action="append",
        required=True,
        metavar="CHUNK:AHEAD",
        help="motions per chunk and chunks of look-ahead (repeatable)",
    )
    args = ap.parse_args()
    settings = [tuple(int(x) for x in s.split(":")) for s in args.setting]
    runs: dict[tuple[int, ...], list[dict]] = {s: [] for s in settings}
    with tempfile.TemporaryDirectory() as d:
        program, prof = bench.program_and_profile(args, Path(d))
        for _ in range(args.runs):
            for s in settings:
                cmd = [
                    sys.executable,
                    __file__,
                    "--child",
                    program,
                    prof,
                    args.format,
                    str(s[0]),
                    str(s[1]),
                    str(Path(d) / "out"),
                ]
                done = subprocess.run(cmd, capture_output=True, text=True, check=True)
                runs[s].append(json.loads(done.stdout.splitlines()[-1]))
    print(f"{args.format}, {Path(program).name}: wall s; peak MB main + interpreter + writer")
    for (chunk, ahead), rs in runs.items():
        walls = ", ".join(f"{r['wall_s']:.2f}" for r in rs)
        mbs = ", ".join(
            f"{r['mb'][0]:.0f} + {r['mb'][1]:.0f} + {r['mb'][2]:.0f} = {sum(r['mb']):.0f}"
            for r in rs
        )
        print(f"chunk {chunk}, ahead {ahead}: {walls} s; {mbs} MB")


if __name__ == "__main__":
    main()
