"""What a model leaves: the test that says "left unexplained" (issue 32).

A data kind is flagged when a statistical test rejects "its residual is the
noise" at 99.9 % confidence, not when its RMS is a little above the noise: judged
here on ballbar residuals made of known parts (seeded white noise, a periodic
error, errors of table values within their standard errors), against the closed
forms of the tests (von Neumann's ratio of successive differences; the false
alarm rate is the confidence's complement).
"""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import profile as profile_mod
from prsxy_post.diagnose import leftover
from prsxy_post.diagnose.model import Data
from prsxy_post.measure import BallbarRun

from .synthetic import circle

NOISE_MM = 0.5e-3


def _data(nominal: profile_mod.Profile, residual_mm: list[np.ndarray]) -> Data:
    """Ballbar runs (50 mm circles, 10 ms samples) whose residual is given."""
    runs = []
    for k, r in enumerate(residual_mm):
        q, t = circle(50.0, 0.0, 1 if k % 2 else -1)
        n = len(r)
        runs.append(
            BallbarRun(f"r{k}.csv", f"r{k}", np.zeros(3), 50.0, t[:n], q[:n], r * 1e3, np.arange(n))
        )
    return Data([], runs, [], nominal)


def _runs(rng: np.random.Generator, n_runs: int = 8) -> list[np.ndarray]:
    return [rng.normal(0.0, NOISE_MM, 1800) for _ in range(n_runs)]


def _left(data: Data, resid: np.ndarray, **kw: object) -> list[dict]:
    _, segs = data.measured()
    return leftover.unexplained(
        data, resid, segs, {"ballbar": NOISE_MM}, np.full(len(resid), 1 / NOISE_MM), **kw
    )  # type: ignore[arg-type]


def test_noise_alone_is_flagged_at_the_stated_rate(nominal: profile_mod.Profile) -> None:
    """60 runs of pure noise: at 99.9 % confidence the expected number of false
    alarms is 0.06, so more than one (p < 0.002 by the binomial law) would say the
    test does not hold its confidence."""
    alarms = 0
    for seed in range(60):
        parts = _runs(np.random.default_rng(seed))
        alarms += bool(_left(_data(nominal, parts), np.concatenate(parts)))
    assert alarms <= 1


def test_a_small_periodic_error_is_found_and_the_test_is_stated(
    nominal: profile_mod.Profile,
) -> None:
    """A 0.15 µm periodic error (0.11 µm RMS: the residual is 1.02 times the noise,
    its smooth part a fifth of the noise) over 14 400 samples is beyond the noise:
    flagged, with the test, its statistic, degrees of freedom and confidence in the
    sentence and the JSON."""
    rng = np.random.default_rng(7)
    parts = []
    for r in _runs(rng):
        x = 50.0 * np.linspace(0, 2 * np.pi, len(r))  # path length [mm]
        parts.append(r + 0.15e-3 * np.sin(2 * np.pi * x / 7.3))
    resid = np.concatenate(parts)
    data = _data(nominal, parts)
    (u,) = _left(data, resid)
    assert u["kind"] == "ballbar" and u["ratio"] < 1.05
    assert u["test"] == "von Neumann ratio of successive samples"
    assert u["dof"] == [len(resid)] and u["confidence"] == 0.999 and u["p_value"] < 1e-3
    # the statistic is von Neumann's ratio, recomputed here
    dd = sum(float(np.sum(np.diff(p) ** 2)) for p in parts)
    assert u["statistic"] == pytest.approx(dd / float(resid @ resid))
    assert "not the noise at 99.9% confidence (von Neumann ratio" in u["sentence"]
    assert "14 400 degrees of freedom" in u["sentence"]
    # the same error in the noise alone (no error added) is not flagged
    assert not _left(data, np.concatenate(_runs(np.random.default_rng(7))))


def test_table_errors_within_their_standard_error_are_allowed_for(
    nominal: profile_mod.Profile,
) -> None:
    """The residual of a calibrated machine holds what the laser could not resolve:
    its tables' values are each off by up to their standard error (here 0.15 µm;
    hat functions of a table every 20 mm of the path). Those are not an effect left
    unexplained: with their signatures and standard errors given, nothing is
    flagged; without, the structure they make is (it is beyond white noise)."""
    rng = np.random.default_rng(3)
    parts = _runs(rng)
    n = sum(len(p) for p in parts)
    s = np.concatenate([50.0 * np.linspace(0, 2 * np.pi, len(p)) for p in parts])
    knots = np.arange(0.0, 340.0, 20.0)
    cols = {
        f"table[5]+{j}": np.interp(s, knots, np.eye(len(knots))[j])[:, None]
        for j in range(len(knots))
    }
    sd = dict.fromkeys(cols, 0.15e-3)
    c = rng.normal(0.0, 0.15e-3, len(knots))
    resid = np.concatenate(parts) + np.hstack(list(cols.values())) @ c
    data = _data(nominal, np.split(resid, np.cumsum([len(p) for p in parts])[:-1]))
    assert len(resid) == n
    assert _left(data, resid), "the table errors make structure the noise does not"
    assert _left(data, resid, table_errors=lambda: (cols, sd)) == []
