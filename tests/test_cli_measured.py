"""The measuring commands as users meet them: simulate, calibrate, diagnose, ballbar.

Provenance in the data (which profile commanded the machine), the warning when
something is left unexplained, and the HTML reports opened in a real browser.
"""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
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


# ---------------------------------------------------------------- never silent


def test_what_no_library_effect_explains_is_said_on_stderr_and_in_the_json(
    runner: CliRunner, tmp_path: Path
) -> None:
    """A cyclic error of a pitch the library does not scan (7.3 mm) on motor 5: the
    diagnosis warns that the ballbar data are left above their noise, where, and
    that no library effect takes it; the JSON carries the same."""
    truth = tmp_path / "truth.toml"
    truth.write_text(
        (ROOT / NOMINAL).read_text()
        + "\n[[effects.cyclic]]\nmotor = 5\namplitude = 0.004\nperiod = 7.3\n"
    )
    files = _simulate(runner, tmp_path / "m", str(truth), NOMINAL, "--radii", "100")
    r = invoke(runner, "diagnose", *files, "--profile", NOMINAL)
    assert r.exit_code == 0, r.output
    warn = [ln for ln in r.stderr.splitlines() if ln.startswith("warning: Left unexplained")]
    assert warn and "ballbar residual" in warn[0] and "no effect of the library" in warn[0], (
        r.stderr
    )
    assert "warning" not in r.stdout
    r = invoke(runner, "diagnose", *files, "--profile", NOMINAL, "--json")
    j = json.loads(r.stdout)
    (u,) = [x for x in j["unexplained"] if x["kind"] == "ballbar"]
    assert u["ratio"] > 1.5 and u["regions"] and u["library_share"] < 0.5


def test_a_clean_diagnosis_warns_of_nothing(runner: CliRunner, tmp_path: Path) -> None:
    files = _simulate(runner, tmp_path / "m", NOMINAL, NOMINAL)
    r = invoke(runner, "diagnose", *files, "--profile", NOMINAL, "--json", "--quiet")
    assert r.exit_code == 0 and r.stderr == "", r.stderr
    assert json.loads(r.stdout)["unexplained"] == []


# ---------------------------------------------------------------- reports in a browser

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
#: a transparent 1x1 PNG: what an image that failed to render would leave
BLANK = (
    "iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mNkYPhfDwAChwGA60e6kgAAAABJRU5Erk"
    "Jggg=="
)


def _screenshot(page: Path, out: Path, profile_dir: Path) -> np.ndarray:
    """The page as headless Chromium renders it, (h, w, 3) in 0..1."""
    subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            f"--user-data-dir={profile_dir}",
            "--hide-scrollbars",
            "--window-size=1200,4200",
            f"--screenshot={out}",
            page.as_uri(),
        ],
        check=True,
        capture_output=True,
        timeout=180,
    )
    import matplotlib.image

    return matplotlib.image.imread(str(out))[:, :, :3]


def _renders_every_plot(page: Path, tmp: Path) -> np.ndarray:
    """Every embedded plot is drawn: the page with that image blanked out differs
    from the page as written over a large area (a broken or empty image would not).
    Returns the page's screenshot."""
    text = page.read_text()
    assert "http://" not in text and "https://" not in text  # nothing fetched
    images = re.findall(r'<img id="([^"]+)"[^>]*src="data:image/png;base64,([^"]+)"', text)
    assert images and len(images) == text.count("<img")
    full = _screenshot(page, tmp / "full.png", tmp / "chromium")
    # not a blank page: over the height the page takes (the window is taller than
    # most reports), a good share of the pixels is ink
    ink = np.any(full < 0.9, axis=2)
    rows = np.flatnonzero(ink.any(axis=1))
    assert rows.size and rows[-1] > 500, "the page is empty"
    assert float(np.mean(ink[: rows[-1] + 1])) > 0.05
    for name, data in images:
        blanked = tmp / f"without-{name}.html"
        blanked.write_text(text.replace(data, BLANK))
        shot = _screenshot(blanked, tmp / f"without-{name}.png", tmp / "chromium")
        h = min(len(full), len(shot))
        changed = np.mean(np.any(np.abs(full[:h] - shot[:h]) > 0.1, axis=2))
        assert changed > 0.01, f"{name}: the plot does not show in the page ({changed:.4f})"
    return full


