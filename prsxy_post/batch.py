"""Several programs at once (``convert --jobs``): N forked worker processes, each
converting one program after another, and what became of each.

One program's error does not stop the others. Ctrl-C does: every worker is told
to stop at once (SIGTERM), removes its temp files, and says whether its outputs
were already in place, whole; :class:`Interrupted` carries the outcomes. A
worker killed outright is an error for its program (exit 3), its temp files
removed here.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Callable, Sequence
from typing import Any

from . import sinks
from .convert import ConvertJob, convert_file
from .errors import ProcessFailed, PrsxyError
from .runtime import crash_text


class Outcome:
    """What became of one job of :func:`convert_many`.

    state : "waiting" (not started), "running", "done" (``written`` holds every
        file it wrote, each whole), "failed" (``error`` says why; nothing of it
        written) or "stopped" (interrupted; nothing of it written)
    """

    def __init__(
        self,
        job: ConvertJob,
        state: str = "waiting",
        written: list[str] | None = None,
        error: PrsxyError | None = None,
    ) -> None:
        self.job = job
        self.state = state
        self.written = [] if written is None else written
        self.error = error


class Interrupted(KeyboardInterrupt):
    """Ctrl-C (SIGINT) stopped :func:`convert_many`: every process it started has
    ended and removed its temp files. ``outcomes`` says, per job, what was
    written whole (state "done") and what was not."""

    def __init__(self, outcomes: list[Outcome]) -> None:
        super().__init__("interrupted")
        self.outcomes = outcomes


def convert_many(
    jobs: Sequence[ConvertJob],
    workers: int = 1,
    progress: Callable[[ConvertJob, int, int], None] | None = None,
    finished: Callable[[Outcome], None] | None = None,
) -> list[Outcome]:
    """Convert several programs, in ``workers`` processes when more than one.

    One program's error does not stop the others. Ctrl-C does: the processes
    stop at once, each removing its temp files, and :class:`Interrupted` is
    raised with the outcomes so far.

    Parameters
    ----------
    jobs : the programs
    workers : processes converting at once (forked; one means here, in turn)
    progress : ``progress(job, characters read, file size)`` as each program is
        read, when converted here
    finished : ``finished(outcome)`` as each program is done or has failed

    Returns
    -------
    list of Outcome
        Per job, in order: its files (state "done") or its error ("failed").
    """
    outcomes = [Outcome(job) for job in jobs]
    try:
        if workers > 1 and len(jobs) > 1 and sinks.can_fork():
            _run_in_processes(outcomes, workers, finished)
        else:
            for o in outcomes:
                _run_here(o, progress)
                if finished is not None:
                    finished(o)
    except KeyboardInterrupt:
        for o in outcomes:
            if o.state == "running":
                o.state = "stopped"
                sinks.remove_leftovers(o.job.output)
        raise Interrupted(outcomes) from None
    return outcomes


def _run_here(o: Outcome, progress: Callable[[ConvertJob, int, int], None] | None) -> None:
    def published(files: list[str]) -> None:
        o.state, o.written = "done", files

    def bar(done: int, total: int) -> None:
        if progress is not None:
            progress(o.job, done, total)

    o.state = "running"
    try:
        stats = convert_file(o.job, bar if progress is not None else None, published)
    except PrsxyError as err:
        o.state, o.error = "failed", err
        return
    o.state, o.written = "done", stats.written


class _Stop(BaseException):
    """A --jobs worker told to stop (SIGTERM): unwinds its conversion, whose
    ``finally`` blocks remove the temp files."""


def _raise_stop(signum: int, frame: Any) -> None:
    signal.signal(signal.SIGTERM, signal.SIG_IGN)  # once: the cleanup is not cut short
    raise _Stop


def _job_worker(conn: Any, jobs: Sequence[ConvertJob]) -> None:
    """A --jobs worker (forked by :func:`sinks.forked`, once for every process that
    converts at once): converts the jobs it is sent one after the other, ("job",
    i) for ``jobs[i]`` (the list it was forked with: a job's ``on_message`` is a
    function of the command, which does not pickle), answering each once; ("quit",)
    ends it. Told to stop (SIGTERM), it unwinds the conversion under way (its
    ``finally`` blocks remove its temp files), answers it, and ends."""
    signal.signal(signal.SIGTERM, _raise_stop)
    try:
        while (msg := conn.recv())[0] == "job":
            if not _convert_one(conn, jobs[msg[1]]):
                return
    except (_Stop, EOFError, OSError):
        pass  # stopped between two jobs, or the parent is gone: nothing under way
    finally:
        conn.close()


def _convert_one(conn: Any, job: ConvertJob) -> bool:
    """One job in a worker: sends ("done", files) the moment they are in place, or
    ("error", PrsxyError), ("crash", text), ("stopped",), one message a job (what
    comes after its outputs are in place cannot undo them). False: stopped."""
    sent = False

    def published(files: list[str]) -> None:
        nonlocal sent
        conn.send(("done", files))  # with the stop signals held: whole, or not sent
        sent = True

    try:
        answer: tuple[Any, ...]
        try:
            answer = ("done", convert_file(job, None, published).written)
        except PrsxyError as err:
            answer = ("error", err)
        except _Stop:
            if not sent:
                conn.send(("stopped",))
            return False
        except BaseException:
            answer = ("crash", crash_text())
        if not sent:
            conn.send(answer)
        return True
    except (_Stop, OSError):
        return False  # stopped while it said how it ended: the parent hears nothing, or a part


def _settle(o: Outcome, msg: tuple[Any, ...] | None, proc: Any) -> None:
    """An outcome from what its worker said (None: it said nothing readable)."""
    if msg is None and o.state == "stopped":
        return
    if msg is None:
        o.state = "failed"
        o.error = ProcessFailed(
            f"the process converting it ended without a result ({sinks.how_it_ended(proc)}); "
            f"{o.job.output} not written",
            source=o.job.program,
        )
    elif msg[0] == "done":
        o.state, o.written = "done", msg[1]
    elif msg[0] == "error":
        o.state, o.error = "failed", msg[1].located(source=o.job.program)
    elif msg[0] == "stopped":
        o.state = "stopped"
    else:
        o.state = "failed"
        last = msg[1].strip().splitlines()[-1] if msg[1].strip() else "?"
        o.error = ProcessFailed(
            f"internal error in the process converting it: {last} (a bug: report it)",
            source=o.job.program,
        )


def _message(conn: Any, timeout: float | None = None) -> tuple[Any, ...] | None:
    try:
        if timeout is not None and not conn.poll(timeout):
            return None
        msg = conn.recv()
    except Exception:  # closed without a word, or what came cannot be read
        return None
    return msg if isinstance(msg, tuple) and msg else None


class _Worker:
    """A --jobs worker process, its end of the pipe, and the job it converts (None:
    none, it waits for one)."""

    def __init__(self, jobs: Sequence[ConvertJob]) -> None:
        self.conn, child = sinks.pipe(duplex=True)
        self.proc = sinks.forked(_job_worker, child, jobs)
        child.close()
        self.job: int | None = None


def _run_in_processes(
    outcomes: list[Outcome], workers: int, finished: Callable[[Outcome], None] | None
) -> None:
    """The jobs in ``workers`` forked processes, each converting one job after
    another (a fork costs a small program's conversion time again: 80 programs
    of 16-26 lines took as long with two processes as with one when each had a
    process of its own); a worker that dies fails its job and another takes its
    place. On Ctrl-C, SIGTERM to every worker, whose answers (written whole, or
    stopped) are then collected."""
    # here, not at the top: a single conversion (most commands) never forks
    from multiprocessing.connection import wait

    jobs = [o.job for o in outcomes]
    waiting = list(range(len(outcomes)))[::-1]
    pool: list[_Worker] = []
    try:
        while waiting or any(w.job is not None for w in pool):
            _hand_out(outcomes, waiting, pool, workers, jobs)
            busy = [w for w in pool if w.job is not None]
            ready = wait([w.conn.fileno() for w in busy])
            for w in busy:
                if w.conn.fileno() in ready:
                    _heard(outcomes, w, pool, finished)
    except KeyboardInterrupt:
        _stop_all(outcomes, pool)
        raise
    _end_pool(pool)


def _hand_out(
    outcomes: list[Outcome],
    waiting: list[int],
    pool: list[_Worker],
    workers: int,
    jobs: Sequence[ConvertJob],
) -> None:
    """The next waiting jobs to the idle workers, forking more up to ``workers``;
    the idle workers end once no job waits."""
    for w in pool:
        if not waiting:
            break
        if w.job is None:
            _assign(outcomes, waiting, w)
    while waiting and len(pool) < workers:
        with sinks.signals_held():  # a Ctrl-C finds it started and listed, or neither
            pool.append(_Worker(jobs))
        _assign(outcomes, waiting, pool[-1])
    if not waiting:
        _end_pool([w for w in pool if w.job is None])
        pool[:] = [w for w in pool if w.job is not None]


def _assign(outcomes: list[Outcome], waiting: list[int], w: _Worker) -> None:
    """The next waiting job to worker ``w``, and marked running."""
    i = waiting.pop()
    with sinks.signals_held():  # a Ctrl-C finds it running and sent, or neither
        outcomes[i].state = "running"
        w.job = i
        try:
            w.conn.send(("job", i))
        except OSError:
            pass  # the worker is gone: its end of the pipe reads as closed (below)


def _heard(
    outcomes: list[Outcome],
    w: _Worker,
    pool: list[_Worker],
    finished: Callable[[Outcome], None] | None,
) -> None:
    """A worker's answer to its job, or its end (the job failed): the worker leaves
    the pool when it has ended."""
    i = w.job
    assert i is not None
    msg = _message(w.conn)
    _settle(outcomes[i], msg, w.proc)
    w.job = None
    if msg is None or msg[0] == "stopped":  # it has ended, or is ending
        _ended(w)
        pool.remove(w)
    if outcomes[i].state != "done":  # a worker killed outright left them
        sinks.remove_leftovers(outcomes[i].job.output)
    if finished is not None:
        finished(outcomes[i])


def _end_pool(pool: list[_Worker]) -> None:
    """Idle workers told to end, and ended."""
    for w in pool:
        try:
            w.conn.send(("quit",))
        except OSError:
            pass  # already gone
    for w in pool:
        _ended(w)


def _ended(w: _Worker) -> None:
    """A worker that ends by itself, waited for (killed if it has not within
    seconds), its pipe closed."""
    w.proc.join(10.0)
    sinks.stop(w.proc)
    w.conn.close()


def _stop_all(outcomes: list[Outcome], pool: list[_Worker]) -> None:
    """SIGTERM to every worker at once; each answers its job (done or stopped) and
    ends within seconds, or is killed and its temp files removed here. A second
    Ctrl-C meanwhile is ignored, so the cleanup is not cut short."""
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        for w in pool:
            if w.proc.is_alive():
                w.proc.terminate()
        deadline = time.monotonic() + 10.0
        for w in pool:
            o = outcomes[w.job] if w.job is not None else None
            if o is not None and o.state == "running":  # not yet heard
                o.state = "stopped"
                _settle(o, _message(w.conn, max(0.0, deadline - time.monotonic())), w.proc)
            sinks.stop(w.proc, max(0.0, deadline - time.monotonic()))
            w.conn.close()
            if o is not None and o.state != "done":
                sinks.remove_leftovers(o.job.output)
    finally:
        signal.signal(signal.SIGINT, old)
