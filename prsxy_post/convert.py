"""Converting programs: G-code files in, controller programs out, streamed.

The library's conversion engine (the ``convert`` command is a thin shell over
:func:`convert_file` and :func:`convert_many`). A program is read as a stream of
line batches, interpreted, and fed chunk by chunk through the compensation
chain (:mod:`prsxy_post.chain`) into the dialect's writer; memory stays flat on
programs of millions of lines. A program of :data:`PARALLEL_FROM_BYTES` or more
may have its text formatted and written in a second process
(:mod:`prsxy_post.sinks`) while this one runs the chain, and, where the output's
dialect leaves a core for it (``Dialect.interpreter_apart``: PMAC's light writer
does, G-code's, which solves the FK at every point, does not), be read, interpreted
and planned, and its points put through the error map and the IK, in a third,
while this one runs the rest of the chain (reversals, real-axis tables, play, servo
lead); the output is byte for byte the same.

Example
-------
>>> from prsxy_post.convert import ConvertJob, convert_file
>>> stats = convert_file(ConvertJob("part.ngc", "shop.toml", "pmac", "part.pmc"))
... # doctest: +SKIP
"""

from __future__ import annotations

import contextlib
import os
import queue
import sys
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any

from . import sinks, wire, writers
from .chain import Stages
from .errors import ProcessFailed, PrsxyError, write_failed
from .files import (
    inspect_source,
    load_profile,
    publish,
    read_text,
    refuse_to_overwrite,
    sha256_of,
)
from .program import iter_program_batches
from .runtime import crash_text, few_gc_passes, peak_rss_mb


@dataclass(frozen=True)
class ConvertJob:
    """One program to convert.

    program : G-code file, or "-" for standard input
    profile_path : the machine profile (TOML)
    fmt : output dialect ("pmac" or "gcode")
    output : a path, or "-" for standard output; split parts get .partN before
        the suffix
    start : start pose (x, y, z, a, b) [mm, deg]; default the profile's
    stages : which compensation stages run
    options : how it was asked for, for the output's header
    chunk : motions per chunk through the chain (the output does not depend on it);
        None: the output's own, :data:`CHUNK_MOTIONS`
    parallel : write the output in a second process and, where the dialect says so
        (``interpreter_apart``), read, interpret and plan the program, and solve its
        points' map and IK, in a third, while this one runs the rest of the chain
        (the output is the same; only the wall time changes)
    on_message : receives the program's messages (gcode.InterpreterConfig)
    """

    program: str
    profile_path: str
    fmt: str
    output: str  # a path, or "-" for standard output; parts get .partN before the suffix
    start: tuple[float, ...] | None = None
    stages: Stages = field(default_factory=Stages)
    options: str = ""
    chunk: int | None = None
    parallel: bool = False
    #: the program's (MSG/DEBUG/PRINT): on_message(source, line, kind, text)
    on_message: Callable[[str, int, str, str], None] | None = None


@dataclass
class ConvertStats:
    """What a conversion did, for the benchmark: paths, counts and seconds per stage.

    ``timings`` are CPU seconds (``time.process_time``) of each stage in the
    process that runs it: with the interpreter and writer processes running at
    the same time as the main one, a wall clock would count the time a process
    waited for a core."""

    written: list[str]
    lines: int = 0
    motions: int = 0
    points: int = 0
    timings: dict[str, float] | None = None
    #: peak resident memory of the interpreter process [MB] when one ran
    helper_peak_rss_mb: float | None = None
    #: peak resident memory of the writer process [MB] when one ran
    writer_peak_rss_mb: float | None = None


