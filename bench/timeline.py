"""Timeline of a parallel conversion: its processes, when each works and waits.

Usage::

    python bench/timeline.py --lines 200000               # generated (bench.py's generate())
    python bench/timeline.py --lines 200000 --format gcode
    python bench/timeline.py --program x.ngc --profile p.toml --runs 3

``convert_file`` runs as the ``convert`` command runs it (``parallel=True``): an
interpreter process (read, interpret, plan, the map and the IK; with G-code output
none, this process doing its work: ``Dialect.interpreter_apart``), this process (the
rest of the chain) and a writer process (text). The script wraps, in this process
before the others are forked from it, the pipe's ``send`` and ``recv``
(:class:`prsxy_post.sinks.Channel`), the interpreter's chunk generator, the
chain's ``feed_ready``, the writer's ``feed`` and the queue between this process's
reading thread and its chain, and logs each call's wall and CPU time (one file per
process). It prints, per process: when it starts and ends (seconds from the start
of ``convert_file``), its CPU, the time it works, the time it waits for the
process before it (a message) or after it (a full pipe), what it sends (messages,
MB, seconds pickling and writing); when the first chunk reaches this process and
the writer, how long the writer runs after this process sent its last chunk; and a
strip per process (``#`` working, ``-`` sending, ``.`` waiting, one character a
slot). The figures are wall-clock seconds on a machine that may be loaded: compare
runs made side by side, and look at CPU against wall.
"""

from __future__ import annotations

import contextlib
import json
import os
import queue
import sys
import tempfile
import threading
import time
import types
from collections import defaultdict
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "bench"))

import bench  # noqa: E402
from prsxy_post import allocator, chain, convert, sinks  # noqa: E402

_LOG: dict[str, Any] = {"dir": "", "role": "main", "pid": -1, "fh": None}


def _emit(kind: str, t0: float, t1: float, cpu: float, **extra: Any) -> None:
    """One event of this process (its role: main, interp, writer) to its log file."""
    if _LOG["pid"] != os.getpid():  # a forked process writes a file of its own
        _LOG["pid"] = os.getpid()
        path = os.path.join(_LOG["dir"], f"{os.getpid()}.jsonl")
        _LOG["fh"] = open(path, "a", buffering=1)  # lives with the process
    rec = {
        "role": _LOG["role"],
        "thread": threading.current_thread().name,
        "kind": kind,
        "t0": t0,
        "t1": t1,
        "cpu": cpu,
        **extra,
    }
    _LOG["fh"].write(json.dumps(rec) + "\n")


def _timed(kind: str, fn: Any, *args: Any, **extra: Any) -> Any:
    t0, c0 = time.perf_counter(), time.thread_time()
    try:
        return fn(*args)
    finally:
        _emit(kind, t0, time.perf_counter(), time.thread_time() - c0, **extra)


def _install() -> None:
    """Wrap the conversion's calls (in this process, before any fork)."""
    _install_channel()
    _install_stages()


def _install_channel() -> None:
    """sinks.Channel's send and recv, logged with their bytes and waits."""
    send, write, recv, read_into = (
        sinks.Channel.send,
        sinks.Channel._write,
        sinks.Channel.recv,
        sinks.Channel._read_into,
    )
    local = threading.local()

    def t_write(self: Any, parts: list[Any]) -> None:
        local.nbytes = sum(memoryview(p).nbytes for p in parts)
        _timed("write", write, self, parts)

    def t_send(self: Any, obj: Any) -> None:
        local.nbytes = 0
        t0, c0 = time.perf_counter(), time.thread_time()
        send(self, obj)
        kind = obj[0] if isinstance(obj, tuple) and obj and isinstance(obj[0], str) else "?"
        _emit(
            "send",
            t0,
            time.perf_counter(),
            time.thread_time() - c0,
            msg=kind,
            nbytes=local.nbytes,
        )

    def t_read_into(self: Any, views: list[memoryview]) -> None:
        local.nbytes = getattr(local, "nbytes", 0) + sum(v.nbytes for v in views)
        read_into(self, views)

    def t_recv(self: Any) -> Any:
        t0, c0 = time.perf_counter(), time.thread_time()
        self.conn.poll(None)  # the wait for a message, apart from reading it
        t1 = time.perf_counter()
        local.nbytes = 0
        try:
            obj = recv(self)
        except BaseException:
            _emit("recv", t0, time.perf_counter(), time.thread_time() - c0, wait=t1 - t0)
            raise
        kind = obj[0] if isinstance(obj, tuple) and obj and isinstance(obj[0], str) else "?"
        _emit(
            "recv",
            t0,
            time.perf_counter(),
            time.thread_time() - c0,
            wait=t1 - t0,
            msg=kind,
            nbytes=local.nbytes,
        )
        return obj

    sinks.Channel.send = t_send  # type: ignore[method-assign]
    sinks.Channel._write = t_write  # type: ignore[method-assign]
    sinks.Channel.recv = t_recv  # type: ignore[method-assign]
    sinks.Channel._read_into = t_read_into  # type: ignore[method-assign]


