"""Where a conversion's text goes: the writer and the output's files.

A dialect's writer turns point chunks into text pieces ``(part, text)``; the
pieces go to temp files beside their targets (``x.pmc``, or ``x.part1.pmc`` …
for split programs), or are held for standard output. Nothing is published
here: the conversion renames the temp files onto their targets once the whole
program has gone through (:func:`prsxy_post.files.publish`).

The writing runs in this process (:class:`WriterHere`) or, for large programs
where processes can fork, in a process of its own (:class:`WriterProcess`),
so formatting and writing the text overlap with the chain. The bytes are the
same either way, and so is the error a user sees: the earliest in the program.

Signals: Ctrl-C reaches every process of the terminal's process group, but only
the process that started the conversion acts on it. A process forked for the
work (:func:`forked`) ignores SIGINT and ends on SIGTERM, removing what it wrote
(its parent sends SIGTERM when it stops); so no child prints a traceback, and a
stop leaves no temp file.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from . import wire
from .errors import ProcessFailed, PrsxyError, write_failed
from .files import temp_beside
from .runtime import crash_text, peak_rss_mb

Piece = tuple[int, str]


#: the signals a stop arrives by: Ctrl-C (to the whole process group) and the
#: SIGTERM a parent sends its children
STOP_SIGNALS = frozenset({signal.SIGINT, signal.SIGTERM})


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM held back in this thread, and delivered when the block
    ends: a stop cannot fall between renaming an output into place and saying so,
    and a process or thread started inside begins with them held (so it can set
    its own handling before any arrives). Does nothing off the main thread, where
    Python runs no signal handler anyway."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, STOP_SIGNALS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _exit_on_term(signum: int, frame: Any) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: the cleanup is not cut short
    raise SystemExit(128 + signum)


def _fork_context() -> Any:
    """multiprocessing's fork context, imported here and not at the top: a single
    conversion of a small program (most commands) never forks, and importing
    multiprocessing is start-up it does not need."""
    import multiprocessing

    return multiprocessing.get_context("fork")


#: bytes a pipe between the processes holds: a chunk of points (MB) goes in one
#: write, not in many of the 64 KiB a pipe holds, each waiting for the reading
#: thread to get the interpreter lock (while the writing process stands)
PIPE_BYTES = 4 << 20


def pipe(duplex: bool) -> tuple[Channel, Channel]:
    """A pipe between this process and one :func:`forked` from it (its ends
    :class:`Channel` s): a pair of connected Unix sockets, whose buffers hold
    :data:`PIPE_BYTES` where the system allows (an OS pipe holds at most 1 MiB
    unprivileged). ``duplex`` says how the caller uses it: both ends send, or
    only the second (the sockets carry either way)."""
    ends = _fork_context().Pipe(duplex=True)
    for end in ends:
        _widen(end.fileno())
    return Channel(ends[0]), Channel(ends[1])


def _widen(fd: int) -> None:
    """Let the socket ``fd`` hold :data:`PIPE_BYTES` each way (Linux doubles the
    value asked for, then caps it at net.core.wmem_max and rmem_max). Only the
    speed depends on it."""
    import socket

    with socket.socket(fileno=os.dup(fd)) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, PIPE_BYTES)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, PIPE_BYTES)


class Channel:
    """One end of a pipe between the processes of a conversion: ``send`` and
    ``recv`` objects as :class:`multiprocessing.connection.Connection` does, but
    pickled with protocol 5 and their arrays' bytes out of band: written from the
    arrays' own memory and read into the memory of the arrays rebuilt, in a few
    large reads and writes (a chunk of points is MB: Connection copies it through
    the pickle, a buffer and 64 KiB reads, three times the CPU). The arrays
    rebuilt lie in one block of memory, each :data:`ALIGN` bytes aligned from its
    start, and can be written to.

    Raises as Connection does: EOFError when the other end closed, OSError when
    writing to a closed pipe, whatever unpickling raises for what cannot be read.
    """

    #: where each rebuilt array starts in the received bytes [bytes]
    ALIGN = 64
    #: numpy asks the kernel for huge pages (madvise) for an array of this many
    #: bytes or more, whose first touch by the read then costs more CPU than
    #: zeroing a bytearray does (the chain's reading thread on a 200k-line G-code
    #: conversion, bench/timeline.py: 0.23-0.38 s against 0.21-0.22 s); below
    #: it, memory not zeroed first saves the zeroing (PMAC: 0.124-0.133 s -> 0.075-0.088 s)
    HUGE_PAGES_FROM = 4 << 20

    def __init__(self, conn: Any) -> None:
        self.conn = conn
        self.fd: int = conn.fileno()

    def fileno(self) -> int:
        return self.fd

    def poll(self, timeout: float | None = 0.0) -> bool:
        ready: bool = self.conn.poll(timeout)
        return ready

    def close(self) -> None:
        self.conn.close()

    def send(self, obj: Any) -> None:
        import pickle
        import struct

        bufs: list[pickle.PickleBuffer] = []
        data = pickle.dumps(obj, protocol=5, buffer_callback=bufs.append)
        raws = [b.raw() for b in bufs]
        sizes = [r.nbytes for r in raws]
        head = struct.pack(f"<QI{len(sizes)}Q", len(data), len(sizes), *sizes)
        parts: list[Any] = [struct.pack("<I", len(head)) + head, data]
        pad = b"\0" * self.ALIGN
        for r in raws:
            parts += [r, pad[: -r.nbytes % self.ALIGN]]
        self._write(parts)

    def _write(self, parts: list[Any]) -> None:
        views = [memoryview(p).cast("B") for p in parts if len(p)]
        while views:
            n = os.writev(self.fd, views[:512])
            while n:
                if n >= views[0].nbytes:
                    n -= views[0].nbytes
                    views.pop(0)
                else:
                    views[0] = views[0][n:]
                    n = 0

    def recv(self) -> Any:
        import pickle
        import struct

        (n_head,) = struct.unpack("<I", self._read(4))
        head = self._read(n_head)
        n_data, n_bufs = struct.unpack_from("<QI", head)
        sizes = struct.unpack_from(f"<{n_bufs}Q", head, 12)
        spans = [size + (-size % self.ALIGN) for size in sizes]
        data = bytearray(n_data)
        size = sum(spans)
        # not zeroed first where numpy does not ask for huge pages (bytearray(n)
        # writes every byte once more before the read writes it)
        body = (
            np.empty(size, dtype=np.uint8).data
            if size < self.HUGE_PAGES_FROM
            else memoryview(bytearray(size))
        )
        self._read_into([memoryview(data), body])
        views, at = [], 0
        for size, span in zip(sizes, spans, strict=True):
            views.append(body[at : at + size])
            at += span
        return pickle.loads(data, buffers=views)

    def _read(self, n: int) -> bytearray:
        out = bytearray(n)
        self._read_into([memoryview(out)])
        return out

    def _read_into(self, views: list[memoryview]) -> None:
        views = [v for v in views if v.nbytes]
        while views:
            n = os.readv(self.fd, views)
            if n == 0:
                raise EOFError("the other end of the pipe closed")
            while n:
                if n >= views[0].nbytes:
                    n -= views[0].nbytes
                    views.pop(0)
                else:
                    views[0] = views[0][n:]
                    n = 0


def forked(target: Callable[..., None], *args: Any) -> Any:
    """Start ``target(*args)`` in a forked process that ignores Ctrl-C (its parent
    handles it) and, on SIGTERM, raises SystemExit, so its ``finally`` and
    ``except`` blocks clean up and it ends without a traceback. The process
    starts with the stop signals held (:func:`signals_held`) until its handling
    is set."""
    ctx = _fork_context()
    sys.stdout.flush()
    sys.stderr.flush()
    with signals_held():
        proc = ctx.Process(target=_child, args=(target, *args), daemon=True)
        proc.start()
    return proc


def _child(target: Callable[..., None], *args: Any) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _exit_on_term)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, STOP_SIGNALS)
    target(*args)


def how_it_ended(proc: Any) -> str:
    """What became of a child process, for a message: "killed by SIGKILL", "exit
    status 1"."""
    proc.join(timeout=1.0)
    code = proc.exitcode
    if code is None:
        return "still running"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


