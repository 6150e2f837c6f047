"""The conversion's processes (prsxy_post.convert): the interpreter process
reads, plans and solves the points' map and IK ahead of the main process, and
every error still arrives where one process would meet it, first in the program,
at its line and column."""

from __future__ import annotations

from pathlib import Path

import pytest

from prsxy_post.chain import Stages
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.errors import PrsxyError

from .conftest import ROOT

SHOP = str(ROOT / "profiles" / "prsxy-shop.toml")


def _program(tmp_path: Path, n: int, at: dict[int, str]) -> str:
    """n moving lines, line k (1-based, from the second) replaced by at[k]."""
    lines = ["G21 G90 G1 F3000"]
    for k in range(2, n + 1):
        lines.append(at.get(k, f"X{(k % 40) * 0.25:.2f} Y{(k % 9) * 0.5:.1f}"))
    path = tmp_path / "job.ngc"
    path.write_text("\n".join([*lines, "M2"]) + "\n")
    return str(path)


def _error(program: str, out: Path, parallel: bool) -> str:
    job = ConvertJob(program, SHOP, "pmac", str(out), None, Stages(), "", 700, parallel)
    with pytest.raises(PrsxyError) as err:
        convert_file(job)
    assert not out.exists()
    return str(err.value)


#: a tilt past the profile's 30° in a short move: found with the points' map and IK
TILT = {6999: "X0 A29.9", 7000: "X0 A30.5"}


@pytest.mark.parametrize(
    ("at", "line"),
    [
        (TILT, 7000),  # found by the interpreter process (chain.Planning.solve)
        ({**TILT, 9000: "G1 X1 Q"}, 7000),  # and a G-code error after it
        ({3000: "X900", **TILT}, 3000),  # beyond X's travel before it: the main process's
        ({9000: "G1 X1 Q"}, 9000),  # a G-code error alone
    ],
)
def test_errors_arrive_in_program_order_from_the_interpreter_process(
    tmp_path: Path, at: dict[int, str], line: int
) -> None:
    """Whichever process finds it (the pose problems of a piece's points are
    found with their map and IK in the interpreter process, and raised by the
    main one as it comes to them), the error is the one a single process
    reports: the first in the program, located."""
    program = _program(tmp_path, 10_000, at)
    here = _error(program, tmp_path / "a.pmc", parallel=False)
    apart = _error(program, tmp_path / "b.pmc", parallel=True)
    assert apart == here
    assert here.startswith(f"{program}:{line}:"), here


def test_the_interpreter_process_makes_way_for_the_chain_and_the_writer(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The interpreter process, which runs ahead and waits for the chain most of the
    time, runs INTERPRETER_NICE lower in priority than the command's own process
    (where it converts the program, as the forked process inherits the patch); the
    output is that of one process."""
    import os

    from prsxy_post import convert

    planned_here = convert._planned_here
    seen = tmp_path / "niceness"

    def planned(*args, **kwargs):  # type: ignore[no-untyped-def]
        seen.write_text(str(os.getpriority(os.PRIO_PROCESS, 0)))
        return planned_here(*args, **kwargs)

    monkeypatch.setattr(convert, "_planned_here", planned)
    program = _program(tmp_path, 3000, {})
    for parallel, out in ((False, tmp_path / "a.pmc"), (True, tmp_path / "b.pmc")):
        convert_file(ConvertJob(program, SHOP, "pmac", str(out), parallel=parallel))
        mine = os.getpriority(os.PRIO_PROCESS, 0)
        want = min(mine + convert.INTERPRETER_NICE, 19) if parallel else mine
        assert int(seen.read_text()) == want
    assert (tmp_path / "b.pmc").read_bytes() == (tmp_path / "a.pmc").read_bytes()


@pytest.mark.parametrize(
    ("fmt", "processes"),
    [("pmac", ["_planning_child", "_serve"]), ("gcode", ["_serve"])],
)
def test_the_dialect_says_whether_the_interpreter_runs_apart(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fmt: str, processes: list[str]
) -> None:
    """In parallel, PMAC output is converted in three processes (the interpreter's
    forked first, then the writer's) and corrected G-code in two (the writer's,
    which solves the FK at every point and has the second core to itself; the
    interpreter runs in this one): ``Dialect.interpreter_apart``. Either way the
    output is that of one process."""
    from prsxy_post import sinks

    forked = sinks.forked
    seen: list[str] = []

    def spy(target, *args):  # type: ignore[no-untyped-def]
        seen.append(target.__name__)
        return forked(target, *args)

    monkeypatch.setattr(sinks, "forked", spy)
    program = _program(tmp_path, 3000, {})
    outs = [tmp_path / d / f"job.{fmt}" for d in ("here", "apart")]
    for parallel, out in zip((False, True), outs, strict=True):
        out.parent.mkdir()
        convert_file(ConvertJob(program, SHOP, fmt, str(out), parallel=parallel))
    assert seen == processes
    assert outs[1].read_bytes() == outs[0].read_bytes()
