"""Which kernel runs, and that the command line says so (issue 31): without the
compiled extension the program still runs, on the reference, with the same output,
and warns; ``--version`` names the kernel."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from prsxy_post import kernel

from .conftest import ROOT
from .kernel_cases import REQUIRE

#: a fresh interpreter in which the compiled modules cannot be imported, as on a
#: machine without a compiler
WITHOUT_EXTENSION = (
    "import sys\n"
    "sys.modules['prsxy_post.kernel._ik'] = None\n"
    "sys.modules['prsxy_post.kernel._text'] = None\n"
    "from prsxy_post.cli import main\n"
    "main(sys.argv[1:], prog_name='prsxy-post')\n"
)


def _run(code: str, *args: str, **env: str) -> subprocess.CompletedProcess[str]:
    e = {k: v for k, v in os.environ.items() if k != kernel.ENV}
    e.update(env, PYTHONPATH=str(ROOT))
    return subprocess.run(
        [sys.executable, "-c", code, *args], cwd=ROOT, env=e, capture_output=True, text=True
    )


def test_without_the_extension_the_output_is_the_same_and_it_warns(tmp_path: Path) -> None:
    out = tmp_path / "pocket.pmc"
    r = _run(
        WITHOUT_EXTENSION,
        "convert",
        "samples/pocket.ngc",
        "--profile",
        "profiles/prsxy-shop.toml",
        "-o",
        str(out),
        "--quiet",
    )
    assert r.returncode == 0, r.stderr
    assert r.stderr.startswith("prsxy-post: warning: the compiled extension is not built ("), (
        r.stderr
    )
    assert "running the pure numpy kernel" in r.stderr
    assert out.read_text() == (ROOT / "tests" / "golden" / "pocket.prsxy-shop.pmac").read_text()
    v = _run(WITHOUT_EXTENSION, "--version")
    assert v.stdout.splitlines()[1].startswith("kernel: pure numpy (the compiled extension is not")


def test_the_environment_selects_the_reference_without_a_warning() -> None:
    r = _run(
        "from prsxy_post.cli import main; main(prog_name='prsxy-post')",
        "--version",
        PRSXY_KERNEL="pure",
    )
    assert r.stdout.splitlines()[1] == "kernel: pure numpy (PRSXY_KERNEL=pure)"
    assert r.stderr == ""


def test_version_names_the_compiled_kernel() -> None:
    r = _run("from prsxy_post.cli import main; main(prog_name='prsxy-post')", "--version")
    line = r.stdout.splitlines()[1]
    if not line.startswith("kernel: compiled (Cython 3.") and not REQUIRE:
        pytest.skip(f"the compiled kernel is not built here ({line})")
    assert line.startswith("kernel: compiled (Cython 3.")
    assert r.stderr == ""


def test_the_kernel_imports_nothing_above_it() -> None:
    """The kernel is the layer above profile and types: it must not import the
    stream, the writers, the chain, profile loading or the command line."""
    code = (
        "import sys\nimport prsxy_post.kernel\n"
        "import json\nprint(json.dumps([m for m in sys.modules if m.startswith('prsxy_post')]))"
    )
    mods = json.loads(_run(code).stdout)
    assert set(mods) <= {
        "prsxy_post",
        "prsxy_post.kernel",
        "prsxy_post.kernel.ik",
        "prsxy_post.kernel.libm",
        "prsxy_post.kernel.text",
        "prsxy_post.kernel._ik",
        "prsxy_post.kernel._text",
    }, mods
