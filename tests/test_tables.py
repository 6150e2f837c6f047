"""Laser tables, ISO 230-2 figures, and the LinuxCNC and Turbo PMAC table formats."""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import axiscomp, measure, tables
from prsxy_post import profile as profile_mod
from prsxy_post.errors import MeasurementError

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
    f = tables.iso230_2(
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
    got = tables.tables_from_axis(a.motor, a.target, a.measured, a.direction, a.run)
    truth = profile_mod.loads((VECTORS / "perturbed.toml").read_text(), "perturbed")
    mt = axiscomp.tables_by_motor(truth.axis_comp)
    for t in got:
        lo = mt[t.motor].lo(t.positions) - t.positions
        hi = mt[t.motor].hi(t.positions) - t.positions
        assert np.abs(lo - t.forward).max() < 0.6e-3
        assert np.abs(hi - t.reverse).max() < 0.6e-3


def _table() -> tables.AxisTable:
    p = np.linspace(-200, 200, 21)
    f = 0.003 * np.sin(p / 60) - 0.002
    return tables.AxisTable(5, p, f, f + 0.004)


@pytest.mark.parametrize("file_type", [0, 1])
def test_linuxcnc_round_trip(file_type: int) -> None:
    t = _table()
    back = tables.read_linuxcnc_comp(
        tables.format_linuxcnc_comp(t, file_type=file_type), "x.comp", file_type=file_type, motor=5
    )
    np.testing.assert_allclose(back.positions, t.positions)
    np.testing.assert_allclose(back.forward, t.forward, atol=2e-9)
    np.testing.assert_allclose(back.reverse, t.reverse, atol=2e-9)


def test_pmac_round_trip_to_the_count() -> None:
    """Exact to 1/16 count but at the end the rollover shares with zero."""
    t = _table()
    text = tables.format_pmac_comp(t, motor=5, counts_per_mm=10000.0)
    assert "DEFINE COMP 20,#5,#5,4000000" in text and "I586=" in text
    back = tables.read_pmac_comp(text, "x.pmc", counts_per_mm=10000.0)[0]
    inner = t.positions > -200
    for a, b in ((back.forward, t.forward), (back.reverse, t.reverse)):
        np.testing.assert_allclose(
            np.interp(t.positions[inner], back.positions, a), b[inner], atol=1 / 16 / 10000 + 1e-12
        )


def test_bad_table_files_are_located() -> None:
    with pytest.raises(MeasurementError, match=r"x.comp:3: nominal positions do not ascend"):
        tables.read_linuxcnc_comp("0 0 0\n1 1 1\n0.5 0 0\n", "x.comp", file_type=0, motor=5)
    with pytest.raises(MeasurementError, match=r"x.comp:2: 2 numbers"):
        tables.read_linuxcnc_comp("0 0 0\n1 1\n", "x.comp", file_type=1, motor=5)
    with pytest.raises(MeasurementError, match="no DEFINE COMP"):
        tables.read_pmac_comp("I586=3\n", "x.pmc", counts_per_mm=1000.0)
