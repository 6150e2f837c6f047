"""The compiled G-code writer's decisions against their plain-Python reference: the
same ops, F values and state, to the bit.

Recorded inputs (every chunk the corrected G-code of the sample programs and of a
generated bench program, bench/bench.py's, on its calibrated machine with tables
and play, is decided in) and generated ones (hypothesis: runs of points moving
straight, turning corners, stopping, dwelling, with machine functions and play
crossings, A and B still, creeping or turning; tolerance 0 or not, the tilt held
or not, ``g61_every_line`` on or off; cut into chunks at any point, so that held
points, corners and the line before carry over). Also CPython's ``math.fsum`` and
``math.hypot`` (which is not libm's hypot) against the twin's own. Arcs (the
writer's rule 5): every call, stops for a refit and resumes included, of arcs,
helices and helices that turn A and B a little, on the nominal machine and random
ones with and without play, whole and in chunks.
"""

from __future__ import annotations

import copy
import importlib.util
import itertools
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post import kernel
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.kernel import arcs as karcs
from prsxy_post.kernel import gwrite, vnorm

from .conftest import ROOT
from .kernel_cases import compiled, record, same_bits
from .test_linuxcnc_motion import arc_programs

Ops = gwrite.Ops


def _same_ops(got: Ops, want: Ops) -> bool:
    return (
        all(
            np.array_equal(g, w) and g.dtype == w.dtype
            for g, w in zip(got[:4], want[:4], strict=True)
        )
        and same_bits(got[4], want[4])
        and got[5].shape == want[5].shape
        and same_bits(got[5], want[5])
    )


def _same_state(a: gwrite.GState, b: gwrite.GState) -> bool:
    n = int(a.i[gwrite.I_NAMES.index("run_n")])
    return (
        np.array_equal(a.i, b.i)
        and all(
            same_bits(x, y)
            for x, y in (
                (a.f, b.f),
                (a.last_q, b.last_q),
                (a.last_ab, b.last_ab),
                (a.held_ab, b.held_ab),
                (a.lead0, b.lead0),
                (a.corner_q, b.corner_q),
                (a.run_q[:n], b.run_q[:n]),
                (a.corner_in, b.corner_in),
                (a.pend_v, b.pend_v),
                (a.pend_t, b.pend_t),
            )
        )
        and np.array_equal(a.pend_i, b.pend_i)
        and np.array_equal(a.fit_i, b.fit_i)
        and a.fit_i.dtype == b.fit_i.dtype
        and same_bits(a.fit_f, b.fit_f)
    )


def _both(args: tuple[Any, ...]) -> Ops:
    """Run the reference and the twin from copies of the same state; assert they
    agree (ops and state) and return the ops."""
    _gwrite = compiled("_gwrite")
    st_r, st_c = copy.deepcopy(args[0]), copy.deepcopy(args[0])
    gwrite.reserve(st_c, len(args[1]))
    want = gwrite.gcode_ops(st_r, *args[1:])
    got = _gwrite.gcode_ops(st_c, *args[1:])
    assert _same_ops(got, want)
    assert _same_state(st_c, st_r)
    return want


REQ = {n: gwrite.I_NAMES.index(n) for n in ("stop_at", "req_kind", "req_arc", "req_answer")}


