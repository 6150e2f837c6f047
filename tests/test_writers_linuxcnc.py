"""The corrected G-code writer (prsxy_post/writers/linuxcnc.py), read back.

LinuxCNC's termination modes, from its G-code reference: ``G61`` (exact path)
"Moves will slow or stop as needed to reach every programmed point"; ``G64 P``
blends within P. The mode is modal and each line is queued with the mode active
when it is read; it governs the junction at the line's end. What LinuxCNC does
with the written program is in test_linuxcnc_motion.py.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from prsxy_post import kinematics, writers
from prsxy_post.writers.cartesian import WrittenPoints
from prsxy_post.writers.linuxcnc import GcodeWriter, corner_cut

from . import controllers as ctl
from .conftest import ROOT
from .test_controller_truth import TBALL_WITH_A_TILT, XY_CORNER_AT_F60
from .test_tracking import convert, truth_machine, with_output_setting

PROGRAMS = [
    ("xy-corner-F60", XY_CORNER_AT_F60),
    *[(p.name, p.read_text()) for p in sorted((ROOT / "samples").glob("*.ngc"))],
]


def _moves_and_modes(text: str) -> tuple[list[str], list[bool], list[bool]]:
    """Every G0/G1/G2/G3/G4 line of the written program but the ``G4 P0`` settles, whether
    G61 was in force when it was read, and whether a ``G4 P0`` follows it."""
    moves: list[str] = []
    exact: list[bool] = []
    settled: list[bool] = []
    mode = False
    for raw in text.splitlines():
        s = raw.strip()
        if s == "G61":
            mode = True
        elif re.fullmatch(r"G64 P[\d.]+", s):
            mode = False
        elif s == "G4 P0":
            assert moves and moves[-1].startswith(("G1 ", "G2 ", "G3 ")), "G4 P0 after no move"
            settled[-1] = True
        elif s.startswith(("G0 ", "G1 ", "G2 ", "G3 ", "G4 ")):
            moves.append(s)
            exact.append(mode)
            settled.append(False)
    return moves, exact, settled


@pytest.mark.parametrize(("name", "text"), PROGRAMS, ids=[n for n, _ in PROGRAMS])
def test_a_line_ending_where_the_motion_stands_runs_in_exact_path_mode(name: str, text: str):
    """Each written move is one of the chain's points (no tolerance set): a G1 that
    ends where the plan stands (speed 0) is read under G61, every other under G64 P
    but at a block's end where a parabolic blend would cut the corner by more than
    half the tolerance (0.25 µm, 0.25 arcsec). Each of those is followed by ``G4 P0``
    and no other line: LinuxCNC's task waits for the motion to end before a dwell
    (``emctaskmain.cc``, ``emcTaskCheckPreconditions``: ``EMC_TRAJ_DELAY_TYPE`` returns
    ``EMC_TASK_EXEC_WAITING_FOR_MOTION_AND_IO``), so the next line starts from a servo
    sample at the corner, which ``tpHandleSplitCycle`` would otherwise skip; and that
    next line is read under G61 too (writers/linuxcnc.py's docstring)."""
    truth = with_output_setting(truth_machine("random", 12), "gcode", "tolerance_mm", 0.0)
    _, res, texts = convert(truth, text, "gcode")
    moves, exact, settled = _moves_and_modes(texts[0])
    pts = res.points
    written = [k for k in range(len(pts)) if pts.fn[k] is None]
    assert len(written) == len(moves)
    q = np.array([[float(v) for v in re.findall(r"[XYZAB](-?[\d.]+)", m)] for m in moves])
    # the plan's times (a line the writer slows down for LinuxCNC's blend carries a
    # lower F: writers/linuxcnc.py, rule 4)
    dt = np.array([pts.dt[k] if " F" in m else 0.0 for m, k in zip(moves, written, strict=True)])
    accel = truth.limits.max_accel_mm_s2
    want = []
    for i, k in enumerate(written):
        if not moves[i].startswith("G1 "):
            want.append(False)  # G0 and G4 lines: no junction of their own here
        elif pts.speed[k] == 0.0:
            want.append(True)
        else:
            corner = pts.block_end[k] and i + 1 < len(moves) and moves[i + 1].startswith("G1 ")
            if corner:
                mm, deg = corner_cut(q[i - 1], q[i], q[i + 1], dt[i], dt[i + 1], accel)
                want.append(mm > 0.25e-3 or deg > 0.25 / 3600)
            else:
                want.append(False)
    # a G1 into which LinuxCNC blends the one before parabolically (read under G64 P,
    # not settled, one of the two turning A or B) is read under G64 P if settled
    # (under G61 it would speed up at its whole acceleration limit while the line
    # before slows down at half of it, over F); and a line the writer stops for such
    # a blend is settled where the plan does not stand (writers/linuxcnc.py, rule 4)
    g1 = [m.startswith("G1 ") for m in moves]
    ab = [m[m.index(" A") :].split(" F")[0] if " A" in m else None for m in moves]
    turns = [k > 0 and a is not None and a != ab[k - 1] for k, a in enumerate(ab)]
    into = [
        k + 1 < len(moves) and g1[k] and g1[k + 1] and (turns[k] or turns[k + 1])
        for k in range(len(moves))
    ]
    for i, (s, w) in enumerate(zip(settled, want, strict=True)):
        assert s or not w, f"not settled: {moves[i]}"
        assert w or not s or (into[i] and not exact[i]), f"settled: {moves[i]}"
    # the last G1 before each move was settled (a program's own G4 keeps the queue
    # drained, so the flag carries over dwells and functions), or there was none
    after, last = [], True  # the program's first G1 too: LinuxCNC's queue starts empty
    for is_g1, st in zip(g1, settled, strict=True):
        after.append(last)
        last = st if is_g1 else last
    parabolic = [
        k > 0
        and g1[k]
        and g1[k - 1]
        and not exact[k - 1]
        and not settled[k - 1]
        and (turns[k - 1] or turns[k])
        for k in range(len(moves))
    ]
    # (a line the writer stops for a blend stays under G64 P, as it was read before
    # the next line showed the blend: its G4 P0 stops it all the same)
    stopped = [s and not w for s, w in zip(settled, want, strict=True)]
    assert [e for e, g, st in zip(exact, g1, stopped, strict=True) if g and not st] == [
        (s or a) and not (s and p)
        for s, a, p, g, st in zip(settled, after, parabolic, g1, stopped, strict=True)
        if g and not st
    ]
    assert exact[g1.index(True)], "the first G1 is not read under G61"
    # and the program stands somewhere beside its end (a corner, a rapid's end)
    assert sum(pts.speed[k] == 0.0 for k in written) >= 2


def test_the_program_s_first_g1_runs_in_exact_path_mode() -> None:
    """LinuxCNC's queue starts empty, as after a ``G4 P0``: the program's first G1 is
    read under G61 even where it ends in motion, and the line after it is not. On a
    machine without play the first G1 is the first step of the program's rapid (with
    play it is the crossing that sets each part at the start, which stands anyway).
    A line to every point (no tolerance), so that lines and points pair up."""
    truth = with_output_setting(
        truth_machine("random", 12, play=False), "gcode", "tolerance_mm", 0.0
    )
    text = "G21 G90 G17 G94\nG0 X-20 Y-10 Z0\nG1 X20 F1200\nG1 Y10\nG0 Z5\nM2\n"
    _, res, texts = convert(truth, text, "gcode")
    moves, exact, settled = _moves_and_modes(texts[0])
    pts = res.points
    written = [k for k in range(len(pts)) if pts.fn[k] is None]
    first = next(i for i, m in enumerate(moves) if m.startswith("G1 "))
    assert pts.speed[written[first]] > 0.0, "the first G1 stands: this cannot tell the rule"
    assert not settled[first]
    assert exact[first], "the first G1 is not read under G61"
    assert moves[first + 1].startswith("G1 ") and not exact[first + 1]


def test_a_sharp_tilt_corner_in_motion_runs_in_exact_path_mode() -> None:
    """tball-with-a-tilt-F1016's last line turns B by 0.5° over 0.47 mm at F1016,
    from lines that hold it: the line into that corner is read under G61, and the
    lines inside the blocks are not (a line to every point: no tolerance)."""
    truth = with_output_setting(truth_machine("random", 21), "gcode", "tolerance_mm", 0.0)
    _, res, texts = convert(truth, TBALL_WITH_A_TILT, "gcode")
    _, exact, settled = _moves_and_modes(texts[0])
    pts = res.points
    written = [k for k in range(len(pts)) if pts.fn[k] is None]
    # a line after a G4 P0 runs in G61 for the dwell's sake, not its corner's
    moving_exact = [
        i
        for i, k in enumerate(written)
        if exact[i] and pts.speed[k] > 0 and not (i and settled[i - 1])
    ]
    assert moving_exact, "no tilt corner taken in G61"
    assert all(pts.block_end[written[i]] for i in moving_exact)


def test_the_corner_cut_in_closed_form() -> None:
    """A right-angle corner in X Y at 10 mm/s over 10 ms lines, acceleration
    2000 mm/s²: the blend lasts min(10 ms, 2 v / a = 10 ms), the direction turns by
    √2, the cut is √2 · 10 mm/s · 10 ms / 8. The same line slowing from 10 to 5
    mm/s cuts nothing; a tilt turning from 0 to 100 °/s on a straight line cuts
    100 °/s · 10 ms / 8 in A B alone."""

    def pose(x: float, y: float = 0.0, b: float = 0.0) -> np.ndarray:
        return np.array([x, y, 0.0, 0.0, b])

    mm, deg = corner_cut(pose(-0.1), pose(0.0), pose(0.0, 0.1), 0.01, 0.01, 2000.0)
    assert mm == pytest.approx(np.sqrt(2) * 10.0 * 0.01 / 8) and deg == 0.0
    mm, deg = corner_cut(pose(-0.1), pose(0.0), pose(0.05), 0.01, 0.01, 2000.0)
    assert mm == pytest.approx(0.0, abs=1e-15) and deg == 0.0
    mm, deg = corner_cut(pose(-0.1), pose(0.0), pose(0.1, b=1.0), 0.01, 0.01, 2000.0)
    assert mm == pytest.approx(0.0, abs=1e-15)
    assert deg == pytest.approx(100.0 * 0.01 / 8)


@pytest.mark.parametrize(("name", "text"), PROGRAMS, ids=[n for n, _ in PROGRAMS])
def test_g61_every_line_writes_the_same_moves_all_in_exact_path(name: str, text: str) -> None:
    """``[output.gcode] g61_every_line = 1``: the same moves as by default, every one
    read under G61, and no G64 in the program (so LinuxCNC blends nothing). By
    default a line that turns A or B before one that holds them may run slower
    (its F lower: writers/linuxcnc.py, rule 4); in G61 nothing is blended, so
    nothing is slowed. By default an arc that starts where the motion stands
    starts a piece later, the line to there read under G61 (the line after a stop
    is, rule 5): those lines are the only moves the default adds."""
    truth = truth_machine("random", 12)
    _, _, default = convert(truth, text, "gcode")
    _, _, exact = convert(with_output_setting(truth, "gcode", "g61_every_line", 1), text, "gcode")
    moves_default, _, settled = _moves_and_modes(default[0])
    moves, modes, _ = _moves_and_modes(exact[0])

    def point(m: str) -> str:
        return re.split(r" [FIJK]-?\d", m)[0].split(" ", 1)[1]

    kept: list[str] = []
    for i, d in enumerate(moves_default):
        if len(kept) < len(moves) and point(d) == point(moves[len(kept)]):
            # an arc that starts a piece later is timed anew: its F not compared
            kept.append(d if point(moves_default[i - 1]) == point(moves[len(kept) - 1]) else "")
            continue
        # a line the default adds: one piece after a stop, an arc after it
        assert d.startswith("G1 ") and moves_default[i + 1].startswith(("G2 ", "G3 ")), d
        assert settled[i - 1] or moves_default[i - 1].startswith("G4 "), d
    assert len(kept) == len(moves)
    moves_default = kept
    for m, d in zip(moves, moves_default, strict=True):
        if " F" in m and d:
            assert float(d.split(" F")[1]) <= float(m.split(" F")[1])
    assert all(modes)
    assert not any(line.startswith("G64") for line in exact[0].splitlines())


def test_a_line_s_acceleration_limit_is_linuxcnc_s() -> None:
    """LinuxCNC's canon gives a line the path length over the longest time an axis
    takes at its own limit (emccanon.cc getStraightAcceleration: each axis's
    distance over its limit, A and B at theirs): √2 times the axes' limit on an X Y
    diagonal, the limit along an axis, less where B's turn takes longer."""
    truth = truth_machine("random", 11, play=False)
    w = GcodeWriter(truth, writers.settings_of(truth, "gcode"), None)
    a, a_deg = truth.limits.max_accel_mm_s2, truth.limits.max_accel_deg_s2
    assert w._line_accel([1.0, 1.0, 0.0], [0.0, 0.0]) == pytest.approx(np.sqrt(2) * a)
    assert w._line_accel([3.0, 0.0, 0.0], [0.0, 0.0]) == pytest.approx(a)
    # B turning 10 degrees over 1 mm: B's time rules
    assert w._line_accel([1.0, 0.0, 0.0], [0.0, 10.0]) == pytest.approx(a_deg / 10.0)


HELIX_F10000 = "G21 G90 G17 G94\nG0 X10 Y0 Z2\nG1 Z0 F10000\nG2 X10 Y0 Z-3 I-10 J0 P2\nG0 Z2\nM2\n"


@pytest.mark.parametrize("seed", [None, 11, 13])
def test_arcs_are_written_as_arcs_within_the_tolerance(seed: int | None) -> None:
    """A two-turn helix on R10 at F10000 (rule 5): a few G2 where there were some
    1400 chords; every point the chain made lies within ``tolerance_mm`` of the
    written moves as LinuxCNC runs them (arcs read back by the tests' model of
    LinuxCNC's arc, tests/controllers.GcodeArc); no arc turns A or B where the
    tilt is held, and each runs no faster than √(24 R e / 7) / T (e the path
    tolerance less the chord tolerance, T 1 ms: LinuxCNC's smoothing)."""
    truth = (
        truth_machine("nominal", None)
        if seed is None
        else truth_machine("random", seed, play=False)
    )
    _, res, texts = convert(truth, HELIX_F10000, "gcode")
    text = texts[0]
    run = ctl.run_gcode(text)
    assert 3 <= len(run.arcs) <= 12
    assert text.count("\nG1 ") <= 12
    tol = writers.settings_of(truth, "gcode")["tolerance_mm"]
    e = truth.interpolation.path_tolerance_mm - tol
    # every point the chain made, as written: its distance from the written moves
    pts = WrittenPoints(kinematics.controller_geometry(truth))(res.points)
    dist = np.full(len(pts), np.inf)
    for k in range(1, len(run.q)):
        a, b = run.q[k - 1], run.q[k]
        if k in run.arcs:
            d = run.arcs[k].distance(a, b, pts, 0.0)
        else:
            ab = b - a
            u = np.clip((pts - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
            d = np.linalg.norm((pts - (a + u[:, None] * ab))[:, :3], axis=1)
        dist = np.minimum(dist, d)
    for arc_end, arc in run.arcs.items():
        a, b = run.q[arc_end - 1], run.q[arc_end]
        assert np.array_equal(a[3:], b[3:])  # no tilt turned on an arc
        _, sweep, r0, r1 = arc.geometry(a, b)
        length = np.hypot(min(r0, r1) * abs(sweep), b[2] - a[2])
        v = length / (run.t[arc_end] - run.t[arc_end - 1])
        # F has 3 decimals: a relative 1e-5 on F200
        assert v <= np.sqrt(24.0 * min(r0, r1) * e / 7.0) / 1e-3 * (1 + 1e-5)
    assert dist.max() <= tol * (1 + 1e-6)
    # the tilt is held over the whole helix (_center_tilt): its compensated tilt
    # drifts by 0.61 arcsec on random 11 and 13, LinuxCNC all but stops at a line
    # that turns A or B, and none does inside the helix, nor the line from its end
    # (a parabolic join there halves the last arc's acceleration: 1.08 x the plan
    # on random 11 before, bench/linuxcnc_speed.py), the held tilt within arc_hold
    # (0.4 arcsec) of every point of the helix
    last = max(run.arcs)
    held = {tuple(run.q[k, 3:]) for k in [*run.arcs, last + 1]}
    assert len(held) == 1
    on_helix = res.points.line == 4
    off = np.abs(pts[on_helix, 3:] - np.array(next(iter(held)))).max() * 3600.0
    assert off <= 0.4 + 0.001


def test_lines_that_turn_the_tilt_are_no_arcs() -> None:
    """five-axis.ngc on random 13: the lines that turn B by 15 degrees bend a little
    in X Y Z (the compensated tip); an arc fitted there was split at every point
    where the written tilt changes, a line to every point (242 lines where the
    chords take 11; LinuxCNC 1.14 x the plan). Only the tilted circle is arcs; each
    block that turns the tilt is as few lines as without arcs."""
    truth = truth_machine("random", 13, play=False)
    text = (ROOT / "samples" / "five-axis.ngc").read_text()
    _, _, texts = convert(truth, text, "gcode")
    blocks: dict[int, list[str]] = {}
    cur = 0
    for row in texts[0].splitlines():
        m = re.fullmatch(r"\(line (\d+)\)", row)
        if m:
            cur = int(m.group(1))
        elif row.startswith(("G1 ", "G2 ", "G3 ")):
            blocks.setdefault(cur, []).append(row)
    arcs = {k for k, rows in blocks.items() if any(r.startswith(("G2", "G3")) for r in rows)}
    assert arcs == {13}  # the circle
    assert all(len(blocks[k]) <= 20 for k in (9, 10, 12))
