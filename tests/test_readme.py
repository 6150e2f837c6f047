"""The README and the docs as a reader meets them: short, every link and repository
path pointing at a file a clone has, and the README's command-line walk running as
printed (measure, calibrate, diagnose, check, convert, export the tables), so that
it cannot go stale.
"""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from .conftest import ROOT

README = ROOT / "README.md"
WALK = "## From measuring a machine to loading its programs"
#: the Markdown files whose links and paths a reader follows (the corpus's own
#: SOURCES files describe other projects and are left out)
DOCS = [
    README,
    *sorted((ROOT / "docs").glob("*.md")),
    ROOT / "profiles" / "README.md",
    ROOT / "tests" / "data" / "vectors" / "README.md",
    ROOT / "tests" / "data" / "spec" / "README.md",
]
#: a code span naming a file or folder of the repository
REPO_PATH = re.compile(
    r"`((?:\.\.?/)+[\w./-]+|(?:docs|profiles|samples|tests|bench|prsxy_post|requirements)/[\w./-]*)`"
)
#: simulate's options that make the rehearsal small enough for a test (one X-Y
#: circle pair, 100 poses): every command still runs as printed otherwise
SMALL = "--only-xy --radii 50 --poses 100"


def _section(text: str, heading: str) -> str:
    assert heading in text, f"README.md has no section {heading!r}"
    return re.split(r"\n## ", text.split(heading, 1)[1], maxsplit=1)[0]


def _section_commands(section: str) -> list[str]:
    """The command lines of a section's ```sh blocks."""
    blocks = re.findall(r"```sh\n(.*?)```", section, re.S)
    return [line.strip() for b in blocks for line in b.splitlines() if line.strip()]


def _resolves(doc: Path, target: str) -> bool:
    path = (doc.parent / target).resolve()
    return path.is_relative_to(ROOT) and path.exists()


def test_readme_is_at_most_250_lines() -> None:
    n = len(README.read_text().splitlines())
    assert n <= 250, f"README.md has {n} lines (expected at most 250: details go into docs/)"


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_point_at_files_of_the_repository(doc: Path) -> None:
    text = doc.read_text()
    bad = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue  # a web address or an anchor of the same page
        if not _resolves(doc, target.split("#", 1)[0]):
            bad.append(f"link {target}")
    for span in REPO_PATH.findall(text):
        # repository paths in code spans are written from the root, or relative
        # to the file when they start with ../ or ./
        base = doc if span.startswith(".") else ROOT / "README.md"
        if not _resolves(base, span):
            bad.append(f"path `{span}`")
    assert not bad, f"{doc.relative_to(ROOT)} points at what a clone does not have: {bad}"


def test_the_walk_names_no_file_outside_the_repository() -> None:
    """The walk's inputs (profiles, samples, test data) are the repository's own."""
    walk = _section(README.read_text(), WALK)
    inputs = {
        w
        for line in _section_commands(walk)
        for w in shlex.split(line)
        if w.startswith(("profiles/", "samples/", "tests/"))
    }
    assert inputs, "the walk names none of the repository's files"
    missing = sorted(w for w in inputs if not (ROOT / w).exists())
    assert not missing, missing


def _run(commands: list[str], cwd: Path) -> str:
    """Run README command lines with bash (its globbing), `prsxy-post` being this
    work tree's package; return what they printed. Any failure stops the walk."""
    script = "\n".join(
        [
            "set -euo pipefail",
            f'prsxy-post() {{ {shlex.quote(sys.executable)} -m prsxy_post.cli "$@"; }}',
            *commands,
        ]
    )
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    r = subprocess.run(
        ["bash", "-c", script], cwd=cwd, env=env, capture_output=True, text=True, timeout=600
    )
    assert r.returncode == 0, f"the README's commands failed:\n{script}\n{r.stdout}\n{r.stderr}"
    return r.stdout + r.stderr


def _workdir(tmp_path: Path) -> Path:
    """A scratch folder that looks like the repository's root to the commands:
    its inputs linked in, its outputs written here."""
    for name in ("profiles", "samples"):
        (tmp_path / name).symlink_to(ROOT / name)
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "data").symlink_to(ROOT / "tests" / "data")
    return tmp_path


def test_quick_start_converts_as_printed(tmp_path: Path) -> None:
    quick = _section(README.read_text(), "## Quick start")
    line = next(ln.strip() for ln in quick.splitlines() if "prsxy-post convert" in ln)
    # the install before `&&` is what the suite already runs in
    command = line.split("&&")[-1].strip()
    _run([command], _workdir(tmp_path))
    assert (tmp_path / "pocket.pmc").read_text().startswith("; prsxy-post")


