"""The measuring commands as users meet them: simulate, calibrate, diagnose, ballbar.

Provenance in the data (which profile commanded the machine), the warning when
something is left unexplained, and the HTML reports opened in a real browser.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import pytest
from click.testing import CliRunner

from prsxy_post import measure
from prsxy_post.cli import main

from .conftest import ROOT

NOMINAL = "profiles/prsxy-nominal.toml"


@pytest.fixture
def runner(monkeypatch: pytest.MonkeyPatch) -> CliRunner:
    monkeypatch.chdir(ROOT)
    return CliRunner()


def invoke(runner: CliRunner, *args: str):
    return runner.invoke(main, list(args), catch_exceptions=False)


def _simulate(runner: CliRunner, out: Path, truth: str, commanded: str, *extra: str) -> list[str]:
    r = invoke(
        runner,
        "simulate",
        "--truth",
        truth,
        "--profile",
        commanded,
        "-o",
        str(out),
        "--only-xy",
        "--radii",
        "50",
        "--poses",
        "30",
        "--no-axis-runs",
        *extra,
    )
    assert r.exit_code == 0, r.output
    return sorted(str(p) for p in out.glob("*.csv"))


@pytest.fixture(scope="module")
def square_truth(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The nominal machine with its table 0.1 mm/m out of square."""
    p = tmp_path_factory.mktemp("truth") / "truth.toml"
    text = (ROOT / NOMINAL).read_text()
    assert "squareness = 0.0" in text
    p.write_text(text.replace("squareness = 0.0", "squareness = 1e-4"))
    return p


def test_simulate_writes_which_profile_commanded_every_file(
    runner: CliRunner, tmp_path: Path, square_truth: Path
) -> None:
    files = _simulate(runner, tmp_path / "m", str(square_truth), NOMINAL)
    digest = hashlib.sha256((ROOT / NOMINAL).read_bytes()).hexdigest()
    assert len(files) == 3  # two ballbar runs and the poses
    for f in files:
        text = Path(f).read_text()
        assert f"# commanded_with: prsxy-nominal.toml sha256:{digest}\n" in text
        m = measure.read_measurement(text, f)
        assert m.commanded_with == measure.CommandedWith("prsxy-nominal.toml", digest)


def test_data_commanded_with_another_profile_are_refused(
    runner: CliRunner, tmp_path: Path, square_truth: Path
) -> None:
    """diagnose (and calibrate) told the wrong commanding profile refuse, naming
    the file, its line, both profiles and the way out; told right, they run."""
    files = _simulate(runner, tmp_path / "m", str(square_truth), NOMINAL)
    other = tmp_path / "other.toml"
    other.write_text((ROOT / NOMINAL).read_text() + "\n# a comment changes the bytes\n")
    for cmd in (["diagnose"], ["calibrate", "-o", str(tmp_path / "cal.toml")]):
        r = invoke(runner, *cmd, *files, "--profile", str(other))
        assert r.exit_code == 1, r.output
        first = r.output.splitlines()[0]
        assert first.startswith(f"{files[0]}:2: commanded_with: measured while"), first
        assert "prsxy-nominal.toml" in first and "other.toml" in first
        assert "--commanded-with" in first and "--ignore-provenance" in first
        assert "Traceback" not in r.output
    assert not (tmp_path / "cal.toml").exists()
    # the right commanding profile named: the squareness is found
    r = invoke(runner, "diagnose", *files, "--profile", str(other), "--commanded-with", NOMINAL)
    assert r.exit_code == 0, r.output
    assert "effect: table.squareness" in r.output
    # or the check waived on purpose
    r = invoke(runner, "diagnose", *files, "--profile", str(other), "--ignore-provenance")
    assert r.exit_code == 0, r.output


def test_a_profile_written_by_diagnose_is_not_taken_for_the_commanding_one(
    runner: CliRunner, tmp_path: Path, square_truth: Path
) -> None:
    """The trap of issue 13: diagnose run again on its own output with the same data
    would have reprinted the same "before -> after"; now the data say who commanded."""
    files = _simulate(runner, tmp_path / "m", str(square_truth), NOMINAL)
    upd = tmp_path / "upd.toml"
    r = invoke(runner, "diagnose", *files, "--profile", NOMINAL, "-o", str(upd))
    assert r.exit_code == 0, r.output
    r = invoke(runner, "diagnose", *files, "--profile", str(upd))
    assert r.exit_code == 1 and "--commanded-with" in r.output, r.output
    r = invoke(runner, "diagnose", *files, "--profile", str(upd), "--commanded-with", NOMINAL)
    assert r.exit_code == 0, r.output
    assert "no missing effect found" in r.output


def test_malformed_provenance_line_is_located(runner: CliRunner, tmp_path: Path) -> None:
    bad = tmp_path / "poses.csv"
    lines = (ROOT / "tests/data/spec/poses.csv").read_text().splitlines()
    bad.write_text("\n".join([lines[0], "# commanded_with: shop.toml sha256:abc", *lines[1:]]))
    r = invoke(runner, "diagnose", str(bad), "--profile", NOMINAL)
    assert r.exit_code == 1
    assert r.output.startswith(f"{bad}:2: commanded_with: commanded_with is"), r.output
    assert "64 hex digits" in r.output
