"""The compiled inverse kinematics against its numpy reference: the same bits.

Recorded inputs (every IK call the sample programs make, as the golden files are
converted) and generated ones (hypothesis: poses inside and outside the workspace,
tool lengths, the table's scale, squareness and straightness errors of issue 30's
``Machine``). The reference calls the C library's acos and atan2 (kernel/libm.py) and
numpy's sin and cos; the compiled kernel calls the C library's for all four, so numpy's
must be the C library's on the machine the tests run on: checked here too.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from prsxy_post import kinematics, profile
from prsxy_post.kernel import ik

from .conftest import ROOT, VECTORS
from .kernel_cases import compiled, record, record_many, same_bits

PROFILES = [ROOT / "profiles" / "prsxy-shop.toml", VECTORS / "perturbed.toml"]


def _arrays(path: Path) -> ik.IKArrays:
    prof = profile.loads(path.read_text(), path.name)
    geo = kinematics.Geometry.from_params(prof.kinematics, prof.origin, prof.table, prof.effects)
    return geo.ik_arrays


def test_sample_programs_ik_is_bit_identical(tmp_path: Path) -> None:
    _ik = compiled("_ik")
    # the points' IK runs with their velocity in one pass (motion_rows): its poses
    # are solved here too, as the IK alone
    rec = record_many(["_inverse_rows", "_motion_rows"], tmp_path)
    calls = rec["_inverse_rows"] + [(m, q, tz) for m, q, _, tz, _ in rec["_motion_rows"]]
    assert len(calls) > 20
    rows = 0
    for m, q, tz in calls:
        want = ik.inverse_rows(m, q, tz)
        got = _ik.inverse_rows(m, q, tz)
        assert same_bits(got, want), f"{len(q)} rows: compiled and reference differ"
        rows += len(q)
    assert rows > 10_000  # the samples' points, each solved several times


def same_cols(got: ik.PlatformCols, want: ik.PlatformCols) -> bool:
    """Every column of two platform solutions equal to the bit."""
    return all(same_bits(getattr(got, f), getattr(want, f)) for f in ik.PlatformCols._fields)


def test_sample_programs_platform_cols_are_bit_identical(tmp_path: Path) -> None:
    """Step 1 of the IK alone (the FK's warm start, IKResult.pose), as the sample
    programs call it."""
    _ik = compiled("_ik")
    calls = record("_platform_cols", tmp_path)
    assert len(calls) >= 3  # every G-code run's chunks
    for m, q, tz in calls:
        assert same_cols(_ik.platform_cols(m, q, tz), ik.platform_cols(m, q, tz))
    assert sum(len(q) for _, q, _ in calls) > 5_000


#: tilts to ±180°: beyond about 50° some poses have no solution (NaN rows)
POSE = st.tuples(
    st.floats(-150, 150),
    st.floats(-150, 150),
    st.floats(-80, 40),
    st.one_of(st.floats(-45, 45), st.floats(-180, 180)),
    st.one_of(st.floats(-45, 45), st.floats(-180, 180)),
)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(POSE, min_size=1, max_size=40),
    st.sampled_from(PROFILES),
    st.one_of(st.none(), st.floats(-30, 120)),
    st.floats(-1e-3, 1e-3),
    st.floats(-1e-3, 1e-3),
    st.one_of(st.none(), hnp.arrays(np.float64, 2, elements=st.floats(-0.05, 0.05))),
)
def test_generated_poses_are_bit_identical(
    poses: list[tuple[float, ...]],
    path: Path,
    tool: float | None,
    scale: float,
    square: float,
    straight: np.ndarray | None,
) -> None:
    _ik = compiled("_ik")
    m = _arrays(path)._replace(
        scale_x=scale, scale_y=-scale, squareness=square, straightness=straight
    )
    q = np.array(poses, dtype=float)
    tz = ik.tool_z(m, len(q), tool)
    assert same_bits(_ik.inverse_rows(m, q, tz), ik.inverse_rows(m, q, tz))
    assert same_cols(_ik.platform_cols(m, q, tz), ik.platform_cols(m, q, tz))


def test_unreachable_rows_are_nan_in_both() -> None:
    _ik = compiled("_ik")
    m = _arrays(PROFILES[0])
    q = np.array(
        [
            [0.0, 0.0, 0.0, 0.0, 0.0],
            [-49.2, -104.9, 31.4, -133.3, 52.7],
            [0, -22.4, -47.1, -56.4, -139.3],
        ]
    )
    tz = ik.tool_z(m, 3, None)
    got, want = _ik.inverse_rows(m, q, tz), ik.inverse_rows(m, q, tz)
    assert same_bits(got, want)
    assert same_cols(_ik.platform_cols(m, q, tz), ik.platform_cols(m, q, tz))
    assert np.isfinite(got[0]).all() and np.isnan(got[1:, :3]).any(axis=1).all()


def test_bowed_guides_run_the_reference() -> None:
    """The compiled IK hands a geometry with bowed guides to the reference (kernel
    module docstring): the same numbers, by construction."""
    _ik = compiled("_ik")
    m = _arrays(PROFILES[0])._replace(bow=np.array([0.01, -0.02, 0.005]))
    q = np.array([[10.0, -5.0, -20.0, 12.0, -7.0]])
    tz = ik.tool_z(m, 1, None)
    assert same_bits(_ik.inverse_rows(m, q, tz), ik.inverse_rows(m, q, tz))


@pytest.mark.parametrize(("name", "lo", "hi"), [("sin", -1.6, 1.6), ("cos", -1.6, 1.6)])
def test_numpy_trig_is_the_c_librarys_here(name: str, lo: float, hi: float) -> None:
    """The reference's np.sin and np.cos give what the C library's give on this
    machine (the compiled kernel calls those): were it not so, the two kernels
    would differ here, and the reference would have to call them through math."""
    x = np.random.default_rng(7).uniform(lo, hi, 200_000)
    want = np.fromiter(map(getattr(math, name), x.tolist()), float, x.size)
    assert same_bits(getattr(np, name)(x), want)


def test_geometry_solves_its_linear_algebra_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Issue 30: the SVD and pseudo-inverse of M were made on every IK call
    (0.2 ms each); now once per geometry."""
    prof = profile.loads(PROFILES[0].read_text(), "shop")
    geo = kinematics.Geometry.from_params(prof.kinematics, prof.origin)
    n_svd = 0
    svd = np.linalg.svd

    def counting(*a: object, **k: object) -> object:
        nonlocal n_svd
        n_svd += 1
        return svd(*a, **k)  # type: ignore[call-overload]

    monkeypatch.setattr(np.linalg, "svd", counting)
    q = np.array([[1.0, 2.0, -10.0, 5.0, -3.0]])
    first = kinematics.inverse(geo, q).P
    for _ in range(5):
        assert same_bits(kinematics.inverse(geo, q).P, first)
    kinematics.solve_platform(geo, q)
    assert n_svd == 1
    # a new geometry (another profile's, or the same rebuilt) solves its own
    geo2 = kinematics.Geometry.from_params(prof.kinematics, prof.origin + 1.0)
    kinematics.inverse(geo2, q)
    assert n_svd == 2


def test_read_only_poses_are_taken_as_the_reference_takes_them() -> None:
    """Poses in a read-only array (a broadcast row, a memory-mapped file) solve as
    the reference solves them, instead of failing in the compiled kernel only."""
    _ik = compiled("_ik")
    m = _arrays(PROFILES[0])
    q = np.broadcast_to(np.array([1.0, 2.0, -3.0, 4.0, 5.0]), (4, 5))
    tz = np.broadcast_to(np.array(m.tool[2]), (4,))
    assert not q.flags.writeable
    assert same_bits(_ik.inverse_rows(m, q, tz), ik.inverse_rows(m, q, tz))


def _old_derivative(
    m: ik.IKArrays, q: np.ndarray, dq: np.ndarray, tz: np.ndarray, P: np.ndarray, step: float
) -> np.ndarray:
    """The chain's IK difference as it was written before the kernel took it (the
    compiled IK over the stepped poses, then numpy's subtraction and division)."""
    return (_compiled_ik().inverse_rows(m, q + step * dq, tz) - P) / step


def _compiled_ik() -> ModuleType:
    return compiled("_ik")


def test_sample_programs_ik_differences_are_bit_identical(tmp_path: Path) -> None:
    """The IK's velocity, directional derivatives and Jacobians as the sample
    programs ask for them (the chain's points, the corners' velocities, the
    crossing windows' levers, the settling's shorts): compiled, reference, and the
    differences as the chain took them before (IK of the stepped poses, numpy's
    difference) all the same bits."""
    _ik = _compiled_ik()
    calls = record_many(["_motion_rows", "_derivative_rows", "_jacobian_rows"], tmp_path)
    assert len(calls["_motion_rows"]) >= 7  # every run's chunks
    rows = 0
    for m, q, qdot, tz, step in calls["_motion_rows"]:
        P, V = _ik.motion_rows(m, q, qdot, tz, step)
        P_ref, V_ref = ik.motion_rows(m, q, qdot, tz, step)
        assert same_bits(P, P_ref) and same_bits(V, V_ref)
        assert same_bits(P, _ik.inverse_rows(m, q, tz))
        moving = np.any(qdot != 0.0, axis=1)
        assert same_bits(V[moving], _old_derivative(m, q, qdot, tz, P, step)[moving])
        assert not V[~moving].any()
        rows += len(q)
    assert rows > 5_000
    # (the planner's directions, the samples' calls of derivative_rows once, go
    # through end_slopes now: test_sample_programs_end_slopes_are_bit_identical)
    assert calls["_jacobian_rows"]
    for m, q, dq, tz, P, step in calls["_derivative_rows"]:
        got = _ik.derivative_rows(m, q, dq, tz, P, step)
        assert same_bits(got, ik.derivative_rows(m, q, dq, tz, P, step))
        assert same_bits(got, _old_derivative(m, q, dq, tz, P, step))
    for m, q, tz, step, P in calls["_jacobian_rows"]:
        got = _ik.jacobian_rows(m, q, tz, step, P)
        assert same_bits(got, ik.jacobian_rows(m, q, tz, step, P))
        for j in range(5):
            e = np.zeros((len(q), 5))
            e[:, j] = 1.0
            base = _ik.inverse_rows(m, q, tz) if P is None else P
            assert same_bits(got[:, :, j], _old_derivative(m, q, e, tz, base, step))


#: velocities (directions): standing, any, in the table's plane alone, without
#: tilting, and so small that a step leaves the pose's bits as they are (the
#: compiled kernel takes the part of the IK a stepped pose shares with its pose
#: from the pose's: every case of it)
QDOT = st.one_of(
    st.just((0.0,) * 5),
    POSE,
    POSE.map(lambda p: (p[0], p[1], 0.0, 0.0, 0.0)),
    POSE.map(lambda p: (p[0], p[1], p[2], -0.0, 0.0)),
    POSE.map(lambda p: (p[0], 0.0, 0.0, p[3], 0.0)),
    POSE.map(lambda p: tuple(x * 1e-300 for x in p)),
)


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.tuples(POSE, QDOT), min_size=1, max_size=30),
    st.sampled_from(PROFILES),
    st.one_of(st.none(), st.floats(-30, 120)),
    st.sampled_from([1e-6, 1e-4, 0.5]),
    st.one_of(st.none(), hnp.arrays(np.float64, 2, elements=st.floats(-0.05, 0.05))),
    st.booleans(),
    st.sampled_from(["", "tilts", "tilts and height"]),
)
def test_generated_ik_differences_are_bit_identical(
    rows: list[tuple[tuple[float, ...], tuple[float, ...]]],
    path: Path,
    tool: float | None,
    step: float,
    straight: np.ndarray | None,
    given_P: bool,
    shared: str,
) -> None:
    """Poses inside and outside the workspace (NaN rows), standing rows (q̇ = 0) among
    moving ones, the table's straightness (its fixed-point steps); poses that keep
    their tilts, or tilts and height, from row to row (the compiled kernel keeps
    step 1 of the IK, or its tilts' part, from the row before then)."""
    _ik = _compiled_ik()
    m = _arrays(path)._replace(straightness=straight, squareness=1e-4)
    q = np.array([r[0] for r in rows], dtype=float)
    qdot = np.array([r[1] for r in rows], dtype=float)
    if shared:
        q[:, 3:] = q[0, 3:]
    if shared == "tilts and height":
        q[:, 2] = q[0, 2]
    tz = ik.tool_z(m, len(q), tool)
    assert same_bits(_ik.inverse_rows(m, q, tz), ik.inverse_rows(m, q, tz))
    P, V = _ik.motion_rows(m, q, qdot, tz, step)
    P_ref, V_ref = ik.motion_rows(m, q, qdot, tz, step)
    assert same_bits(P, P_ref) and same_bits(V, V_ref)
    D = _ik.derivative_rows(m, q, qdot, tz, P, step)
    assert same_bits(D, ik.derivative_rows(m, q, qdot, tz, P, step))
    moving = np.any(qdot != 0.0, axis=1)
    assert same_bits(V[moving], D[moving])
    Pj = P if given_P else None
    assert same_bits(_ik.jacobian_rows(m, q, tz, step, Pj), ik.jacobian_rows(m, q, tz, step, Pj))