def stop(proc: Any, timeout: float = 10.0) -> None:
    """End a child process started by :func:`forked`: SIGTERM (it cleans up and
    exits), then SIGKILL if it has not ended within ``timeout`` seconds."""
    if proc.is_alive():
        proc.terminate()
        proc.join(timeout)
    if proc.is_alive():
        proc.kill()
    proc.join()


def remove_leftovers(out: str) -> None:
    """Remove the temp files :class:`Parts` makes for the output ``out`` (or its
    parts) that are still on disk: a process killed before it could remove its
    own left them."""
    if out == "-":
        return
    target = Path(out)
    base, ext = (re.escape(x) for x in os.path.splitext(target.name))
    ours = re.compile(rf"\.{base}(\.part\d+)?{ext}\.[^.]+\.tmp")
    for tmp in target.parent.glob(".*.tmp"):
        if ours.fullmatch(tmp.name):
            tmp.unlink(missing_ok=True)


def part_path(out: str, part: int, split: bool) -> str:
    """The file of one part: the output itself, or ``base.partN.ext`` when split."""
    if not split:
        return out
    base, ext = os.path.splitext(out)
    return f"{base}.part{part + 1}{ext}"


#: a part's text is put on disk (``fdatasync``) each time this much more of it
#: [characters: the text is ASCII, bytes] has been written, so the disk writes as
#: the conversion runs and the end waits only for the rest: the last ``fsync`` of
#: a 69 MB PMAC program took 0.04 s of the command's wall time on its own
#: (``bench/timeline.py --lines 200000``: the writer ran 0.047 s after the chain's
#: last chunk)
SYNC_CHARS = 8 << 20


