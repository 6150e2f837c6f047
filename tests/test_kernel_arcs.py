"""The compiled arc search (fit, find, refit) against its numpy reference: the same
bits.

Recorded inputs (every call while arcs, helices, helices that turn A and B and
arcs in G18 and G19 convert on the nominal machine and random 11 and 13, whole and
5 motions a chunk, and bench/bench.py's five-axis program on its calibrated
machine) and generated ones (hypothesis: runs of lines and arcs in any plane,
helices, with noise below, about and above the tolerance, written with 4 to 7
decimals; rates that dip, tables that move, A and B that stray, points that are
not free, block ends).
"""

from __future__ import annotations

import copy
import importlib.util
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
from prsxy_post.kernel import arcs

from .conftest import ROOT
from .kernel_cases import compiled, same_bits
from .test_linuxcnc_motion import arc_programs

Rows = tuple[np.ndarray, np.ndarray]


def _same_rows(got: Rows, want: Rows) -> bool:
    return (
        got[0].dtype == want[0].dtype == np.int64
        and np.array_equal(got[0], want[0])
        and same_bits(got[1], want[1])
    )


def _spying(
    attrs: list[str], where: Any = kernel
) -> tuple[dict[str, list[tuple[Any, ...]]], pytest.MonkeyPatch]:
    calls: dict[str, list[tuple[Any, ...]]] = {a: [] for a in attrs}
    mp = pytest.MonkeyPatch()
    for attr in attrs:
        inner: Callable[..., Any] = getattr(where, attr)

        def spy(*args: Any, _a: str = attr, _f: Callable[..., Any] = inner) -> Any:
            calls[_a].append(tuple(copy.deepcopy(x) for x in args))
            return _f(*args)

        mp.setattr(where, attr, spy)
    return calls, mp


def test_recorded_searches_are_bit_identical(tmp_path: Path) -> None:
    """Every find and refit the arc programs and the bench program make: the same
    rows from both, arcs found in every plane, refits where the G-code writer's
    kernel stops (it calls the arc kernel's refit_arcs itself, the twin's or, with
    PRSXY_KERNEL=pure, the reference's)."""
    _arcs = compiled("_arcs")
    from .test_tracking import convert, truth_machine

    calls, mp = _spying(["_find_arcs"])
    refit_calls, mp_refit = _spying(["refit_arcs"], kernel._RUN["gwrite"]._arcs)
    calls.update(_refit_arcs=refit_calls["refit_arcs"])
    spec = importlib.util.spec_from_file_location("prsxy_bench", ROOT / "bench" / "bench.py")
    assert spec is not None and spec.loader is not None
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    prog = tmp_path / "bench.ngc"
    prog.write_text(bench.generate(2000))
    prof = bench.bench_profile(tmp_path / "bench.toml")
    try:
        for m in (
            truth_machine("nominal", None),
            truth_machine("random", 11, play=False),
            truth_machine("random", 13),
        ):
            for text in arc_programs():
                for chunk in (0, 5):
                    convert(m, text, "gcode", chunk)
        convert_file(ConvertJob(str(prog), str(prof), "gcode", str(tmp_path / "out.ngc")))
    finally:
        mp.undo()
        mp_refit.undo()
    found = []
    for args in calls["_find_arcs"]:
        want = arcs.find_arcs(*args)
        assert _same_rows(_arcs.find_arcs(*args), want)
        found.append(want[0])
    rows = np.concatenate(found)
    assert len(rows) > 500 and set(rows[:, 2].tolist()) == {17, 18, 19}
    assert set(rows[:, 3].tolist()) == {0, 1}  # G2 and G3
    refits = 0
    for args in calls["_refit_arcs"]:
        want = arcs.refit_arcs(*args)
        assert _same_rows(_arcs.refit_arcs(*args), want)
        refits += len(want[0])
    assert len(calls["_refit_arcs"]) > 20 and refits > 20


@st.composite
def _points(draw: st.DrawFn) -> np.ndarray:
    rows: list[np.ndarray] = []
    p = np.array([draw(st.floats(-50.0, 50.0)) for _ in range(3)] + [0.0, 0.0])
    rows.append(p[None, :].copy())
    for _ in range(draw(st.integers(1, 4))):
        m = draw(st.integers(2, 40))
        if draw(st.booleans()):
            d = np.array([draw(st.floats(-0.3, 0.3)) for _ in range(3)] + [0.0, 0.0])
            seg = p + np.arange(1, m + 1)[:, None] * d
        else:
            iu, iv, iw = arcs.PLANES[draw(st.sampled_from([17, 18, 19]))]
            r = draw(st.floats(0.2, 30.0))
            step = draw(st.floats(-0.3, 0.3).filter(lambda x: abs(x) > 1e-3))
            ang0 = draw(st.floats(-math.pi, math.pi))
            dw = draw(st.sampled_from([0.0, 0.0, 0.01, -0.05]))
            c = p.copy()
            c[iu] -= r * math.cos(ang0)
            c[iv] -= r * math.sin(ang0)
            ang = ang0 + step * np.arange(1, m + 1)
            seg = np.repeat(p[None, :], m, axis=0)
            seg[:, iu] = c[iu] + r * np.cos(ang)
            seg[:, iv] = c[iv] + r * np.sin(ang)
            seg[:, iw] = p[iw] + dw * np.arange(1, m + 1)
        rows.append(seg)
        p = seg[-1]
    q = np.concatenate(rows)
    q = q[: draw(st.integers(3, len(q)))]
    noise = draw(st.sampled_from([0.0, 1e-6, 5e-5, 3e-4]))
    seed = draw(st.integers(0, 2**32 - 1))
    rng = np.random.default_rng(seed)
    q[:, :3] += rng.normal(0.0, noise, (len(q), 3)) if noise else 0.0
    # A and B: still, turning a little, or straying
    q[:, 3:] = draw(st.sampled_from([0.0, 1e-5, 1e-3])) * np.arange(len(q))[:, None]
    if draw(st.booleans()):
        q[:, 3:] += rng.normal(0.0, 2e-4, (len(q), 2))
    dec = draw(st.sampled_from([4, 5, 7]))
    return np.round(q, dec) + 0.0