def _answering(
    fn: Callable[..., Ops], st: gwrite.GState, args: tuple[Any, ...], kinds: list[int]
) -> Ops:
    """``fn`` (a gcode_ops) on ``st`` with ``args`` (those after the state, ``fit``
    last) as the writer called it before the kernel refitted itself: without
    ``fit``, stopping where an arc must be refitted, answered here as the writer
    answered (``kernel.arcs.refit_arcs`` over the chunk's points, from the stop on,
    and for ARC_TO first from the arc's start to the point before), called again
    from the stop. ``st.fit_i``, ``st.fit_f``: the arcs refitted; each stop's kind
    appended to ``kinds``."""
    *head, arc_of, arc_i, arc_f, fit = args
    q = head[0]
    arc_of = np.array(arc_of, dtype=np.int64)
    arc_i = np.array(arc_i, dtype=np.int64).reshape(-1, 4)
    arc_f = np.array(arc_f, dtype=float).reshape(-1, 2)
    new: list[tuple[np.ndarray, np.ndarray]] = []
    while True:
        gwrite.reserve(st, len(q))  # as kernel.gcode_ops does before each call
        ops = fn(st, *head, arc_of, arc_i, arc_f)
        k = int(st.i[REQ["stop_at"]])
        if k < 0:
            break
        kind, a = int(st.i[REQ["req_kind"]]), int(st.i[REQ["req_arc"]])
        kinds.append(kind)
        start, end, plane = (int(x) for x in arc_i[a, :3])
        rows = []
        if kind == gwrite.REQ_ARC_TO:
            part = karcs.refit_arcs(q, plane, start, k - 1, *fit)
            st.i[REQ["req_answer"]] = -1
            if len(part[0]) == 1 and int(part[0][0, 1]) == k - 1:
                st.i[REQ["req_answer"]] = len(arc_i)
                rows.append(part)
        arc_of[k : end + 1] = -1
        part = karcs.refit_arcs(q, plane, k, end, *fit)
        first = len(arc_i) + sum(len(r[0]) for r in rows)
        for j, (s, e) in enumerate(part[0][:, :2].tolist()):
            arc_of[s + 1 : e + 1] = first + j
        rows.append(part)
        for ai, af in rows:
            new.append((ai, af))
            arc_i = np.concatenate([arc_i, np.column_stack([ai[:, :3], np.ones(len(ai), int)])])
            arc_f = np.concatenate([arc_f, af[:, 3::2]])
    st.fit_i = np.concatenate([np.zeros((0, 4), np.int64)] + [a for a, _ in new])
    st.fit_f = np.concatenate([np.zeros((0, 6))] + [f for _, f in new])
    return ops


def test_the_twin_names_the_state_as_the_reference() -> None:
    _gwrite = compiled("_gwrite")
    assert _gwrite.F_NAMES == gwrite.F_NAMES and _gwrite.I_NAMES == gwrite.I_NAMES


_float = st.one_of(
    st.floats(-1e3, 1e3),
    st.floats(-1e-300, 1e-300),
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e150, max_value=1e150),
    st.sampled_from([0.0, -0.0, 1e-320, 5e-324, 1.0, 0.1, 3.0]),
)


_pos = st.floats(1e-4, 1e4)


@settings(max_examples=1000, deadline=None)
@given(
    moves=st.tuples(_pos, _pos, _pos, _pos, _pos, _pos),
    arcs=st.sampled_from([(1, 0), (0, 1), (1, 1)]),
    radius=st.floats(1e-3, 1e3),
)
def test_arc_blend_cut_is_bit_identical(
    moves: tuple[float, ...], arcs: tuple[int, int], radius: float
) -> None:
    """The cut of a parabolic blend into or out of an arc (rule 5), compiled and
    reference, to the bit: short and long moves, slow and fast, small and large
    radii."""
    _gwrite = compiled("_gwrite")
    len_p, t_p, a_p, len_n, t_n, a_n = moves
    args = (len_p, t_p, a_p, radius * arcs[0], len_n, t_n, a_n, radius * arcs[1])
    assert same_bits(np.array(_gwrite.arc_blend_cut(*args)), np.array(gwrite.arc_blend_cut(*args)))