def _planned_here(
    job: ConvertJob,
    prof: Any,
    counts: dict[str, float],
    bar: Any = None,
    planning_made: Callable[[Any], None] | None = None,
) -> Iterator[Any]:
    """The program's motions, chunk by chunk, through :func:`chain.prepare`, the
    planner and the map and IK of its pieces' points (:class:`chain.Planning`,
    :meth:`~chain.Planning.cut`), the last one final; ``planning_made`` is given
    the :class:`chain.Planning` before the first chunk."""
    from . import chain, gcode, program

    cfg = program.interpreter_config(prof, job.start, on_message=job.on_message)

    def counted(batches: Iterator[list[str]]) -> Iterator[list[str]]:
        for batch in batches:
            counts["lines"] += len(batch)
            yield batch

    batches = (
        iter_program_batches(job.program, bar)
        if job.program != "-"
        else gcode.batches_of(gcode.split_lines(read_text("-", "G-code program")))
    )
    # a program whose loops and calls jump back reads those lines again from the file
    lines_from = gcode.FileLines(job.program) if job.program != "-" else None
    # the moves of the compiled fast path come as rows, never a Motion each
    items = gcode.iter_motion_items(counted(batches), cfg, job.program, lines_from=lines_from)
    from . import errormap

    dialect = writers.dialect(job.fmt)
    planning = chain.Planning(
        prof,
        job.stages,
        errormap.from_profile(prof) if job.stages.error_map else None,
        segment=dialect.segment,
        max_part_points=dialect.parts(writers.settings_of(prof, job.fmt)),
    )
    if planning_made is not None:
        planning_made(planning)
    limits = planning.limits
    size = job.chunk if job.chunk is not None else CHUNK_MOTIONS[dialect.segment]
    chunks = gcode.rows.chunks(items, size)
    while True:
        t0 = time.process_time()
        batch = gcode.rows.table(next(chunks))
        prepared = chain.prepare(batch, prof, limits)
        counts["parse"] += time.process_time() - t0
        counts["motions"] += len(batch)
        yield planning.cut(planning.plan(prepared), solve=True)
        if len(batch) < size:
            last = planning.plan(chain.prepare([], prof, limits), final=True)
            yield planning.cut(last, solve=True)
            return


def _planning_child(conn: Any, job: ConvertJob, prof: Any) -> None:
    """Runs in the interpreter process: sends ("chunk", chain.Ready, chars read),
    then ("done", counts, peak MB, chars read), or ("error", PrsxyError) / ("crash", text).
    Stopped (SIGTERM, :func:`sinks.stop`), it just ends: nobody reads any more."""
    chars = [0]

    def progress(n: int) -> None:
        chars[0] = n

    counts = {"lines": 0.0, "motions": 0.0, "parse": 0.0}
    made: list[Any] = []
    _make_way()
    try:
        for ready in _planned_here(job, prof, counts, progress, made.append):
            # only what the chain reads crosses, in its narrowest exact form
            conn.send(("chunk", wire.pack_ready(ready, made[0].plan_read), chars[0]))
        conn.send(("done", counts, peak_rss_mb(), chars[0]))
    except PrsxyError as err:
        conn.send(("error", err, counts))
    except SystemExit:
        raise
    except BaseException:
        conn.send(("crash", crash_text(), counts))
    finally:
        conn.close()


@contextlib.contextmanager
def _planned_chunks(
    job: ConvertJob, prof: Any, counts: dict[str, float], bar: Any
) -> Iterator[Iterator[Any]]:
    """Planned chunks of the program (read, interpreted, planned and sampled, cut
    into pieces whose points' map and IK are solved: :class:`chain.Ready`), made
    here or, with ``job.parallel`` where processes can fork and the dialect keeps
    its interpreter apart, by a second process that runs ahead, at most
    :data:`AHEAD` chunks (a bounded queue, then the pipe, hold it back), so memory
    stays bounded. Errors arrive in program order: every
    chunk before a G-code error is delivered first, as when run here."""
    apart = job.parallel and writers.dialect(job.fmt).interpreter_apart
    if not apart or job.program == "-" or not sinks.can_fork():
        yield _planned_here(job, prof, counts, bar)
        return
    recv, send = sinks.pipe(duplex=False)
    proc = sinks.forked(_planning_child, send, job, prof)
    send.close()

    # a thread takes chunks off the pipe as they come, so the interpreter runs up
    # to AHEAD chunks ahead while this process is busy (a queue, not the pipe's
    # 64 KiB, holds them): chunk times vary, and neither side waits for the other
    ahead: queue.Queue[tuple[Any, ...]] = queue.Queue(
        maxsize=AHEAD[writers.dialect(job.fmt).segment]
    )
    stop = threading.Event()

    def pump() -> None:
        while not stop.is_set():
            try:
                msg = recv.recv()
            except (EOFError, OSError):
                msg = ("eof",)
            except BaseException as exc:  # what came cannot be read (it does not unpickle)
                msg = ("unreadable", f"{type(exc).__name__}: {exc}")
            while not stop.is_set():
                try:
                    ahead.put(msg, timeout=0.1)
                    break
                except queue.Full:
                    continue
            if msg[0] != "chunk":
                return

    # started with the stop signals held, which it keeps: they are the main
    # thread's to handle (sinks.signals_held)
    pumping = threading.Thread(target=pump, daemon=True)
    with sinks.signals_held():
        pumping.start()

    def died(what: str) -> ProcessFailed:
        return ProcessFailed(f"the interpreter process {what}; no output written")

    def next_message() -> tuple[Any, ...]:
        while True:
            try:
                return ahead.get(timeout=0.5)
            except queue.Empty:
                if not pumping.is_alive() and ahead.empty():
                    raise died("could not be read any more") from None

    def receive() -> Iterator[Any]:
        while True:
            msg = next_message()
            if msg[0] == "eof":
                raise died(f"ended without a result ({sinks.how_it_ended(proc)})")
            if msg[0] == "unreadable":
                raise died(f"sent what cannot be read ({msg[1]})")
            if msg[0] == "chunk":
                if bar is not None:
                    bar(msg[2])
                yield wire.unpack_ready(msg[1])
                continue
            counts.update(msg[2] if msg[0] != "done" else msg[1])
            if msg[0] == "done":
                counts["helper_peak_rss_mb"] = msg[2] or 0.0
                if bar is not None:
                    bar(msg[3])
                return
            if msg[0] == "error":
                raise msg[1]
            raise RuntimeError("in the interpreter process:\n" + msg[1])

    try:
        yield receive()
    finally:
        stop.set()
        sinks.stop(proc)
        pumping.join(timeout=5.0)
        recv.close()


