"""prsxy_post.allocator: the memory a chunk frees is reused, not mapped anew.

Each case runs in a fresh Python process (the setting is the whole process's, and
this one must keep glibc's own): a chunk's worth of arrays (fourteen of 1.1 MB,
the fields of a corrected G-code chunk) made, written and freed, round after
round, counting the page faults of the rounds after the first. glibc's moving
thresholds hand the freed top of the heap back (more than twice its largest block
is free there), so every round faults its pages in again; with the thresholds
fixed, the rounds reuse the pages of the first.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from prsxy_post import allocator

pytestmark = pytest.mark.skipif(not allocator.on_glibc(), reason="glibc's malloc only")

ROUNDS = """
import json, resource, sys
import numpy as np
from prsxy_post import allocator
kept = allocator.keep_freed_memory() if sys.argv[1] == "keep" else None
faults = []
for _ in range(6):
    f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    arrays = [np.ones((28_000, 5)) for _ in range(14)]
    del arrays
    faults.append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
print(json.dumps({"kept": kept, "faults": faults}))
"""

#: pages one round writes: 14 arrays of 28 000 x 5 floats
PAGES = 14 * 28_000 * 5 * 8 // 4096


def rounds(mode: str, **env: str) -> dict:
    clean = {k: v for k, v in os.environ.items() if k not in ("GLIBC_TUNABLES",)}
    proc = subprocess.run(
        [sys.executable, "-c", ROUNDS, mode],
        capture_output=True,
        text=True,
        check=True,
        env=clean | env,
    )
    out: dict = json.loads(proc.stdout)
    return out


def test_freed_chunks_are_reused_in_place():
    kept = rounds("keep")
    glibc = rounds("glibc")
    assert kept["kept"] is True
    # glibc's own thresholds: every round maps its arrays' pages again
    assert min(glibc["faults"][1:]) > 0.8 * PAGES
    # fixed: the rounds after the first write into the pages of the first
    assert max(kept["faults"][1:]) < 0.05 * PAGES


def test_a_users_malloc_setting_stays():
    out = rounds("keep", GLIBC_TUNABLES="glibc.malloc.trim_threshold=131072")
    assert out["kept"] is False
    assert min(out["faults"][1:]) > 0.8 * PAGES


def test_the_command_sets_it_first():
    # cli.run, the executable's entry point, makes the setting before the command
    # runs (importing the library does not: the "glibc" rounds above import it)
    probe = (
        "import sys\n"
        "from prsxy_post import allocator, cli\n"
        "allocator.keep_freed_memory = lambda: print('allocator set') or True\n"
        "sys.argv = ['prsxy-post', '--version']\n"
        "cli.run()\n"
    )
    proc = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("allocator set\nprsxy-post ")
