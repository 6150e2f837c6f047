"""Kinematics against the contract's vectors, an independent solver and round trips."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import optimize

from prsxy_post import kinematics as K
from prsxy_post import profile as profile_mod
from prsxy_post import simulate

from .conftest import VECTORS, read_vector_csv


def _geo(p: profile_mod.Profile) -> K.Geometry:
    return K.Geometry.from_params(p.kinematics, p.origin, p.table)


@pytest.mark.parametrize("name", ["nominal", "perturbed"])
def test_inverse_matches_contract_vectors(name: str) -> None:
    prof = profile_mod.loads((VECTORS / f"{name}.toml").read_text(), name)
    d = read_vector_csv(VECTORS / f"ik-{name}.csv")
    q = np.column_stack([d["x"], d["y"], d["z"], d["a"], d["b"]])
    r = K.inverse(_geo(prof), q)
    P = np.column_stack([d["p1"], d["p2"], d["p3"], d["p5"], d["p6"]])
    np.testing.assert_allclose(r.P, P, atol=1e-6, rtol=0)
    np.testing.assert_allclose(
        r.pose.c, np.column_stack([d["cx"], d["cy"], d["cz"]]), atol=1e-6, rtol=0
    )
    np.testing.assert_allclose(np.degrees(r.pose.gamma), d["gamma"], atol=1e-6, rtol=0)


def test_nominal_home_is_origin(nominal: profile_mod.Profile) -> None:
    """Contract: all motors at 0 put the platform level at M's origin, tip at W's origin."""
    geo = _geo(nominal)
    r = K.inverse(geo, np.zeros((1, 5)))
    np.testing.assert_allclose(r.P, 0.0, atol=1e-12)
    q, ok = K.forward(geo, np.zeros((1, 5)))
    assert ok.all()
    np.testing.assert_allclose(q, 0.0, atol=1e-12)


def _contract_ik_newton(geo: K.Geometry, q: np.ndarray) -> np.ndarray:
    """The contract's IK step 1 literally: Newton (fsolve) from c = 0, γ = 0, per point."""
    out = []
    for x, y, z, a, b in q:
        Rab = K.rot_y(np.radians(b)) @ K.rot_x(np.radians(a))

        def f(v: np.ndarray, Rab: np.ndarray = Rab, z: float = z) -> np.ndarray:
            c, g = v[:3], v[3]
            R = Rab @ K.rot_z(np.array(g))
            s = c + (R @ geo.b.T).T
            T = c + R @ geo.tool
            return np.concatenate(
                [np.einsum("ij,ij->i", s - geo.g, geo.u), [T[2] - geo.origin[2] - z]]
            )

        sol = optimize.root(f, np.zeros(4), method="lm", options={"xtol": 1e-14})
        assert np.max(np.abs(f(sol.x))) < 1e-10
        c, g = sol.x[:3], sol.x[3]
        R = Rab @ K.rot_z(np.array(g))
        s = c + (R @ geo.b.T).T
        v = s - geo.g
        dv = np.einsum("ij,ij->i", v, geo.d)
        p = dv + np.sqrt(dv**2 - np.einsum("ij,ij->i", v, v) + geo.L**2)
        T = c + R @ geo.tool
        D = geo.origin + np.array([x, y, z]) - T
        p6 = D[1] / (1 + geo.scale_y)
        p5 = (D[0] - geo.squareness * p6) / (1 + geo.scale_x)
        out.append([*p, p5, p6])
    return np.array(out)


def test_closed_form_equals_contract_newton(perturbed: profile_mod.Profile) -> None:
    rng = np.random.default_rng(1)
    q = np.column_stack(
        [rng.uniform(-150, 150, (30, 2)), rng.uniform(-60, 40, 30), rng.uniform(-25, 25, (30, 2))]
    )
    geo = _geo(perturbed)
    np.testing.assert_allclose(K.inverse(geo, q).P, _contract_ik_newton(geo, q), atol=1e-8)


