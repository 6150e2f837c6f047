"""The Turbo PMAC writer (prsxy_post/writers/pmac.py), read back from its text.

With I42 = 0 Turbo PMAC keeps a PVT time as 12 integer and 12 fractional bits of a
ms (User Manual, "PVT-Mode Moves"): only whole 1/4096 ms run as written, and the
manual does not say whether a time between two is rounded or truncated.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from prsxy_post.writers.pmac import PVT_QUANTA_PER_MS, pvt_ms_text

from .conftest import ROOT
from .test_tracking import convert, read_pmac, truth_machine

SAMPLES = sorted((ROOT / "samples").glob("*.ngc"))
#: one PVT quantum [s]
QUANTUM_S = 1e-3 / PVT_QUANTA_PER_MS


@given(st.integers(0, 2**24 - 1))
def test_a_pvt_time_is_written_exactly(quanta: int) -> None:
    """The text is the time itself (no decimal rounding), with at least 4 decimals."""
    text = pvt_ms_text(quanta)
    assert float(text) * PVT_QUANTA_PER_MS == quanta
    assert len(text.split(".")[1]) >= 4


@pytest.mark.parametrize("path", SAMPLES, ids=lambda p: p.name)
def test_pvt_times_are_whole_quanta_never_shorter_than_planned(path) -> None:
    """Every PVT time of the written program is a whole 1/4096 ms, and the chain's
    segment time rounded up by less than one (a segment never runs faster than
    planned); dwells keep their time. On a machine with play, whose crossing
    windows make segments of a fraction of a ms."""
    truth = truth_machine("random", 12)
    _, res, texts = convert(truth, path.read_text())
    times = [float(m) for m in re.findall(r"^PVT(\d+\.\d+)$", texts[0], re.M)]
    assert times and all((ms * PVT_QUANTA_PER_MS).is_integer() for ms in times)
    _, dt, _ = read_pmac(texts[0])
    pts = res.points
    rows = ~(pts.dwell & (pts.dt == 0))
    rows[0] = True
    planned = pts.dt[rows]
    dwell = pts.dwell[rows]
    assert len(dt) == len(planned)
    moving = ~dwell
    moving[0] = False  # the RAPID start
    longer = dt[moving] - planned[moving]
    # shorter by at most the writer's 1e-6 of a quantum (for the rounding of dt)
    assert np.all(longer >= -1e-6 * QUANTUM_S), f"{-longer.min() * 1e9:.6f} ns shorter"
    assert np.all(longer < QUANTUM_S)
    assert np.min(planned[moving]) < 1e-3, "no segment under a ms: the windows were not met"
    np.testing.assert_allclose(dt[dwell], planned[dwell], atol=5e-8)  # 4 decimals of a ms
