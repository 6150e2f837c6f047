"""The everyday things a user meets first: help with examples, where outputs go,
inputs that are never overwritten, grouped problems, profiles that keep their
comments. Error texts are asserted as the user reads them."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import click
import pytest
from click.testing import CliRunner

from prsxy_post.cli import EXAMPLES, main

from .conftest import ROOT

NOMINAL = str(ROOT / "profiles" / "prsxy-nominal.toml")
SHOP = ROOT / "profiles" / "prsxy-shop.toml"
SPEC = ROOT / "tests" / "data" / "spec"


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def run(runner: CliRunner, *args: str) -> click.testing.Result:
    return runner.invoke(main, list(args), catch_exceptions=False)


# ---------------------------------------------------------------- help


def _commands(group: click.Group, path: tuple[str, ...] = ()) -> list[tuple[str, ...]]:
    out = [path]
    for name, cmd in group.commands.items():
        if isinstance(cmd, click.Group):
            out += _commands(cmd, (*path, name))
        else:
            out.append((*path, name))
    return out


COMMANDS = _commands(main)


def test_every_command_has_examples() -> None:
    assert {" ".join(p) for p in COMMANDS} == set(EXAMPLES)


@pytest.mark.parametrize("path", COMMANDS, ids=lambda p: " ".join(p) or "prsxy-post")
def test_help_ends_with_examples_that_parse(runner: CliRunner, path: tuple[str, ...]) -> None:
    r = run(runner, *path, "--help")
    assert r.exit_code == 0
    shown = r.output.split("Examples:\n", 1)[1].splitlines()
    examples = EXAMPLES[" ".join(path)]
    assert [s.strip() for s in shown] == list(examples)
    for ex in examples:
        words = shlex.split(ex.split("#")[0].split("|")[0])
        assert words[0] == "prsxy-post"
        if "COMMAND" in words:
            continue
        # click parses the example against the command's options (types, choices,
        # required ones) without running it
        ctx = main.make_context("prsxy-post", words[1:])
        cmd: click.Command = main
        args = [*ctx._protected_args, *ctx.args] if hasattr(ctx, "_protected_args") else ctx.args
        while isinstance(cmd, click.Group):
            name, sub, args = cmd.resolve_command(ctx, args)
            assert sub is not None, ex
            ctx = sub.make_context(name or "", args, parent=ctx)
            cmd = sub
            args = [*getattr(ctx, "_protected_args", []), *ctx.args]
        assert not ctx.args, ex


def test_help_shows_each_example_once(runner: CliRunner) -> None:
    """calibrate and ballbar once printed an example in their text as well as
    the Examples section; every example is shown once, under Examples only."""
    for path in COMMANDS:
        r = run(runner, *path, "--help")
        assert "Example:" not in r.output, path
        lines = [x.strip() for x in r.output.splitlines()]
        for ex in EXAMPLES[" ".join(path)]:
            assert lines.count(ex) == 1, (path, ex)


def test_inspect_json_is_an_optional_flag(runner: CliRunner) -> None:
    r = runner.invoke(main, ["inspect", "--help"], prog_name="prsxy-post")
    assert r.output.startswith("Usage: prsxy-post inspect [OPTIONS] PROGRAM\n")
    line = next(x for x in r.output.splitlines() if x.strip().startswith("--json"))
    assert "required" not in line


def test_tables_import_examples_read_what_export_writes(
    runner: CliRunner, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Run the `tables export` examples, then every `tables import` example on
    what they wrote: each file an import example names is one export writes."""
    monkeypatch.chdir(tmp_path)
    for name in ("shop.toml", "a.toml"):
        (tmp_path / name).write_text(
            (ROOT / "tests" / "data" / "vectors" / "perturbed.toml").read_text()
        )
    for ex in EXAMPLES["tables export"]:
        r = run(runner, *shlex.split(ex)[1:])
        assert r.exit_code == 0, (ex, r.output)
    imports = [ex for ex in {*EXAMPLES["tables"], *EXAMPLES["tables import"]} if " import " in ex]
    assert len(imports) >= 2
    for ex in imports:
        words = shlex.split(ex)[1:]
        assert Path(words[2]).is_file(), f"{ex}: tables export writes no {words[2]}"
        r = run(runner, *words)
        assert r.exit_code == 0, (ex, r.output)
        assert Path(words[-1]).is_file()


