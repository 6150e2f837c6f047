"""The process helpers: the collector's passes restored, the process's peak memory,
and the text a forked process sends when it fails unforeseen."""

from __future__ import annotations

import gc
import subprocess
import sys

import pytest

from prsxy_post.runtime import crash_text, few_gc_passes


def test_few_gc_passes_restores_the_collectors_thresholds() -> None:
    before = gc.get_threshold()
    with few_gc_passes():
        assert gc.get_threshold()[0] == 50_000
    assert gc.get_threshold() == before
    with pytest.raises(KeyError), few_gc_passes():
        raise KeyError("x")
    assert gc.get_threshold() == before


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/status")
def test_peak_rss_grows_with_an_array_the_process_touches() -> None:
    # in a fresh process: this one's high-water mark is the suite's
    code = (
        "import numpy as np; from prsxy_post.runtime import peak_rss_mb; low = peak_rss_mb(); "
        "a = np.ones(64 << 20, dtype=np.uint8); print(low, peak_rss_mb())"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    low, high = map(float, out.stdout.split())
    assert 0.0 < low and high >= low + 60.0  # 64 MB, every page written


def test_crash_text_is_the_handled_exceptions_traceback() -> None:
    def fails() -> None:
        raise ZeroDivisionError("the divisor of the test")

    try:
        fails()
    except ZeroDivisionError:
        text = crash_text()
    lines = text.splitlines()
    assert lines[0] == "Traceback (most recent call last):"
    assert "in fails" in text
    assert lines[-1] == "ZeroDivisionError: the divisor of the test"


def test_the_command_line_starts_without_the_modules_only_failures_and_writes_need() -> None:
    # traceback and tempfile (with shutil, random, bz2, lzma) are 6-7 ms of every
    # command's start: imported where a crash is reported or a file is written
    code = (
        "import sys; from prsxy_post import batch; from prsxy_post.cli import run; "
        "print(' '.join(m for m in ('traceback', 'tempfile') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""