def _slopes_as_before(
    m: ik.IKArrays,
    start: np.ndarray,
    end: np.ndarray,
    dq_in: np.ndarray,
    dq_out: np.ndarray,
    tz: np.ndarray,
    step: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The planner's directions as the chain made them before the kernel took them:
    the compiled IK of every start and end, then the compiled differences."""
    _ik = _compiled_ik()
    d_in = _ik.derivative_rows(m, start, dq_in, tz, _ik.inverse_rows(m, start, tz), step)
    d_out = -_ik.derivative_rows(m, end, -dq_out, tz, _ik.inverse_rows(m, end, tz), step)
    return d_in, d_out


def test_sample_programs_end_slopes_are_bit_identical(tmp_path: Path) -> None:
    """The planner's directions at the blocks' ends (chain.Planning._directions) as
    the sample programs ask for them: compiled, reference, and the IK and its
    differences taken row by row as before, all the same bits."""
    _ik = _compiled_ik()
    calls = record("_end_slopes", tmp_path)
    assert calls  # the perturbed profile's motors have play (the shop's have none)
    rows = 0
    shared = 0
    for m, start, end, dq_in, dq_out, tz, step in calls:
        got = _ik.end_slopes(m, start, end, dq_in, dq_out, tz, step)
        want = ik.end_slopes(m, start, end, dq_in, dq_out, tz, step)
        before = _slopes_as_before(m, start, end, dq_in, dq_out, tz, step)
        for g, w, b in zip(got, want, before, strict=True):
            assert same_bits(g, w) and same_bits(g, b)
        rows += len(start)
        shared += int(np.all(start[1:] == end[:-1], axis=1).sum())
    assert rows >= 10 and shared > rows // 2  # a path's junctions: their IK taken again


#: a block's tangent: any direction, or none along the tilts
TANGENT = st.one_of(POSE, POSE.map(lambda p: (p[0], p[1], p[2], 0.0, 0.0)))


@settings(max_examples=150, deadline=None)
@given(
    st.lists(st.tuples(POSE, POSE, TANGENT, TANGENT, st.booleans()), min_size=1, max_size=25),
    st.sampled_from(PROFILES),
    st.lists(st.sampled_from([0.0, -0.0, 12.5, 40.0]), min_size=25, max_size=25),
    st.sampled_from([1e-4, 1e-6, 0.5]),
    st.one_of(st.none(), hnp.arrays(np.float64, 2, elements=st.floats(-0.05, 0.05))),
)
def test_generated_end_slopes_are_bit_identical(
    blocks: list[tuple[tuple[float, ...], ...]],
    path: Path,
    tools: list[float],
    step: float,
    straight: np.ndarray | None,
) -> None:
    """Blocks that start where the block before ends (to the bit, the IK taken
    again) or elsewhere, with the same tool length or another (0.0 and −0.0: other
    bits, the same height), inside and outside the workspace (NaN rows), the
    table's straightness: compiled, reference and the row-by-row differences agree."""
    _ik = _compiled_ik()
    m = _arrays(path)._replace(straightness=straight, squareness=1e-4)
    start = np.array([b[0] for b in blocks], dtype=float)
    end = np.array([b[1] for b in blocks], dtype=float)
    joined = np.array([b[4] for b in blocks])
    joined[0] = False
    for j in np.flatnonzero(joined):
        start[j] = end[j - 1]
    dq_in = np.array([b[2] for b in blocks], dtype=float)
    dq_out = np.array([b[3] for b in blocks], dtype=float)
    tz = ik.tool_z(m, len(start), np.array(tools[: len(start)]))
    got = _ik.end_slopes(m, start, end, dq_in, dq_out, tz, step)
    want = ik.end_slopes(m, start, end, dq_in, dq_out, tz, step)
    before = _slopes_as_before(m, start, end, dq_in, dq_out, tz, step)
    for g, w, b in zip(got, want, before, strict=True):
        assert same_bits(g, w) and same_bits(g, b)


def test_ik_differences_with_bowed_guides_run_the_reference() -> None:
    _ik = _compiled_ik()
    m = _arrays(PROFILES[0])._replace(bow=np.array([0.01, -0.02, 0.005]))
    q = np.array([[10.0, -5.0, -20.0, 12.0, -7.0], [0.0, 1.0, -3.0, 2.0, 1.0]])
    qdot = np.array([[1.0, 2.0, 0.5, 0.1, -0.2], [0.0, 0.0, 0.0, 0.0, 0.0]])
    tz = ik.tool_z(m, 2, None)
    got, want = _ik.motion_rows(m, q, qdot, tz, 1e-6), ik.motion_rows(m, q, qdot, tz, 1e-6)
    assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])
    assert same_bits(
        _ik.derivative_rows(m, q, qdot, tz, got[0], 1e-4),
        ik.derivative_rows(m, q, qdot, tz, want[0], 1e-4),
    )
    assert same_bits(_ik.jacobian_rows(m, q, tz, 1e-4), ik.jacobian_rows(m, q, tz, 1e-4))
    for g, w in zip(
        _ik.end_slopes(m, q, q[::-1], qdot, qdot, tz, 1e-4),
        ik.end_slopes(m, q, q[::-1], qdot, qdot, tz, 1e-4),
        strict=True,
    ):
        assert same_bits(g, w)


