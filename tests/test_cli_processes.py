"""The processes of a conversion, as a user meets them in a real `prsxy-post`
process: Ctrl-C stops every one at once and says what was written whole; a
process that dies or sends what cannot be read is an error (exit 3) within
seconds, not a hang. Nothing half-written is left either way, and no child
prints a traceback."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from click.testing import CliRunner

from prsxy_post import convert
from prsxy_post.cli import main
from prsxy_post.convert import ConvertJob, convert_file

from .conftest import ROOT

SHOP = str(ROOT / "profiles" / "prsxy-shop.toml")
#: exit status after Ctrl-C: 128 + SIGINT, the CLI's convention (cli.EXIT_INTERRUPTED)
INTERRUPTED = 130
ERASE = "\r\x1b[K"


def _program(path: Path, lines: int) -> Path:
    moves = [f"X{(i % 50) * 0.2:.4f} Y{(i % 7) * 0.1:.4f} Z0.0000" for i in range(lines)]
    path.write_text("\n".join(["G21 G90 G1 F3000", *moves, "M2"]) + "\n")
    return path


def _start(*args: str) -> subprocess.Popen[bytes]:
    """prsxy-post in a session of its own, so a signal to its process group is
    what Ctrl-C on a terminal sends (to the command and every process it made)."""
    cmd = [sys.executable, "-m", "prsxy_post.cli", *args]
    return subprocess.Popen(
        cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, start_new_session=True
    )


def _descendants(pid: int) -> list[int]:
    """Every process below ``pid`` (Linux /proc)."""
    out: list[int] = []
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return out
    for tid in tasks:
        try:
            kids = Path(f"/proc/{pid}/task/{tid}/children").read_text().split()
        except OSError:
            continue
        for k in kids:
            out += [int(k), *_descendants(int(k))]
    return out


def _has_open(pid: int, want: Callable[[str], bool]) -> bool:
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return False
    for fd in fds:
        try:
            if want(os.readlink(f"/proc/{pid}/fd/{fd}")):
                return True
        except OSError:
            continue
    return False


def _wait_for(what: Callable[[], object], timeout: float, proc: subprocess.Popen[bytes]) -> object:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        got = what()
        if got:
            return got
        if proc.poll() is not None:
            _, err = proc.communicate()
            pytest.fail(f"prsxy-post ended first ({proc.returncode}): {err.decode()}")
        time.sleep(0.02)
    proc.kill()
    pytest.fail("timed out waiting")


def _ended_within(proc: subprocess.Popen[bytes], seconds: float) -> tuple[int, str, float]:
    t0 = time.monotonic()
    try:
        _, err = proc.communicate(timeout=seconds)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.communicate()
        pytest.fail(f"prsxy-post still ran {seconds} s after the signal")
    return proc.returncode, err.decode(), time.monotonic() - t0


def _no_temp_files(d: Path) -> None:
    assert sorted(p.name for p in d.iterdir() if p.name.endswith(".tmp")) == []


def _reference(program: Path, out: Path) -> bytes:
    """The program converted through the library, one process."""
    convert_file(ConvertJob(str(program), SHOP, "pmac", str(out), options="--format pmac"))
    return out.read_bytes()


# ---------------------------------------------------------------- Ctrl-C


@pytest.mark.parametrize("to", ["process group", "command only"])
def test_ctrl_c_with_jobs_stops_everything_and_says_what_was_written(
    tmp_path: Path, to: str
) -> None:
    """Three programs, --jobs 2: the small one is converted and on disk, the two
    large ones are being converted (or wait) when SIGINT comes. The command ends
    within seconds (not after the queued program), lists the small one's output
    as written whole and the others as not written, and the disk says the same:
    the whole output equals a conversion of its own, the others and every temp
    file are absent. No process prints a traceback."""
    src = tmp_path / "src"
    src.mkdir()
    small = _program(src / "a.ngc", 50)
    big = [_program(src / f"{n}.ngc", 300_000) for n in ("b", "c")]
    out = tmp_path / "out"
    proc = _start(
        "convert", str(small), *map(str, big), "--profile", SHOP, "--out-dir", str(out), "-j", "2"
    )
    # SIGINT once the small program's output is in place and the large ones' temp
    # files are being written: every state a program can be in at once
    _wait_for(lambda: (out / "a.pmc").exists(), 60, proc)
    _wait_for(lambda: any(p.name.startswith(".b.pmc.") for p in out.iterdir()), 60, proc)
    if to == "process group":
        os.killpg(proc.pid, signal.SIGINT)
    else:
        proc.send_signal(signal.SIGINT)
    code, err, took = _ended_within(proc, 10.0)
    assert code == INTERRUPTED, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert took < 10.0
    lines = err.splitlines()
    assert lines[0] == "interrupted: every conversion stopped", err
    assert f"  written whole: {out / 'a.pmc'} (from {small})" in lines
    not_written = [line for line in lines if line.startswith("  not written: ")]
    assert len(not_written) == 2, err
    for n, prog in zip("bc", big, strict=True):
        assert re.fullmatch(
            rf"  not written: {re.escape(str(out / f'{n}.pmc'))} \({re.escape(str(prog))}: "
            r"(stopped while being converted|not started)\)",
            not_written["bc".index(n)],
        ), err
    assert sorted(p.name for p in out.iterdir()) == ["a.pmc"]
    assert (out / "a.pmc").read_bytes() == _reference(small, tmp_path / "ref.pmc")
    _no_temp_files(out)
    assert _descendants(proc.pid) == []


@pytest.mark.parametrize(("fmt", "children"), [("pmac", 2), ("gcode", 1)])
def test_ctrl_c_on_one_large_program_stops_its_processes(
    tmp_path: Path, fmt: str, children: int
) -> None:
    """One large program is written by a writer process and, with PMAC output,
    read by an interpreter process (corrected G-code's interpreter runs in the
    command's own: Dialect.interpreter_apart): Ctrl-C on the terminal reaches them
    all; the command says the output was not written, an existing file of that
    name is untouched, and no temp file or child process is left."""
    program = _program(tmp_path / "big.ngc", 300_000)
    out = tmp_path / f"big.{fmt}"
    out.write_text("keep me")
    proc = _start("convert", str(program), "--profile", SHOP, "--format", fmt, "-o", str(out))
    _wait_for(lambda: len(_descendants(proc.pid)) >= children, 60, proc)
    temp = f".{out.name}."
    _wait_for(lambda: any(p.name.startswith(temp) for p in tmp_path.iterdir()), 60, proc)
    os.killpg(proc.pid, signal.SIGINT)
    code, err, _ = _ended_within(proc, 10.0)
    assert code == INTERRUPTED, err
    assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
    assert err.splitlines() == [
        "interrupted: every conversion stopped",
        f"  not written: {out} ({program}: stopped while being converted)",
    ]
    assert out.read_text() == "keep me"
    _no_temp_files(tmp_path)


# ---------------------------------------------------------------- a process that dies


@pytest.mark.parametrize(
    ("which", "fmt"), [("interpreter", "pmac"), ("writer", "pmac"), ("writer", "gcode")]
)
def test_a_killed_process_is_exit_3_within_seconds(tmp_path: Path, which: str, fmt: str) -> None:
    """SIGKILL the interpreter process (the one reading the program; PMAC output
    has one) or the writer process (the one writing the temp file) mid-run: exit 3
    and a message naming it within 10 s, not a hang; no output, no temp file."""
    program = _program(tmp_path / "big.ngc", 300_000)
    out = tmp_path / f"big.{fmt}"
    temp = f".{out.name}."
    proc = _start("convert", str(program), "--profile", SHOP, "--format", fmt, "-o", str(out))

    def holding(pid: int) -> bool:
        if which == "interpreter":
            return _has_open(pid, lambda f: f == str(program))
        return _has_open(pid, lambda f: Path(f).name.startswith(temp))

    def victim() -> int | None:
        # the writer has the temp file open once text comes; the interpreter has
        # the program open while it reads, which it does ahead of the chain
        if not any(p.name.startswith(temp) for p in tmp_path.iterdir()):
            return None
        return next((p for p in _descendants(proc.pid) if holding(p)), None)

    pid = _wait_for(victim, 60, proc)
    assert isinstance(pid, int)
    os.kill(pid, signal.SIGKILL)
    code, err, took = _ended_within(proc, 10.0)
    assert code == 3, err
    assert took < 10.0
    assert err.strip() == (
        f"{program}: the {which} process ended without a result (killed by SIGKILL); "
        + ("no output written" if which == "interpreter" else f"{out} not written")
    )
    assert not out.exists()
    _no_temp_files(tmp_path)


def test_a_killed_jobs_worker_is_exit_3_and_the_others_are_written(tmp_path: Path) -> None:
    """--jobs 2: the worker converting one program is killed outright; that
    program is an error (exit 3, saying so within seconds), the others are
    written whole, and no temp file is left (the parent removes the killed
    worker's)."""
    src = tmp_path / "src"
    src.mkdir()
    progs = [_program(src / "a.ngc", 50), _program(src / "b.ngc", 300_000)]
    progs.append(_program(src / "c.ngc", 60))
    out = tmp_path / "out"
    proc = _start("convert", *map(str, progs), "--profile", SHOP, "--out-dir", str(out), "-j", "2")
    b = str(progs[1])

    def victim() -> int | None:
        if not (out.is_dir() and any(p.name.startswith(".b.pmc.") for p in out.iterdir())):
            return None
        return next((p for p in _descendants(proc.pid) if _has_open(p, lambda f: f == b)), None)

    pid = _wait_for(victim, 60, proc)
    assert isinstance(pid, int)
    os.kill(pid, signal.SIGKILL)
    code, err, _ = _ended_within(proc, 30.0)
    assert code == 3, err
    assert "Traceback" not in err
    assert err.splitlines() == [
        f"{progs[0]} -> {out / 'a.pmc'}",
        f"{b}: the process converting it ended without a result (killed by SIGKILL); "
        f"{out / 'b.pmc'} not written",
        f"{progs[2]} -> {out / 'c.pmc'}",
    ]
    assert sorted(p.name for p in out.iterdir()) == ["a.pmc", "c.pmc"]
    assert (out / "c.pmc").read_bytes() == _reference(progs[2], tmp_path / "c.pmc")


class _Unreadable:
    """Pickles fine, fails to unpickle (as an object whose class cannot be
    rebuilt in the receiving process)."""

    def __reduce__(self) -> tuple[object, tuple[()]]:
        return (_refuse, ())


def _refuse() -> None:
    raise TypeError("cannot be rebuilt here")


def test_what_the_interpreter_sends_that_cannot_be_read_is_an_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The interpreter process sends a chunk that does not unpickle: the thread
    reading the pipe reports it, and the command exits 3 with the reason, where
    it once waited forever. The forked interpreter inherits the patch (on what it
    sends: its third chunk as packed for the pipe)."""
    program = _program(tmp_path / "big.ngc", 40_000)
    pack_ready = convert.wire.pack_ready
    sent = [0]

    def spoiled(*args: object, **kwargs: object) -> object:
        sent[0] += 1
        return _Unreadable() if sent[0] == 3 else pack_ready(*args, **kwargs)  # type: ignore[arg-type]

    monkeypatch.setattr(convert.wire, "pack_ready", spoiled)
    out = tmp_path / "big.pmc"
    t0 = time.monotonic()
    r = CliRunner().invoke(main, ["convert", str(program), "--profile", SHOP, "-o", str(out)])
    assert time.monotonic() - t0 < 30.0
    assert r.exit_code == 3, r.output
    assert r.stderr.strip() == (
        f"{program}: the interpreter process sent what cannot be read "
        "(TypeError: cannot be rebuilt here); no output written"
    )
    assert not out.exists()
    _no_temp_files(tmp_path)


# ---------------------------------------------------------------- progress of convert


class _Job:
    program = "part.ngc"


def test_convert_progress_shows_the_time_left_at_the_rate_so_far() -> None:
    """ETA = elapsed × (1 − f) / f at fraction f read: 30 % after 3 s leaves 7 s;
    none before a second has passed (no rate yet); the line is erased at the end."""
    from prsxy_post import cli

    now = [100.0]
    runner = CliRunner()
    with runner.isolation() as (_, err, _):
        bar = cli._Progress(clock=lambda: now[0])
        job = _Job()
        bar(job, 0, 1000)
        now[0] += 0.5
        bar(job, 100, 1000)
        now[0] += 2.5
        bar(job, 300, 1000)
        now[0] += 3600.0
        bar(job, 500, 1000)
        bar.close()
        text = err.getvalue().decode()
    assert text.split("\r\x1b[K") == [
        "",
        "part.ngc:   0.0%",
        "part.ngc:  10.0%",
        "part.ngc:  30.0%  ETA 0:07",
        "part.ngc:  50.0%  ETA 1:00:03",
        "",
    ]


def test_convert_shows_progress_only_on_a_terminal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from prsxy_post import cli

    program = _program(tmp_path / "big.ngc", 30_000)
    args = ["convert", str(program), "--profile", SHOP, "-o", str(tmp_path / "big.pmc")]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0 and r.stderr == f"{program} -> {tmp_path / 'big.pmc'}\n"
    monkeypatch.setattr(cli, "_stderr_is_terminal", lambda: True)
    r = CliRunner().invoke(main, [*args, "--quiet"])
    assert r.exit_code == 0 and r.stderr == ""
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0
    shown = r.stderr.split("\r\x1b[K")
    pattern = re.compile(rf"{re.escape(str(program))}: +([\d.]+)%(  ETA \d+:\d\d)?")
    percents = []
    for s in shown[1:-1]:
        m = pattern.fullmatch(s)
        assert m is not None, s
        percents.append(float(m[1]))
    assert len(percents) >= 2 and percents == sorted(percents) and percents[-1] == 100.0
    assert shown[-1] == f"{program} -> {tmp_path / 'big.pmc'}\n"


def test_convert_jobs_on_a_terminal_counts_the_programs_done(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With --jobs the programs are read in other processes: the line counts
    those done, with the time left by their sizes, and is erased before the
    summary."""
    from prsxy_post import cli

    monkeypatch.setattr(cli, "_stderr_is_terminal", lambda: True)
    progs = [str(_program(tmp_path / f"{n}.ngc", 2000)) for n in "abc"]
    out = tmp_path / "out"
    r = CliRunner().invoke(
        main, ["convert", *progs, "--profile", SHOP, "--out-dir", str(out), "-j", "2"]
    )
    assert r.exit_code == 0, r.output
    shown = r.stderr.split(ERASE)
    assert shown[0] == "" and shown[1] == "3 programs: 0 done"
    for k, line in enumerate(shown[2:5], start=1):
        assert re.fullmatch(rf"3 programs: {k} done  ETA \d+:\d\d", line), line
    assert shown[4].endswith("ETA 0:00")
    assert shown[5].splitlines() == [
        f"{p} -> {out / Path(p).with_suffix('.pmc').name}" for p in progs
    ]


def test_ctrl_c_after_the_outputs_are_written_does_not_deny_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ctrl-C while the summary is printed: the output is on disk, and the
    command says it was written whole (not "no output written")."""
    from prsxy_post import cli

    def interrupted(*args: object) -> int:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_say_outcomes", interrupted)
    prog = _program(tmp_path / "a.ngc", 50)
    out = tmp_path / "a.pmc"
    r = CliRunner().invoke(main, ["convert", str(prog), "--profile", SHOP, "-o", str(out)])
    assert r.exit_code == INTERRUPTED
    assert f"  written whole: {out} (from {prog})" in r.stderr.splitlines()
    assert "no output written" not in r.stderr
    assert out.read_bytes() == _reference(prog, tmp_path / "ref.pmc")


def test_ctrl_c_after_calibrate_wrote_its_profile_says_so(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Any command: Ctrl-C once its output is written (while it prints) names
    the file written whole instead of saying nothing was."""
    from prsxy_post import cli

    def interrupted(*args: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(cli, "_print_stage", interrupted)
    out = tmp_path / "cal.toml"
    axis = ROOT / "tests" / "data" / "spec" / "axis.csv"
    args = ["calibrate", str(axis), "--profile", SHOP, "--stages", "tables", "-q"]
    args.append("--ignore-provenance")
    r = CliRunner().invoke(main, [*args, "-o", str(out)])
    assert r.exit_code == INTERRUPTED, r.output
    assert r.stderr == f"interrupted; written whole: {out}\n"
    assert out.is_file()
    # before anything is written, it says that
    monkeypatch.setattr(cli, "profile_files", interrupted)
    r = CliRunner().invoke(main, [*args, "-o", str(tmp_path / "b.toml")])
    assert r.exit_code == INTERRUPTED
    assert r.stderr == "interrupted; no output written\n"
