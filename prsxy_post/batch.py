"""Several programs at once (``convert --jobs``): each in a forked process of its
own, a few at a time, and what became of each.

One program's error does not stop the others. Ctrl-C does: every worker is told
to stop at once (SIGTERM), removes its temp files, and says whether its outputs
were already in place, whole; :class:`Interrupted` carries the outcomes. A
worker killed outright is an error for its program (exit 3), its temp files
removed here.
"""

from __future__ import annotations

import signal
import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any

from . import sinks
from .convert import ConvertJob, convert_file
from .errors import ProcessFailed, PrsxyError


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


def _job_process(conn: Any, job: ConvertJob) -> None:
    """A --jobs worker (forked by :func:`sinks.forked`): converts one program and
    sends ("done", files) the moment they are in place, or ("error", PrsxyError),
    ("crash", text), ("stopped",)."""
    signal.signal(signal.SIGTERM, _raise_stop)
    sent = False

    def published(files: list[str]) -> None:
        nonlocal sent
        conn.send(("done", files))  # with the stop signals held: whole, or not sent
        sent = True

    try:
        try:
            stats = convert_file(job, None, published)
            if not sent:
                conn.send(("done", stats.written))
        except PrsxyError as err:
            conn.send(("error", err))
        except _Stop:
            if not sent:
                conn.send(("stopped",))
        except BaseException:
            conn.send(("crash", traceback.format_exc()))
        finally:
            conn.close()
    except (_Stop, OSError):
        pass  # stopped while it said how it ended: the parent hears nothing, or a part


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


def _run_in_processes(
    outcomes: list[Outcome], workers: int, finished: Callable[[Outcome], None] | None
) -> None:
    """Each job in a forked process of its own, ``workers`` at a time; on Ctrl-C,
    SIGTERM to every one running, whose answers (written whole, or stopped) are
    then collected."""
    # here, not at the top: a single conversion (most commands) never forks
    from multiprocessing.connection import wait

    waiting = list(range(len(outcomes)))[::-1]
    running: dict[int, tuple[Any, Any]] = {}
    try:
        while waiting or running:
            while waiting and len(running) < workers:
                i = waiting.pop()
                with sinks.signals_held():  # a Ctrl-C finds it started and listed, or neither
                    recv, send = sinks.pipe(duplex=False)
                    outcomes[i].state = "running"
                    running[i] = (sinks.forked(_job_process, send, outcomes[i].job), recv)
                    send.close()
            ready = wait([conn for _, conn in running.values()])
            for i, (proc, conn) in list(running.items()):
                if conn in ready:
                    _settle(outcomes[i], _message(conn), proc)
                    proc.join()
                    conn.close()
                    del running[i]
                    if outcomes[i].state != "done":  # a worker killed outright left them
                        sinks.remove_leftovers(outcomes[i].job.output)
                    if finished is not None:
                        finished(outcomes[i])
    except KeyboardInterrupt:
        _stop_all(outcomes, running)
        raise


def _stop_all(outcomes: list[Outcome], running: dict[int, tuple[Any, Any]]) -> None:
    """SIGTERM to every worker at once; each answers (done or stopped) and ends
    within seconds, or is killed and its temp files removed here. A second
    Ctrl-C meanwhile is ignored, so the cleanup is not cut short."""
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        for proc, _ in running.values():
            if proc.is_alive():
                proc.terminate()
        deadline = time.monotonic() + 10.0
        for i, (proc, conn) in running.items():
            o = outcomes[i]
            if o.state == "running":  # not yet heard (a Ctrl-C may fall just after)
                o.state = "stopped"
                _settle(o, _message(conn, max(0.0, deadline - time.monotonic())), proc)
            sinks.stop(proc, max(0.0, deadline - time.monotonic()))
            conn.close()
            if o.state != "done":
                sinks.remove_leftovers(o.job.output)
    finally:
        signal.signal(signal.SIGINT, old)
