"""The compiled fast path (gcode/_fast.pyx) against its reference (gcode/fast.py).

The interpreter runs each program twice, once per implementation of the fast path,
and must give the same motions, every field of every Motion to the bit (floats
compared as their IEEE bytes, so 0.0 is not -0.0; types too), the same error
after the same motions, and take the same lines the fast way. And a third time
in rows mode (gcode/rows.py, what convert runs: the compiled twin writes its
moves as rows of a table): the table of its motions must be the reference's
motions' table to the bit, with the same error and the same lines taken. Programs: the
samples, the tests/data programs (feature programs and the real CAM corpus),
bench.py's generated five-axis program, and generated CAM lines (hypothesis)
with odd spacing, signs, leading and trailing dots, long numbers (past the exact
division, to Python's own parser), N words, lower case, G0/G00/G01/G2/G03, inch
and millimetre, absolute and relative, R and IJK arcs, planes, offsets.
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from prsxy_post import gcode, kernel
from prsxy_post.curves import Nurbs
from prsxy_post.errors import GCodeError
from prsxy_post.gcode import fast

from .conftest import DATA, ROOT
from .kernel_cases import REQUIRE

CFG = gcode.InterpreterConfig(
    work_offsets={55: (100.0, 0.0, -5.0, 0.0, 0.0), 56: (-40.5, 25.25, 0.125, 3.0, -2.0)},
    g28_position=(1.0, 2.0, 3.0, 0.0, 0.0),
    tool_table={1: gcode.ToolEntry(35.0), 2: gcode.ToolEntry(20.0)},
)
EXTENSIONS = (".ngc", ".nc", ".gcode", ".tap", ".cnc", ".gc")


def compiled() -> fast.FastPath:
    """The compiled fast path; skip (fail under PRSXY_REQUIRE_COMPILED=1) when the
    extension is not built."""
    if fast.COMPILED is None:
        why = "the compiled fast path (gcode/_fast) is not built: pip install -e . builds it"
        if REQUIRE:
            pytest.fail(f"PRSXY_REQUIRE_COMPILED=1 but {why}")
        pytest.skip(why)
    return fast.COMPILED


def bits(v: object) -> object:
    """A value with its floats as their bytes and every type named: equal exactly
    when the values are the same to the bit."""
    if type(v) is float:
        return ("float", struct.pack("<d", v))
    if isinstance(v, tuple | list):
        return (type(v).__name__, tuple(bits(x) for x in v))
    if isinstance(v, np.ndarray):
        return ("ndarray", v.dtype.str, v.shape, v.tobytes())
    if isinstance(v, Nurbs):
        return ("Nurbs", *(bits(getattr(v, f.name)) for f in fields(v) if f.compare))
    return (type(v).__name__, v)


def outcome(
    lines: list[str], path: fast.FastPath, source: str = "t.ngc"
) -> tuple[list[object], str | None, int]:
    """(the motions to the bit, the error, the lines the fast path took) of a program
    interpreted with ``path`` as the fast path."""
    taken = 0

    def run(it: Any, matches: list[Any], i: int, n0: int) -> int:
        nonlocal taken
        k = path.run(it, matches, i, n0)
        taken += k - i
        return k

    got: list[object] = []
    error = None
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fast, "SELECTED", fast.FastPath(path.name, path.matches, run, path.run_rows))
        try:
            for m in gcode.iter_motions(lines, CFG, source):
                got.append(bits(m))
        except GCodeError as exc:
            error = str(exc)
        except (OverflowError, ValueError) as exc:  # the same, raised by both
            error = f"{type(exc).__name__}: {exc}"
    return got, error, taken


def rows_outcome(
    lines: list[str], path: fast.FastPath, source: str = "t.ngc"
) -> tuple[object, str | None, int]:
    """:func:`outcome` in rows mode: (the table of the motions to the bit, the
    error, the lines taken fast)."""
    taken = 0

    def run(it: Any, matches: list[Any], i: int, n0: int) -> int:
        nonlocal taken
        k = path.run_rows(it, matches, i, n0)
        taken += k - i
        return k

    items: list[gcode.rows.Item] = []
    error = None
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(fast, "SELECTED", fast.FastPath(path.name, path.matches, path.run, run))
        try:
            for item in gcode.iter_motion_items([lines], CFG, source):
                items.append(item)
        except GCodeError as exc:
            error = str(exc)
        except (OverflowError, ValueError) as exc:
            error = f"{type(exc).__name__}: {exc}"
    return table_bits(items), error, taken


def table_bits(items: list[gcode.rows.Item]) -> object:
    t = gcode.rows.table(items)
    return bits(t.rows), [(i, bits(m)) for i, m in t.objects]


def same(lines: list[str], source: str = "t.ngc") -> int:
    """Assert both fast paths give the same, in both modes; the number of lines
    taken fast."""
    want = outcome(lines, fast.PURE, source)
    got = outcome(lines, compiled(), source)
    assert got[1] == want[1]
    assert len(got[0]) == len(want[0])
    for k, (g, w) in enumerate(zip(got[0], want[0], strict=True)):
        assert g == w, f"motion {k}"
    assert got[2] == want[2]
    pure_rows = rows_outcome(lines, fast.PURE, source)
    assert pure_rows[1:] == want[1:]  # the reference makes Motions in rows mode too
    assert rows_outcome(lines, compiled(), source) == pure_rows
    return want[2]


def test_the_selection_follows_the_kernel_selector() -> None:
    """PRSXY_KERNEL=pure selects the reference here too; otherwise the compiled twin
    runs when it is built, and the reference where it is not (no compiler)."""
    compiled()
    code = "from prsxy_post.gcode import fast; print(fast.SELECTED.name)"
    env = {k: v for k, v in os.environ.items() if k != kernel.ENV}

    def run(code: str, **extra: str) -> str:
        return subprocess.run(
            [sys.executable, "-c", code],
            cwd=ROOT,
            env={**env, **extra, "PYTHONPATH": str(ROOT)},
            capture_output=True,
            text=True,
            check=True,
        ).stdout.strip()

    assert run(code) == "compiled"
    assert run(code, PRSXY_KERNEL="pure") == "pure"
    without = "import sys; sys.modules['prsxy_post.gcode._fast'] = None; " + code
    motions = "; from prsxy_post import gcode; print(len(gcode.interpret('G0 X1\\nM2')))"
    assert run(without + motions).split() == ["pure", "2"]


def _programs() -> Iterator[Path]:
    yield from sorted((ROOT / "samples").glob("*.ngc"))
    yield from sorted((DATA / "gcode" / "features").glob("*.ngc"))
    yield from sorted(
        p for p in (DATA / "gcode" / "corpus").rglob("*") if p.suffix.lower() in EXTENSIONS
    )


@pytest.mark.parametrize("path", list(_programs()), ids=lambda p: p.name)
def test_sample_and_data_programs(path: Path) -> None:
    text = path.read_text(encoding="utf-8", errors="surrogateescape")
    same(gcode.split_lines(text), str(path))


def test_the_generated_five_axis_program_goes_the_fast_way() -> None:
    # bench/ as the namespace package the other tests import it as (a module named
    # ``bench`` in sys.modules would hide it from them)
    from bench.bench import generate

    lines = gcode.split_lines(generate(20_000, seed=3))
    taken = same(lines)
    assert taken > 19_000  # what the test is about: nearly every line fast


DIGITS = st.text("0123456789", min_size=1, max_size=4)
GOOD_NUMBER = st.one_of(
    st.builds(
        lambda sign, whole, frac, dot: sign + whole + (("." + frac) if dot else ""),
        st.sampled_from(["", "", "-", "+"]),
        DIGITS,
        st.text("0123456789", max_size=6),
        st.booleans(),
    ),
    st.builds(lambda s, f: s + "." + f, st.sampled_from(["", "-", "+"]), DIGITS),  # .5
    st.builds(lambda d: d + ".", DIGITS),  # 3.
    st.sampled_from(["0", "-0", "-.0", "0.", "+0", "007.50", "0.1", "0.3", "2.675"]),
    # moves of about 1e-12 mm: the squared length beside the fast path's 1e-24
    st.builds(lambda s, d: s + "0.00000000000" + d, st.sampled_from(["", "-"]), DIGITS),
    st.builds(lambda d: "0.0000000000000" + d, DIGITS),  # the same in inch
)
#: past 15 digits or 22 decimals: Python's own parser in the compiled path
LONG_NUMBER = st.builds(
    lambda a, b: a + "." + b,
    st.text("0123456789", min_size=1, max_size=20),
    st.text("0123456789", min_size=10, max_size=30),
)
#: what the regex does not take as a number
BAD_NUMBER = st.sampled_from(["1e3", "--1", "-", ".", "1..2", "+-1", "1.2.3", "0x1", "\u0661"])
#: mostly good numbers (one_of draws its branches evenly: a weight picks one)
NUMBER = st.integers(0, 39).flatmap(
    lambda k: GOOD_NUMBER if k < 36 else LONG_NUMBER if k < 39 else BAD_NUMBER
)
BLANK = st.sampled_from(["", "", " ", "\t", "  ", " \t"])
LETTERS = "XYZABIJKRF"
G_STRAIGHT = st.sampled_from(["", "", "", "G0", "G00", "G000", "g1", "G01", "G 1", "g0 "])
G_ARC = st.sampled_from(["G2", "g02", "G3", "G03", "G 2", "G002", ""])
G_OTHER = st.sampled_from(["G4", "G10", "G0.", "G1.0", "G04", "G5", "G81", "G"])


def _case(draw: st.DrawFn, c: str) -> str:
    return c.lower() if draw(st.integers(0, 4)) == 0 else c


@st.composite
def cam_line(draw: st.DrawFn) -> str:
    """A CAM block in any spelling: mostly straight moves and arcs the fast path
    takes, some it must leave to the full path."""
    sep = draw(BLANK)
    parts = [draw(BLANK)]
    if draw(st.booleans()):
        parts.append(_case(draw, "N") + draw(BLANK) + draw(DIGITS))
    kind = draw(st.sampled_from(["straight"] * 12 + ["r arc"] * 2 + ["ijk arc"] * 2 + ["any"]))
    if kind == "straight":
        parts.append(draw(G_STRAIGHT))
        letters = draw(st.lists(st.sampled_from("XYZAB"), min_size=1, max_size=5, unique=True))
        letters.sort(key=LETTERS.index)
        if draw(st.integers(0, 3)) == 0:
            letters.append("F")
    elif kind == "r arc":  # a radius that reaches any end point drawn here
        parts.append(draw(G_ARC))
        letters = ["X", "Y", "R"]
    elif kind == "ijk arc":  # a helix about a centre in the plane: on the circle
        parts.append(draw(G_ARC))
        letters = [*draw(st.sampled_from(["ZIJ"] * 4 + ["YIK", "XJK", "ZI", "ZJ", "Z"]))]
        letters.sort(key=LETTERS.index)
    else:
        parts.append(draw(st.one_of(G_STRAIGHT, G_ARC, G_OTHER)))
        letters = draw(st.lists(st.sampled_from(LETTERS), max_size=6, unique=True))
        if draw(st.integers(0, 3)) > 0:
            letters.sort(key=LETTERS.index)
    for c in letters:
        if c == "R":
            number = draw(st.sampled_from(["", "-"])) + "1" + draw(DIGITS) + "000"
        elif kind == "ijk arc" and c in "XYZ":
            number = draw(GOOD_NUMBER)
        else:
            number = draw(NUMBER)
        parts.append(_case(draw, c) + draw(BLANK) + number)
    if draw(st.integers(0, 9)) == 0:
        parts.append(draw(st.sampled_from(["(c)", ";c", "M3 S100", "X1", "P2"])))
    return sep.join(p for p in parts if p) + draw(BLANK)


MODAL = st.sampled_from(
    ["G20", "G21", "G90", "G91", "G17", "G18", "G19", "G90.1", "G91.1", "G55", "G56", "G54",
     "G92 X1.5 Y-2", "G92.1", "F300", "F0", "G93", "G94", "G1", "G0", "G2", "G80",
     "G10 L2 P1 R15", "G10 L2 P1 R0", "G43 H1", "G49", "G64 P0.01", "M3 S1000", "T2 M6",
     "G41.1 D1", "G40"]
)  # fmt: skip


#: squared lengths beside the fast path's 1e-24 mm^2 (inch): moved, not, not, moved
BESIDE_THE_THRESHOLD = [
    "G20 G1 F10 X0",
    "X.0000000000000394 A1",
    "X.0000000000000787 A2",
    "X.000000000000118 A3",
    "X.0000000000001574 A4",
]


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.integers(0, 9).flatmap(lambda k: MODAL if k == 0 else cam_line()), max_size=30))
@example(["G1 X1.", "X.5 Y-.25", "x 1 y\t2", "N10 G00 X0", "G2 X1 Y1 R1", "G3 X0 Y0 I-.5 J-.5"])
@example(["G20", "G91 G1 X1.23456789012345678 F10", "A1 B-1", "A-1 F+20", "Z" + "9" * 400])
@example(["G1 X1 F10", "X1" + "0" * 200, "X2"])  # (1e200 - 1) ** 2 overflows
@example(BESIDE_THE_THRESHOLD)
@example(
    ["G1 F10 X0 A0", "X0.000000000001 A1", "Y0.0000000000007 B1", "Z.00000000000071 A2"]
)  # (1e200 - 1) ** 2 overflows
def test_generated_cam_lines(body: list[str]) -> None:
    same(["G21 G90 G17 G94 G1 F500", *body, "M2"])


def test_a_line_that_holds_a_line_end_leaves_the_batch_to_the_full_path() -> None:
    """A line given with a line end in it would be two lines to the regex: the whole
    batch goes the full way, in both."""
    lines = ["G1 X1 F100", "X2\nX3", "X4", "M2"]
    assert same(lines) == 0
    assert same(["G1 X1 F100", "X2", "X4", "M2"]) == 3


#: each plane: its axes, its normal and its centre words
PLANES = {"G17": ("XY", "Z", "IJ"), "G18": ("ZX", "Y", "KI"), "G19": ("YZ", "X", "JK")}


@st.composite
def arc_program(draw: st.DrawFn) -> list[str]:
    """Arcs the interpreter accepts, mostly: R arcs with a radius that reaches,
    helixes about a centre (the end point on the circle), in every plane, unit,
    distance mode and centre mode, after offsets."""
    plane = draw(st.sampled_from(sorted(PLANES)))
    axes, normal, centre = PLANES[plane]
    modes = [draw(st.sampled_from(pair)) for pair in (("G20", "G21"), ("G90", "G91"))]
    modes += [draw(st.sampled_from(pair)) for pair in (("G90.1", "G91.1"), ("G54", "G55"))]
    out = [f"{plane} {' '.join(modes)} G1 F{draw(DIGITS)}1"]
    if draw(st.booleans()):
        out.append("G92 X3 Y-1 Z.5")
    for k in range(draw(st.integers(1, 8))):
        g = draw(G_ARC) if k else draw(st.sampled_from(["G2", "G03"]))
        if draw(st.booleans()):
            a, b = draw(GOOD_NUMBER), draw(GOOD_NUMBER)
            r = draw(st.sampled_from(["", "-"])) + "1" + draw(DIGITS) + "000"
            words = [f"{axes[0]}{a}", f"{axes[1]}{b}", f"R{r}"]
        else:
            words = [f"{normal}{draw(GOOD_NUMBER)}", f"{centre[0]}{draw(GOOD_NUMBER)}"]
            words.append(f"{centre[1]}{draw(GOOD_NUMBER)}")
        words.sort(key=lambda w: LETTERS.index(w[0]))
        if draw(st.booleans()):
            words.append(f"F{draw(DIGITS)}")
        out.append(" ".join([g, *words]))
    return out


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(arc_program())
def test_generated_arcs(body: list[str]) -> None:
    same(["G21 G90 G94 G0 X1 Y2 Z3", *body, "M2"])


def test_a_move_whose_square_overflows_is_a_move_on_every_path() -> None:
    """(1e200 - 1) ** 2 overflows a float: the fast path raised OverflowError (a
    traceback) where the full interpreter takes the move; now all three agree."""
    lines = ["G21 G90 G1 F10 X1", "X1" + "0" * 200, "Y2", "M2"]
    full = [bits(m) for m in gcode.iter_motions(lines, CFG, "t.ngc", fast=False)]
    want = outcome(lines, fast.PURE)
    assert want == (full, None, 2)
    assert outcome(lines, compiled()) == want
