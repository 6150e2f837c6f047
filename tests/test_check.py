"""check: what the machine cannot do, per line at its worst point, grouped by kind.

References: on the nominal machine motor 5 is the X of the workpiece and the
tilt of A alone is A (contract: D = (P5, P6, 0), tool axis (cos A sin B, −sin A,
cos A cos B)); a strut's shortfall is checked against the contract's reach
condition by lengthening the struts; and convert, which stops at the first
problem with its own message.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from prsxy_post import chain, check, kinematics
from prsxy_post import profile as profile_mod
from prsxy_post.convert import ConvertJob, convert_file
from prsxy_post.errors import GCodeError, LimitError, PrsxyError

from .conftest import ROOT

NOMINAL = ROOT / "profiles" / "prsxy-nominal.toml"


def test_worst_point_of_each_line_and_runs_of_lines(nominal: profile_mod.Profile) -> None:
    text = "\n".join(
        [
            "G21 G90 G1 F3000",
            "X304.8",  # 2: out to X304.8 (motor 5 = X on the nominal machine)
            "(a comment line makes no points)",
            "X310",  # 4: further out
            "X0",  # 5: starts at 310 and comes back
            "X-10",  # 6: fine
            "X-301.5",  # 7: out at the other end
            "X0",
            "M2",
        ]
    )
    rep = check.check_text(text, nominal, source="t.ngc")
    travel = [p for p in rep.problems if p.kind == "travel"]
    assert [(p.line, p.motor) for p in travel] == [(2, 5), (4, 5), (5, 5), (7, 5), (8, 5)]
    worst = {p.line: p.value for p in travel}
    assert worst[2] == pytest.approx(304.8, abs=1e-9)
    assert worst[4] == pytest.approx(310.0, abs=1e-9)
    assert worst[7] == pytest.approx(-301.5, abs=1e-9)
    assert 300.0 < worst[5] < 310.0  # its first point, on the way back in
    (g,) = rep.groups()
    assert (g.kind, g.motor, g.count) == ("travel", 5, 5)
    assert g.ranges == ((2, 5), (7, 8))  # the comment line does not cut a run
    assert (g.worst.line, g.worst.value) == (4, pytest.approx(310.0))
    text_g = g.describe(nominal, "t.ngc")
    assert text_g == (
        "t.ngc:2: motor 5 (X) commanded beyond its travel on 5 lines (2-5, 7-8), "
        "worst 310.0000 mm at line 4 (expected -300 to 300 mm (motors[5].min/max))"
    )
    assert not rep.ok and rep.stopped is None


def test_tilt_and_feed_figures(nominal: profile_mod.Profile) -> None:
    text = "G21 G90\nG1 X10 F40000\nG1 A35 F1000\nG1 A0\nG1 A10 B-33\nG1 A0 B0\nM2\n"
    rep = check.check_text(text, nominal)
    by = {(p.kind, p.line): p for p in rep.problems}
    assert by[("feed", 2)].value == 40000.0
    assert by[("tilt", 3)].value == pytest.approx(35.0, abs=1e-9)
    assert 30.0 < by[("tilt", 4)].value < 35.0  # on its way back from A35
    # from level to A10 B-33 the tilt grows to the end: arccos(cos 10° cos 33°)
    tilt = math.degrees(math.acos(math.cos(math.radians(10)) * math.cos(math.radians(33))))
    assert by[("tilt", 5)].value == pytest.approx(tilt, abs=1e-9)
    assert [g.kind for g in rep.groups()] == ["feed", "tilt"]


def _short_struts(strut: float) -> profile_mod.Profile:
    """The nominal machine with struts of ``strut`` mm (guides lowered so the
    platform still sits level at the origin): a tilt soon takes a ball joint out
    of reach."""
    text = NOMINAL.read_text()
    h = math.sqrt(strut**2 - 150.0**2)
    text = text.replace("strut_length = 400.0", f"strut_length = {strut!r}")
    text = re.sub(r"guide_height = [\d.]+", f"guide_height = {h!r}", text)
    return profile_mod.loads(text + "\n[limits]\nmax_tilt_deg = 60.0\n", "short.toml")


def test_reach_figure_is_how_much_longer_the_strut_must_be() -> None:
    prof = _short_struts(155.0)
    rep = check.check_text("G21 G1 F1000 A25\nG1 A0\nM2\n", prof)
    reach = [p for p in rep.problems if p.kind == "reach"]
    assert reach and reach[0].line == 1
    lack = max(p.value for p in reach)
    assert 0 < lack < 50
    # the contract's reach: P_i exists iff the strut is at least as long as the
    # ball joint is far from its guide line; the pose at the line's end is the
    # worst here (the tilt grows along the line)
    q = np.array([[0.0, 0.0, 0.0, 25.0, 0.0]])

    def reachable(extra: float) -> bool:
        doc = dict(prof.raw)
        doc["kinematics"] = dict(doc["kinematics"])
        doc["kinematics"]["legs"] = [
            dict(leg, strut_length=leg["strut_length"] + extra) for leg in doc["kinematics"]["legs"]
        ]
        p2 = profile_mod.profile_from_dict(doc)
        geo = chain.ik_geometry(p2, chain.Stages())
        return bool(kinematics.inverse(geo, q).reachable[0])

    assert not reachable(lack - 1e-4)
    assert reachable(lack + 1e-6)


def test_gcode_error_ends_the_check_after_the_problems_before_it(
    nominal: profile_mod.Profile,
) -> None:
    text = "G21 G90\nG1 X310 F3000\nG1 X0\nG1 X1 Q\nM2\n"
    rep = check.check_text(text, nominal, source="e.ngc")
    assert isinstance(rep.stopped, GCodeError)
    assert str(rep.stopped).startswith("e.ngc:4:")
    assert [p.line for p in rep.problems] == [2, 3]


def test_too_much_work_stops_the_check(nominal: profile_mod.Profile) -> None:
    prof = profile_mod.loads(NOMINAL.read_text() + "\n[limits]\nmax_points = 100\n", "p")
    rep = check.check_text("G21 G1 X100 F600\nM2\n", prof, source="w.ngc")
    assert isinstance(rep.stopped, LimitError) and "100 points" in str(rep.stopped)


def test_chunking_does_not_change_the_report(
    nominal: profile_mod.Profile, monkeypatch: pytest.MonkeyPatch
) -> None:
    body = [
        f"G1 X{(i % 7) * 60.0 - 50:.1f} A{(i % 5) * 9.0:.1f} F{(i % 3 + 1) * 12000}"
        for i in range(60)
    ]
    text = "G21 G90\n" + "\n".join(body) + "\nM2\n"
    whole = check.check_text(text, nominal)
    monkeypatch.setattr(check, "CHUNK", 3)
    parts = check.check_text(text, nominal)
    assert parts.problems == whole.problems and parts.points == whole.points
    assert [g.ranges for g in parts.groups()] == [g.ranges for g in whole.groups()]
    assert {p.kind for p in whole.problems} == {"feed", "tilt", "travel"}


def test_a_clean_program_is_ok(nominal: profile_mod.Profile) -> None:
    rep = check.check_file(ROOT / "samples" / "pocket.ngc", nominal)
    assert rep.ok and rep.problems == [] and rep.points > 1000 and rep.seconds > 1.0


# ---------------------------------------------------------------- check and convert agree


def _convert_error(tmp_path: Path, text: str) -> PrsxyError:
    prog = tmp_path / "p.ngc"
    prog.write_text(text)
    with pytest.raises(PrsxyError) as exc:
        convert_file(ConvertJob(str(prog), str(NOMINAL), "pmac", str(tmp_path / "p.pmc")))
    return exc.value


def _first_figure(text: str) -> tuple[int, float]:
    m = re.search(r":(\d+): motor \d \(\w\) commanded to (-?[\d.]+) mm", text)
    assert m, text
    return int(m.group(1)), float(m.group(2))


def test_check_and_convert_give_the_same_figure_for_a_long_move(
    tmp_path: Path, nominal: profile_mod.Profile
) -> None:
    """The issue's case: check said 300.7575 where convert said 304.8000."""
    text = "G20 G90\nG1 X12 F100\nM2\n"  # 304.8 mm, slowly: thousands of points
    conv = _convert_error(tmp_path, text)
    rep = check.check_text(text, nominal, source=str(tmp_path / "p.ngc"))
    first = rep.problems[0]
    assert _first_figure(str(conv)) == (first.line, round(first.value, 4)) == (2, 304.8)
    assert str(first.error(nominal, str(tmp_path / "p.ngc"))) == str(conv)


def test_check_and_convert_give_the_same_figure_for_a_rapid(
    tmp_path: Path, nominal: profile_mod.Profile
) -> None:
    text = "G20 G90\nG0 X12 Y1\nG1 X-12 F100\nM2\n"
    conv = _convert_error(tmp_path, text)
    rep = check.check_text(text, nominal)
    first = rep.problems[0]
    assert _first_figure(str(conv)) == (first.line, round(first.value, 4))