def _fk_oracle(geo: K.Geometry, P: np.ndarray, guess: np.ndarray) -> np.ndarray:
    """Forward kinematics straight from the contract's six equations, by least squares."""

    def res(v: np.ndarray, p: np.ndarray) -> np.ndarray:
        c, A, B, g = v[:3], v[3], v[4], v[5]
        R = K.rot_y(np.array(B)) @ K.rot_x(np.array(A)) @ K.rot_z(np.array(g))
        s = c + (R @ geo.b.T).T
        a = geo.g + p[:3, None] * geo.d
        return np.concatenate(
            [np.einsum("ij,ij->i", s - geo.g, geo.u), np.linalg.norm(s - a, axis=1) - geo.L]
        )

    out = []
    for p, g0 in zip(P, guess, strict=True):
        sol = optimize.least_squares(res, g0, args=(p,), xtol=1e-15, ftol=1e-15, gtol=1e-15)
        c, A, B, g = sol.x[:3], sol.x[3], sol.x[4], sol.x[5]
        R = K.rot_y(np.array(B)) @ K.rot_x(np.array(A)) @ K.rot_z(np.array(g))
        T = c + R @ geo.tool
        D = K.table_displacement(geo, np.array([p[3]]), np.array([p[4]]))[0]
        w = T - geo.origin + D
        axis = R @ np.array([0.0, 0.0, 1.0])
        a_deg, b_deg = K.angles_from_axis(axis)
        out.append([*w, float(a_deg), float(b_deg)])
    return np.array(out)


def test_forward_matches_independent_solver(perturbed: profile_mod.Profile) -> None:
    rng = np.random.default_rng(2)
    q = np.column_stack(
        [rng.uniform(-150, 150, (20, 2)), rng.uniform(-60, 40, 20), rng.uniform(-25, 25, (20, 2))]
    )
    geo = _geo(perturbed)
    P = K.inverse(geo, q).P
    guess = np.zeros((20, 6))
    guess[:, 2] = P[:, :3].mean(axis=1)
    q_oracle = _fk_oracle(geo, P, guess)
    np.testing.assert_allclose(q_oracle, q, atol=1e-8)
    q_fk, ok = K.forward(geo, P)
    assert ok.all()
    np.testing.assert_allclose(q_fk, q, atol=1e-9)


def test_fk_start_is_the_ik_pose(perturbed: profile_mod.Profile) -> None:
    """The writer's FK start (:func:`fk_start`) is the platform of the IK's pose,
    bit for bit (platform_guess of solve_platform); Newton from it and from a
    start parallel to the table lands on the same tool poses (0.1 nm), so the start
    changes only how far Newton has to go."""
    rng = np.random.default_rng(5)
    q = np.column_stack(
        [rng.uniform(-150, 150, (50, 2)), rng.uniform(-60, 40, 50), rng.uniform(-25, 25, (50, 2))]
    )
    geo = _geo(perturbed)
    x0 = K.fk_start(geo, q)
    assert np.array_equal(x0, K.platform_guess(K.solve_platform(geo, q), q))
    P = K.inverse(geo, q).P + rng.normal(0.0, 1e-3, (50, 5))
    warm, ok_w = K.forward(geo, P, guess=x0)
    cold, ok_c = K.forward(geo, P)
    assert ok_w.all() and ok_c.all()
    np.testing.assert_allclose(warm, cold, atol=1e-10)


pose = st.tuples(
    st.floats(-200, 200),
    st.floats(-200, 200),
    st.floats(-80, 60),
    st.floats(-30, 30),
    st.floats(-30, 30),
)


@settings(max_examples=200, deadline=None)
@given(pose, st.integers(0, 2**32 - 1))
def test_ik_fk_round_trip_random_machines(qv: tuple[float, ...], seed: int) -> None:
    """FK(IK(q)) = q to 1 nm on machines with random errors in every contract term."""
    nominal = profile_mod.loads((VECTORS / "nominal.toml").read_text(), "nominal")
    truth = simulate.random_machine(nominal, np.random.default_rng(seed))
    geo = _geo(truth)
    q = np.array([qv])
    r = K.inverse(geo, q)
    assert r.reachable.all()
    q2, ok = K.forward(geo, r.P)
    assert ok.all()
    np.testing.assert_allclose(q2, q, atol=1e-9)


def test_unreachable_pose_is_flagged(nominal: profile_mod.Profile) -> None:
    """Struts of 152 mm span the 150 mm from guide to ball level, not a tilted platform."""
    import dataclasses

    geo = dataclasses.replace(_geo(nominal), L=np.full(3, 152.0))
    r = K.inverse(geo, np.array([[0, 0, 0, 0, 0], [0, 0, -50, 0, 20], [0, 0, 0, 0, -20]]))
    assert r.reachable.tolist() == [True, False, False]
    assert np.isnan(r.P[1]).any()


