"""Laser runs: the real-axis tables and the ISO 230-2 figures."""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import axiscomp, iso230_2, measure
from prsxy_post import profile as profile_mod
from prsxy_post.errors import MeasurementError
from prsxy_post.profile import AxisComp

from .conftest import DATA, VECTORS


def test_iso230_2_by_hand() -> None:
    """Two targets, three runs each way; the figures computed from the definitions."""
    up = {0.0: [0.001, 0.002, 0.003], 10.0: [0.004, 0.004, 0.007]}
    dn = {0.0: [-0.001, -0.002, 0.0], 10.0: [0.002, 0.001, 0.003]}
    rows = []
    for run in range(3):
        for t in (0.0, 10.0):
            rows.append((5, t, t + up[t][run], 1, run + 1))
            rows.append((5, t, t + dn[t][run], -1, run + 1))
    a = np.array(rows)
    f = iso230_2.iso230_2(
        a[:, 0].astype(int), a[:, 1], a[:, 2], a[:, 3].astype(int), a[:, 4].astype(int)
    )[5]
    mu = {t: np.mean(up[t]) for t in up}
    md = {t: np.mean(dn[t]) for t in dn}
    su = {t: np.std(up[t], ddof=1) for t in up}
    sd = {t: np.std(dn[t], ddof=1) for t in dn}
    b = {t: mu[t] - md[t] for t in up}
    assert f.reversal_B == pytest.approx(max(abs(v) for v in b.values()))
    assert f.systematic_E == pytest.approx(
        max(*mu.values(), *md.values()) - min(*mu.values(), *md.values())
    )
    assert f.repeatability_R == pytest.approx(
        max(max(2 * su[t] + 2 * sd[t] + abs(b[t]), 4 * su[t], 4 * sd[t]) for t in up)
    )
    assert f.accuracy_A == pytest.approx(
        max(max(mu[t] + 2 * su[t], md[t] + 2 * sd[t]) for t in up)
        - min(min(mu[t] - 2 * su[t], md[t] - 2 * sd[t]) for t in up)
    )


def test_tables_from_the_spec_example_match_the_machine() -> None:
    """The example laser runs were measured on perturbed.toml: its tables come back
    within the laser noise (0.3 µm, averaged over the runs)."""
    a = measure.read_axis((DATA / "spec" / "axis.csv").read_text(), "axis.csv")
    got = iso230_2.tables_from_axis(a.motor, a.target, a.measured, a.direction, a.run)
    truth = profile_mod.loads((VECTORS / "perturbed.toml").read_text(), "perturbed")
    mt = axiscomp.tables_by_motor(truth.axis_comp)
    for t in got:
        lo = mt[t.motor].lo(t.positions) - t.positions
        hi = mt[t.motor].hi(t.positions) - t.positions
        assert np.abs(lo - t.forward).max() < 0.6e-3
        assert np.abs(hi - t.reverse).max() < 0.6e-3


def test_tables_are_the_profiles_table_type() -> None:
    a = measure.read_axis((DATA / "spec" / "axis.csv").read_text(), "axis.csv")
    got = iso230_2.tables_from_axis(a.motor, a.target, a.measured, a.direction, a.run)
    assert got and all(isinstance(t, AxisComp) for t in got)


def test_too_few_runs_are_located() -> None:
    rows = np.array([(5, 0.0, 0.001, 1, 1), (5, 0.0, 0.0, -1, 1)])
    with pytest.raises(
        MeasurementError, match=r"motor 5: motor 5 at 0 mm has 1 \+ and 1 − approaches"
    ):
        iso230_2.tables_from_axis(
            rows[:, 0].astype(int),
            rows[:, 1],
            rows[:, 2],
            rows[:, 3].astype(int),
            rows[:, 4].astype(int),
        )
