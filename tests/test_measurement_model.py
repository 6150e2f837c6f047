"""The shared measurement model: its Jacobians against re-solved forward kinematics,
and the layering that gives calibration and diagnosis one model without a circle."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from prsxy_post import effects, kinematics, measurement_model, simulate
from prsxy_post import profile as profile_mod

from .conftest import ROOT


def test_jacobians_match_the_forward_kinematics_solved_again(
    nominal: profile_mod.Profile,
) -> None:
    """∂y/∂θ and ∂y/∂P from the implicit-function theorem equal central differences
    of y with the forward kinematics solved again at θ ± h and P ± h (an independent
    route: no F_x⁻¹)."""
    names = ["kinematics.tool_length", "kinematics.legs[2].strut_length", "table.squareness"]
    theta = effects.theta_of(nominal, names)

    def make_geo(t: np.ndarray) -> kinematics.Geometry:
        return effects.geometry_at(nominal, names, t)

    q = np.array([[20.0, -30.0, -10.0, 8.0, -5.0], [-60.0, 40.0, 20.0, -12.0, 15.0]])
    P = simulate.pose_commands(nominal, q)
    steps = effects.fd_steps(names, theta)
    _, J, xv, JP = measurement_model.fk_with_jacobian(
        make_geo, theta, P, want_jac=True, steps=steps, motors=True
    )
    assert J is not None and JP is not None
    for j in range(len(names)):
        h = np.zeros_like(theta)
        h[j] = steps[j]
        yp = measurement_model.fk_with_jacobian(make_geo, theta + h, P, xv, False)[0]
        ym = measurement_model.fk_with_jacobian(make_geo, theta - h, P, xv, False)[0]
        np.testing.assert_allclose(J[:, :, j], (yp - ym) / (2 * steps[j]), rtol=1e-4, atol=1e-7)
    for m in range(5):
        dP = np.zeros_like(P)
        dP[:, m] = 1e-4
        yp = measurement_model.fk_with_jacobian(make_geo, theta, P + dP, xv, False)[0]
        ym = measurement_model.fk_with_jacobian(make_geo, theta, P - dP, xv, False)[0]
        np.testing.assert_allclose(JP[:, :, m], (yp - ym) / 2e-4, rtol=1e-4, atol=1e-7)


def _imported(path: Path) -> set[str]:
    """Every module name an import statement in ``path`` names, inside functions too."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            out.add(node.module or "")
            out.update(f"{node.module or ''}.{a.name}" for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
    return out


def test_diagnose_and_the_measurement_model_do_not_import_calibrate() -> None:
    """Calibration's physical stage runs diagnose's selection, so diagnose (and the
    measurement model under both) must not import calibrate back (issue 30)."""
    pkg = ROOT / "prsxy_post"
    for path in [*sorted((pkg / "diagnose").glob("*.py")), pkg / "measurement_model.py"]:
        names = _imported(path)
        assert not any(n.split(".")[-1] == "calibrate" for n in names), path
