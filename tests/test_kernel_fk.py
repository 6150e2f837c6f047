"""The compiled forward kinematics against its numpy reference: the same bits.

:func:`prsxy_post.kinematics.forward_platform` runs the FK's whole Newton iteration
in the kernel (``kernel/fk.py`` and its twin ``_fk.pyx``): the equations and their
Jacobian, the 6 × 6 solve written out, the steps and the residual check. Recorded
inputs (every FK the sample programs make while converting to G-code, as the
golden files are made), generated ones (hypothesis: any angles, centres, struts
and matrices, negative zero, tiny and huge values, NaN and infinities; poses of
random machines with motors moved off their IK), and whole forward solutions with
either kernel. The reference's solve is checked against LAPACK's (numpy's) for
accuracy.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import kernel, kinematics, profile, simulate
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.kernel import fk

from .conftest import ROOT, VECTORS
from .kernel_cases import RUNS, compiled, same_bits

PROFILES = [ROOT / "profiles" / "prsxy-shop.toml", VECTORS / "perturbed.toml"]
#: the kinematics' tolerances: a step below 1e-9 ends Newton, a residual below
#: 1e-9 mm is a solution
LIMIT, MAX_ITER, RES_TOL = 1e-9, 30, 1e-9


def _geometry(path: Path) -> kinematics.Geometry:
    prof = profile.loads(path.read_text(), path.name)
    return kinematics.Geometry.from_params(prof.kinematics, prof.origin, prof.table, prof.effects)


def _same(got: tuple[np.ndarray, ...], want: tuple[np.ndarray, ...]) -> bool:
    return len(got) == len(want) and all(
        a.shape == b.shape and same_bits(a, b) for a, b in zip(got, want, strict=True)
    )


@pytest.fixture(scope="module")
def recorded_calls(tmp_path_factory: pytest.TempPathFactory) -> list[tuple[Any, ...]]:
    """The arguments of every whole FK (:func:`kernel.forward_poses_anchored`: the
    anchors' Newton, the starts, Newton, then the tool poses of its solutions) while
    the sample programs convert to G-code (:data:`kernel_cases.RUNS`), in this
    process: (m, d, P, x0, t, origin, D, limit, max_iter, res_tol, every, phase,
    carry)."""
    calls: list[tuple[Any, ...]] = []
    mp = pytest.MonkeyPatch()
    inner: Callable[..., Any] = kernel.forward_poses_anchored

    def call(*args: Any) -> Any:
        calls.append(tuple(a.copy() if isinstance(a, np.ndarray) else a for a in args))
        return inner(*args)

    mp.setattr(kernel, "forward_poses_anchored", call)
    tmp = tmp_path_factory.mktemp("fk")
    try:
        for i, (sample, fmt, prof) in enumerate(RUNS):
            if fmt == "gcode":
                out = str(tmp / f"{i}.ngc")
                convert_file(ConvertJob(str(ROOT / "samples" / sample), str(ROOT / prof), fmt, out))
    finally:
        mp.undo()
    return calls


@pytest.fixture(scope="module")
def recorded(recorded_calls: list[tuple[Any, ...]]) -> list[tuple[Any, ...]]:
    """The Newton iterations of the recorded FKs: (m, off, x0, limit, max_iter,
    res_tol), the hinges' offsets as ``Geometry.hinge_offset`` makes them."""
    return [
        (m, P[:, :3, None] * d[None], x0, limit, max_iter, res_tol)
        for m, d, P, x0, _t, _o, _D, limit, max_iter, res_tol, *_ in recorded_calls
    ]


def test_sample_programs_fk_is_bit_identical(recorded: list[tuple[Any, ...]]) -> None:
    """Each recorded FK: the solution and its flags, and the equations, Jacobian
    and Newton step at the start, the same with either kernel."""
    _fk = compiled("_fk")
    assert len(recorded) >= 3  # every G-code run's chunks
    rows = 0
    for m, off, x0, limit, max_iter, res_tol in recorded:
        assert (limit, max_iter, res_tol) == (LIMIT, MAX_ITER, RES_TOL)
        want = fk.forward_newton(m, off, x0, limit, max_iter, res_tol)
        assert _same(_fk.forward_newton(m, off, x0, limit, max_iter, res_tol), want)
        assert np.all(want[1])  # every written point solved
        f, J = fk.fk_system(m, off, x0)
        assert _same(_fk.fk_system(m, off, x0), (f, J))
        assert _same((_fk.fk_residual(m, off, x0),), (f,))
        assert _same((_fk.solve6(J, -f),), (fk.solve6(J, -f),))
        rows += len(x0)
    assert rows > 5_000


def test_sample_programs_tool_poses_are_bit_identical(
    recorded_calls: list[tuple[Any, ...]],
) -> None:
    """Each recorded FK whole (the written G-code's points: Newton and the tool
    poses in one call), and the tool poses of its solutions on their own, the same
    with either kernel; the whole is the reference's parts one after the other."""
    _fk = compiled("_fk")
    assert len(recorded_calls) >= 3
    for m, d, P, x0, t, origin, D, limit, max_iter, res_tol, *_ in recorded_calls:
        want = fk.forward_poses(m, d, P, x0, t, origin, D, limit, max_iter, res_tol)
        got = _fk.forward_poses(m, d, P, x0, t, origin, D, limit, max_iter, res_tol)
        assert _same(got, want)
        x, ok = fk.forward_newton(m, P[:, :3, None] * d[None], x0, limit, max_iter, res_tol)
        assert _same((fk.tool_poses(x, ok, t, origin, D), ok), want)
        assert _same((_fk.tool_poses(x, ok, t, origin, D),), (want[0],))
    assert sum(len(c[2]) for c in recorded_calls) > 5_000


def test_sample_programs_anchored_fk_is_bit_identical(
    recorded_calls: list[tuple[Any, ...]],
) -> None:
    """Each recorded anchored FK (the written G-code's points: the anchors, the
    starts, Newton and the tool poses), its poses, flags and carried offset, the
    same with either kernel; its starts are the reference's anchored starts."""
    _fk = compiled("_fk")
    assert len(recorded_calls) >= 3
    phases = set()
    for call in recorded_calls:
        want = fk.forward_poses_anchored(*call)
        assert _same(_fk.forward_poses_anchored(*call), want)
        every, phase = call[10:12]
        assert every == kinematics.FK_ANCHOR_EVERY and np.all(want[1])
        phases.add(phase)
    assert len(phases) > 1  # chunks that start between anchors, with a carry


@settings(max_examples=150, deadline=None)
@given(
    st.integers(0, 1200),
    st.integers(1, 40),
    st.integers(0, 10**6),
    st.sampled_from(["zeros", "small", "nan"]),
    st.lists(st.integers(0, 1199), max_size=4),
    st.integers(0, 2**32 - 1),
)
def test_generated_anchored_fk_is_bit_identical(
    n: int, every: int, phase: int, carry_kind: str, lost: list[int], seed: int
) -> None:
    """Anchored FK over rows crossing the compiled twin's blocks (512 rows), any
    spacing and phase, a carried offset of zeros, of a few µm or NaN, and rows that
    do not converge (a motor far out of reach or NaN: an anchor among them gives no
    offset): poses, flags and carry the reference's bits."""
    _fk = compiled("_fk")
    geo = _geometry(PROFILES[1])
    rng = np.random.default_rng(seed)
    q = np.column_stack(
        [rng.uniform(-100, 100, (n, 2)), rng.uniform(-60, 0, n), rng.uniform(-30, 30, (n, 2))]
    )
    P = kinematics.inverse(geo, q).P + rng.normal(0, 1e-3, (n, 5))
    for i, k in enumerate(r for r in lost if r < n):
        P[k, i % 3] = (1e6, np.nan, -1e6)[i % 3]
    x0 = kinematics.fk_start(geo, q)
    t = np.broadcast_to(geo.tool, (n, 3)).copy()
    D = kinematics.table_displacement(geo, P[:, 3], P[:, 4])
    carry = {"zeros": np.zeros(6), "small": rng.normal(0, 1e-3, 6), "nan": np.full(6, np.nan)}
    args = (geo.fk_arrays, geo.d, P, x0, t, geo.origin, D, LIMIT, MAX_ITER, RES_TOL)
    with np.errstate(all="ignore"):  # the unreachable rows: numpy warns, C does not
        want = fk.forward_poses_anchored(*args, every, phase % every, carry[carry_kind])
        got = _fk.forward_poses_anchored(*args, every, phase % every, carry[carry_kind])
    assert _same(got, want)


VALUES = st.one_of(
    st.floats(-1e3, 1e3),
    st.sampled_from([0.0, -0.0, 5e-324, -1e-300, 1e300, np.inf, -np.inf, np.nan]),
)


def _rows(*shape: int) -> st.SearchStrategy[np.ndarray]:
    return hnp.arrays(np.float64, shape, elements=VALUES)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_generated_fk_arithmetic_is_bit_identical(data: st.DataObject) -> None:
    """Any values, NaN and infinities too: the equations, the Jacobian, the solve
    (singular and non-finite matrices included) and whole iterations."""
    _fk = compiled("_fk")
    n = data.draw(st.integers(0, 8))
    m = fk.FKArrays(
        g=data.draw(_rows(3, 3)),
        u=data.draw(_rows(3, 3)),
        b=data.draw(_rows(3, 3)),
        L=data.draw(_rows(3)),
    )
    # x as forward_platform may pass it: a view
    x = data.draw(_rows(n, 7))[:, 1:]
    off = data.draw(_rows(n, 3, 3))
    with np.errstate(all="ignore"):  # NaN and infinities: numpy warns, C does not
        assert _same(_fk.fk_system(m, off, x), fk.fk_system(m, off, x))
        assert _same((_fk.fk_residual(m, off, x),), (fk.fk_residual(m, off, x),))
        J = data.draw(
            st.one_of(
                _rows(n, 6, 6),
                # ties and zeros in the pivot columns, singular matrices
                hnp.arrays(
                    np.float64, (n, 6, 6), elements=st.sampled_from([0.0, -0.0, 1.0, -1.0, 2.0])
                ),
            )
        )
        r = data.draw(_rows(n, 6))
        assert _same((_fk.solve6(J, r),), (fk.solve6(J, r),))
        limit = data.draw(st.sampled_from([1e-9, 0.0, 1e3, np.inf]))
        it = data.draw(st.integers(0, 4))
        assert _same(
            _fk.forward_newton(m, off, x, limit, it, 1e-9),
            fk.forward_newton(m, off, x, limit, it, 1e-9),
        )
        # the whole FK: offsets from motors and guide directions, Newton, tool poses
        d, P = data.draw(_rows(3, 3)), data.draw(_rows(n, 5))
        t, origin, D = data.draw(_rows(n, 3)), data.draw(_rows(3)), data.draw(_rows(n, 3))
        assert _same(
            _fk.forward_poses(m, d, P, x, t, origin, D, limit, it, 1e-9),
            fk.forward_poses(m, d, P, x, t, origin, D, limit, it, 1e-9),
        )


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_generated_tool_poses_are_bit_identical(data: st.DataObject) -> None:
    """Any solutions, tool vectors, origins and table displacements, NaN and
    infinities too, rows solved or not: the same poses with either kernel."""
    _fk = compiled("_fk")
    n = data.draw(st.integers(0, 8))
    x = data.draw(_rows(n, 7))[:, 1:]  # a view, as forward_platform's solution may be
    ok = data.draw(hnp.arrays(np.bool_, (n,)))
    t, origin, D = data.draw(_rows(n, 3)), data.draw(_rows(3)), data.draw(_rows(n, 3))
    with np.errstate(all="ignore"):
        want = fk.tool_poses(x, ok, t, origin, D)
        assert _same((_fk.tool_poses(x, ok, t, origin, D),), (want,))
    assert np.all(np.isnan(want[~ok]))


@pytest.mark.parametrize("path", PROFILES, ids=lambda p: p.stem)
def test_tool_poses_sum_as_numpy_einsum(path: Path) -> None:
    """The tool poses' written-out sum of R t is numpy's ``einsum`` here, bit for
    bit (it was the einsum before it moved into the kernel: the G-code written and
    the simulator's poses did not change): tool vectors with all three components
    and tool lengths, on the rotations of random poses, signed zeros included."""
    geo = _geometry(path)
    rng = np.random.default_rng(11)
    n = 20_000
    x = np.column_stack([rng.uniform(-200, 200, (n, 3)), rng.uniform(-0.6, 0.6, (n, 3))])
    x[::97, 3:] = 0.0
    t = rng.uniform(-200, 200, (n, 3))
    t[::3] = np.broadcast_to(geo.tool, (n, 3))[::3] - rng.uniform(0, 100, (len(t[::3]), 1)) * [
        0,
        0,
        1,
    ]
    t[::5, :2] = [0.0, -0.0]
    D = rng.uniform(-1, 1, (n, 3))
    ok = rng.random(n) < 0.99
    R = kinematics.platform_rotation(x[:, 3], x[:, 4], x[:, 5])
    q = np.column_stack(
        [
            x[:, :3] + np.einsum("nij,nj->ni", R, t) - geo.origin + D,
            np.degrees(x[:, 3]),
            np.degrees(x[:, 4]),
        ]
    )
    q[~ok] = np.nan
    assert same_bits(fk.tool_poses(x, ok, t, geo.origin, D), q)


@settings(max_examples=100, deadline=None)
@given(
    st.integers(0, 2**32 - 1),
    st.integers(1, 20),
    st.sampled_from([0.0, 1e-6, 1e-3, 0.1, 5.0]),
    st.booleans(),
)
def test_generated_machines_fk_is_bit_identical(seed: int, n: int, moved: float, bow: bool) -> None:
    """Random machines (every contract term perturbed, bowed guides or straight),
    poses anywhere in the work space, motors moved off their IK by up to
    ``moved`` mm, warm-started at the IK's pose: the same solution and flags."""
    _fk = compiled("_fk")
    rng = np.random.default_rng(seed)
    nominal = profile.loads((VECTORS / "nominal.toml").read_text(), "nominal")
    truth = simulate.random_machine(nominal, rng, effects=bow)
    geo = kinematics.Geometry.from_params(
        truth.kinematics, truth.origin, truth.table, truth.effects
    )
    q = np.column_stack(
        [rng.uniform(-150, 150, (n, 2)), rng.uniform(-60, 40, n), rng.uniform(-30, 30, (n, 2))]
    )
    P = kinematics.inverse(geo, q).P + rng.uniform(-moved, moved, (n, 5))
    x0 = kinematics.platform_guess(kinematics.solve_platform(geo, q), q)
    off = geo.hinge_offset(P[:, :3])
    with np.errstate(all="ignore"):
        want = fk.forward_newton(geo.fk_arrays, off, x0, LIMIT, MAX_ITER, RES_TOL)
        got = _fk.forward_newton(geo.fk_arrays, off, x0, LIMIT, MAX_ITER, RES_TOL)
    assert _same(got, want)


def test_solve_matches_lapack() -> None:
    """The written-out elimination solves as LAPACK does (numpy.linalg.solve), to
    rounding, on well and badly conditioned matrices; a singular one gives a
    non-finite step, which the Newton iteration treats as a failed row."""
    rng = np.random.default_rng(3)
    J = rng.normal(size=(2000, 6, 6))
    J[:1000] += 6.0 * np.eye(6)  # well conditioned
    r = rng.normal(size=(2000, 6))
    s = fk.solve6(J, r)
    want = np.linalg.solve(J, r[..., None])[..., 0]
    cond = np.linalg.cond(J)
    err = np.max(np.abs(s - want), axis=1) / np.max(np.abs(want), axis=1)
    assert np.all(err <= 1e-14 * cond)
    assert np.allclose(np.einsum("nij,nj->ni", J, s), r, atol=1e-9 * np.max(cond))
    singular = J[:2].copy()
    singular[:, 5] = singular[:, 4]
    assert not np.all(np.isfinite(fk.solve6(singular, r[:2])))


@pytest.mark.parametrize("bow", [False, True], ids=["straight", "bowed"])
@pytest.mark.parametrize("path", PROFILES, ids=lambda p: p.stem)
def test_forward_kinematics_is_bit_identical_with_either_kernel(
    path: Path, bow: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Whole forward solutions (Newton from the nominal guess and warm-started, then
    the residual check) with the compiled kernel and with the reference; with
    straight guides and with bowed ones (``effects.guide_bow``)."""
    _fk = compiled("_fk")
    geo = _geometry(path)
    if bow:
        geo = dataclasses.replace(geo, guide_bow=np.array([0.004, -0.002, 0.003]))
    rng = np.random.default_rng(7)
    q = np.column_stack(
        [rng.uniform(-100, 100, (500, 2)), rng.uniform(-60, 0, 500), rng.uniform(-30, 30, (500, 2))]
    )
    P = kinematics.inverse(geo, q).P + rng.normal(0, 1e-3, (500, 5))
    guess = kinematics.platform_guess(kinematics.solve_platform(geo, q), q)
    results = {}
    for mod in (_fk, fk):
        monkeypatch.setattr(kernel, "_fk_mod", mod)
        results[mod] = (
            *kinematics.forward(geo, P),
            *kinematics.forward(geo, P, guess=guess),
            *kinematics._fk_system(geo, P, guess),
        )
    got, want = results[_fk], results[fk]
    assert np.all(want[1]) and np.all(want[3])  # every pose solved
    assert all(same_bits(a, b) for a, b in zip(got, want, strict=True))


@pytest.mark.parametrize("n", [511, 512, 513, 3 * 512 + 5])
def test_whole_fk_across_its_blocks_is_bit_identical(n: int) -> None:
    """The compiled whole FK solves its rows a block at a time (``BLOCK`` rows of
    scratch): chunks ending on, before and after a block's edge, with rows that do
    not converge (a motor far off its reach, a NaN) on either side of an edge, give
    the reference's bits, row for row."""
    _fk = compiled("_fk")
    geo = _geometry(PROFILES[0])
    rng = np.random.default_rng(11)
    q = np.column_stack(
        [rng.uniform(-100, 100, (n, 2)), rng.uniform(-60, 0, n), rng.uniform(-30, 30, (n, 2))]
    )
    P = kinematics.inverse(geo, q).P + rng.normal(0, 1e-3, (n, 5))
    P[[0, 510, n - 1], 0] = [1e6, np.nan, -1e6]
    x0 = kinematics.fk_start(geo, q)
    t = np.broadcast_to(geo.tool, (n, 3)).copy()
    D = kinematics.table_displacement(geo, P[:, 3], P[:, 4])
    args = (geo.fk_arrays, geo.d, P, x0, t, geo.origin, D, LIMIT, MAX_ITER, RES_TOL)
    with np.errstate(all="ignore"):  # the unreachable rows: numpy warns, C does not
        want = fk.forward_poses(*args)
    assert _same(_fk.forward_poses(*args), want)
    assert not want[1][[0, 510, n - 1]].any() and want[1][1:510].all()


def test_compiled_fk_refuses_wrong_shapes() -> None:
    """The twin runs without bounds checks: it checks its inputs' shapes first."""
    _fk = compiled("_fk")
    geo = _geometry(PROFILES[0])
    m = geo.fk_arrays
    x, off = np.zeros((4, 6)), np.zeros((4, 3, 3))
    with pytest.raises(ValueError):
        _fk.forward_newton(m, off[:3], x, LIMIT, MAX_ITER, RES_TOL)
    with pytest.raises(ValueError):
        _fk.fk_system(m, off, x[:, :5])
    with pytest.raises(ValueError):
        _fk.fk_residual(m._replace(L=np.ones(2)), off, x)
    with pytest.raises(ValueError):
        _fk.solve6(np.zeros((4, 6, 5)), x)
    with pytest.raises(ValueError):
        _fk.tool_poses(x, np.ones(4, bool), x[:, :3], x[0, :3], x[:3, :3])
    with pytest.raises(ValueError):
        _fk.forward_poses(m, geo.d, x[:3], x, x[:, :3], x[0, :3], x[:, :3], LIMIT, 30, RES_TOL)
    args = (m, geo.d, x, x, x[:, :3], x[0, :3], x[:, :3], LIMIT, 30, RES_TOL)
    with pytest.raises(ValueError):
        _fk.forward_poses_anchored(*args, 16, 0, np.zeros(5))
    with pytest.raises(ValueError):
        _fk.forward_poses_anchored(*args, 0, 0, np.zeros(6))
