"""The compiled poses on lines and arcs against their numpy reference: the same bits.

Recorded inputs (every batch of points the sample programs place on their blocks,
and the blocks' end tangents, as the golden files are made) and generated ones
(hypothesis: lines, rotary-only moves, arcs and helices in G17, G18 and G19 with
changing radii and several turns, points before, on and past the ends). Both kernels
call the C library's cos and sin (kernel/libm.py); the reference's is checked
against numpy's here, which the planner used before the kernel.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from prsxy_post.kernel import libm, path

from .kernel_cases import compiled, record_many, same_bits

#: in-plane axes (u, v) of G17, G18, G19 (interpolate.geometry.PLANE_AXES)
PLANES = [(0, 1), (2, 0), (1, 2)]


def test_sample_programs_poses_are_bit_identical(tmp_path: Path) -> None:
    _path = compiled("_path")
    recorded = record_many(["_poses", "_velocities"], tmp_path)
    for args in recorded["_velocities"]:
        assert same_bits(_path.velocities(*args), path.velocities(*args))
    assert sum(int(np.count_nonzero(a[3])) for a in recorded["_velocities"]) > 20  # 38 corners
    calls = recorded["_poses"]
    assert len(calls) > 20
    points = on_arcs = 0
    for p, k, s in calls:
        want = path.poses(p, k, s)
        got = _path.poses(p, k, s)
        assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])
        points += len(k)
        on_arcs += int(np.count_nonzero(p.arc[k]))
    assert points > 10_000
    assert on_arcs > 1_000  # pocket.ngc's and five-axis.ngc's arcs


BLOCK = st.tuples(
    st.lists(st.floats(-500, 500), min_size=5, max_size=5),  # start
    st.lists(st.floats(-500, 500), min_size=5, max_size=5),  # end
    st.one_of(st.just(0.0), st.floats(1e-9, 2000.0)),  # L
    st.booleans(),  # arc
    st.floats(-math.pi, math.pi),  # theta0
    st.one_of(st.floats(-4 * math.pi, 4 * math.pi), st.sampled_from([2 * math.pi, -math.pi])),
    st.floats(0.0, 300.0),  # r0
    st.floats(0.0, 300.0),  # r1
    st.lists(st.floats(-500, 500), min_size=3, max_size=3),  # centre
    st.integers(0, 2),  # plane
)


def _arrays(rows: list[tuple[object, ...]]) -> path.PathArrays:
    cols = list(zip(*rows, strict=True))
    plane = np.array(cols[9])
    arc = np.array(cols[3], dtype=bool) & (np.array(cols[2]) > 0)  # arcs have a length
    return path.PathArrays(
        start=np.array(cols[0], dtype=float),
        end=np.array(cols[1], dtype=float),
        length=np.array(cols[2], dtype=float),
        arc=arc,
        theta0=np.array(cols[4], dtype=float),
        sweep=np.array(cols[5], dtype=float),
        r0=np.array(cols[6], dtype=float),
        r1=np.array(cols[7], dtype=float),
        center=np.array(cols[8], dtype=float),
        iu=np.array([PLANES[i][0] for i in plane]),
        iv=np.array([PLANES[i][1] for i in plane]),
    )


@settings(max_examples=300, deadline=None)
@given(
    st.lists(BLOCK, min_size=1, max_size=12),
    st.lists(st.one_of(st.floats(-0.1, 1.1), st.sampled_from([0.0, 1.0])), max_size=60),
)
def test_generated_poses_are_bit_identical(
    rows: list[tuple[object, ...]], shares: list[float]
) -> None:
    _path = compiled("_path")
    p = _arrays(rows)
    k = np.arange(len(shares), dtype=np.intp) % len(rows)
    s = np.array(shares, dtype=float) * p.length[k]
    want = path.poses(p, k, s)
    got = _path.poses(p, k, s)
    assert same_bits(got[0], want[0]) and same_bits(got[1], want[1])
    # the velocities at the points, every third a corner taken at speed
    v = np.abs(s) + 1.0
    corner = np.arange(len(k)) % 3 == 0
    dq_next = np.roll(p.end - p.start, 1, axis=0)
    args = (v, want[1], k, corner, p.end - p.start, dq_next)
    assert same_bits(_path.velocities(*args), path.velocities(*args))


def test_an_arc_ends_on_its_end_point_and_its_tangent_is_the_circles() -> None:
    """A quarter circle of radius 10 about the origin in G17 from (10, 0) to (0, 10),
    L = 5π: its end is the programmed end exactly, its middle on the circle, its
    tangents (0, 1) and (−1, 0), in both kernels."""
    _path = compiled("_path")
    end = np.array([[0.0, 10.0, 0.0, 0.0, 0.0]])
    p = path.PathArrays(
        start=np.array([[10.0, 0.0, 0.0, 0.0, 0.0]]),
        end=end,
        length=np.array([5 * math.pi]),
        arc=np.array([True]),
        theta0=np.zeros(1),
        sweep=np.array([math.pi / 2]),
        r0=np.array([10.0]),
        r1=np.array([10.0]),
        center=np.zeros((1, 3)),
        iu=np.array([0]),
        iv=np.array([1]),
    )
    s = np.array([0.0, 2.5 * math.pi, 5 * math.pi, 99.0])
    for kern in (path, _path):
        q, dq = kern.poses(p, np.zeros(4, dtype=np.intp), s)
        assert np.array_equal(q[2], end[0]) and np.array_equal(q[3], end[0])
        assert np.allclose(np.hypot(q[:, 0], q[:, 1]), 10.0, rtol=0, atol=1e-12)
        assert np.allclose(dq[0], [0, 1, 0, 0, 0], atol=1e-15)
        assert np.allclose(dq[2], [-1, 0, 0, 0, 0], atol=1e-15)


def test_the_c_librarys_trig_is_numpys_here() -> None:
    """The planner called numpy's cos and sin before the kernel: on this machine
    they are the C library's, so the outputs did not change by a bit."""
    x = np.random.default_rng(11).uniform(-30.0, 30.0, 100_000)
    assert same_bits(libm.cos(x), np.cos(x)) and same_bits(libm.sin(x), np.sin(x))
    special = np.array([np.inf, -np.inf, np.nan, 0.0, -0.0])
    assert same_bits(libm.sin(special), [np.nan, np.nan, np.nan, 0.0, -0.0])


