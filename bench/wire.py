"""What the interpreter process's chunks cost to cross to the chain: bytes and CPU.

Usage::

    python bench/wire.py --lines 200000                 # generated (bench.py's generate())
    python bench/wire.py --program x.ngc --profile p.toml --format gcode --runs 3

The program's planned chunks (:class:`prsxy_post.chain.Ready`, as the interpreter
process makes them) are made first, in this process; then, for each way of sending
them (``whole``: pickled as they are; ``packed``: :func:`prsxy_post.wire.pack_ready`
before and :func:`~prsxy_post.wire.unpack_ready` after), a forked process receives
them all through a :func:`prsxy_post.sinks.pipe` while this one sends them. It
prints the MB sent, this process's CPU to pack and send them, and the receiving
process's CPU to read and unpack them (thread CPU seconds: on a loaded machine
compare runs made side by side). With ``--format gcode`` it measures what would
cross: corrected G-code's interpreter runs in the chain's process, partly for this
cost (``Dialect.interpreter_apart``, docs/measurements.md).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import bench  # noqa: E402
from prsxy_post import convert, sinks, wire  # noqa: E402
from prsxy_post.files import load_profile  # noqa: E402


def readies(program: str, profile: str, fmt: str) -> tuple[list[Any], bool]:
    """The program's planned chunks, and whether the chain reads their plans."""
    job = convert.ConvertJob(program, profile, fmt, "-")
    made: list[Any] = []
    counts = {"lines": 0.0, "motions": 0.0, "parse": 0.0}
    out = list(convert._planned_here(job, load_profile(profile), counts, None, made.append))
    return out, made[0].plan_read


def _receive(conn: Any, answer: Any, packed: bool) -> None:
    c0 = time.thread_time()
    while True:
        msg = conn.recv()
        if msg[0] != "chunk":
            break
        if packed:
            wire.unpack_ready(msg[1])
    answer.send(("cpu", time.thread_time() - c0))


def crossing(chunks: list[Any], plan_read: bool, packed: bool) -> tuple[float, float, float]:
    """(MB sent, sending CPU [s], receiving CPU [s]) of ``chunks`` sent one way."""
    recv, send = sinks.pipe(duplex=False)
    back_r, back_s = sinks.pipe(duplex=False)
    proc = sinks.forked(_receive, recv, back_s, packed)
    recv.close()
    back_s.close()
    nbytes = 0
    write = sinks.Channel._write

    def counted(self: Any, parts: list[Any]) -> None:
        nonlocal nbytes
        nbytes += sum(memoryview(p).nbytes for p in parts)
        write(self, parts)

    sinks.Channel._write = counted  # type: ignore[method-assign]
    try:
        c0 = time.thread_time()
        for ready in chunks:
            send.send(("chunk", wire.pack_ready(ready, plan_read) if packed else ready))
        send.send(("done",))
        cpu = time.thread_time() - c0
    finally:
        sinks.Channel._write = write  # type: ignore[method-assign]
    answer = back_r.recv()
    proc.join()
    return nbytes / 1e6, cpu, answer[1]


def main() -> None:
    args = bench.program_parser(__doc__.split("\n")[0]).parse_args()
    with tempfile.TemporaryDirectory() as d:
        program, profile = bench.program_and_profile(args, Path(d))
        chunks, plan_read = readies(program, profile, args.format)
        points = sum(len(s) for r in chunks for _, s, _ in r.earlier + r.pieces)
        print(f"{len(chunks)} chunks, {points:,} points; the chain reads the plans: {plan_read}")
        for _ in range(args.runs):
            for packed in (False, True):
                mb, sent, got = crossing(chunks, plan_read, packed)
                print(
                    f"{'packed' if packed else 'whole':6s} {mb:7.1f} MB "
                    f"({mb * 1e6 / points:5.1f} B/point) | sending CPU {sent:.3f} s | "
                    f"receiving CPU {got:.3f} s | both {sent + got:.3f} s"
                )


if __name__ == "__main__":
    main()