#: motions per chunk through the chain, by how the output moves between its points
#: (the dialect's ``segment``). Straight lines need about 2.4 times the points of
#: cubics for the same motions (they must stay within the chord tolerance), and a
#: chunk's points are the memory of every process: with 4 096 motions a conversion
#: to G-code of bench/bench.py's program at 2 M lines peaked at 301-327 MB (three
#: processes, as G-code's conversion then ran; ten runs), with 3 072 and a
#: look-ahead of two (:data:`AHEAD`) at 278-300 MB (eleven runs), the command as
#: fast (alternating rounds at 2 M and at 200 k lines: the same within their
#: spread; bench/chunk_memory.py)
CHUNK_MOTIONS = {"cubic": 4096, "chord": 3072}

#: chunks the interpreter process may run ahead of the chain (in the queue; the
#: pipe and the thread that fills the queue hold one or two more), by the output's
#: segment as :data:`CHUNK_MOTIONS`. Each is memory of this process: 8.8 MB a chunk
#: of 4 096 motions' points of G-code output. Three keep the chain as fed as eight
#: did (bench/bench.py's program at 200 k lines, both formats, and G-code at 2 M:
#: the same times within their spread) in 45-55 MB less at 2 M lines with G-code
#: output, 17-27 MB less with PMAC output; with G-code's smaller chunks two do (the
#: chord's figures from when G-code's interpreter ran apart, which it no longer
#: does: ``Dialect.interpreter_apart``)
AHEAD = {"cubic": 3, "chord": 2}

#: programs from this size on are converted in parallel (``ConvertJob.parallel``)
PARALLEL_FROM_BYTES = 256 * 1024

#: how far the interpreter process lowers its scheduling priority (nice, :func:`_make_way`)
INTERPRETER_NICE = 5


def _make_way() -> None:
    """The interpreter process lowers its own scheduling priority by
    :data:`INTERPRETER_NICE`. It runs up to :data:`AHEAD` chunks ahead of the chain
    and waits for it most of the time, while the chain and the writer are the
    conversion's slowest steps: where the three processes want more cores than there
    are, those two get them first. With G-code output, when its interpreter ran apart
    (``Dialect.interpreter_apart``), the command took 6-10 % less time
    (``bench/bench.py``, docs/measurements.md); with PMAC output, whose chain is the
    slowest, the same. The system runs the interpreter whenever
    a core is free, and with the session's processes grouped (Linux's autogroup) the
    priority counts only against them. POSIX lets a process lower its own priority;
    a system that refused would change the speed only, never the output, so the
    conversion goes on."""
    try:
        os.nice(INTERPRETER_NICE)
    except OSError:
        pass


def convert_file(
    job: ConvertJob,
    progress: Callable[[int, int], None] | None = None,
    published: Callable[[list[str]], None] | None = None,
) -> ConvertStats:
    """Convert one program, streaming, into its output file(s).

    Outputs go to temp files beside the targets and are renamed only when the
    whole conversion succeeded; on any error, or a stop (KeyboardInterrupt,
    SystemExit), the temp files are removed. With ``output="-"`` the text is
    written to standard output at the end.

    Parameters
    ----------
    job : ConvertJob
    progress : called with (characters read, file size) as the program is read
    published : called with the files written, right after they are renamed into
        place and before a stop (SIGINT, SIGTERM) held meanwhile can arrive: what
        it is told is exactly what is on disk

    Raises
    ------
    PrsxyError
        Located at the program's line (and column) that cannot be converted.
    """
    with few_gc_passes():
        return _convert_file(job, progress, published)