@st.composite
def _search(draw: st.DrawFn) -> tuple[Any, ...]:
    q = draw(_points())
    n = len(q)
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    free = rng.random(n) > draw(st.sampled_from([0.0, 0.02, 0.2]))
    ends = ~free & (rng.random(n) > 0.5)
    rate = np.full(n, 10.0)
    if draw(st.booleans()):
        rate *= 1.0 + draw(st.sampled_from([1e-4, 2e-3, 0.3])) * rng.standard_normal(n)
    lead = np.zeros((n, 5))
    if draw(st.booleans()):
        lead += draw(st.sampled_from([1e-6, 1e-4])) * np.cumsum(rng.random((n, 5)), axis=0)
    tol = draw(st.sampled_from([1e-4, 2e-4, 1e-3]))
    tol_deg = draw(st.sampled_from([5e-5, 1e-3]))
    dec = draw(st.sampled_from([4, 5, 7]))
    span = draw(st.sampled_from([math.inf, 1e-4, 0.05]))
    return q, free, ends, rate, lead, tol, tol_deg, dec, 1e-3, span


@settings(max_examples=300, deadline=None)
@given(case=_search())
def test_generated_searches_are_bit_identical(case: tuple[Any, ...]) -> None:
    _arcs = compiled("_arcs")
    want = arcs.find_arcs(*case)
    assert _same_rows(_arcs.find_arcs(*case), want)
    q, free, _, _, _, tol, tol_deg, dec = case[:8]
    # what the search promises: arcs in order, each on free points, long enough
    for s, e, _p, _c in want[0].tolist():
        assert e - s >= arcs.MIN_POINTS and bool(np.all(free[s + 1 : e]))
    assert np.all(want[0][1:, 0] >= want[0][:-1, 1])
    # every arc refitted from its start and from a later point, and whole runs fitted
    for s, e, p, _c in want[0].tolist():
        for k in (s, (s + e) // 2):
            args = (q, p, k, e, tol, tol_deg, dec)
            assert _same_rows(_arcs.refit_arcs(*args), arcs.refit_arcs(*args))
    for plane in (17, 18, 19):
        for m in (3, len(q) // 2, len(q)):
            args2 = (q[:m], plane, tol, tol_deg, dec)
            assert same_bits(_arcs.fit_arc(*args2), arcs.fit_arc(*args2))


def test_a_fitted_arc_holds_its_points_within_the_tolerance() -> None:
    """A helix of R10 (noise 20 nm) fits in G17 only, both ways: its row names the
    center as written (within the rounding of its true one), the sweep's way and
    LinuxCNC's length."""
    _arcs = compiled("_arcs")
    ang = np.linspace(0.0, 1.0, 30)
    rng = np.random.default_rng(5)
    q = np.zeros((30, 5))
    q[:, 0], q[:, 1], q[:, 2] = 1.0 + 10 * np.cos(ang), 2.0 + 10 * np.sin(ang), -0.02 * ang
    q[:, :3] += rng.normal(0.0, 2e-5, (30, 3))
    q = np.round(q, 7)
    for mod in (arcs, _arcs):
        row = mod.fit_arc(q, 17, 1e-4, 1e-4, 7)
        assert row[0] == 1.0 and abs(row[1] - 1.0) < 1e-4 and abs(row[2] - 2.0) < 1e-4
        assert row[4] == pytest.approx(math.hypot(10.0, 0.02), rel=1e-4)
        assert row[5] <= 1e-4
        back = mod.fit_arc(q[::-1], 17, 1e-4, 1e-4, 7)
        assert back[0] == 0.0
        assert np.all(np.isnan(mod.fit_arc(q, 18, 1e-4, 1e-4, 7)))
        assert np.all(np.isnan(mod.fit_arc(q, 17, 1e-6, 1e-4, 7)))  # noise beyond


def test_compiled_search_refuses_wrong_shapes() -> None:
    _arcs = compiled("_arcs")
    q, b = np.zeros((6, 5)), np.ones(6, dtype=bool)
    with pytest.raises(ValueError, match=r"rate must have one value a point \(6, as q\), got 5"):
        _arcs.find_arcs(q, b, b, np.ones(5), np.zeros((6, 5)), 1e-4, 1e-4, 7, 1e-3, math.inf)
    with pytest.raises(ValueError, match=r"lead must have 5 values a point, got 4"):
        _arcs.find_arcs(q, b, b, np.ones(6), np.zeros((6, 4)), 1e-4, 1e-4, 7, 1e-3, math.inf)
    with pytest.raises(ValueError, match=r"q must have 5 values a point, got 3"):
        _arcs.fit_arc(np.zeros((6, 3)), 17, 1e-4, 1e-4, 7)
    with pytest.raises(ValueError, match=r"start and end must be points of q \(0 to 5\)"):
        _arcs.refit_arcs(q, 17, 0, 6, 1e-4, 1e-4, 7)
    with pytest.raises(ValueError, match=r"plane must be 17, 18 or 19, got 16"):
        _arcs.refit_arcs(q, 16, 0, 5, 1e-4, 1e-4, 7)
