"""What a long run of the library needs from the Python process: fewer passes of
the cycle collector, its own peak memory for the benchmark's figures, and the text
of an unexpected exception for the process that reports it."""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator
from pathlib import Path


@contextlib.contextmanager
def few_gc_passes() -> Iterator[None]:
    """Rarer passes of the cycle collector: a conversion makes millions of
    short-lived tuples and no cycles to speak of, and the passes over them cost a
    fifth of the interpreter's time (measured). Objects that exist before are
    frozen out of the passes; all is as it was afterwards."""
    old = gc.get_threshold()
    gc.freeze()
    gc.set_threshold(50_000, 20, 20)
    try:
        yield
    finally:
        gc.set_threshold(*old)
        gc.unfreeze()


def crash_text() -> str:
    """The traceback of the exception being handled, as text: what a forked
    process sends its parent when it fails where no error was foreseen. The
    traceback module is imported here, when one happens: with what it imports,
    it is 2.6 ms of every command's start."""
    import traceback

    return traceback.format_exc()


def peak_rss_mb() -> float | None:
    """This process's own peak resident memory [MB] (Linux), None where unknown.
    Not ru_maxrss: Linux carries the parent's high-water mark into a forked or
    exec'd child."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmHWM:"):
                return int(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None
