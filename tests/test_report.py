"""The report pages: they lead with the conclusion (findings largest first, what to
do next, where the page is). That the modules drawing and writing them sit above
the analysis, in no import circle, is tests/test_layers.py's."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from prsxy_post import ballbar as bb
from prsxy_post import experiments, measure, report
from prsxy_post.diagnose import Data, Diagnosis, Effect
from prsxy_post.profile import Profile

# ---------------------------------------------------------------- the diagnose page


def _effect(name: str, chi2: float, estimate: float = 1e-3, period: float | None = None):
    return Effect(name, estimate, estimate / 100, "mm", period=period, chi2=chi2, p_value=1e-9)


def _diagnosis(effects: list[Effect], unexplained: list[dict] | None = None) -> Diagnosis:
    return Diagnosis(
        effects=effects,
        noise={"ballbar": 0.0005},
        rms_before_um=12.0,
        rms_after_um=0.6,
        per_run=[
            {
                "source": "r.csv",
                "kind": "ballbar",
                "name": "xy r50 ccw",
                "unit": "um",
                "rms_before": 12.0,
                "rms_after": 0.6,
                "max_before": 30.0,
                "max_after": 2.0,
            }
        ],
        regions=[],
        unexplained=unexplained or [],
        updated={},
        summary="",
    )


def _axis(motor: int, spacing: float) -> measure.AxisData:
    t = np.arange(0.0, 100.0 + spacing / 2, spacing)
    return measure.AxisData(
        "axis.csv", np.full(len(t), motor), t, t, np.ones(len(t)), np.ones(len(t)), t * 0, {}
    )


def _page(result: Diagnosis, nominal: Profile, axis=(), where=None) -> str:
    pytest.importorskip("matplotlib", reason="plots need the optional matplotlib")
    files = report.diagnose_report(result, Data([], [], list(axis), nominal), where)
    md = files["report.md"]
    assert isinstance(md, str)
    return md


def test_findings_come_largest_first_with_what_to_do_next(nominal: Profile, tmp_path: Path) -> None:
    effects = [
        _effect("kinematics.tool_length", 5.0),
        _effect("table.squareness", 500.0),
        _effect("cyclic[2]", 50.0, period=16.0),
    ]
    md = _page(_diagnosis(effects), nominal, where=tmp_path)
    # the conclusion first, then the next step, then where the page is
    heads = re.findall(r"^## (.*)$", md, re.M)
    assert heads[0] == "Conclusion", heads
    head = md.split("## Effects")[0]
    assert "3 effect(s) missing" in head and "12.000 µm to 0.600 µm" in head
    assert "What to do next: Calibrate" in head
    # no laser run: the 16 mm cyclic error needs targets at most 8 mm apart
    assert "motor 2 at most 8 mm apart (no laser run now)" in head
    assert str((tmp_path / "report.html").resolve()) in head
    # by chi2, in the list and in the table
    order = [e.sentence() for e in sorted(effects, key=lambda e: -e.chi2)]
    at = [head.index(s) for s in order]
    assert at == sorted(at), order
    rows = [ln for ln in md.split("## Effects")[1].splitlines() if ln.startswith("| ")][1:]
    names = [r.split(" | ")[2] for r in rows[:3]]
    assert names == ["table.squareness", "cyclic[2] @ 16 mm", "kinematics.tool_length"], names


def test_the_laser_spacing_asked_for_is_what_the_laser_runs_lack(nominal: Profile) -> None:
    effects = [_effect("cyclic[2]", 50.0, period=16.0)]
    md = _page(_diagnosis(effects), nominal, axis=[_axis(2, 20.0)])
    assert "motor 2 at most 8 mm apart (now 20 mm)" in md
    md = _page(_diagnosis(effects), nominal, axis=[_axis(2, 5.0)])
    assert "at most 8 mm" not in md and "What to do next: Calibrate" in md


def test_nothing_found_says_so_and_unexplained_says_measure_again(nominal: Profile) -> None:
    md = _page(_diagnosis([]), nominal)
    assert "What to do next: Nothing to do" in md
    left = {
        "kind": "ballbar",
        "unit": "um",
        "rms": 0.9,
        "noise": 0.5,
        "ratio": 1.8,
        "regions": [],
        "library_share": 0.1,
        "closest": [{"name": "cyclic[5]", "period_mm": 6.0, "share": 0.01}],
        "sentence": "Left unexplained: the ballbar residual ...",
    }
    md = _page(_diagnosis([], [left]), nominal, axis=[_axis(5, 20.0)])
    assert "What to do next: Re-measure: the ballbar data" in md
    assert "motor 5 at most 3 mm apart (now 20 mm)" in md
    assert md.index("What to do next") < md.index("Left unexplained: the ballbar")


def test_ballbar_page_is_a_table_and_asks_for_the_other_direction(nominal: Profile) -> None:
    pytest.importorskip("matplotlib", reason="plots need the optional matplotlib")
    run = experiments.ballbar_run(
        nominal, nominal, np.random.default_rng(1), radius=20.0, plane="YZ", ccw=False
    )
    files = report.ballbar_report(bb.analyse([run]), "somewhere")
    md = files["report.md"]
    assert isinstance(md, str)
    assert re.findall(r"^## (.*)$", md, re.M)[:3] == ["Conclusion", "Polar plots", "Runs"]
    assert "What to do next: Re-measure: 1 circle(s) ran one way only" in md
    row = next(ln for ln in md.splitlines() if ln.startswith(f"| {Path(run.source).name}"))
    assert "| YZ r20 | cw (G19 G2, from +X) | F1000 |" in row, row
    assert str(Path("somewhere").resolve() / "report.html") in md


# ---------------------------------------------------------------- plots


def test_the_bar_chart_draws_each_files_noise(nominal: Profile) -> None:
    """A black dash at each bar's noise, in the unit its bar is in (µm here)."""
    pytest.importorskip("matplotlib", reason="plots need the optional matplotlib")
    from prsxy_post import plots

    result = _diagnosis([])
    fig = plots.residuals_figure(result)
    (ax,) = fig.axes
    (noise,) = [c for c in ax.collections if c.get_label() == "noise"]
    (seg,) = noise.get_segments()
    assert seg[:, 0] == pytest.approx([0.5, 0.5])  # 0.0005 mm of ballbar noise, in µm
    assert "noise" in [t.get_text() for t in ax.get_legend().get_texts()]
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_a_residual_of_the_noise_size_spans_divisions() -> None:
    """The residual panel's scale makes a 0.5 µm structure in 0.5 µm noise span two
    divisions or more, where the measured panel's 10 µm/div would show a twentieth."""
    from prsxy_post import plots

    th = np.linspace(-np.pi, np.pi, 2000, endpoint=False)
    rng = np.random.default_rng(0)
    r = 0.5 * np.sin(7 * th) + rng.normal(0, 0.5, th.size)
    div = plots.residual_scale(plots.smooth(th, r), 0.5)
    assert 2 * 0.5 / div >= 2, div
    # and the samples' scatter stays inside the plot (±4.8 divisions)
    assert np.mean(np.abs(r) < 4.8 * div) > 0.99