@dataclass
class Parts:
    """The output's parts as temp files beside their targets (or in memory for
    standard output, ``output == "-"``), each on disk at :meth:`close`."""

    output: str
    split: bool
    temps: dict[int, str] = field(default_factory=dict)
    memory: dict[int, list[str]] = field(default_factory=dict)
    _files: dict[int, Any] = field(default_factory=dict)
    _unsynced: dict[int, int] = field(default_factory=dict)

    def emit(self, pieces: list[Piece]) -> None:
        for part, text in pieces:
            if self.output == "-":
                self.memory.setdefault(part, []).append(text)
                continue
            if part not in self._files:
                fd, tmp = temp_beside(Path(part_path(self.output, part, self.split)))
                self.temps[part] = tmp
                self._files[part] = os.fdopen(fd, "w", encoding="utf-8", newline="\n")
                self._unsynced[part] = 0
            fh = self._files[part]
            fh.write(text)
            self._unsynced[part] += len(text)
            if self._unsynced[part] >= SYNC_CHARS:
                fh.flush()
                _datasync(fh.fileno())
                self._unsynced[part] = 0

    def close(self) -> None:
        """Every part complete on disk."""
        for fh in self._files.values():
            fh.flush()
            os.fsync(fh.fileno())
            fh.close()

    def discard(self) -> None:
        """Close and remove every temp file (a failed conversion leaves none)."""
        for fh in self._files.values():
            if not fh.closed:
                fh.close()
        for tmp in self.temps.values():
            if os.path.exists(tmp):
                os.unlink(tmp)


def _datasync(fd: int) -> None:
    """The file's data on disk (``fdatasync``; ``fsync`` where the system has no
    such call): :meth:`Parts.close`'s ``fsync`` then has only the rest to write."""
    getattr(os, "fdatasync", os.fsync)(fd)


@dataclass
class Written:
    """What the writing left: temp file per part, the text per part for standard
    output, the seconds the writer took, and the writer process's peak memory
    [MB] (None when it wrote in this process)."""

    temps: dict[int, str]
    memory: dict[int, list[str]]
    seconds: float
    peak_rss_mb: float | None = None


class WriterHere:
    """The writer in this process: each chunk is written as it comes."""

    def __init__(self, writer: Any, parts: Parts) -> None:
        self.writer = writer
        self.parts = parts
        self.seconds = 0.0

    def _run(self, method: str, *args: Any) -> None:
        t0 = time.process_time()
        self.parts.emit(getattr(self.writer, method)(*args))
        self.seconds += time.process_time() - t0

    def begin(self) -> None:
        self._run("begin")

    def feed(self, chunk: Any) -> None:
        self._run("feed", chunk)

    def finish(self) -> Written:
        """Write the end and close every part; raises the writer's error."""
        self._run("finish")
        self.parts.close()
        return Written(self.parts.temps, self.parts.memory, self.seconds)

    def earlier_error(self) -> PrsxyError | None:
        """The writer's error on a chunk before the one the chain failed on: none
        here, every chunk was written (or failed) as it came."""
        return None

    def discard(self) -> None:
        self.parts.discard()


