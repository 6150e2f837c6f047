"""The C allocator told to keep the memory the chain frees, for the command.

A conversion makes and frees arrays of about a megabyte at every chunk (a chunk's
points, a field at a time). glibc's ``malloc`` maps such blocks from the system
one by one (above its ``mmap`` threshold, which it raises and lowers as it goes)
and hands freed memory at the top of its heap back above its trim threshold, so
the next chunk's arrays touch new pages again: every page a fault and a page of
zeros from the kernel. With both thresholds fixed well above a chunk's arrays, the
memory freed is reused in place: the corrected G-code conversion of bench.py's
200 000-line program with about 60 % fewer page faults and 4 % less time and CPU
(``bench/allocator.py``; ``docs/measurements.md``, "Conversion speed"); PMAC output,
with chunks of half the size, the same.

The command line calls :func:`keep_freed_memory` once, before any conversion (the
processes it forks inherit the setting); the library never does: a program that
imports it keeps its own allocator. A threshold the user set in the environment
(``MALLOC_MMAP_THRESHOLD_``, ``MALLOC_TRIM_THRESHOLD_``, ``GLIBC_TUNABLES``) stays.
"""

from __future__ import annotations

import ctypes
import os
import sys

#: mallopt's parameters (glibc's malloc.h)
M_TRIM_THRESHOLD = -1
M_MMAP_THRESHOLD = -3
#: blocks up to this many bytes come from the heap (glibc's own ceiling of its
#: moving threshold: the largest a 64-bit build moves it to)
MMAP_FROM = 32 << 20
#: free memory at the heap's top is handed back above this many bytes: twice the
#: largest block the heap holds, as glibc sets it when it moves the threshold
TRIM_FROM = 2 * MMAP_FROM
#: the environment through which a user tunes glibc's malloc themselves
USER_SETTINGS = ("MALLOC_MMAP_THRESHOLD_", "MALLOC_TRIM_THRESHOLD_", "GLIBC_TUNABLES")


def keep_freed_memory() -> bool:
    """Fix glibc's mmap and trim thresholds at :data:`MMAP_FROM` and
    :data:`TRIM_FROM` for this process and those forked from it. Returns whether
    they were set: not with another C library, nor where the user tunes malloc."""
    if not on_glibc():
        return False
    if any(k in os.environ for k in USER_SETTINGS):
        return False
    mallopt = getattr(ctypes.CDLL(None), "mallopt", None)
    if mallopt is None:
        return False
    mallopt.argtypes = (ctypes.c_int, ctypes.c_int)
    mallopt.restype = ctypes.c_int
    # mallopt returns 1 on success; setting either threshold stops glibc moving
    # both (malloc.c: no_dyn_threshold)
    return bool(mallopt(M_MMAP_THRESHOLD, MMAP_FROM)) and bool(mallopt(M_TRIM_THRESHOLD, TRIM_FROM))


def on_glibc() -> bool:
    """This process runs on Linux's glibc (musl and others have no such thresholds)."""
    if sys.platform != "linux":
        return False
    try:
        return (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc")
    except (ValueError, OSError):  # no such name: not glibc
        return False
