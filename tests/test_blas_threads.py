"""The command's process runs one OpenBLAS thread (prsxy_post/blas_threads.py).

Judged by what the operating system counts: the threads of a process that imported
the command and then numpy (Linux's /proc/self/status), against a process that
imported numpy alone, where OpenBLAS starts one thread per core.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(
    not Path("/proc/self/status").exists(), reason="counts threads in Linux's /proc"
)

_COUNT = (
    "import numpy\n"
    "print([l.split()[1] for l in open('/proc/self/status') if l.startswith('Threads:')][0])\n"
)


def _threads(first: str, env: dict[str, str]) -> int:
    r = subprocess.run(
        [sys.executable, "-c", first + _COUNT],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=env,
        check=True,
    )
    return int(r.stdout)


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    return {**env, **extra}


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS starts no pool on one core")
def test_the_command_starts_no_openblas_pool() -> None:
    # numpy alone: OpenBLAS's pool beside the main thread (the reference)
    assert _threads("", _env()) >= 2
    assert _threads("import prsxy_post.cli\n", _env()) == 1


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS starts no pool on one core")
def test_a_thread_count_the_user_set_stays() -> None:
    assert _threads("import prsxy_post.cli\n", _env(OPENBLAS_NUM_THREADS="2")) == 2


def test_the_library_leaves_the_threads_alone() -> None:
    # a program importing the library (not the command) keeps its own setting
    code = "import os, prsxy_post.convert\nprint(os.environ.get('OPENBLAS_NUM_THREADS'))\n"
    r = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=_env()
    )
    assert r.stdout.strip() == "None"