def _serve(conn: Any, here: WriterHere) -> None:
    """The writer process: ("begin",), ("feed", chunk)… then ("finish",), answered
    with ("done", Written) or ("error", PrsxyError) / ("crash", text); or
    ("check",), answered with the first error so far or ("ok",); or
    ("discard",). After an error the chunks still coming are read and dropped,
    so the chain never writes into a closed pipe. On SIGTERM (:func:`stop`) or
    anything else that ends it early, it removes its temp files first."""
    failed: tuple[str, Any] | None = None
    try:
        while True:
            msg = conn.recv()
            kind = msg[0]
            if kind == "discard":
                here.discard()
                return
            if kind == "check":
                conn.send(failed or ("ok",))
                continue
            if failed is None:
                try:
                    if kind == "begin":
                        here.begin()
                    elif kind == "feed":
                        here.feed(_chunk(msg[1]))
                    elif kind == "finish":
                        written = here.finish()
                        written.peak_rss_mb = peak_rss_mb()
                        conn.send(("done", written))
                        return
                except PrsxyError as err:
                    failed = ("error", err)
                except OSError as exc:
                    # as the conversion says it when it writes in its own process
                    failed = ("error", write_failed(exc, here.parts.output))
                except Exception:
                    failed = ("crash", crash_text())
            if kind == "finish":
                assert failed is not None
                here.discard()
                conn.send(failed)
                return
    except SystemExit:
        here.discard()
        raise
    except BaseException:
        here.discard()
        with contextlib.suppress(Exception):
            conn.send(("crash", crash_text()))
    finally:
        conn.close()


def _fields(chunk: Any, names: tuple[str, ...]) -> dict[str, Any]:
    """The fields ``names`` of a point chunk in their narrowest exact form
    (:func:`.wire.pack_points`), for :func:`_chunk` to rebuild."""
    return wire.pack_points(chunk, names)


def _chunk(sent: Any) -> Any:
    """A point chunk from what :class:`WriterProcess` sent: the whole chunk, or
    the fields its writer reads (:func:`_fields`); the others None, so that a
    writer reading one it did not declare fails loudly."""
    if not isinstance(sent, dict):
        return sent
    return wire.unpack_points(sent)


class WriterProcess:
    """The writer in a process of its own (forked with the writer and parts as
    made here, before any text): the chain sends each chunk down a pipe and goes
    on. The pipe's buffer is the only queue, and the writer keeps up with the
    chain, so memory stays bounded."""

    def __init__(self, writer: Any, parts: Parts) -> None:
        self.conn, child = pipe(duplex=True)
        self.proc = forked(_serve, child, WriterHere(writer, parts))
        child.close()
        self.reads: tuple[str, ...] | None = getattr(writer, "reads", None)
        self.output = parts.output
        self.done = False
        self.result: Written | None = None

    def _died(self) -> ProcessFailed:
        return ProcessFailed(
            f"the writer process ended without a result ({how_it_ended(self.proc)}); "
            f"{self.output} not written"
        )

    def _send(self, *msg: Any) -> None:
        try:
            self.conn.send(msg)
        except OSError:
            # only the writer reads this pipe, and it closes it only as it ends
            self.proc.join(timeout=1.0)
            if self.proc.is_alive():
                raise
            raise self._died() from None

    def begin(self) -> None:
        self._send("begin")

    def feed(self, chunk: Any) -> None:
        # only what the writer reads crosses (a third of a chunk's bytes for PMAC)
        self._send("feed", chunk if self.reads is None else _fields(chunk, self.reads))

    def _answer(self) -> tuple[Any, ...]:
        try:
            return self.conn.recv()
        except (EOFError, OSError):
            raise self._died() from None

    def finish(self) -> Written:
        self._send("finish")
        msg = self._answer()
        if msg[0] == "done":
            self.result = msg[1]
        self.done = True
        self.proc.join()
        if msg[0] == "done":
            return msg[1]
        if msg[0] == "error":
            raise msg[1]
        raise RuntimeError("in the writer process:\n" + msg[1])

    def earlier_error(self) -> PrsxyError | None:
        """The writer's error on a chunk sent before the one the chain failed on
        (it is earlier in the program, so it is the one to report)."""
        if self.done or not self.proc.is_alive():
            return None
        try:
            self._send("check")
        except OSError:
            return None
        msg = self._answer()
        if msg[0] == "error":
            return msg[1]
        if msg[0] == "crash":
            raise RuntimeError("in the writer process:\n" + msg[1])
        return None

    def discard(self) -> None:
        """Stop the writer and remove its temp files: it removes them itself when
        stopped (:func:`stop`); after ``finish`` they are this process's to remove."""
        stop(self.proc)
        if self.result is not None:
            for tmp in self.result.temps.values():
                if os.path.exists(tmp):
                    os.unlink(tmp)
        elif self.proc.exitcode is None or self.proc.exitcode < 0:
            # killed before it could remove its own (SIGKILL, the OOM killer)
            remove_leftovers(self.output)
        self.conn.close()


def can_fork() -> bool:
    """Whether this platform forks processes (multiprocessing's "fork" start)."""
    import multiprocessing

    return "fork" in multiprocessing.get_all_start_methods()
