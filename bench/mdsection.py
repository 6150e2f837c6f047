"""The head of a section of docs/measurements.md, for the scripts' ``--markdown``.

A section of that page is a ``## `` heading, the command that regenerates it and
when it was measured, then what the script prints (its table)::

    ## Calibration closes the loop

    - Regenerate: `python bench/calibration_accuracy.py --seeds 7 8 9`
    - Measured: 2026-11-27, commit `45e4057`

The command is the script's own command line without ``--markdown``; the commit is
the work tree's ``HEAD``, marked when the tracked files differ from it.
"""

from __future__ import annotations

import datetime
import os
import platform
import shlex
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def command(argv: list[str] | None = None) -> str:
    """``python <script> <args>`` as run, the script relative to the repository."""
    argv = sys.argv if argv is None else argv
    script = Path(argv[0]).resolve()
    shown = script.relative_to(ROOT).as_posix() if script.is_relative_to(ROOT) else argv[0]
    return " ".join(["python", shown, *(shlex.quote(a) for a in argv[1:] if a != "--markdown")])


def commit() -> str:
    """The work tree's commit, or why there is none."""

    def git(*args: str) -> str:
        return subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, check=True
        ).stdout.strip()

    try:
        head = git("rev-parse", "--short", "HEAD")
        dirty = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.CalledProcessError):
        return "unknown (not a git work tree)"
    return f"`{head}`" + (" with uncommitted changes" if dirty else "")


def machine() -> str:
    """The machine line of the speed sections."""
    cpu = platform.processor() or platform.machine()
    return (
        f"Machine: {platform.platform()}, {os.cpu_count()} cores, {cpu}, "
        f"Python {platform.python_version()}"
    )


def header(title: str, argv: list[str] | None = None) -> str:
    """A section's heading and provenance, followed by a blank line."""
    today = datetime.datetime.now(datetime.UTC).date().isoformat()
    return (
        f"## {title}\n\n- Regenerate: `{command(argv)}`\n- Measured: {today}, commit {commit()}\n"
    )
