"""Long commands are never silent: calibrate and diagnose say each stage as it
begins (a line per stage for logs; on a terminal one bar line, redrawn with the
time so far), and nothing of it with --quiet. The library only calls
``progress(stage, fraction)``; the command line prints."""

from __future__ import annotations

import re
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from click.testing import CliRunner

from prsxy_post import calibrate as cal
from prsxy_post import cli
from prsxy_post import diagnose as dg
from prsxy_post.cli import main

from .conftest import ROOT

NOMINAL = str(ROOT / "profiles" / "prsxy-nominal.toml")
PERTURBED = str(ROOT / "tests" / "data" / "vectors" / "perturbed.toml")
ERASE = "\r\x1b[K"


@pytest.fixture(scope="module")
def measured(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small measurement set of the contract's perturbed machine: laser runs,
    40 poses, one X-Y circle each way."""
    out = tmp_path_factory.mktemp("measured")
    r = CliRunner().invoke(
        main,
        [
            *("simulate", "--truth", PERTURBED, "--profile", NOMINAL, "-o", str(out)),
            *("--only-xy", "--radii", "50", "--poses", "40"),
        ],
    )
    assert r.exit_code == 0, r.output
    return out


def _marking(module: Any, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Write <name> on stderr when the library function runs: where it falls
    among the stage lines shows they are said as the work goes."""
    fn: Callable[..., Any] = getattr(module, name)

    def marked(*args: Any, **kwargs: Any) -> Any:
        sys.stderr.write(f"<{name}>\n")
        return fn(*args, **kwargs)

    monkeypatch.setattr(module, name, marked)


def _plain(command: str, text: str) -> tuple[list[str], list[int]]:
    """The stage lines (and markers) of the plain output, and their times [s]."""
    lines, times = [], []
    for line in text.splitlines():
        m = re.fullmatch(rf"{command} \[(\d+):(\d\d)\]: (.*)", line)
        if m:
            lines.append(m[3])
            times.append(60 * int(m[1]) + int(m[2]))
        elif line.startswith("<"):
            lines.append(line)
    return lines, times


def test_calibrate_says_each_stage_as_it_begins(
    measured: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _marking(cal, "stage_tables", monkeypatch)
    _marking(cal, "stage_kinematics", monkeypatch)
    files = [str(measured / n) for n in ("axis.csv", "poses.csv")]
    args = ["calibrate", *files, "--profile", NOMINAL, "-o", str(tmp_path / "cal.toml")]
    r = CliRunner().invoke(main, [*args, "--stages", "tables,kinematics"])
    assert r.exit_code == 0, r.output
    lines, times = _plain("calibrate", r.stderr)
    assert lines == [
        "real-axis tables from the laser runs of motors 1, 2, 3, 5, 6",
        "<stage_tables>",
        "kinematic parameters from 40 poses and 0 ballbar runs",
        "<stage_kinematics>",
        "done",
    ], r.stderr
    assert times == sorted(times)
    assert r.stdout.startswith("== real-axis tables") and r.stdout.endswith(
        f"wrote {tmp_path}/cal.toml\n"
    )
    # --quiet: the results, no stage
    r = CliRunner().invoke(main, [*args, "--stages", "tables", "--quiet"])
    assert r.exit_code == 0, r.output
    assert _plain("calibrate", r.stderr)[0] == ["<stage_tables>"]
    assert "wrote" in r.stdout


def test_diagnose_says_each_stage_as_it_begins(
    measured: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _marking(dg, "find_effects", monkeypatch)
    _marking(dg.leftover, "unexplained", monkeypatch)
    r = CliRunner().invoke(main, ["diagnose", str(measured / "axis.csv"), "--profile", NOMINAL])
    assert r.exit_code == 0, r.output
    lines, times = _plain("diagnose", r.stderr)
    assert lines == [
        "looking for the effects the model misses (up to 3 rounds)",
        "<find_effects>",
        "testing what is left against the noise",
        "<unexplained>",
        "done",
    ], r.stderr
    assert times == sorted(times)
    # the warnings come after the stages, as whole lines
    assert r.stderr.index("diagnose [") < r.stderr.index("warning: ")


def test_on_a_terminal_one_bar_line_with_the_stage(
    measured: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """stderr a terminal (faked): no stage lines, one line redrawn in place: a
    bar of the stages done, the time so far, the stage; erased before the
    results and warnings."""
    monkeypatch.setattr(cli, "_stderr_is_terminal", lambda: True)
    r = CliRunner().invoke(main, ["diagnose", str(measured / "axis.csv"), "--profile", NOMINAL])
    assert r.exit_code == 0, r.output
    assert "\n" not in r.stderr.split("warning: ")[0]
    drawn = r.stderr.split("warning: ")[0].split(ERASE)
    assert drawn[0] == "" and drawn[-1] == ""
    pattern = re.compile(r"diagnose \[([#-]{20})\] (\d+:\d\d) (.*)")
    shown = [pattern.fullmatch(d) for d in drawn[1:-1]]
    assert all(shown), drawn
    stages = [(m[1], m[3]) for m in shown if m]
    assert stages[0] == ("-" * 20, "looking for the effects the model misses (up to 3 rounds)")
    assert stages[-1] == ("#" * 10 + "-" * 10, "testing what is left against the noise")
    # --quiet: nothing but the warnings
    r = CliRunner().invoke(
        main, ["diagnose", str(measured / "axis.csv"), "--profile", NOMINAL, "-q"]
    )
    assert r.stderr.startswith("warning: "), r.stderr


def test_the_bar_keeps_the_time_going_between_stages() -> None:
    """A stage of two minutes is not a frozen line: the bar is redrawn every
    tick with the time so far."""
    now = [0.0]
    runner = CliRunner()
    with runner.isolation() as (_, err, _):
        stages = cli._Stages("calibrate", terminal=True, clock=lambda: now[0], tick=0.01)
        stages("physical effects beyond the kinematic parameters", 0.5)
        for t in (61.0, 125.0):
            now[0] = t
            deadline = time.monotonic() + 5.0
            while f"{int(t) // 60}:{int(t) % 60:02d}" not in err.getvalue().decode():
                assert time.monotonic() < deadline, "not redrawn"
                time.sleep(0.01)
        stages.close()
        text = err.getvalue().decode()
    assert text.endswith(ERASE)
    shown = set(text.split(ERASE)[1:-1])
    assert {
        f"calibrate [{'#' * 10}{'-' * 10}] {t} physical effects beyond the kinematic parameters"
        for t in ("0:00", "1:01", "2:05")
    } <= shown


def test_a_real_terminal_gets_the_bar(measured: Path) -> None:
    """stderr on a pseudo-terminal (no faking): the command itself sees a
    terminal and draws the bar in place, then erases it."""
    import os
    import pty
    import subprocess

    master, slave = pty.openpty()
    cmd = [sys.executable, "-m", "prsxy_post.cli", "diagnose", str(measured / "axis.csv")]
    proc = subprocess.Popen(
        [*cmd, "--profile", NOMINAL], cwd=ROOT, stdout=subprocess.PIPE, stderr=slave
    )
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:  # the terminal's other side closed: the command ended
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    proc.communicate(timeout=120)
    assert proc.returncode == 0
    err = b"".join(chunks).decode()
    assert f"{ERASE}diagnose [{'-' * 20}] 0:" in err
    assert "looking for the effects the model misses" in err
    assert "diagnose [0:" not in err  # no plain stage lines
    assert err.split("warning: ")[0].endswith(ERASE)