@pytest.mark.parametrize("motor", ["4", "0", "7", "P1"])
def test_tables_import_refuses_a_motor_the_machine_has_not(
    runner: CliRunner, tmp_path: Path, motor: str
) -> None:
    """The contract's motors are P1, P2, P3, P5, P6 (docs/machine-model.md)."""
    comp = tmp_path / "motor4.comp"
    comp.write_text("0 0 0\n10 0 0\n")
    args = ["tables", "import", str(comp), "--profile", str(SHOP), "--format", "linuxcnc1"]
    r = runner.invoke(main, [*args, "--motor", motor, "-o", str(tmp_path / "b.toml")])
    assert r.exit_code == 2
    assert (
        f"Error: Invalid value for '--motor': '{motor}' is not a motor of the PRS-XY machine "
        "(expected one of 1 (P1), 2 (P2), 3 (P3), 5 (P5), 6 (P6); there is no motor 4)"
    ) in r.stderr
    assert not (tmp_path / "b.toml").exists()


@pytest.mark.parametrize("motor", ["1", "2", "3", "5", "6"])
def test_tables_import_takes_each_motor_of_the_machine(
    runner: CliRunner, tmp_path: Path, motor: str
) -> None:
    comp = tmp_path / "t.comp"
    comp.write_text("0 0 0\n10 0.001 -0.001\n")
    out = tmp_path / "b.toml"
    r = run(
        runner,
        "tables",
        "import",
        str(comp),
        "--profile",
        str(SHOP),
        "--format",
        "linuxcnc1",
        "--motor",
        motor,
        "-o",
        str(out),
    )
    assert r.exit_code == 0, r.output
    assert f"wrote {out} with tables for motors {motor}" in r.stderr


# ---------------------------------------------------------------- convert outputs


@pytest.fixture
def part(tmp_path: Path) -> Path:
    p = tmp_path / "part.ngc"
    p.write_text((ROOT / "samples" / "pocket.ngc").read_text())
    return p


def test_without_o_the_output_goes_beside_the_program(runner: CliRunner, part: Path) -> None:
    r = run(runner, "convert", str(part), "--profile", NOMINAL)
    assert r.exit_code == 0, r.output
    out = part.with_suffix(".pmc")
    assert out.read_text().startswith(";") and "OPEN PROG" in out.read_text()
    assert r.stdout == ""
    assert r.stderr == f"{part} -> {out}\n"


def test_o_dash_is_standard_output(runner: CliRunner, part: Path) -> None:
    r = run(runner, "convert", str(part), "--profile", NOMINAL, "-o", "-")
    assert r.exit_code == 0 and "OPEN PROG" in r.stdout
    assert not part.with_suffix(".pmc").exists()


def test_several_programs_each_beside_itself(runner: CliRunner, part: Path) -> None:
    other = part.parent / "sub" / "other.ngc"
    other.parent.mkdir()
    other.write_text(part.read_text())
    r = run(runner, "convert", str(part), str(other), "--profile", NOMINAL, "--jobs", "2")
    assert r.exit_code == 0, r.output
    assert part.with_suffix(".pmc").exists() and other.with_suffix(".pmc").exists()


def test_standard_input_needs_o(runner: CliRunner, part: Path) -> None:
    r = runner.invoke(main, ["convert", "-", "--profile", NOMINAL], input=part.read_text())
    assert r.exit_code == 2
    assert r.stderr == (
        "the program comes from standard input, so there is no file to write beside "
        "(expected -o FILE, or -o - for standard output)\n"
    )


def _unchanged(path: Path, text: str) -> None:
    assert path.read_text() == text
    assert [p.name for p in path.parent.iterdir() if p.name.startswith(".")] == []