def _install_stages() -> None:
    """The processes' roles and lives, their work and the queue to the chain."""
    planning_child, serve, planned_here = (
        convert._planning_child,
        sinks._serve,
        convert._planned_here,
    )

    def as_role(role: str, fn: Any) -> Any:
        def run(*args: Any) -> None:
            _LOG["role"] = role
            t0 = time.perf_counter()
            try:
                fn(*args)
            finally:
                _emit("life", t0, time.perf_counter(), time.process_time())

        return run

    def t_planned_here(*args: Any) -> Iterator[Any]:
        chunks = planned_here(*args)
        while True:
            t0, c0 = time.perf_counter(), time.thread_time()
            try:
                ready = next(chunks)
            except StopIteration:
                return
            _emit("chunk", t0, time.perf_counter(), time.thread_time() - c0)
            yield ready

    convert._planning_child = as_role("interp", planning_child)  # type: ignore[assignment]
    sinks._serve = as_role("writer", serve)
    convert._planned_here = t_planned_here  # type: ignore[assignment]

    feed_ready, w_feed = chain.Pipeline.feed_ready, sinks.WriterHere.feed

    def t_feed_ready(self: Any, ready: Any) -> Any:
        return _timed("chain", feed_ready, self, ready)

    def t_w_feed(self: Any, chunk: Any) -> None:
        _timed("text", w_feed, self, chunk, points=len(chunk))

    chain.Pipeline.feed_ready = t_feed_ready  # type: ignore[method-assign]
    sinks.WriterHere.feed = t_w_feed  # type: ignore[method-assign]

    class TimedQueue(queue.Queue):  # type: ignore[type-arg]
        """The queue from the reading thread to the chain: its waits logged."""

        def get(self, block: bool = True, timeout: float | None = None) -> Any:
            return _timed("qget", super().get, block, timeout)

        def put(self, item: Any, block: bool = True, timeout: float | None = None) -> None:
            _timed("qput", super().put, item, block, timeout)

    convert.queue = types.SimpleNamespace(  # type: ignore[assignment]
        Queue=TimedQueue, Empty=queue.Empty, Full=queue.Full
    )


def _load(log_dir: str) -> dict[str, list[dict[str, Any]]]:
    by_role: dict[str, list[dict[str, Any]]] = defaultdict(list)
    for path in Path(log_dir).glob("*.jsonl"):
        for line in path.read_text().splitlines():
            rec = json.loads(line)
            by_role[rec["role"]].append(rec)
    return by_role


def _sum(evs: list[dict[str, Any]], key: str = "wall") -> float:
    if key == "wall":
        return sum(e["t1"] - e["t0"] for e in evs)
    return float(sum(e.get(key, 0.0) for e in evs))


def _strip(spans: list[tuple[float, float, str]], t_end: float, width: int) -> str:
    """One character a slot of t_end / width seconds: the kind covering most of it."""
    slot = t_end / width
    cover: list[dict[str, float]] = [defaultdict(float) for _ in range(width)]
    for a, b, ch in spans:
        i = max(0, int(a / slot))
        while i < width and i * slot < b:
            lo, hi = max(a, i * slot), min(b, (i + 1) * slot)
            if hi > lo:
                cover[i][ch] += hi - lo
            i += 1
    return "".join(max(c, key=lambda k: c[k]) if c else " " for c in cover)


