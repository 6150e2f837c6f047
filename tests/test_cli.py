"""The command line as users meet it: outputs, golden files, errors and exit codes."""

from __future__ import annotations

import json
import os
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from prsxy_post.cli import main

from .conftest import ROOT

GOLDEN = ROOT / "tests" / "golden"
SAMPLES = sorted(p.name for p in (ROOT / "samples").glob("*.ngc"))
SHOP = "profiles/prsxy-shop.toml"
PERTURBED = "tests/data/vectors/perturbed.toml"


@pytest.fixture
def runner(monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    monkeypatch.chdir(ROOT)  # golden headers name paths relative to the project
    return CliRunner()


def invoke(runner: CliRunner, *args: str):
    return runner.invoke(main, list(args), catch_exceptions=False)


def _no_traceback(text: str) -> None:
    assert "Traceback" not in text


# ---------------------------------------------------------------- golden files

CASES = [(s, fmt, SHOP) for s in SAMPLES for fmt in ("pmac", "gcode")]
CASES += [(s, "pmac", PERTURBED) for s in ("pocket.ngc", "five-axis.ngc")]


@pytest.mark.parametrize(
    ("sample", "fmt", "prof"), CASES, ids=[f"{s}-{f}-{Path(p).stem}" for s, f, p in CASES]
)
def test_golden_outputs(
    runner: CliRunner, tmp_path: Path, sample: str, fmt: str, prof: str
) -> None:
    out = tmp_path / "out.txt"
    r = invoke(
        runner,
        "convert",
        f"samples/{sample}",
        "--profile",
        prof,
        "--format",
        fmt,
        "-o",
        str(out),
        "--quiet",
    )
    assert r.exit_code == 0, r.output
    golden = GOLDEN / f"{Path(sample).stem}.{Path(prof).stem}.{fmt}"
    got = out.read_text()
    if os.environ.get("PRSXY_UPDATE_GOLDEN"):
        golden.write_text(got)
    assert golden.exists(), f"no golden file {golden.name} (PRSXY_UPDATE_GOLDEN=1 writes it)"
    assert got == golden.read_text(), f"{golden.name} changed"


def test_outputs_get_ordinary_file_modes(runner: CliRunner, tmp_path: Path) -> None:
    """Written through a temp file, an output still gets the mode a new file gets
    (umask applied), and a replaced file keeps its own."""
    old = os.umask(0o022)
    try:
        new = tmp_path / "new.pmc"
        invoke(runner, "convert", "samples/pocket.ngc", "--profile", SHOP, "-o", str(new))
        assert new.stat().st_mode & 0o777 == 0o644
        kept = tmp_path / "kept.pmc"
        kept.write_text("old")
        kept.chmod(0o640)
        invoke(runner, "convert", "samples/pocket.ngc", "--profile", SHOP, "-o", str(kept))
        assert kept.read_text() != "old"
        assert kept.stat().st_mode & 0o777 == 0o640
    finally:
        os.umask(old)


def test_output_is_deterministic(runner: CliRunner, tmp_path: Path) -> None:
    a, b = tmp_path / "a.pmc", tmp_path / "b.pmc"
    invoke(runner, "convert", "samples/pocket.ngc", "--profile", PERTURBED, "-o", str(a))
    invoke(runner, "convert", "samples/pocket.ngc", "--profile", PERTURBED, "-o", str(b))
    assert a.read_bytes() == b.read_bytes()


def test_streamed_output_equals_one_shot(tmp_path: Path) -> None:
    """Chunks of 3 motions (cutting arcs, reversals and the canned cycles) = one chunk."""
    from prsxy_post.chain import Stages
    from prsxy_post.convert import ConvertJob, convert_file

    os.chdir(ROOT)
    for sample in SAMPLES:
        outs = []
        for chunk in (3, 1_000_000):
            out = tmp_path / f"{sample}.{chunk}.pmc"
            convert_file(
                ConvertJob(
                    f"samples/{sample}",
                    SHOP if "drill" in sample else PERTURBED,
                    "pmac",
                    str(out),
                    None,
                    Stages(),
                    "",
                    chunk=chunk,
                )
            )
            outs.append(out.read_bytes())
        assert outs[0] == outs[1], sample


def _convert(tmp_path: Path, program: str, prof: str, fmt: str, parallel: bool, chunk: int):
    """Output text (or the error) of one conversion, in one process or two."""
    from prsxy_post.chain import Stages
    from prsxy_post.convert import ConvertJob, convert_file
    from prsxy_post.errors import PrsxyError

    out = tmp_path / f"{Path(program).stem}.{fmt}.{parallel}.{chunk}"
    job = ConvertJob(
        program,
        prof,
        fmt,
        str(out),
        None,
        Stages(),
        f"--format {fmt}",
        chunk=chunk,
        parallel=parallel,
    )
    try:
        convert_file(job)
    except PrsxyError as err:
        assert not out.exists()
        return "error: " + str(err)
    return out.read_text()


@pytest.mark.parametrize("fmt", ["pmac", "gcode"])
def test_two_processes_give_the_same_output(tmp_path: Path, fmt: str) -> None:
    """The interpreter in a second process, chunks of 3 motions: the same bytes."""
    os.chdir(ROOT)
    for sample in SAMPLES:
        prof = SHOP if "drill" in sample else PERTURBED
        one = _convert(tmp_path, f"samples/{sample}", prof, fmt, False, 3)
        two = _convert(tmp_path, f"samples/{sample}", prof, fmt, True, 3)
        assert not one.startswith("error") and one == two, sample


@pytest.mark.parametrize(
    ("bad", "where"),
    [
        ("G1 X10 Y10 X5", "9000:"),  # a G-code error, far into the program
        ("G1 X900", "9000:"),  # out of reach, found by the chain
        ("G1 X10 F99999999", "9000:"),  # a feed above the machine's
    ],
)
def test_two_processes_give_the_same_errors(tmp_path: Path, bad: str, where: str) -> None:
    body = ["G21 G90 G1 F1000"] + [
        f"X{(i % 50) * 0.2:.1f} Y{(i % 7) * 0.1:.1f}" for i in range(2, 9000)
    ]
    program = tmp_path / "big.ngc"
    program.write_text("\n".join([*body, bad, "X0 Y0", "M2"]) + "\n")
    one = _convert(tmp_path, str(program), SHOP, "pmac", False, 1000)
    two = _convert(tmp_path, str(program), SHOP, "pmac", True, 1000)
    assert one.startswith("error: ") and where in one
    assert one == two


def test_large_programs_run_in_two_processes(runner: CliRunner, tmp_path: Path) -> None:
    """Above the size where a second process pays, the CLI uses one, with the
    same output and the same errors (at the right line) as one process."""
    from prsxy_post.convert import PARALLEL_FROM_BYTES, worth_a_second_process

    lines = [f"X{(i % 50) * 0.2:.4f} Y{(i % 7) * 0.1:.4f} Z0.0000" for i in range(20000)]
    program = tmp_path / "big.ngc"
    program.write_text("\n".join(["G21 G90 G1 F3000", *lines, "M2"]) + "\n")
    assert program.stat().st_size >= PARALLEL_FROM_BYTES
    assert worth_a_second_process(str(program))
    out = tmp_path / "big.pmc"
    r = invoke(runner, "convert", str(program), "--profile", SHOP, "-o", str(out), "-q")
    assert r.exit_code == 0, r.output
    assert out.read_text() == _convert(tmp_path, str(program), SHOP, "pmac", False, 4096)
    program.write_text("\n".join(["G21 G90 G1 F3000", *lines, "G2 X1", "M2"]) + "\n")
    out.write_text("keep me")
    r = runner.invoke(main, ["convert", str(program), "--profile", SHOP, "-o", str(out)])
    assert r.exit_code == 1
    assert f"big.ngc:{len(lines) + 2}:" in r.output
    _no_traceback(r.output)
    assert out.read_text() == "keep me"


def test_batch_with_jobs(runner: CliRunner, tmp_path: Path) -> None:
    r = invoke(
        runner,
        "convert",
        *[f"samples/{s}" for s in SAMPLES],
        "--profile",
        SHOP,
        "--out-dir",
        str(tmp_path),
        "--jobs",
        "2",
        "--quiet",
    )
    assert r.exit_code == 0, r.output
    for s in SAMPLES:
        got = (tmp_path / f"{Path(s).stem}.pmc").read_text()
        assert got == (GOLDEN / f"{Path(s).stem}.prsxy-shop.pmac").read_text()


def _forks_counted(monkeypatch: pytest.MonkeyPatch) -> list[str]:
    """The names of the functions :func:`sinks.forked` starts from now on."""
    from prsxy_post import sinks

    forked: list[str] = []
    fork = sinks.forked

    def counted(target, *args):  # type: ignore[no-untyped-def]
        forked.append(target.__name__)
        return fork(target, *args)

    monkeypatch.setattr(sinks, "forked", counted)
    return forked


def _jobs_of(runner: CliRunner, src: Path, texts: dict[str, str], out: Path):  # type: ignore[no-untyped-def]
    """``convert`` of programs ``texts`` (name: text, written into ``src``) into
    ``out`` with --jobs 2."""
    src.mkdir()
    for name, text in texts.items():
        (src / name).write_text(text)
    args = ["convert", *[str(src / n) for n in texts], "--profile", SHOP, "--out-dir", str(out)]
    return runner.invoke(main, [*args, "--jobs", "2", "--quiet"])


def test_jobs_are_converted_by_as_many_worker_processes_as_asked(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Nine programs with --jobs 2: two worker processes are forked, each converting
    one program after another (a process per program cost as much as the small
    programs' conversions), and every output is its golden file, one bad program
    among them failing alone with its own error."""
    forked = _forks_counted(monkeypatch)
    programs = [f"samples/{s}" for s in SAMPLES] * 3
    items = [(f"{i}-{Path(p).name}", (ROOT / p).read_text()) for i, p in enumerate(programs)]
    items.insert(4, ("bad.ngc", "G1 X1 F100\nG1 X2 Q\n"))
    src, out = tmp_path / "src", tmp_path / "out"
    r = _jobs_of(runner, src, dict(items), out)
    assert r.exit_code == 1, r.output
    assert forked == ["_job_worker", "_job_worker"]
    assert r.stderr.startswith(f"{src / 'bad.ngc'}:2:"), r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert not (out / "bad.pmc").exists()
    for i, prog in enumerate(programs):
        name = f"{i}-{Path(prog).name}"
        got = (out / f"{Path(name).stem}.pmc").read_text()
        want = (GOLDEN / f"{Path(prog).stem}.prsxy-shop.pmac").read_text()
        # the golden header names the sample; the rest is the same text
        assert got.replace(str(src / name), prog) == want


def test_a_jobs_worker_that_dies_fails_its_program_and_another_takes_its_place(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """--jobs 2, the worker converting the first program is killed outright (the
    patched conversion, inherited by the forked workers, kills its own process on
    that program): that program fails, saying so, and a third worker is forked for
    the programs still waiting, which are written whole."""
    import signal

    from prsxy_post import batch

    forked = _forks_counted(monkeypatch)
    convert = batch.convert_file

    def dying(job, *args):  # type: ignore[no-untyped-def]
        if Path(job.program).name == "x.ngc":
            os.kill(os.getpid(), signal.SIGKILL)
        return convert(job, *args)

    monkeypatch.setattr(batch, "convert_file", dying)
    pocket = (ROOT / "samples" / "pocket.ngc").read_text()
    src, out = tmp_path / "src", tmp_path / "out"
    r = _jobs_of(runner, src, {f"{n}.ngc": pocket for n in "xabc"}, out)
    assert r.exit_code == 3, r.output
    assert r.stderr.strip() == (
        f"{src / 'x.ngc'}: the process converting it ended without a result "
        f"(killed by SIGKILL); {out / 'x.pmc'} not written"
    )
    assert forked == ["_job_worker"] * 3
    assert sorted(p.name for p in out.iterdir()) == ["a.pmc", "b.pmc", "c.pmc"]
    want = (GOLDEN / "pocket.prsxy-shop.pmac").read_text()
    for name in "abc":
        got = (out / f"{name}.pmc").read_text()
        assert got.replace(str(src / f"{name}.ngc"), "samples/pocket.ngc") == want


def test_stdout_and_split_programs(runner: CliRunner, tmp_path: Path) -> None:
    r = invoke(runner, "convert", "samples/pocket.ngc", "--profile", SHOP, "-o", "-")
    assert r.exit_code == 0 and "OPEN PROG 1 CLEAR" in r.output
    prof = tmp_path / "split.toml"
    prof.write_text(
        (ROOT / SHOP)
        .read_text()
        .replace("max_points_per_program = 0", "max_points_per_program = 1500")
    )
    r = invoke(
        runner,
        "convert",
        "samples/pocket.ngc",
        "--profile",
        str(prof),
        "-o",
        str(tmp_path / "p.pmc"),
    )
    assert r.exit_code == 0, r.output
    parts = sorted(tmp_path.glob("p.part*.pmc"))
    assert len(parts) >= 2
    assert "OPEN PROG 2 CLEAR" in parts[1].read_text()
    # the old flat key is still read, with a note saying where it goes now
    old = tmp_path / "old.toml"
    old.write_text(
        prof.read_text()
        .replace("[output.pmac]", "[output]")
        .replace("[output.gcode]", "[output.gcode_unused]")
    )
    old.write_text(old.read_text().split("[output.gcode_unused]")[0])
    r = invoke(runner, "convert", "samples/pocket.ngc", "--profile", str(old), "-o", "-")
    assert r.exit_code == 0
    assert "output.max_points_per_program: deprecated key, read as " in r.output
    assert "output.pmac.max_points_per_program" in r.output


def test_stages_can_be_switched_off(runner: CliRunner, tmp_path: Path) -> None:
    outs = {}
    for flag in ("", "--no-axis-comp", "--nominal-kinematics"):
        out = tmp_path / f"o{flag}.pmc"
        args = ["convert", "samples/pocket.ngc", "--profile", PERTURBED, "-o", str(out)]
        r = invoke(runner, *(args + ([flag] if flag else [])))
        assert r.exit_code == 0
        body = out.read_text().split("OPEN PROG")[1]
        outs[flag] = body
        if flag:
            assert flag in out.read_text().split("\n")[5]  # the options header line
    assert len(set(outs.values())) == 3


def test_macros_messages_and_subroutine_files_through_convert(
    runner: CliRunner, tmp_path: Path
) -> None:
    """A program with loops and a call by name to a file on the profile's
    subroutine path converts, in one process or two, to the same output; its
    (MSG,...) and (PRINT,...) reach standard error with their lines."""
    subs = tmp_path / "subs"
    subs.mkdir()
    (subs / "ring.ngc").write_text(
        "o<ring> sub\nG0 X#1 Y0\nG3 X#1 Y0 I[-#1] J0 F600\no<ring> endsub\n"
    )
    prof = tmp_path / "shop.toml"
    prof.write_text(
        (ROOT / SHOP).read_text().replace("subroutine_path = []", 'subroutine_path = ["subs"]')
    )
    body = "G21 G90\nG0 Z5\n(MSG, rings next)\n#1 = 1\no1 while [#1 le 3]\n"
    body += "  o<ring> call [#1 * 10]\n  (PRINT, ring %d#1 done)\n  #1 = [#1 + 1]\no1 endwhile\n"
    program = tmp_path / "rings.ngc"
    program.write_text(body + "G1 X0 Y0 F500\n" * 30000 + "M2\n")  # large: two processes
    # the command itself, in its own process: a large program is interpreted in a
    # forked second process, whose messages go to the same standard error
    import subprocess
    import sys

    out = tmp_path / "rings.pmc"
    args = ["convert", str(program), "--profile", str(prof), "-o", str(out), "--quiet"]
    r = subprocess.run(
        [sys.executable, "-m", "prsxy_post.cli", *args], capture_output=True, text=True, cwd=ROOT
    )
    assert r.returncode == 0, r.stderr
    assert f"{program}:3: (MSG) rings next" in r.stderr
    assert f"{program}:7: (PRINT) ring 3 done" in r.stderr
    one = _convert(tmp_path, str(program), str(prof), "pmac", False, 4096)
    two = _convert(tmp_path, str(program), str(prof), "pmac", True, 4096)
    assert not one.startswith("error") and one == two
    assert out.read_text().split("\n")[3:] == one.split("\n")[3:]  # but the header's options


def test_inspect_json(runner: CliRunner) -> None:
    r = invoke(runner, "inspect", "samples/pocket.ngc", "--json")
    assert r.exit_code == 0

    def strict(name: str) -> None:  # NaN and Infinity are not JSON
        raise AssertionError(f"{name} in the JSON")

    rows = [json.loads(x, parse_constant=strict) for x in r.output.splitlines()]
    assert rows[-1]["kind"] == "function" and rows[-1]["feed"] is None
    assert rows[0]["kind"] == "rapid" and rows[0]["line"] == 5
    arcs = [x for x in rows if x["kind"] == "arc"]
    assert arcs and {"plane", "center", "rotation"} <= set(arcs[0])


def test_check_lists_every_problem(runner: CliRunner, tmp_path: Path) -> None:
    prog = tmp_path / "far.ngc"
    prog.write_text("G21 G90\nG0 X500\nG1 Y0 A40 F100\nG1 F99999 X0\nM2\n")
    r = invoke(runner, "check", str(prog), "--profile", SHOP)
    assert r.exit_code == 1
    assert f"{prog}:2:" in r.output and "beyond its travel" in r.output
    assert f"{prog}:3:" in r.output and "tilted" in r.output
    assert f"{prog}:4:" in r.output and "above the machine's maximum" in r.output
    ok = invoke(runner, "check", "samples/pocket.ngc", "--profile", SHOP)
    assert ok.exit_code == 0


def test_check_streams_long_programs_and_lists_problems_in_line_order(
    runner: CliRunner, tmp_path: Path
) -> None:
    """Problems in different chunks of a long program, listed by line, each once."""
    body = [f"X{(i % 40) * 0.5:.1f} Y{(i % 9) * 0.5:.1f}" for i in range(10000)]
    body[6000] = "X500"  # beyond the table's travel (and on the way back)
    body[2000], body[2001] = "X1 A40", "X1 A0"  # tilted beyond the limit
    body[9000], body[9001] = "X2 F99999", "X1 F2000"  # above the machine's feed
    prog = tmp_path / "long.ngc"
    prog.write_text("\n".join(["G21 G90 G1 F2000", *body, "M2"]) + "\n")
    r = invoke(runner, "check", str(prog), "--profile", SHOP, "--each-line")
    assert r.exit_code == 1
    found = [int(m) for m in re.findall(rf"^{re.escape(str(prog))}:(\d+):", r.stdout, re.M)]
    assert found == sorted(found)
    assert set(found) >= {2002, 6002, 9002}
    assert len(found) <= 6
    assert f"{len(set(found))} lines with problems in 3 groups" in r.stderr
    grouped = invoke(runner, "check", str(prog), "--profile", SHOP)
    starts = re.findall(rf"^{re.escape(str(prog))}:(\d+): (\w+)", grouped.stdout, re.M)
    assert [(int(n), w) for n, w in starts] == [(2002, "tool"), (6002, "motor"), (9002, "feed")]


# ---------------------------------------------------------------- errors

BAD_PROGRAMS = [
    ("G21\nG1 X1 Y1 Z#<depth> F100\nM2\n", ":2:11:", "#<depth> is not defined"),
    ("G21\nG0 X1\n", ":2:", "ends without M2"),
    ("G21\nG1 X10\nM2\n", ":2:4:", "no feed rate"),
    ("G21\nG0 X9000\nM2\n", ":2:", "beyond its travel"),
    ("G21\nG0 B60\nM2\n", ":2:", "tilted"),
    ("G21\nM2\n", "", "moves nothing"),
    ("", "", "ends without M2"),
]


@pytest.mark.parametrize(("text", "where", "what"), BAD_PROGRAMS, ids=[b[2] for b in BAD_PROGRAMS])
def test_bad_programs_fail_cleanly_and_keep_the_old_output(
    runner: CliRunner, tmp_path: Path, text: str, where: str, what: str
) -> None:
    prog = tmp_path / "bad.ngc"
    prog.write_text(text)
    out = tmp_path / "out.pmc"
    out.write_text("precious\n")
    r = invoke(runner, "convert", str(prog), "--profile", SHOP, "-o", str(out))
    assert r.exit_code == 1
    assert f"{prog}{where}" in r.output and what in r.output, r.output
    _no_traceback(r.output)
    assert out.read_text() == "precious\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.ngc", "out.pmc"]


def test_binary_file(runner: CliRunner, tmp_path: Path) -> None:
    prog = tmp_path / "bin.ngc"
    prog.write_bytes(b"G21\nG0 X1\n\x00\x01\x02")
    r = invoke(runner, "convert", str(prog), "--profile", SHOP, "-o", str(tmp_path / "o"))
    assert r.exit_code == 1 and f"{prog}:3: binary data" in r.output


def test_bad_profile_names_the_key(runner: CliRunner, tmp_path: Path) -> None:
    prof = tmp_path / "p.toml"
    prof.write_text(
        (ROOT / SHOP).read_text().replace("strut_length = 400.0", "strut_length = -1", 1)
    )
    r = invoke(
        runner,
        "convert",
        "samples/pocket.ngc",
        "--profile",
        str(prof),
        "-o",
        str(tmp_path / "o.pmc"),
    )
    assert r.exit_code == 1
    assert "kinematics.legs[1].strut_length" in r.output
    _no_traceback(r.output)


@pytest.mark.parametrize(
    "args",
    [
        ["convert", "samples/pocket.ngc", "samples/drill.ngc", "--profile", SHOP, "-o", "x"],
        ["convert", "samples/pocket.ngc", "--profile", SHOP, "--start", "1,2"],
        ["convert", "samples/pocket.ngc", "--profile", SHOP, "--format", "dxf"],
        ["convert", "samples/pocket.ngc"],
    ],
)
def test_usage_errors_exit_2(runner: CliRunner, args: list[str]) -> None:
    r = runner.invoke(main, args)
    assert r.exit_code == 2, r.output
    _no_traceback(r.output)


def test_missing_file(runner: CliRunner) -> None:
    r = invoke(runner, "convert", "nope.ngc", "--profile", SHOP)
    assert r.exit_code == 1 and "nope.ngc" in r.output


def test_calibrate_refuses_to_overwrite_its_input(runner: CliRunner, tmp_path: Path) -> None:
    prof = tmp_path / "p.toml"
    prof.write_text((ROOT / SHOP).read_text())
    r = invoke(
        runner, "calibrate", "tests/data/spec/poses.csv", "--profile", str(prof), "-o", str(prof)
    )
    assert r.exit_code == 2 and "--in-place" in r.output
    assert prof.read_text() == (ROOT / SHOP).read_text()


def test_malformed_measurement_names_file_and_row(runner: CliRunner, tmp_path: Path) -> None:
    bad = tmp_path / "poses.csv"
    lines = (ROOT / "tests/data/spec/poses.csv").read_text().splitlines()
    lines[5] = lines[5].replace(",", ",nan,", 1).rsplit(",", 1)[0]
    bad.write_text("\n".join(lines) + "\n")
    r = invoke(runner, "calibrate", str(bad), "--profile", SHOP, "-o", str(tmp_path / "o.toml"))
    assert r.exit_code == 1 and f"{bad}:6" in r.output, r.output
    assert not (tmp_path / "o.toml").exists()


NUMERIC = [
    ("G21\nG1 Xnan F100\nM2\n", ":2:", "no number"),
    ("G21\nG1 X1e308 F100\nM2\n", ":2:", "E word with no M66"),
    ("G21\nG1 X999999999 F100\nM2\n", ":2:", "beyond its travel"),
    ("G21\nG1 X1 F-5\nM2\n", ":2:", "negative F"),
    ("G21\nG1 X1 F0\nM2\n", ":2:", "no feed rate"),
    ("G21\nG0 X1\nG2 X1 Y0 R5 F100\nM2\n", ":3:", "end point is its start point"),
    ("G21\nG0 X0\nG2 X0.000001 Y0 I0.0000001 J0 F100\nM2\n", ":3:", "zero-radius arc"),
    ("G21\nG0 X0 Y0\nG2 X0 Y0 I1000000 J0 F100\nM2\n", ":3:", "would interpolate to more than"),
    ("G21\nG0 Z-2000\nM2\n", ":2:", "beyond its travel"),
]


@pytest.mark.parametrize(("text", "where", "what"), NUMERIC, ids=[n[2] for n in NUMERIC])
def test_numeric_hygiene(
    runner: CliRunner, tmp_path: Path, text: str, where: str, what: str
) -> None:
    prog = tmp_path / "n.ngc"
    prog.write_text(text)
    out = tmp_path / "o.pmc"
    r = invoke(runner, "convert", str(prog), "--profile", SHOP, "-o", str(out))
    assert r.exit_code == 1, r.output
    assert f"{prog}{where}" in r.output and what in r.output, r.output
    _no_traceback(r.output)
    assert not out.exists()


def test_pose_at_the_edge_of_reach(runner: CliRunner, tmp_path: Path) -> None:
    """Tilts up to the profile's limit convert; one step beyond is refused at its line."""
    prog = tmp_path / "tilt.ngc"
    prog.write_text("G21\nG1 B30 F1000\nG1 B30.01\nM2\n")
    r = invoke(runner, "check", str(prog), "--profile", SHOP)
    assert r.exit_code == 1
    assert f"{prog}:3:" in r.output and f"{prog}:2:" not in r.output


def test_in_place_keeps_a_backup(runner: CliRunner, tmp_path: Path) -> None:
    prof = tmp_path / "p.toml"
    original = (ROOT / SHOP).read_text()
    prof.write_text(original)
    r = invoke(
        runner,
        "calibrate",
        *sorted(str(p) for p in (ROOT / "tests/data/spec").glob("*.csv")),
        "--profile",
        str(prof),
        "-o",
        str(prof),
        "--in-place",
        "--commanded-with",
        "tests/data/vectors/nominal.toml",
    )
    assert r.exit_code == 0, r.output
    assert (tmp_path / "p.toml.bak").read_text() == original
    assert prof.read_text() != original


def _gcode_rejections() -> list[tuple[str, str, str]]:
    from .test_gcode import REJECT

    return REJECT


@pytest.mark.parametrize(
    ("text", "where", "what"), _gcode_rejections(), ids=[r[2][:30] for r in _gcode_rejections()]
)
def test_every_gcode_rejection_through_the_cli(
    runner: CliRunner, tmp_path: Path, text: str, where: str, what: str
) -> None:
    """Each of the reader's rejections, as a user meets it: exit 1, the file, line and
    column, no traceback, and an existing output left as it was."""
    prog = tmp_path / "t.ngc"
    prog.write_text(text)
    out = tmp_path / "out.pmc"
    out.write_text("precious\n")
    r = invoke(
        runner, "convert", str(prog), "--profile", "tests/data/vectors/nominal.toml", "-o", str(out)
    )
    assert r.exit_code == 1
    assert str(prog) + where.removeprefix("t.ngc") in r.output and what in r.output, r.output
    _no_traceback(r.output)
    assert out.read_text() == "precious\n"


def test_gcode_tolerance_reduction_stays_within_it(runner: CliRunner, tmp_path: Path) -> None:
    """With output.gcode.tolerance_mm every dropped point lies within it of the chord."""
    import numpy as np

    from .test_tracking import read_gcode_points

    tol = 0.002
    shop = (ROOT / SHOP).read_text()
    assert "\ntolerance_mm = 0.0001 " in shop
    prof, every = tmp_path / "tol.toml", tmp_path / "every.toml"
    prof.write_text(shop.replace("\ntolerance_mm = 0.0001 ", f"\ntolerance_mm = {tol} "))
    # a line to every point, the dense reference
    every.write_text(shop.replace("\ntolerance_mm = 0.0001 ", "\ntolerance_mm = 0.0 "))
    dense, sparse = tmp_path / "d.ngc", tmp_path / "s.ngc"
    for p, out in ((str(every), dense), (str(prof), sparse)):
        r = invoke(
            runner,
            "convert",
            "samples/pocket.ngc",
            "--profile",
            p,
            "--format",
            "gcode",
            "-o",
            str(out),
        )
        assert r.exit_code == 0, r.output
    qd, _, _ = read_gcode_points(dense.read_text())
    qs, _, _ = read_gcode_points(sparse.read_text())

    def moves(text: str) -> int:  # an arc is one move, read back as many points
        return sum(row.startswith(("G0 ", "G1 ", "G2 ", "G3 ")) for row in text.splitlines())

    assert moves(sparse.read_text()) < 0.8 * moves(dense.read_text())
    worst = 0.0
    a, b = qs[:-1, :3], qs[1:, :3]
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-30)
    for p in qd[:, :3]:
        t = np.clip(np.einsum("ij,ij->i", p - a, d) / dd, 0, 1)
        worst = max(worst, float(np.min(np.linalg.norm(p - (a + t[:, None] * d), axis=1))))
    assert worst <= tol + 2e-5


def test_the_executable_ends_with_its_output_whole_and_its_exit_code(
    runner: CliRunner, tmp_path: Path
) -> None:
    """``prsxy-post`` (cli.run) ends its process without Python's shutdown: what a
    conversion printed to a pipe arrives whole, byte for byte what it writes to a
    file, and each exit code is the command's (0, 1 bad input, 2 bad usage)."""
    import subprocess
    import sys

    def command(*args: str) -> subprocess.CompletedProcess[bytes]:
        cmd = [sys.executable, "-m", "prsxy_post.cli", *args]
        return subprocess.run(cmd, capture_output=True, cwd=ROOT, check=False)

    piped = command("convert", "samples/pocket.ngc", "--profile", SHOP, "-o", "-", "-q")
    assert piped.returncode == 0, piped.stderr
    out = tmp_path / "pocket.pmc"
    r = invoke(runner, "convert", "samples/pocket.ngc", "--profile", SHOP, "-o", str(out), "-q")
    assert r.exit_code == 0
    assert piped.stdout == out.read_bytes()
    missing = command("convert", str(tmp_path / "missing.ngc"), "--profile", SHOP, "-o", "-")
    assert missing.returncode == 1
    assert b"missing.ngc: cannot read G-code program" in missing.stderr
    assert command("convert").returncode == 2