def test_o_never_overwrites_the_program(runner: CliRunner, part: Path) -> None:
    before = part.read_text()
    r = run(
        runner, "convert", str(part), "--profile", NOMINAL, "--format", "gcode", "-o", str(part)
    )
    assert r.exit_code == 2
    assert r.stderr == (
        f"-o {part} would overwrite the G-code program {part} (expected another output file)\n"
    )
    _unchanged(part, before)


def test_the_same_file_by_another_path_is_refused(runner: CliRunner, part: Path) -> None:
    before = part.read_text()
    (part.parent / "link.ngc").symlink_to(part)
    os.link(part, part.parent / "hard.ngc")
    (part.parent / "d").mkdir()
    for out in ("link.ngc", "hard.ngc", "d/../part.ngc"):
        r = run(
            runner, "convert", str(part), "--profile", NOMINAL, "--format", "gcode", "-o",
            str(part.parent / out),
        )  # fmt: skip
        assert r.exit_code == 2 and "would overwrite the G-code program" in r.stderr, out
    _unchanged(part, before)


def test_out_dir_never_overwrites_the_program(runner: CliRunner, part: Path) -> None:
    before = part.read_text()
    d = str(part.parent)
    r = run(runner, "convert", str(part), "--profile", NOMINAL, "--format", "gcode", "--out-dir", d)
    assert r.exit_code == 2
    assert r.stderr == (
        f"--out-dir {d} would write {part} over the G-code program {part} "
        "(expected another directory, or -o FILE)\n"
    )
    _unchanged(part, before)


def test_default_output_never_overwrites_the_program(runner: CliRunner, part: Path) -> None:
    before = part.read_text()
    r = run(runner, "convert", str(part), "--profile", NOMINAL, "--format", "gcode")
    assert r.exit_code == 2
    assert r.stderr == (
        f"the default output {part} (the program's name with the gcode format's extension) "
        f"would overwrite the G-code program {part} (expected -o FILE or --out-dir DIR for "
        "the output)\n"
    )
    _unchanged(part, before)


def test_o_never_overwrites_the_profile(runner: CliRunner, part: Path, tmp_path: Path) -> None:
    prof = tmp_path / "shop.toml"
    prof.write_text(SHOP.read_text())
    r = run(runner, "convert", str(part), "--profile", str(prof), "-o", str(prof))
    assert r.exit_code == 2
    assert (
        r.stderr == f"-o {prof} would overwrite the profile {prof} (expected another output file)\n"
    )
    _unchanged(prof, SHOP.read_text())


def test_two_programs_with_one_name_are_refused(runner: CliRunner, part: Path) -> None:
    other = part.parent / "sub" / "part.ngc"
    other.parent.mkdir()
    other.write_text(part.read_text())
    out = part.parent / "out"
    r = run(runner, "convert", str(part), str(other), "--profile", NOMINAL, "--out-dir", str(out))
    assert r.exit_code == 2
    assert r.stderr == (
        f"{part} and {other} would both be written to {out / 'part.pmc'} (expected programs "
        "with different names, or one convert per directory)\n"
    )
    assert not out.exists()


def test_library_refuses_too(part: Path) -> None:
    from prsxy_post.convert import ConvertJob, convert_file
    from prsxy_post.errors import UsageError

    with pytest.raises(UsageError, match="would overwrite the G-code program"):
        convert_file(ConvertJob(str(part), NOMINAL, "gcode", str(part)))


# ---------------------------------------------------------------- check