def test_walk_runs_as_printed(tmp_path: Path) -> None:
    text = README.read_text()
    walk = _section(text, WALK)
    commands = _section_commands(walk)
    verbs = [shlex.split(c)[1] for c in commands]
    for verb in ("simulate", "calibrate", "diagnose", "convert", "tables"):
        assert verb in verbs, f"the walk does not run {verb}"
    assert all(c.startswith("prsxy-post ") for c in commands), commands
    small = [c + " " + SMALL if shlex.split(c)[1] == "simulate" else c for c in commands]
    out = _run(small, _workdir(tmp_path))

    # every file the walk tells the reader to load is there, as the README says
    loaded = {
        "pocket.pmc": "; prsxy-post",
        "pocket-comp.ngc": "%\n(prsxy-post",
        "pmac/axis-tables.pmc": "; Turbo PMAC real-axis tables",
        "comp/linuxcnc-comp.ini": "",
    }
    for name, start in loaded.items():
        assert f"`{name}`" in walk or f"`{name.split('/')[0]}/`" in walk, name
        assert (tmp_path / name).read_text().startswith(start), name
    assert (tmp_path / "calibrated.toml").is_file()
    assert (tmp_path / "diagnosis" / "report.html").is_file()
    assert (tmp_path / "ballbar-report" / "report.html").is_file()
    assert "wrote calibrated.toml" in out

    # the controller settings the walk lists are the ones the program's header asks
    # for, and the exported table file switches the controller's tables on
    header = "\n".join(
        ln for ln in (tmp_path / "pocket.pmc").read_text().splitlines() if ln.startswith(";")
    )
    load = walk.split("**6. Load the controller.**", 1)[1]
    for setting in ("I42=0", "I51=0", "Mxx69=0", "Ixx86=0", "Isx50=0", "Isx90=1000"):
        assert f"`{setting}`" in load, setting
        pattern = setting.replace("xx", r"(?:xx|\d\d)").replace("sx", r"(?:sx|\d\d)")
        assert re.search(pattern, header), f"the PMAC header does not ask for {setting}"
    assert "442 us or shorter" in header and "442 µs or shorter" in load
    tables = (tmp_path / "pmac" / "axis-tables.pmc").read_text()
    assert "I51=1" in tables and "`I51=1`" in walk
    assert re.search(r"add [+-]\d+ to I\d26", tables) and "`Ixx26`" in load


MEASUREMENTS = ROOT / "docs" / "measurements.md"
#: the two lines under a section's heading: the command, and when it was measured
PROVENANCE = re.compile(
    r"^- Regenerate: `python \S+\.py[^`]*`.*\n(?:  .*\n)*- Measured: \d{4}-\d\d-\d\d", re.M
)


def _sections(text: str) -> dict[str, str]:
    parts = re.split(r"^## (.+)\n", text, flags=re.M)
    return dict(zip(parts[1::2], parts[2::2], strict=True))


def test_every_measured_table_names_its_command_and_date() -> None:
    """A section of docs/measurements.md that holds a table says which script run
    regenerates it and when it was measured."""
    sections = _sections(MEASUREMENTS.read_text())
    tables = {t: s for t, s in sections.items() if re.search(r"^\|", s, re.M)}
    assert len(tables) >= 10, sorted(sections)
    bad = [t for t, s in tables.items() if not PROVENANCE.search(s)]
    assert not bad, f"sections without '- Regenerate: `python ...`' and '- Measured: date': {bad}"


def test_bench_markdown_prints_sections_of_the_page() -> None:
    """What `--markdown` prints heads a section the page has, in the page's format."""
    sys.path.insert(0, str(ROOT / "bench"))
    try:
        import mdsection
    finally:
        sys.path.remove(str(ROOT / "bench"))
    head = mdsection.header("X", [str(ROOT / "bench" / "points.py"), "--lines", "9", "--markdown"])
    assert head.startswith("## X\n\n- Regenerate: `python bench/points.py --lines 9`\n")
    assert PROVENANCE.search(head), head
    sections = _sections(MEASUREMENTS.read_text())
    titles = set()
    for script in sorted((ROOT / "bench").glob("*.py")):
        for line in script.read_text().splitlines():
            if "header(" in line or re.match(r"\s*title = ", line):
                titles.update(re.findall(r'"([A-Z][^"]+)"', line))
    assert len(titles) >= 9, titles
    missing = sorted(t for t in titles if t not in sections)
    assert not missing, f"bench scripts print sections docs/measurements.md lacks: {missing}"