def test_compiled_poses_refuse_bad_indices() -> None:
    _path = compiled("_path")
    p = path.PathArrays(
        *(np.zeros((1, 5)), np.ones((1, 5)), np.ones(1), np.zeros(1, bool)),
        *(np.zeros(1),) * 4,
        np.zeros((1, 3)),
        np.zeros(1, dtype=int),
        np.ones(1, dtype=int),
    )
    with pytest.raises(IndexError, match="out of range"):
        _path.poses(p, np.array([1]), np.zeros(1))
    with pytest.raises(ValueError, match="one row per point"):
        _path.poses(p, np.array([0]), np.zeros(2))


def test_the_blocks_arcs_reach_the_kernel_in_their_planes() -> None:
    """geometry.path_arrays gives the kernel each arc's in-plane axes as
    PLANE_AXES orders them (G17 XY, G18 ZX, G19 YZ); lines G17's."""
    from prsxy_post.interpolate.geometry import PLANE_AXES, Blocks, path_arrays

    plane = np.array([0, 17, 18, 19])
    b = Blocks(**{f: np.zeros(4) for f in Blocks.FIELDS})
    b.plane = plane
    b.kind = np.array([1, 2, 2, 2])
    p = path_arrays(b)
    assert p.iu.tolist() == [0] + [PLANE_AXES[int(pl)][0] for pl in plane[1:]]
    assert p.iv.tolist() == [1] + [PLANE_AXES[int(pl)][1] for pl in plane[1:]]
    assert p.arc.tolist() == [False, True, True, True]
