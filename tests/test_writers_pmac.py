"""The Turbo PMAC writer (prsxy_post/writers/pmac.py), read back from its text.

With I42 = 0 Turbo PMAC keeps a PVT time as 12 integer and 12 fractional bits of a
ms (User Manual, "PVT-Mode Moves"): only whole 1/4096 ms run as written, and the
manual does not say whether a time between two is rounded or truncated.
"""

from __future__ import annotations

import re

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import given
from hypothesis import strategies as st

from prsxy_post.cli import main
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


@pytest.mark.parametrize("with_tables", [True, False])
def test_the_header_says_which_tables_compensate_the_real_axes(tmp_path, with_tables: bool) -> None:
    """With the real-axis tables stage the program carries the motors' errors, and
    the controller's own tables must be off (I51=0) or they would count twice;
    converted without it (``--no-axis-comp``), they must be on (I51=1) with the
    file ``tables export --format pmac`` writes (Software Reference, I51, DEFINE
    COMP, DEFINE BLCOMP)."""
    out = tmp_path / "p.pmc"
    args = ["convert", str(ROOT / "samples" / "drill.ngc"), "--profile"]
    args += [str(ROOT / "profiles" / "prsxy-shop.toml"), "-o", str(out)]
    result = CliRunner().invoke(main, args + ([] if with_tables else ["--no-axis-comp"]))
    assert result.exit_code == 0, result.output
    head = out.read_text().split("\nCLOSE\n")[0]
    if with_tables:
        assert "I51=0" in head and "Ixx86=0" in head and "I51=1" not in head
    else:
        assert "I51=1" in head and "axis-tables.pmc" in head and "do NOT carry" in head
        assert "I51=0" not in head and "Ixx86=0" not in head