#: the backgrounds of the conclusion (blue) and the what-to-do-next (green) boxes
LEAD_RGB, NEXT_RGB = (0xE8, 0xF1, 0xFB), (0xE9, 0xF7, 0xEC)


def _leads_with_the_summary(shot: np.ndarray, page: Path, output: str) -> None:
    """What a reader sees first, on the first screen (the top 900 pixels as
    Chromium draws the page): the conclusion box above the what-to-do-next box,
    both of them there; and the page names where it was written, as the command
    printed it."""
    top = shot[:900]

    def rows_of(rgb: tuple[int, int, int]) -> np.ndarray:
        hit = np.all(np.abs(top - np.array(rgb) / 255) < 0.02, axis=2)
        return np.flatnonzero(hit.sum(axis=1) > 300)  # a box across the page

    lead, nxt = rows_of(LEAD_RGB), rows_of(NEXT_RGB)
    assert lead.size > 20 and nxt.size > 20, (lead.size, nxt.size)
    assert lead.max() < nxt.min()
    text = page.read_text()
    assert text.index("<h2>Conclusion</h2>") < text.index("<table")
    assert "What to do next: " in text
    path = str(page.resolve())
    assert f"wrote the report: {path}" in output and path in text


needs_chromium = pytest.mark.skipif(
    not Path(CHROMIUM).exists(), reason="the report test needs Debian's chromium"
)


@needs_chromium
def test_diagnose_report_renders_in_a_browser(
    runner: CliRunner, tmp_path: Path, square_truth: Path
) -> None:
    files = _simulate(runner, tmp_path / "m", str(square_truth), NOMINAL)
    out = tmp_path / "report"
    r = invoke(runner, "diagnose", *files, "--profile", NOMINAL, "--report", str(out))
    assert r.exit_code == 0, r.output
    assert {"report.html", "report.md", "ballbar.png", "poses.png"} <= {
        p.name for p in out.iterdir()
    }
    page = (out / "report.html").read_text()
    assert "table.squareness" in page and "out of square" in page
    assert "What to do next: Calibrate" in page
    shot = _renders_every_plot(out / "report.html", tmp_path)
    _leads_with_the_summary(shot, out / "report.html", r.output)
    assert {"residuals.png", "ballbar-residual.png"} <= {p.name for p in out.iterdir()}
    # the model after the effect was added is drawn over the measured trace, not
    # hidden under it: tab:blue (31, 119, 180) runs round every panel, a line of
    # at least 250 pixels each (a circle of 5 divisions is about 600 pixels round)
    import matplotlib.image

    img = matplotlib.image.imread(str(out / "ballbar.png"))[:, :, :3]
    blue = np.all(np.abs(img - np.array([31, 119, 180]) / 255) < 0.15, axis=2)
    n_runs = len([f for f in files if Path(f).name.startswith("ballbar")])
    assert blue.sum() > 250 * n_runs, (blue.sum(), n_runs)


@needs_chromium
def test_ballbar_report_renders_in_a_browser(
    runner: CliRunner, tmp_path: Path, square_truth: Path
) -> None:
    files = _simulate(runner, tmp_path / "m", str(square_truth), NOMINAL)
    runs = [f for f in files if Path(f).name.startswith("ballbar")]
    out = tmp_path / "report"
    r = invoke(runner, "ballbar", *runs, "--report", str(out))
    assert r.exit_code == 0, r.output
    page = (out / "report.html").read_text()
    assert "squareness" in page and "µm/div" in (out / "report.md").read_text() + page
    shot = _renders_every_plot(out / "report.html", tmp_path)
    _leads_with_the_summary(shot, out / "report.html", r.output)
    # a table of the runs, one row each, named as RS274 names them
    rows = re.findall(r"<tr><td>(ballbar-[^<]+)</td><td>([^<]+)</td><td>([^<]+)</td>", page)
    assert sorted(rows) == [
        ("ballbar-xy-r50-ccw.csv", "XY r50", "ccw (G17 G3, from +Z)"),
        ("ballbar-xy-r50-cw.csv", "XY r50", "cw (G17 G2, from +Z)"),
    ], rows