def report(by_role: dict[str, list[dict[str, Any]]], t_start: float, t_end: float) -> str:
    """The figures and strips of one conversion (seconds from its start)."""
    out = []
    total = t_end - t_start
    out.append(f"convert_file wall {total:.3f} s")
    rows = []
    strips = {}
    width = 100
    for role, work_kind in (("interp", "chunk"), ("main", "chain"), ("writer", "text")):
        evs = by_role.get(role, [])
        if not evs:
            continue
        life = [e for e in evs if e["kind"] == "life"]
        if role == "main":
            t0, t1, cpu = t_start, t_end, next(e["cpu"] for e in evs if e["kind"] == "total")
        else:
            t0, t1, cpu = life[0]["t0"], life[0]["t1"], life[0]["cpu"]
        work = [e for e in evs if e["kind"] == work_kind]
        sends = [e for e in evs if e["kind"] == "send" and e["thread"] == "MainThread"]
        writes = [e for e in evs if e["kind"] == "write" and e["thread"] == "MainThread"]
        recvs = [e for e in evs if e["kind"] == "recv" and e["thread"] == "MainThread"]
        waits = (
            [e for e in evs if e["kind"] == "qget"]
            if role == "main"
            else [dict(e, t1=e["t0"] + e["wait"]) for e in recvs]
        )
        pump = [e for e in evs if e["kind"] == "recv" and e["thread"] != "MainThread"]
        nbytes = sum(e.get("nbytes", 0) for e in sends)
        chunk_sends = [e for e in sends if e.get("msg") in ("chunk", "feed")]
        rows.append(
            f"{role:7s} start {t0 - t_start:6.3f} end {t1 - t_start:6.3f} "
            f"wall {t1 - t0:6.3f} CPU {cpu:6.3f} | work {_sum(work):6.3f} s "
            f"(CPU {_sum(work, 'cpu'):6.3f}) | waits for input {_sum(waits):6.3f} s"
            + (f" (receiving: CPU {_sum(recvs, 'cpu'):.3f})" if role != "main" and recvs else "")
            + " | "
            + f"sends {len(sends)} msgs {nbytes / 1e6:6.1f} MB in {_sum(sends):6.3f} s "
            f"(CPU {_sum(sends, 'cpu'):.3f}; writing {_sum(writes):.3f}, "
            f"max MB/chunk {max((e['nbytes'] for e in chunk_sends), default=0) / 1e6:.2f})"
        )
        if pump:
            rows.append(
                f"        reading thread: {len(pump)} msgs "
                f"{sum(e.get('nbytes', 0) for e in pump) / 1e6:.1f} MB, "
                f"reading {_sum(pump) - _sum(pump, 'wait'):.3f} s "
                f"(CPU {_sum(pump, 'cpu'):.3f}); blocked on the full queue "
                f"{_sum([e for e in evs if e['kind'] == 'qput']):.3f} s"
            )
        spans = [(e["t0"] - t_start, e["t1"] - t_start, "#") for e in work]
        spans += [(e["t0"] - t_start, e["t1"] - t_start, "-") for e in sends]
        spans += [(e["t0"] - t_start, e["t1"] - t_start, ".") for e in waits]
        strips[role] = _strip(spans, total, width)
        if role == "interp" and work:
            rest = work[1:] or work
            rows.append(
                f"        first chunk made in {work[0]['t1'] - work[0]['t0']:.3f} s "
                f"(CPU {work[0]['cpu']:.3f}), the others in {_sum(rest) / len(rest):.3f} s "
                f"(CPU {_sum(rest, 'cpu') / len(rest):.3f}) on average"
            )
        if role == "main":
            first = min((e["t1"] for e in waits), default=t_start)
            out_last = max((e["t1"] for e in chunk_sends), default=t_start)
            rows.append(
                f"        first chunk in after {first - t_start:.3f} s; "
                f"last chunk to the writer at {out_last - t_start:.3f} s; "
                f"{len(work)} chunks through the chain"
            )
        if role == "writer":
            feeds = [e for e in recvs if e.get("msg") == "feed"]
            if feeds:
                rows.append(
                    f"        first chunk in after {feeds[0]['t1'] - t_start:.3f} s; "
                    f"runs {t1 - max(e['t1'] for e in by_role['main'] if e['kind'] == 'send'):.3f}"
                    f" s after the last message from main; {len(work)} chunks, "
                    f"{sum(e['points'] for e in work):,} points"
                )
    out += rows
    out.append("")
    out.append(f"one character = {total / width * 1000:.1f} ms; # works, - sends, . waits")
    for role, s in strips.items():
        out.append(f"{role:7s}|{s}|")
    return "\n".join(out)


def run_once(program: str, profile: str, fmt: str, output: str) -> str:
    with tempfile.TemporaryDirectory() as log_dir:
        _LOG.update(dir=log_dir, role="main", pid=-1)
        allocator.keep_freed_memory()  # as the command (cli.run)
        t0, c0 = time.perf_counter(), time.process_time()
        job = convert.ConvertJob(program, profile, fmt, output, options="bench", parallel=True)
        convert.convert_file(job)
        t1 = time.perf_counter()
        _emit("total", t0, t1, time.process_time() - c0)
        with contextlib.suppress(Exception):
            _LOG["fh"].close()
        _LOG["pid"] = -1
        return report(_load(log_dir), t0, t1)


def main() -> None:
    args = bench.program_parser(__doc__.split("\n")[0]).parse_args()
    _install()
    with tempfile.TemporaryDirectory() as d:
        program, profile = bench.program_and_profile(args, Path(d))
        suffix = ".pmc" if args.format == "pmac" else ".out.ngc"
        for i in range(args.runs):
            output = os.path.join(d, f"out{i}{suffix}")
            print(run_once(program, profile, args.format, output))
            print()
            os.unlink(output)


if __name__ == "__main__":
    main()
