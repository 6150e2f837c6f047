"""Motions as rows (gcode/rows.py), what convert plans from.

The table of a program's motions, however they came (runs of rows from the
compiled fast path, Motions from everything else), must give planning the very
arrays the Motions themselves give (interpolate.geometry's columns of a Motion
list, the reference); chunks must cut the stream where ``itertools.islice`` cuts
the Motions; and a run of rows must stay in its place around a Motion that the
reference's arc code makes in the middle of a run.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from prsxy_post import chain, gcode, rules
from prsxy_post.errors import GCodeError
from prsxy_post.gcode import fast, rows
from prsxy_post.interpolate import geometry
from prsxy_post.profile import Profile

from .conftest import DATA, ROOT
from .test_gcode_fast import CFG, bits, compiled, same


def _programs() -> list[Path]:
    return [
        *sorted((ROOT / "samples").glob("*.ngc")),
        *sorted((DATA / "gcode" / "features").glob("*.ngc")),
    ]


def _both(path: Path) -> tuple[list[gcode.Motion], list[rows.Item]]:
    """A program's motions and its items in rows mode, each up to the error it
    raises (the same error, after the same motions)."""
    lines = gcode.split_lines(path.read_text(encoding="utf-8"))
    motions: list[gcode.Motion] = []
    items: list[rows.Item] = []
    errors = []
    for out, run in (
        (motions, gcode.iter_motions(lines, CFG, str(path))),
        (items, gcode.iter_motion_items([lines], CFG, str(path))),
    ):
        try:
            out.extend(run)  # type: ignore[attr-defined]
        except GCodeError as exc:
            errors.append(str(exc))
    assert len(errors) in (0, 2) and len(set(errors)) <= 1
    return motions, items


def _assert_same_columns(a: object, b: object) -> None:
    for name in geometry._MotionColumns._fields:
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape, name
        if x.dtype == object:
            assert [bits(v) for v in x] == [bits(v) for v in y], name
        else:
            assert x.tobytes() == y.tobytes(), name  # to the bit: NaNs and -0.0 too


def _rows_selected() -> None:
    """Skip unless the compiled fast path is the one selected: only it makes rows
    (``PRSXY_KERNEL=pure`` selects the reference, which gives Motions)."""
    compiled()
    if fast.SELECTED is not fast.COMPILED:
        pytest.skip("PRSXY_KERNEL=pure selects the reference fast path (Motions only)")


@pytest.mark.parametrize("path", _programs(), ids=lambda p: p.name)
def test_a_programs_table_gives_the_columns_its_motions_give(path: Path) -> None:
    motions, items = _both(path)
    want = geometry.motion_columns(motions)
    _assert_same_columns(geometry.motion_columns(rows.table(items)), want)
    _assert_same_columns(geometry.motion_columns(rows.table(motions)), want)
    one_by_one = np.array([rows.row_of(m) for m in motions], dtype=float)
    assert rows.rows_of(motions).tobytes() == one_by_one.tobytes()


def test_the_generated_program_comes_as_rows_and_plans_the_same(nominal: Profile) -> None:
    """bench.py's five-axis program: nearly all of it in runs of rows (compiled),
    its prepared chunks the same blocks and problems as its Motions'."""
    from bench.bench import generate

    _rows_selected()
    lines = gcode.split_lines(generate(3000, seed=5))
    motions = list(gcode.iter_motions(lines, CFG))
    items = list(gcode.iter_motion_items([lines], CFG))
    assert sum(len(x) for x in items if isinstance(x, np.ndarray)) > 0.95 * len(motions)
    prof = nominal
    limits = chain.limits_of(prof)
    it = iter(motions)
    for chunk in rows.chunks(iter(items), 700):
        ms = list(itertools.islice(it, 700))
        t = rows.table(chunk)
        assert len(t) == len(ms)
        a, b = chain.prepare(t, prof, limits), chain.prepare(ms, prof, limits)
        assert (a.n_motions, a.first_line, a.problems) == (b.n_motions, b.first_line, b.problems)
        for name in geometry.Blocks.FIELDS:
            x, y = getattr(a.blocks, name), getattr(b.blocks, name)
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=x.dtype != object), name


def test_feed_problems_of_a_table_are_those_of_its_motions(nominal: Profile) -> None:
    prof = nominal
    fmax = prof.limits.max_feed_mm_min
    text = f"G21 G90 G17 G94 G1 X1 F{fmax * 2:g}\nX2\nG2 X3 I.5\nG0 X0\nG1 X1 F{fmax / 2:g}\nM2\n"
    lines = gcode.split_lines(text)
    motions = list(gcode.iter_motions(lines, CFG))
    items = list(gcode.iter_motion_items([lines], CFG))
    want = rules.feed_problems(prof, motions)
    assert [p.line for p in want] == [1, 2, 3]
    assert rules.feed_problems(prof, rows.table(items)) == want


@pytest.mark.parametrize("size", [1, 2, 3, 5, 256, 1000])
def test_chunks_cut_where_islice_cuts_the_motions(size: int) -> None:
    items: list[rows.Item] = []
    k = 0
    motions = list(gcode.iter_motions(["G0 X1", "M3 S100", "G4 P1", "M2"], CFG))
    for n in [3, 0, 1, 7, 2, 300, 1, 1]:  # runs of rows between Motions
        items.append(np.arange(k, k + n, dtype=float)[:, None] * np.ones((1, rows.WIDTH)))
        items.append(motions[k % len(motions)]._replace(line=k + n))
        k += n + 1
    flat = rows.table(items).rows
    got = list(rows.chunks(iter(items), size))
    assert all(sum(rows.count(x) for x in c) == size for c in got[:-1])
    assert 0 <= sum(rows.count(x) for x in got[-1]) < size
    assert np.array_equal(np.concatenate([rows.table(c).rows for c in got]), flat, equal_nan=True)


def test_rows_around_a_motion_the_reference_arc_makes_stay_in_order() -> None:
    """An arc with a number of more than 15 digits goes to the reference's arc code
    in the middle of a run: the rows before it go out before its Motion."""
    lines = ["G21 G90 G94 G17 G1 X0 Y0 F100", "X1", "G2 X2 Y0 I.5 A" + "9" * 200, "G1 X3", "X4"]
    same([*lines, "M2"])
    _rows_selected()
    items = list(gcode.iter_motion_items([[*lines, "M2"]], CFG))
    kinds = [type(x).__name__ if isinstance(x, np.ndarray) else x.kind for x in items]
    assert kinds == ["feed", "ndarray", "arc", "ndarray", "function"]
    assert [int(r[rows.ROW_LINE]) for r in rows.table(items).rows] == [1, 2, 3, 4, 5, 6]


def test_a_run_cut_short_holds_only_its_own_rows() -> None:
    """A run of rows ended by a line the full path takes (here a comment) is its
    rows alone, not a view of the room left for the rest of the batch, which
    would stay alive until its chunk is planned."""
    _rows_selected()
    lines = ["G21 G90 G94 G1 X0 Y0 F100"]
    for j in range(100):
        lines += [f"X{j}.5", f"Y{j}", "(a comment)"]
    items = list(gcode.iter_motion_items([[*lines, "M2"]], CFG))
    runs = [x for x in items if isinstance(x, np.ndarray)]
    assert len(runs) == 100 and all(len(r) == 2 for r in runs)
    assert all(r.base is None for r in runs)
