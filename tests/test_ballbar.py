"""Ballbar analysis recovers known terms from synthetic runs (closed form)."""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import ballbar as bb
from prsxy_post import measure

from .conftest import DATA


def run(
    r: float,
    ccw: bool,
    rng: np.random.Generator,
    *,
    sx: float = 0.0,
    sy: float = 0.0,
    sq: float = 0.0,
    backlash: tuple[float, float] = (0.0, 0.0),
    lag_ms: float = 0.0,
    cyc: tuple[float, int] = (0.0, 0),
    noise: float = 0.3,
    feed: float = 1000.0,
    centre: tuple[float, float] = (0.0, 0.0),
) -> measure.BallbarRun:
    """A circle on an X-Y table with the contract's table errors, measured exactly."""
    omega = feed / 60.0 / r
    t = np.arange(0, 2 * np.pi / omega, 0.01)
    sgn = 1 if ccw else -1
    th = sgn * omega * t
    x, y = r * np.cos(th), r * np.sin(th)
    vx, vy = -sgn * np.sin(th), sgn * np.cos(th)
    # where the tip really is: table errors, backlash against the motion, a lag on X
    xa = x * (1 + sx) + sq * y - backlash[0] / 2000 * np.sign(vx) - lag_ms / 1000 * vx * r * omega
    ya = y * (1 + sy) - backlash[1] / 2000 * np.sign(vy)
    dev = (np.hypot(xa - centre[0] / 1000, ya - centre[1] / 1000) - r) * 1000
    dev += cyc[0] * np.sin(cyc[1] * th) + rng.normal(0, noise, len(t))
    q = np.column_stack([x, y, np.zeros((len(t), 3))])
    name = f"xy r{r:g} {'ccw' if ccw else 'cw'}"
    return measure.BallbarRun(name + ".csv", name, np.zeros(3), r, t, q, dev, np.arange(len(t)), {})


def test_squareness_and_scale_mismatch_are_recovered() -> None:
    rng = np.random.default_rng(1)
    res = bb.analyse_run(run(40.0, True, rng, sx=3.2e-4, sy=-3.2e-4, sq=1.349e-4))
    assert res.squareness_mm_per_m == pytest.approx(0.1349, abs=0.002)
    assert res.scale_mismatch_mm == pytest.approx(6.4e-4 * 40, abs=0.0005)
    assert res.plane == "XY" and res.direction == "ccw"


def test_clean_run_reports_nothing_beyond_noise() -> None:
    rng = np.random.default_rng(2)
    res = bb.analyse_run(run(50.0, False, rng, noise=0.5))
    assert res.direction == "cw"
    assert abs(res.squareness_mm_per_m) < 0.002
    assert abs(res.scale_mismatch_mm) < 0.0005
    assert max(abs(b) for b in res.backlash_um) < 0.3
    assert res.cyclic_um < 0.2
    assert res.residual_rms_um == pytest.approx(0.5, rel=0.1)


def test_backlash_centre_and_cyclic() -> None:
    rng = np.random.default_rng(3)
    res = bb.analyse_run(
        run(50.0, True, rng, backlash=(6.0, 3.0), cyc=(1.5, 12), centre=(20.0, -10.0))
    )
    assert res.backlash_um == pytest.approx((6.0, 3.0), abs=0.3)
    assert res.cyclic_order == 12 and res.cyclic_um == pytest.approx(1.5, abs=0.2)
    assert res.centre_offset_um == pytest.approx((-20.0, 10.0), abs=0.5)


def test_servo_mismatch_flips_with_direction_and_the_pair_separates_it() -> None:
    rng = np.random.default_rng(4)
    runs = [run(100.0, ccw, rng, sq=1e-4, lag_ms=2.0, feed=2000.0) for ccw in (True, False)]
    results, pairs = bb.analyse_runs(runs)
    assert results[0].squareness_mm_per_m != pytest.approx(results[1].squareness_mm_per_m, abs=0.01)
    (p,) = pairs
    assert p.squareness_mm_per_m == pytest.approx(0.1, abs=0.003)
    assert abs(p.servo_mismatch_ms) == pytest.approx(2.0, rel=0.1)


def test_spec_example_reads_the_perturbed_table() -> None:
    """The spec's example run was measured on perturbed.toml (squareness 0.13 mm/m)."""
    r = measure.read_ballbar((DATA / "spec" / "ballbar-xy-r50-ccw.csv").read_text(), "x")
    res = bb.analyse_run(r)
    assert res.squareness_mm_per_m == pytest.approx(0.13, abs=0.01)
    cone = measure.read_ballbar((DATA / "spec" / "ballbar-cone5-ccw.csv").read_text(), "c")
    assert bb.analyse_run(cone).plane == "XY"


def test_plot_is_a_png(tmp_path) -> None:
    pytest.importorskip("matplotlib", reason="plots need the optional matplotlib")
    rng = np.random.default_rng(5)
    runs = [run(50.0, ccw, rng, sq=1e-4) for ccw in (True, False)]
    results, _ = bb.analyse_runs(runs)
    png = bb.plot_runs(results, runs)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