def _blend_on_circles(
    len_p: float,
    t_p: float,
    a_p: float,
    r_p: float,
    len_n: float,
    t_n: float,
    a_n: float,
    r_n: float,
) -> float:
    """The largest distance from the path (an arc and its tangent line) of the sum
    of the two moves of a parabolic blend, on the exact circle (sines and cosines,
    4001 instants of the blend), the moves timed as :func:`gwrite.arc_blend_cut`
    times them (tp.c's blend speed, the previous move slowing to a stop, the next
    speeding up a servo cycle ahead)."""
    period = gwrite.SERVO_PERIOD_S
    v_n = len_n / t_n
    v_b = gwrite.blend_speed(len_p, t_p, a_p, len_n, t_n, a_n)
    t = np.linspace(0.0, v_b / a_p, 4001)
    left = np.maximum(v_b * v_b / (2.0 * a_p) - v_b * t + a_p * t * t / 2.0, 0.0)
    tn = t + period
    gone = np.where(a_n * tn < v_n, a_n * tn * tn / 2.0, v_n * tn - v_n * v_n / (2.0 * a_n))
    gone = np.minimum(gone, len_n)
    # the join at the origin, the line along +x, the arc's center at (0, -R)
    arc_first = r_p > 0.0
    radius, on_arc, on_line = (r_p, left, gone) if arc_first else (r_n, gone, left)
    side = -1.0 if arc_first else 1.0
    x = side * (radius * np.sin(on_arc / radius) - on_line)
    y = -radius * (1.0 - np.cos(on_arc / radius))
    span = (len_p if arc_first else len_n) / radius
    angle = side * np.arctan2(x, y + radius)
    end = (side * radius * np.sin(span), -radius * (1.0 - np.cos(span)))
    to_arc = np.where(
        (angle >= 0.0) & (angle <= span),
        np.abs(np.hypot(x, y + radius) - radius),
        np.minimum(np.hypot(x, y), np.hypot(x - end[0], y - end[1])),
    )
    to_line = np.where(side * x <= 0.0, np.abs(y), np.hypot(x, y))
    return float(np.minimum(to_arc, to_line).max())


def test_arc_blend_cut_matches_the_exact_geometry() -> None:
    """The writer's estimate of how far a parabolic blend cuts an arc (rule 5:
    the arc's rise over its tangent for small angles) against the same blend on
    the exact circle: within 1 % where the cut is 0.01 to 1 µm, and the same
    decision against the G64 P tolerance (0.25 µm) everywhere, over moves of
    0.01 to 30 mm at 1 to 300 mm/s, radii 0.03 to 100 mm, into and out of arcs."""
    rng = np.random.default_rng(7)
    close = 0
    for _ in range(400):
        len_p, len_n = 10 ** rng.uniform(-2.0, 1.5, 2)
        v, accel = 10 ** rng.uniform(0.0, 2.5), 10 ** rng.uniform(2.0, 3.7)
        radius = 10 ** rng.uniform(-1.5, 2.0)
        arc_first = bool(rng.integers(2))
        args = (
            len_p, len_p / v, accel / (4.0 if arc_first else 2.0), radius if arc_first else 0.0,
            len_n, len_n / v, accel / 2.0, 0.0 if arc_first else radius,
        )  # fmt: skip
        model, exact = gwrite.arc_blend_cut(*args), _blend_on_circles(*args)
        assert (model > 0.25e-3) == (exact > 0.25e-3), (args, model, exact)
        if 1e-5 < exact < 1e-3:
            close += 1
            assert abs(model / exact - 1.0) < 0.01, (args, model, exact)
    assert close > 100


@settings(max_examples=2000, deadline=None)
@given(x=st.lists(_float, min_size=0, max_size=5))
def test_fsum_and_hypot_are_cpythons(x: list[float]) -> None:
    """The twin's exactly rounded sum is math.fsum's bits (Shewchuk's partials,
    half-even across them), its hypot the reference's (CPython 3.11's vector_norm,
    :mod:`prsxy_post.kernel.vnorm`, not libm's hypot; checked against
    ``math.hypot`` itself in tests/test_kernel_vnorm.py): cancelling pairs,
    subnormals, wide ranges."""
    _gwrite = compiled("_gwrite")
    xs = x + [-v for v in x[:1]]  # a pair that cancels exactly
    for v in (x, xs, [a * 1e-3 for a in x]):
        want = math.fsum(v)
        got = _gwrite.fsum(np.array(v, dtype=float))
        assert same_bits(np.array(got), np.array(want))
    want_h = vnorm.hypot(*x)
    assert same_bits(np.array(_gwrite.hypot(np.array(x, dtype=float))), np.array(want_h))