def test_tool_length_offset_moves_tip_along_spindle(nominal: profile_mod.Profile) -> None:
    """A 10 mm longer tool at B = 30° puts the platform 10 mm back along the tool axis."""
    geo = _geo(nominal)
    q = np.array([[5.0, -3.0, -20.0, 0.0, 30.0]])
    c0 = K.inverse(geo, q).pose.c
    c1 = K.inverse(geo, q, 10.0).pose.c
    axis = K.tool_axis(np.array([0.0]), np.array([30.0]))[0]
    # machine-frame shift of the platform relative to the tip: +10 mm along the axis,
    # the table takes up the x-y part
    P0, P1 = K.inverse(geo, q).P, K.inverse(geo, q, 10.0).P
    q1, _ = K.forward(geo, P1, 10.0)
    np.testing.assert_allclose(q1, q, atol=1e-9)
    assert np.isclose(c1[0, 2] - c0[0, 2], 10 * axis[2], atol=1e-9)
    assert not np.allclose(P0, P1)


@settings(max_examples=50, deadline=None)
@given(pose, st.integers(0, 2**32 - 1))
def test_round_trip_with_effects_beyond_the_contract(qv: tuple[float, ...], seed: int) -> None:
    """Bowed guides and curved table axes ([effects]) are modelled in IK and FK alike."""
    nominal = profile_mod.loads((VECTORS / "nominal.toml").read_text(), "nominal")
    truth = simulate.random_machine(nominal, np.random.default_rng(seed), effects=True)
    geo = K.Geometry.from_params(truth.kinematics, truth.origin, truth.table, truth.effects)
    assert geo.guide_bow is not None
    q = np.array([qv])
    r = K.inverse(geo, q)
    q2, ok = K.forward(geo, r.P)
    assert ok.all()
    np.testing.assert_allclose(q2, q, atol=1e-9)


def test_effects_move_the_tip(nominal: profile_mod.Profile) -> None:
    doc = dict(
        nominal.raw, effects={"guide_bow": [0.01, 0.0, 0.0], "table_straightness": [0.0, 0.0]}
    )
    bowed = profile_mod.profile_from_dict(doc)
    geo_b = K.Geometry.from_params(bowed.kinematics, bowed.origin, bowed.table, bowed.effects)
    q = np.array([[0.0, 0.0, -100.0, 0.0, 0.0]])
    P = K.inverse(geo_b, q).P
    q_plain, _ = K.forward(_geo(nominal), P)
    # 10 µm of bow at 100 mm moves the tip by a few µm
    assert 1e-3 < np.abs(q_plain - q)[0, :3].max() < 2e-2


@settings(max_examples=50, deadline=None)
@given(pose, st.integers(0, 2**32 - 1))
def test_fk_jacobian_is_the_equations_derivative(qv: tuple[float, ...], seed: int) -> None:
    """The closed-form Jacobian Newton's FK steps with equals central differences of
    the six FK equations (on a machine with bowed guides, where the hinge moves
    with the motor and not with the platform)."""
    nominal = profile_mod.loads((VECTORS / "nominal.toml").read_text(), "nominal")
    truth = simulate.random_machine(nominal, np.random.default_rng(seed), effects=True)
    geo = K.Geometry.from_params(truth.kinematics, truth.origin, truth.table, truth.effects)
    r = K.inverse(geo, np.array([qv]))
    # away from the solution too: the Jacobian must hold where Newton starts
    xv = np.column_stack([r.pose.c, np.radians(qv[3]), np.radians(qv[4]), r.pose.gamma])
    xv = xv + np.array([[0.3, -0.2, 0.5, 0.01, -0.02, 0.003]])
    _, J = K._fk_system(geo, r.P, xv)
    h = np.array([1e-5, 1e-5, 1e-5, 1e-7, 1e-7, 1e-7])
    J_fd = np.empty((1, 6, 6))
    for j in range(6):
        xp, xm = xv.copy(), xv.copy()
        xp[:, j] += h[j]
        xm[:, j] -= h[j]
        J_fd[:, :, j] = (K._fk_residual(geo, r.P, xp) - K._fk_residual(geo, r.P, xm)) / (2 * h[j])
    np.testing.assert_allclose(J, J_fd, rtol=0, atol=1e-6 * np.abs(J_fd).max())


def test_platform_rotation_is_the_contract_product() -> None:
    """R_y(B) R_x(A) R_z(γ) written out equals the product of the three matrices."""
    rng = np.random.default_rng(5)
    a, b, g = rng.uniform(-np.pi, np.pi, (3, 50))
    np.testing.assert_allclose(
        K.platform_rotation(a, b, g), K.rot_y(b) @ K.rot_x(a) @ K.rot_z(g), atol=1e-15
    )