def _convert_file(
    job: ConvertJob,
    progress: Callable[[int, int], None] | None,
    published: Callable[[list[str]], None] | None,
) -> ConvertStats:
    inputs = {"G-code program": job.program, "profile": job.profile_path}
    refuse_to_overwrite(job.output, inputs)
    prof = load_profile(job.profile_path)
    bar = None
    if progress is not None and job.program != "-":
        size = os.path.getsize(job.program)

        def bar(done: int) -> None:
            progress(done, size)

    n_points = 0
    counts = {"lines": 0.0, "motions": 0.0, "parse": 0.0}
    out: sinks.WriterHere | sinks.WriterProcess | None = None
    written_parts: sinks.Written | None = None
    try:
        # the interpreter starts first: with a second process, everything below
        # up to the first chunk happens while it reads
        with _planned_chunks(job, prof, counts, bar) as source:
            from . import chain, errormap

            sha = inspect_source(job.program) if job.program != "-" else ""
            stages = job.stages
            emap = errormap.from_profile(prof) if stages.error_map else None
            prov = writers.Provenance(
                source=job.program,
                source_sha256=sha,
                profile_name=prof.name,
                profile_source=job.profile_path,
                profile_sha256=sha256_of(job.profile_path),
                options=job.options,
                axis_comp=stages.axis_comp,
            )
            dialect = writers.dialect(job.fmt)
            settings = writers.settings_of(prof, job.fmt)
            writer = dialect.make(prof, settings, prov)
            split = dialect.parts(settings) > 0
            pipe = chain.Pipeline(
                prof,
                stages,
                emap,
                start=job.start,
                segment=dialect.segment,
                max_part_points=dialect.parts(settings),
                written=dialect.written(settings),
            )
            parts = sinks.Parts(job.output, split)
            # a large program's text is formatted and written by a third process
            # while this one runs the chain (the interpreter has the second)
            out = (
                sinks.WriterProcess(writer, parts)
                if job.parallel and job.output != "-" and sinks.can_fork()
                else sinks.WriterHere(writer, parts)
            )
            out.begin()
            for ready in source:
                for pc in pipe.feed_ready(ready):
                    n_points += len(pc)
                    out.feed(pc)
        written_parts = out.finish()
        written = _publish_parts(job, written_parts.temps, split, published)
        if job.output == "-":
            memory = written_parts.memory
            sys.stdout.write("".join("".join(memory[k]) for k in sorted(memory)))
            written = ["-"]
        timings = {"parse": counts["parse"], **pipe.timings, "write": written_parts.seconds}
        return ConvertStats(
            written,
            int(counts["lines"]),
            int(counts["motions"]),
            n_points,
            timings,
            counts.get("helper_peak_rss_mb"),
            written_parts.peak_rss_mb,
        )
    except PrsxyError as err:
        # the writer may be behind the chain: its error on an earlier chunk is
        # the earlier one in the program
        earlier = out.earlier_error() if out is not None else None
        raise (earlier or err).located(source=job.program) from None
    except OSError as exc:
        raise write_failed(exc, job.output) from None
    finally:
        if out is not None:
            out.discard()
        if written_parts is not None:
            for tmp in written_parts.temps.values():
                if os.path.exists(tmp):
                    os.unlink(tmp)


def _publish_parts(
    job: ConvertJob,
    temps: dict[int, str],
    split: bool,
    published: Callable[[list[str]], None] | None,
) -> list[str]:
    """Rename the finished parts onto their targets, and say so (``published``)
    before a stop held meanwhile arrives: all of it happens, or none."""
    inputs = {"G-code program": job.program, "profile": job.profile_path}
    targets = [sinks.part_path(job.output, part, split) for part in sorted(temps)]
    for target in targets:  # a part's name (x.part1.pmc) too, before any is published
        refuse_to_overwrite(target, inputs)
    written = []
    with sinks.signals_held():
        for part, target in zip(sorted(temps), targets, strict=True):
            publish(temps[part], target)
            written.append(target)
        if published is not None and job.output != "-":
            published(written)
    return written


def worth_a_second_process(program: str) -> bool:
    """A single large program: its conversion's processes share the cores
    (:attr:`ConvertJob.parallel`)."""
    try:
        return program != "-" and os.path.getsize(program) >= PARALLEL_FROM_BYTES
    except OSError:
        return False  # the conversion itself reports the missing file
