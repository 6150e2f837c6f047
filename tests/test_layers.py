"""The package's layers: modules import downward only, with no circle anywhere.

The import graph is read from the source (``ast``), imports inside functions
included: a circle closed only at run time is still a circle for the reader and
for the order modules can be loaded in. Imports under ``if TYPE_CHECKING:`` are
left out (they never run).
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np

from prsxy_post import effects, errormap, simulate, writers
from prsxy_post import profile as profile_mod
from prsxy_post.profile import effects_section
from prsxy_post.profile.output import OUTPUT_SETTINGS

PACKAGE = Path(__file__).resolve().parents[1] / "prsxy_post"


def _modules() -> dict[str, Path]:
    out = {}
    for path in PACKAGE.rglob("*.py"):
        parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for stmt in node.body for n in ast.walk(stmt))
    return skip


def _targets(module: str, is_package: bool, node: ast.AST, mods: set[str]) -> list[str]:
    """The modules an import statement runs: for ``from P import n``, P.n where
    that is a module, else P itself (n is a name P's ``__init__`` defines); and
    every package above them that ``module`` is not inside (Python loads those
    first)."""
    if isinstance(node, ast.Import):
        direct = [a.name for a in node.names]
    elif isinstance(node, ast.ImportFrom):
        if node.level:
            base = module.split(".") if is_package else module.split(".")[:-1]
            base = base[: len(base) - (node.level - 1)]
            name = ".".join([*base, *([node.module] if node.module else [])])
        else:
            name = node.module or ""
        direct = [f"{name}.{a.name}" if f"{name}.{a.name}" in mods else name for a in node.names]
    else:
        return []
    out = []
    for target in direct:
        parts = target.split(".")
        out += [
            ".".join(parts[:i])
            for i in range(2, len(parts))
            if not (module + ".").startswith(".".join(parts[:i]) + ".")
        ]
        out.append(target)
    return [t for t in out if t in mods and t != module]


def import_graph() -> dict[str, set[str]]:
    """module → the package's modules it imports, imports inside functions too."""
    mods = _modules()
    graph: dict[str, set[str]] = {m: set() for m in mods}
    for mod, path in mods.items():
        tree = ast.parse(path.read_text())
        skip = _type_checking_nodes(tree)
        for node in ast.walk(tree):
            if id(node) not in skip:
                graph[mod].update(_targets(mod, path.name == "__init__.py", node, set(mods)))
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                found.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_the_finder_sees_a_circle_through_an_import_inside_a_function() -> None:
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert circles(graph) == [["a", "b", "c"]]
    tree = ast.parse("def f():\n    from . import b, name\n")
    node = next(n for n in ast.walk(tree) if isinstance(n, ast.ImportFrom))
    # a submodule, and a name of the package's __init__ (which runs it)
    assert _targets("pkg.a", False, node, {"pkg", "pkg.a", "pkg.b"}) == ["pkg.b", "pkg"]


#: circles still being taken apart (none: a new one fails the test)
OPEN_CIRCLES: list[list[str]] = []


def test_no_import_circle_in_the_package() -> None:
    found = sorted(circles(import_graph()))
    assert found == OPEN_CIRCLES, "import circles:\n" + "\n".join(" ⇄ ".join(c) for c in found)


def test_loading_a_profile_imports_no_dialect_physics_or_kinematics() -> None:
    """The profile is the bottom layer: reading one loads nothing above it."""
    code = (
        "import sys, prsxy_post.profile as p\n"
        "p.loads(open('profiles/prsxy-nominal.toml').read())\n"
        "print(' '.join(sorted(m for m in sys.modules if m.startswith('prsxy_post'))))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        cwd=PACKAGE.parent,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    above = {"writers", "effects", "kinematics", "chain", "axiscomp", "reversals", "convert"}
    assert not [m for m in out if m.partition(".")[2].split(".")[0] in above], out


#: what the convert command must not load (issue 31: each costs start-up, scipy alone
#: about 0.2 s, for work a conversion never does)
HEAVY = ("scipy", "matplotlib", "tomlkit")


def _machine_with_everything(path: Path) -> Path:
    """A profile with contract errors, real-axis tables with play, bowed guides,
    servo lag and an error map: every stage of the chain runs."""
    nominal = profile_mod.loads((PACKAGE.parent / "profiles" / "prsxy-nominal.toml").read_text())
    rng = np.random.default_rng(5)
    truth = simulate.random_machine(nominal, rng, axis_errors=True, effects=True, name="all")
    q = rng.uniform([-150, -150, -60, -25, -25], [150, 150, 40, 25, 25], (200, 5))
    emap = errormap.fit(q, 1e-3 * np.sin(q / 50.0), rng=rng, degrees=(2,), lambdas=[1e-4])
    effects = dict(truth.raw.get("effects", {}), servo_lag_ms=[0.4, 0.1, 0.3, 0.8, 0.5])
    path.write_text(profile_mod.dumps(dict(truth.raw, effects=effects, error_map=emap.to_dict())))
    return path


def _loaded_by_convert(prof: Path, fmt: str, out: Path) -> list[str]:
    """The modules loaded at the end of a conversion of samples/five-axis.ngc as
    the command runs it."""
    code = (
        "import atexit, sys\n"
        "atexit.register(lambda: sys.stderr.write('MODULES ' + ' '.join(sys.modules) + '\\n'))\n"
        "from prsxy_post.cli import main\n"
        "main(sys.argv[1:], prog_name='prsxy-post')\n"
    )
    r = subprocess.run(
        [
            sys.executable,
            "-c",
            code,
            "convert",
            "samples/five-axis.ngc",
            "--profile",
            str(prof),
            "--format",
            fmt,
            "-o",
            str(out),
            "-q",
        ],
        cwd=PACKAGE.parent,
        capture_output=True,
        text=True,
    )
    assert r.returncode == 0, r.stderr
    line = next(x for x in r.stderr.splitlines() if x.startswith("MODULES "))
    loaded = line.split()[1:]
    assert "prsxy_post.chain" in loaded  # the conversion ran in this process
    return loaded


def test_converting_imports_no_scipy_matplotlib_or_tomlkit(tmp_path: Path) -> None:
    """A conversion as the command runs it, both dialects, on a machine with every
    stage on: the modules loaded at the end name none of :data:`HEAVY`."""
    prof = _machine_with_everything(tmp_path / "all.toml")
    for fmt in ("pmac", "gcode"):
        loaded = _loaded_by_convert(prof, fmt, tmp_path / f"out.{fmt}")
        assert not [m for m in loaded if m.split(".")[0] in HEAVY], fmt


#: what converting a program of lines and arcs does not load (issue 31: start-up):
#: NURBS and canned cycles load with the first G5.x or G8x, numpy.polynomial only
#: to fit a map, numpy.ma (np.unique's import) and json not at all
NOT_LOADED = (
    "prsxy_post.curves",
    "prsxy_post.gcode.cycles",
    "numpy.polynomial",
    "numpy.ma",
    "json",
)


def test_converting_loads_no_module_the_program_does_not_need(tmp_path: Path) -> None:
    """samples/five-axis.ngc (lines and arcs) converted with the nominal profile,
    both dialects: none of :data:`NOT_LOADED` is loaded; with a map and every
    stage on, neither are the spline and cycle modules nor numpy.polynomial."""
    nominal = PACKAGE.parent / "profiles" / "prsxy-nominal.toml"
    for fmt in ("pmac", "gcode"):
        loaded = set(_loaded_by_convert(nominal, fmt, tmp_path / f"out.{fmt}"))
        assert not loaded & set(NOT_LOADED), fmt
    prof = _machine_with_everything(tmp_path / "all.toml")
    loaded = set(_loaded_by_convert(prof, "pmac", tmp_path / "all.pmc"))
    assert not loaded & set(NOT_LOADED[:3])


def test_every_dialect_declares_its_settings_in_the_profile_layer() -> None:
    assert set(writers.DIALECTS) == set(OUTPUT_SETTINGS)
    for name, dialect in writers.DIALECTS.items():
        assert dialect.settings is OUTPUT_SETTINGS[name]


def test_every_effects_key_is_read_by_the_profile_and_owned_by_one_family() -> None:
    owners = [k for f in effects.FAMILIES for k in f.effects_keys]
    assert sorted(owners) == sorted(effects_section.KEYS)
