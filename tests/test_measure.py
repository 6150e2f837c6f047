"""Measurement files: the contract's forms, round trips and located errors."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from prsxy_post import measure
from prsxy_post.errors import MeasurementError

from .conftest import DATA

EXAMPLES = {p.name: p.read_text() for p in (DATA / "spec").glob("*.csv")}


@pytest.mark.parametrize("name", sorted(EXAMPLES))
def test_spec_examples_read_and_round_trip(name: str) -> None:
    m = measure.read_measurement(EXAMPLES[name], name)
    fmt = {
        measure.PoseData: measure.format_poses,
        measure.BallbarRun: measure.format_ballbar,
        measure.AxisData: measure.format_axis,
    }[type(m)]
    again = measure.read_measurement(fmt(m), name)
    for field in ("commanded", "tip", "measured", "dev_um", "target"):
        if hasattr(m, field):
            np.testing.assert_allclose(getattr(again, field), getattr(m, field), atol=1e-6)


def test_poses_may_leave_the_axis_empty() -> None:
    text = "# kind: poses\nx,y,z,a,b,mx,my,mz,ma,mb\n1,2,3,0,0,1,2,3,,\n"
    p = measure.read_poses(text, "p.csv")
    assert np.isnan(p.axis).all() and p.tip.tolist() == [[1.0, 2.0, 3.0]]


BAD = [
    ("x,y\n1,2\n", "p.csv:1", "no '# kind:' line"),
    ("# kind: laser\nx\n1\n", "p.csv:1", "unknown kind"),
    ("# kind: poses\nx,y,z,a,b,mx,my,mz,ma\n1,2,3,4,5,6,7,8,9\n", "p.csv:2", "missing column 'mb'"),
    ("# kind: poses\nx,y,z,a,b,mx,my,mz,ma,mb\n1,2,3,4,5,6,7,x,9,9\n", "p.csv:3:8", "mz is 'x'"),
    ("# kind: poses\nx,y,z,a,b,mx,my,mz,ma,mb\n1,2,3,4,5,6,7,nan,9,9\n", "p.csv:3:8", "mz is nan"),
    ("# kind: poses\nx,y,z,a,b,mx,my,mz,ma,mb\n1,2,3,4,5,6,7,8,9,\n", "p.csv:3:9", "both be given"),
    ("# kind: poses\nx,y,z,a,b,mx,my,mz,ma,mb\n1,2,3\n", "p.csv:3", "row has 3 cells"),
    ("# kind: poses\nx,y,z,a,b,mx,my,mz,ma,mb\n", "p.csv:2", "0 data rows"),
    (
        "# kind: axis\nmotor,target,measured,direction,run\n4,0,0,1,1\n5,0,0,1,1\n",
        "p.csv:3:1",
        "motor is 4",
    ),
    (
        "# kind: axis\nmotor,target,measured,direction,run\n5,0,0,2,1\n5,0,0,1,1\n",
        "p.csv:3:4",
        "direction is 2",
    ),
    ("# kind: ballbar\n# length: 50\nt,x,y,z,a,b,dev_um\n", "p.csv:1", "no '# pivot:' line"),
    (
        "# kind: ballbar\n# pivot: 0,0,0\n# length: -5\nt,x,y,z,a,b,dev_um\n",
        "p.csv:3",
        "length is -5",
    ),
]


@pytest.mark.parametrize(("text", "where", "what"), BAD, ids=[b[2] for b in BAD])
def test_bad_files_name_file_and_row(text: str, where: str, what: str) -> None:
    with pytest.raises(MeasurementError) as exc:
        measure.read_measurement(text, "p.csv")
    assert str(exc.value).startswith(where), str(exc.value)
    assert what in str(exc.value)


def test_ballbar_time_must_increase_and_runs_be_long_enough() -> None:
    head = "# kind: ballbar\n# pivot: 0,0,0\n# length: 50\nt,x,y,z,a,b,dev_um\n"
    rows = [f"{k * 0.01:.2f},50,0,0,0,0,1" for k in range(20)]
    rows[7] = rows[6]
    with pytest.raises(MeasurementError, match="t does not increase"):
        measure.read_ballbar(head + "\n".join(rows), "b.csv")
    with pytest.raises(MeasurementError, match="at least 16 rows"):
        measure.read_ballbar(head + "\n".join(rows[:5]), "b.csv")


def test_wrong_kind_for_a_reader() -> None:
    with pytest.raises(MeasurementError, match="a poses file where a ballbar file"):
        measure.read_ballbar(EXAMPLES["poses.csv"], "poses.csv")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(sorted(EXAMPLES)), st.integers(0, 3000), st.text(max_size=6))
def test_mutated_files_never_crash(name: str, pos: int, junk: str) -> None:
    text = EXAMPLES[name][:4000]
    pos = min(pos, len(text))
    try:
        measure.read_measurement(text[:pos] + junk + text[pos + 1 :], name)
    except MeasurementError as exc:
        assert str(exc).startswith(name)


def test_commanded_with_round_trips_and_is_checked() -> None:
    """The optional provenance line: written, read back, and a mismatch refused at
    its line; files without it (the contract's form) pass unchecked."""
    cw = measure.CommandedWith.of("shop.toml", b"[machine]\n")
    assert cw.sha256 == hashlib.sha256(b"[machine]\n").hexdigest()
    plain = measure.read_measurement(EXAMPLES["poses.csv"], "poses.csv")
    assert plain.commanded_with is None
    text = measure.format_poses(
        measure.PoseData(
            "p.csv", plain.commanded, plain.tip, plain.axis, plain.rows, {}, commanded_with=cw
        )
    )
    assert text.splitlines()[1] == f"# commanded_with: shop.toml sha256:{cw.sha256}"
    again = measure.read_poses(text, "p.csv")
    assert again.commanded_with == cw and again.commanded_with.line == 2
    measure.check_commanded_with([plain, again], cw)  # both fine
    other = measure.CommandedWith.of("cal.toml", b"[machine]\nname = 'x'\n")
    with pytest.raises(MeasurementError) as exc:
        measure.check_commanded_with([plain, again], other)
    assert str(exc.value).startswith("p.csv:2: commanded_with: measured while")
    assert "shop.toml" in str(exc.value) and "cal.toml" in str(exc.value)