def test_sample_programs_decisions_are_bit_identical(tmp_path: Path) -> None:
    calls = record("_gcode_ops", tmp_path)
    # pocket, drill and five-axis as corrected G-code: their chunks and ends
    assert len(calls) >= 6
    lines, arcs = 0, 0
    for args in calls:
        code = _both(args)[0]
        lines += int(np.sum(code == gwrite.G1))
        arcs += int(np.sum(code == gwrite.ARC))
    # pocket's helix and five-axis's arcs are G2/G3 (rule 5): a few lines and arcs
    # where there were 500 lines and more
    assert lines >= 40 and arcs >= 10


def _bench_module() -> Any:
    spec = importlib.util.spec_from_file_location("prsxy_bench", ROOT / "bench" / "bench.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bench_program_decisions_are_bit_identical(tmp_path: Path) -> None:
    """bench/bench.py's generated five-axis program on its calibrated machine (tables
    and play on every motor: the tilt is never held there)."""
    bench = _bench_module()
    prog = tmp_path / "bench.ngc"
    prog.write_text(bench.generate(3000))
    prof = bench.bench_profile(tmp_path / "bench.toml")
    calls: list[tuple[Any, ...]] = []
    inner: Callable[..., Ops] = kernel._gcode_ops

    def spy(*args: Any) -> Ops:
        calls.append(tuple(copy.deepcopy(a) for a in args))
        return inner(*args)

    mp = pytest.MonkeyPatch()
    mp.setattr(kernel, "_gcode_ops", spy)
    try:
        convert_file(ConvertJob(str(prog), str(prof), "gcode", str(tmp_path / "out.ngc")))
    finally:
        mp.undo()
    assert len(calls) >= 2
    ops = [_both(args) for args in calls]
    g1 = sum(int(np.sum(o[0] == gwrite.G1)) for o in ops)
    arcs = sum(int(np.sum(o[0] == gwrite.ARC)) for o in ops)
    stops = sum(int(np.sum(o[0] == gwrite.G4P0)) for o in ops)
    # its arcs are G2/G3 (rule 5): 4935 lines and the arcs where 5000 lines and more were
    assert g1 > 4500 and arcs > 0 and g1 + arcs > 5000 and stops > 0


@st.composite
def _program(draw: st.DrawFn) -> tuple[np.ndarray, ...]:
    """A run of points as the chain hands them to the writer (module docstring)."""
    n = draw(st.integers(1, 40))
    pos = np.array(
        [draw(st.floats(-100, 100)) for _ in range(3)]
        + [draw(st.floats(-20, 20)) for _ in range(2)]
    )
    direction = np.array([draw(st.floats(-1, 1)) for _ in range(3)])
    speed_now = draw(st.sampled_from([1.0, 10.0, 50.0, 0.2]))
    ab_rate = draw(st.sampled_from([0.0, 1e-5, 1e-2, -3.0]))
    lead_now = np.zeros(5)
    rows = []
    line = 1
    kinds = ["move"] * 6 + ["corner", "stop", "dwell", "fn", "end", "cross", "tilt"]
    for _ in range(n):
        kind = draw(st.sampled_from(kinds))
        dtk = draw(st.sampled_from([0.01, 0.0097, 0.004, 2.5e-4]))
        if kind == "corner":
            direction = np.array([draw(st.floats(-1, 1)) for _ in range(3)])
        if kind == "tilt":
            ab_rate = draw(st.sampled_from([0.0, 1e-5, 1e-2, -3.0]))
        norm = float(np.linalg.norm(direction)) or 1.0
        step = np.zeros(5)
        still = kind in ("dwell", "fn", "end")
        if not still:
            step[:3] = direction / norm * speed_now * dtk
            step[:3] += [draw(st.sampled_from([0.0, 1e-7, -3e-5, 2e-4])) for _ in range(3)]
            step[3:] = ab_rate * dtk + draw(st.sampled_from([0.0, 1e-7, -2e-7]))
        pos = pos + step
        if kind == "cross":
            lead_now[draw(st.integers(0, 4))] += draw(st.sampled_from([2e-3, -1e-4, 5e-6]))
        line += draw(st.sampled_from([0, 0, 1, 2]))
        stops = kind in ("stop", "dwell", "fn", "end")
        rows.append(
            (
                *np.round(pos, 7).tolist(),
                dtk,
                line,
                0.0 if stops else speed_now * draw(st.sampled_from([1.0, 0.5, 1.001])),
                kind in ("corner", "stop") or (draw(st.booleans()) and draw(st.booleans())),
                kind in ("fn", "end"),
                kind == "end",
                kind == "dwell" or (kind in ("fn", "end") and draw(st.booleans())),
                *lead_now.tolist(),
            )
        )
    a = np.array(rows, dtype=float)
    q = np.round(a[:, :5], 7) + 0.0
    return (
        q,
        a[:, 5].copy(),
        a[:, 6].astype(np.int64),
        a[:, 7].copy(),
        a[:, 8] > 0,
        a[:, 9] > 0,
        a[:, 10] > 0,
        a[:, 11] > 0,
        np.ascontiguousarray(a[:, 12:17]),
    )


@settings(max_examples=400, deadline=None)
@given(
    prog=_program(),
    tol=st.sampled_from([0.0, 1e-4, 5e-4, 1e-6]),
    hold=st.booleans(),
    all_exact=st.booleans(),
    accel=st.sampled_from([(2000.0, 3000.0), (500.0, 100.0)]),
    cuts=st.lists(st.integers(0, 40), max_size=3),
)
def test_generated_runs_are_bit_identical(
    prog: tuple[np.ndarray, ...],
    tol: float,
    hold: bool,
    all_exact: bool,
    accel: tuple[float, float],
    cuts: list[int],
) -> None:
    _gwrite = compiled("_gwrite")
    arc = 0.5 / 3600.0
    st_r = gwrite.new_state(
        tol,
        0.00025,
        0.5 * arc,
        0.6 * arc if hold else 0.0,
        0.2 * arc,
        *accel,
        all_exact,
        tilt_fit=0.6 * arc if hold else 0.0,
    )
    st_c = copy.deepcopy(st_r)
    n = len(prog[0])
    edges = [0, *sorted(c for c in cuts if c < n), n]
    ops: list[Ops] = []
    for a, b in [*itertools.pairwise(edges), (n, n)]:
        part = tuple(x[a:b] for x in prog)
        end = a == n
        want = gwrite.gcode_ops(st_r, *part, end)
        gwrite.reserve(st_c, b - a)
        got = _gwrite.gcode_ops(st_c, *part, end)
        assert _same_ops(got, want)
        assert _same_state(st_c, st_r)
        ops.append(want)
    code = np.concatenate([o[0] for o in ops])
    assert code[0] == gwrite.G0
    if all_exact:
        # every line in G61, each followed by G4 P0 (a stop at every point)
        assert not np.any(code == gwrite.G64)
        for o in ops:
            g1 = np.flatnonzero(o[0] == gwrite.G1)
            assert np.all(o[0][g1 + 1] == gwrite.G4P0)
    assert np.all(np.concatenate([o[4][o[0] == gwrite.G1] for o in ops]) > 0.0)


def test_arcs_decisions_are_bit_identical() -> None:
    """Every call while arcs, helices and helices that turn A and B a little
    convert (rule 5): the ARC and PLANE ops, the tilts centered before runs of
    arcs, and the stops where the writer refits (after a stop; where A or B leave
    the held tilt: REQ_ARC_TO) and the calls that go on from them."""
    from .test_tracking import convert, truth_machine

    calls: list[tuple[Any, ...]] = []
    inner: Callable[..., Ops] = kernel._gcode_ops

    def spy(*args: Any) -> Ops:
        calls.append(tuple(copy.deepcopy(a) for a in args))
        return inner(*args)

    machines = [
        truth_machine("nominal", None),
        truth_machine("random", 11, play=False),
        truth_machine("random", 13),
    ]
    mp = pytest.MonkeyPatch()
    mp.setattr(kernel, "_gcode_ops", spy)
    try:
        for m in machines:
            for text in arc_programs():
                for chunk in (0, 5):
                    convert(m, text, "gcode", chunk)
    finally:
        mp.undo()
    ops = [_both(args) for args in calls]
    code = np.concatenate([o[0] for o in ops])
    assert np.sum(code == gwrite.ARC) > 100 and np.sum(code == gwrite.PLANE) > 0
    assert sum(len(o[5]) for o in ops) > 0  # tilts centered
    # each call made again as the writer made it before the kernel refitted itself:
    # stopping for every refit, answered outside, resumed (the reference and the
    # twin): the same ops, state and refitted arcs as the call that refits itself
    _gwrite = compiled("_gwrite")
    kinds: list[int] = []
    for args, want in zip(calls, ops, strict=True):
        st_fit = copy.deepcopy(args[0])
        gwrite.gcode_ops(st_fit, *args[1:])
        for fn in (gwrite.gcode_ops, _gwrite.gcode_ops):
            st_s = copy.deepcopy(args[0])
            assert _same_ops(_answering(fn, st_s, args[1:], kinds), want)
            assert _same_state(st_s, st_fit)
    # stops for both kinds of request, resumed
    assert kinds.count(gwrite.REQ_REARC) > 0 and kinds.count(gwrite.REQ_ARC_TO) > 0


def test_arcs_stopped_for_a_blend_are_bit_identical() -> None:
    """The two found programs where an arc meets a move that turns A or B and
    LinuxCNC's parabolic blend would cut the arc (rule 5): led-floor-tiny-arc-as-
    lines-F1000 (an R0.22 arc into a line, 9.86 µm) and corner-arc-tilt (arcs of
    R1 into arcs, 0.38 µm), whole and in chunks of 5: the same ops and state, and
    more arcs written in G64 P and stopped by a G4 P0 than the reference makes with
    that rule taken out."""
    from .test_controller_truth import FOUND, FOUND_IDS
    from .test_tracking import convert, truth_machine

    calls: list[tuple[Any, ...]] = []
    inner: Callable[..., Ops] = kernel._gcode_ops

    def spy(*args: Any) -> Ops:
        calls.append(tuple(copy.deepcopy(a) for a in args))
        return inner(*args)

    found = dict(zip(FOUND_IDS, FOUND, strict=True))
    mp = pytest.MonkeyPatch()
    mp.setattr(kernel, "_gcode_ops", spy)
    try:
        for name in ("led-floor-tiny-arc-as-lines-F1000", "corner-arc-tilt"):
            seed, text = found[name]
            for chunk in (0, 5):
                start = len(calls)
                convert(truth_machine("random", seed), text, "gcode", chunk)
                with_rule = [_both(args)[0] for args in calls[start:]]
                mp.setattr(gwrite, "arc_blend_cut", lambda *a: 0.0)
                without = [_reference(args)[0] for args in calls[start:]]
                mp.setattr(gwrite, "arc_blend_cut", _ARC_BLEND_CUT)
                assert _arcs_stopped(with_rule) > _arcs_stopped(without), (name, chunk)
    finally:
        mp.undo()


_ARC_BLEND_CUT = gwrite.arc_blend_cut


def _reference(args: tuple[Any, ...]) -> Ops:
    return gwrite.gcode_ops(copy.deepcopy(args[0]), *args[1:])


def _arcs_stopped(codes: list[np.ndarray]) -> int:
    """How many ARC ops run in G64 P (the last mode op before them) and are
    followed by a G4 P0."""
    n, exact = 0, False
    for code in codes:
        for k, c in enumerate(code[:-1]):
            exact = True if c == gwrite.G61 else False if c == gwrite.G64 else exact
            n += int(c == gwrite.ARC and not exact and code[k + 1] == gwrite.G4P0)
    return n


def test_fitted_tilts_are_bit_identical() -> None:
    """Every call while the five-axis square converts for random machines without
    play, whole and in chunks of 5 points: chords whose A and B stray from the
    compensated tilt by more than ``tilt_chord`` written with a fitted end tilt
    (``_Run.fit_tilt``), a block end's carried over a chunk's end in the corner."""
    from .test_linuxcnc_motion import PROGRAMS
    from .test_tracking import convert, truth_machine

    calls: list[tuple[Any, ...]] = []
    inner: Callable[..., Ops] = kernel._gcode_ops

    def spy(*args: Any) -> Ops:
        calls.append(tuple(copy.deepcopy(a) for a in args))
        return inner(*args)

    mp = pytest.MonkeyPatch()
    mp.setattr(kernel, "_gcode_ops", spy)
    try:
        for seed in (11, 12, 13):
            m = truth_machine("random", seed, play=False)
            for feed in (3000.0, 10000.0):
                for chunk in (0, 5):
                    convert(m, PROGRAMS["five-axis"](feed), "gcode", chunk)
    finally:
        mp.undo()
    ops = [_both(args) for args in calls]
    # fitted tilts: rows of the calls' tilts, written by G1s (no arcs here)
    assert sum(len(o[5]) for o in ops) > 20
    assert not any(np.any(o[0] == gwrite.ARC) for o in ops)


def test_stops_resumed_in_place_write_the_references_text() -> None:
    """The twin resumes its own stops in the buffers it stopped in (``st.pend_*``
    left as views of them, neither copied out nor back): the writer, calling it
    on its own state from stop to stop as in a conversion, writes the same text
    as with the reference, and the resumed calls did go on in place."""
    from .test_tracking import convert, truth_machine

    _gwrite = compiled("_gwrite")
    in_place: list[bool] = []

    def stopping(st: gwrite.GState, *args: Any) -> Ops:
        before = st.pend_i.base if int(st.i[gwrite.I_NAMES.index("stop_at")]) >= 0 else None
        out: Ops = _gwrite.gcode_ops(st, *args)
        if before is not None:
            # a resumed call: stopped again in the same buffer, or ended
            stopped = int(st.i[gwrite.I_NAMES.index("stop_at")]) >= 0
            in_place.append(not stopped or st.pend_i.base is before)
        return out

    def twin(st: gwrite.GState, *args: Any) -> Ops:
        # the writer's call, which refits itself, made stop by stop on its state
        return _answering(stopping, st, args, [])

    texts = {}
    for name, fn in (("reference", gwrite.gcode_ops), ("twin", twin)):
        mp = pytest.MonkeyPatch()
        mp.setattr(kernel, "_gcode_ops", fn)
        try:
            texts[name] = [
                convert(m, text, "gcode", chunk)[2]
                for m in (truth_machine("nominal", None), truth_machine("random", 13))
                for text in arc_programs()
                for chunk in (0, 5)
            ]
        finally:
            mp.undo()
    assert texts["twin"] == texts["reference"]
    assert len(in_place) > 5 and all(in_place)


def test_calls_on_one_state_fill_its_scratch_again() -> None:
    """The twin's calls on one writer state fill the buffers the first call left
    in ``st.scratch`` again (no new ones: a fresh set costs zeroed huge pages),
    and the writer's text stays the reference's; a copy or a pickle of the state
    starts without them, so that two states never share buffers."""
    import pickle

    from .test_tracking import convert, truth_machine

    _gwrite = compiled("_gwrite")
    reused: list[bool] = []

    def twin(st: gwrite.GState, *args: Any) -> Ops:
        before = st.scratch.bufs
        out: Ops = _gwrite.gcode_ops(st, *args)
        assert st.scratch.bufs is not None
        if before is not None:
            reused.append(st.scratch.bufs is before)
        kept = copy.deepcopy(st)
        assert kept.scratch.bufs is None and _same_state(kept, st)
        assert pickle.loads(pickle.dumps(st)).scratch.bufs is None
        return out

    texts = {}
    for name, fn in (("reference", gwrite.gcode_ops), ("twin", twin)):
        mp = pytest.MonkeyPatch()
        mp.setattr(kernel, "_gcode_ops", fn)
        try:
            m = truth_machine("random", 13)
            texts[name] = [convert(m, text, "gcode", 5)[2] for text in arc_programs()]
        finally:
            mp.undo()
    assert texts["twin"] == texts["reference"]
    # a writer per program: its later calls in the buffers of its first
    assert len(reused) >= len(arc_programs()) and all(reused)