def test_check_groups_problems_by_kind(runner: CliRunner, tmp_path: Path) -> None:
    """60 runs of two lines beyond the table's travel (out to X310, back in to
    X295), each followed by a line within it, then a tilt over two lines."""
    prog = tmp_path / "far.ngc"
    body = ["X310", "X295", "X290"] * 60 + ["X0", "A40", "A0"]  # lines 2..184
    prog.write_text("\n".join(["G21 G90 G1 F3000", *body, "M2"]) + "\n")
    r = run(runner, "check", str(prog), "--profile", NOMINAL)
    assert r.exit_code == 1
    runs = ", ".join(f"{2 + 3 * k}-{3 + 3 * k}" for k in range(8))
    assert r.stdout.splitlines() == [
        f"{prog}:2: motor 5 (X) commanded beyond its travel on 120 lines ({runs}, and 52 "
        "more runs), worst 310.0000 mm at line 2 (expected -300 to 300 mm (motors[5].min/max))",
        f"{prog}:183: tool axis tilted beyond the limit on 2 lines (183-184), worst 40.000° "
        "at line 183 (expected at most 30° (limits.max_tilt_deg))",
    ]
    assert r.stderr == f"{prog}: 122 lines with problems in 2 groups\n"
    each = run(runner, "check", str(prog), "--profile", NOMINAL, "--each-line")
    assert len(each.stdout.splitlines()) == 122
    assert each.stdout.splitlines()[0] == (
        f"{prog}:2: motor 5 (X) commanded to 310.0000 mm, beyond its travel "
        "(expected -300 to 300 mm (motors[5].min/max))"
    )


def test_check_reports_the_problems_before_a_gcode_error(runner: CliRunner, tmp_path: Path) -> None:
    prog = tmp_path / "bad.ngc"
    prog.write_text("G21 G90 G1 F3000\nX310\nX0\nG1 X1 Q\nM2\n")
    r = run(runner, "check", str(prog), "--profile", NOMINAL)
    assert r.exit_code == 1
    assert r.stdout.startswith(f"{prog}:2: motor 5 (X) commanded beyond its travel on 2 lines")
    err = r.stderr.splitlines()
    assert err[0].startswith(f"{prog}:4:")
    assert (
        err[1] == f"{prog}: 2 lines with problems in 1 group; the check stopped at the error above"
    )


# ---------------------------------------------------------------- a pipe closed early


def test_a_closed_pipe_is_not_an_internal_error(tmp_path: Path) -> None:
    prog = tmp_path / "long.ngc"
    prog.write_text("G21 G1 F1000\n" + "".join(f"X{i % 50}\n" for i in range(50000)) + "M2\n")
    cmd = [sys.executable, "-m", "prsxy_post.cli", "inspect", str(prog)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=ROOT)
    assert p.stdout is not None and p.stderr is not None
    p.stdout.readline()
    p.stdout.close()
    err = p.stderr.read().decode()
    p.stderr.close()
    assert p.wait() == 1
    assert err == ""


# ---------------------------------------------------------------- profiles keep comments

COMMENTED = SHOP.read_text().replace(
    "[table]\n", "# squared by hand in March; redo after the move\n[table]   # ballbar\n"
)


def _comments(text: str) -> list[str]:
    return re.findall(r"#.*", text)


def test_calibrate_o_keeps_the_profiles_comments(runner: CliRunner, tmp_path: Path) -> None:
    prof = tmp_path / "shop.toml"
    prof.write_text(COMMENTED)
    out = tmp_path / "cal.toml"
    data = [str(SPEC / f) for f in ("axis.csv", "poses.csv", "ballbar-xy-r50-ccw.csv")]
    r = run(runner, "calibrate", *data, "--profile", str(prof), "-o", str(out))
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert _comments(text) == _comments(COMMENTED)
    assert "[[axis_comp]]" in text and "[error_map]" in text
    assert text.startswith(COMMENTED[: COMMENTED.index("[kinematics]")])  # untouched head


def test_diagnose_o_keeps_the_profiles_comments(runner: CliRunner, tmp_path: Path) -> None:
    prof = tmp_path / "shop.toml"
    prof.write_text(COMMENTED)
    out = tmp_path / "diag.toml"
    r = run(runner, "diagnose", str(SPEC / "axis.csv"), "--profile", str(prof), "-o", str(out))
    assert r.exit_code == 0, r.output
    text = out.read_text()
    assert _comments(text) == _comments(COMMENTED)
    assert "[[provenance.diagnose]]" in text
    # what diagnose did not change is line for line the user's
    for section in ("[limits]", "[start]", "[gcode]", "[[tools]]"):
        i = COMMENTED.index(section)
        assert COMMENTED[i : COMMENTED.index("\n\n", i)] in text