def test_compiled_ik_differences_refuse_mismatched_rows() -> None:
    """The twins run without bounds checks: arrays of other lengths are refused."""
    _ik = _compiled_ik()
    m = _arrays(PROFILES[0])
    q = np.zeros((3, 5))
    tz = ik.tool_z(m, 3, None)
    with pytest.raises(ValueError, match="qdot"):
        _ik.motion_rows(m, q, np.zeros((2, 5)), tz, 1e-6)
    with pytest.raises(ValueError, match="tz"):
        _ik.motion_rows(m, q, q, tz[:2], 1e-6)
    with pytest.raises(ValueError, match="dq"):
        _ik.derivative_rows(m, q, q, tz, np.zeros((2, 5)), 1e-6)
    with pytest.raises(ValueError, match="P must be"):
        _ik.jacobian_rows(m, q, tz, 1e-4, np.zeros((3, 4)))
    with pytest.raises(ValueError, match="tz"):
        _ik.jacobian_rows(m, q, tz[:1], 1e-4)
    with pytest.raises(ValueError, match="dq_out"):
        _ik.end_slopes(m, q, q, q, np.zeros((2, 5)), tz, 1e-4)
    with pytest.raises(ValueError, match="tz"):
        _ik.end_slopes(m, q, q, q, q, tz[:2], 1e-4)
