"""Ballbar analysis recovers known terms from synthetic runs (closed form); every
run is named as RS274/NGC names it, in every plane, in every place it is shown."""

from __future__ import annotations

import numpy as np
import pytest

from prsxy_post import ballbar as bb
from prsxy_post import experiments, measure, plots, simulate
from prsxy_post.profile import Profile

from . import oracle
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


def test_servo_mismatch_keeps_its_meaning_in_the_xz_plane() -> None:
    """The same table errors and lag laid in X-Z (the second axis Z): the runs are
    named the other way round (θ = atan2(z, x) rising is G2 there, seen from +Y), and
    the pair finds the same lag of the first axis with the same sign."""
    runs = [
        run(100.0, ccw, np.random.default_rng(4), sq=1e-4, lag_ms=2.0, feed=2000.0)
        for ccw in (True, False)
    ]
    xz = [
        measure.BallbarRun(
            f"xz-{k}.csv",
            "xz r100",
            r.pivot,
            r.length,
            r.t,
            r.commanded[:, [0, 2, 1, 3, 4]],
            r.dev_um,
            r.rows,
            {},
        )
        for k, r in zip(("a", "b"), runs, strict=True)
    ]
    res_xy, (pair_xy,) = bb.analyse_runs(runs)
    res_xz, (pair_xz,) = bb.analyse_runs(xz)
    assert [r.direction for r in res_xy] == ["ccw", "cw"]
    assert [r.direction for r in res_xz] == ["cw", "ccw"]
    assert [r.plane for r in res_xz] == ["XZ", "XZ"]
    assert pair_xz.servo_mismatch_ms == pytest.approx(pair_xy.servo_mismatch_ms, rel=1e-9)
    assert pair_xz.servo_mismatch_ms == pytest.approx(2.0, rel=0.1)
    assert pair_xz.squareness_mm_per_m == pytest.approx(pair_xy.squareness_mm_per_m, rel=1e-9)


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
    png = plots.ballbar_plot(results, runs)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000


# ---------------------------------------------------------------- names of the runs
#
# RS274/NGC as LinuxCNC documents it (docs/src/gcode/g-code.adoc, "G2, G3 Arc Move"):
# "G2 (clockwise arc) or G3 (counterclockwise arc) ... The direction (CW, CCW) is
# as viewed from the positive end of the axis about which the circular motion
# occurs", that axis being Z for G17 (XY), Y for G18 (XZ) and X for G19 (YZ). So a
# run turns counter-clockwise when its angular momentum about the pivot points
# along the positive axis normal to its plane: sum over k of (p_k x p_k+1) . n > 0.


def rs274_direction(run: measure.BallbarRun) -> tuple[str, str]:
    """(plane, "ccw" | "cw") from the commanded samples alone: the plane's normal is
    the axis the tip does not move along; the sense is the sign of the angular
    momentum about the pivot along the positive end of that axis."""
    p = run.commanded[:, :3] - run.pivot
    normal = int(np.argmin(np.ptp(p, axis=0)))
    plane = {2: "XY", 1: "XZ", 0: "YZ"}[normal]
    n = np.eye(3)[normal]
    momentum = float(np.sum(np.cross(p[:-1], p[1:]) @ n))
    return plane, "ccw" if momentum > 0 else "cw"


def screen_turn(ax, line) -> float:
    """The signed area the line sweeps about the polar plot's centre on the page
    (display coordinates, y up): > 0 when it turns counter-clockwise as drawn."""
    pts = ax.transData.transform(np.column_stack([line.get_xdata(), line.get_ydata()]))
    q = pts - ax.transData.transform([[0.0, 0.0]])[0]
    return float(np.sum(q[:-1, 0] * q[1:, 1] - q[:-1, 1] * q[1:, 0]))


@pytest.fixture(scope="module")
def campaign(nominal: Profile) -> dict[str, measure.BallbarRun]:
    """simulate's ballbar files of one radius: XY, a 5° cone, XZ, YZ, each G3 and G2,
    read back from the text written."""
    files = experiments.measurement_files(
        nominal,
        nominal,
        np.random.default_rng(7),
        radii=(20.0,),
        tilts=(5.0,),
        planes=("XY", "XZ", "YZ"),
        n_poses=0,
        axis_runs=False,
    )
    return {name: measure.read_ballbar(text, name) for name, text in files.items()}


def test_every_plane_and_direction_is_named_as_rs274_turns_it(
    campaign: dict[str, measure.BallbarRun],
) -> None:
    """The file name, the analysis, its JSON and its text all give the direction the
    commanded samples turn (G3 ccw, G2 cw) in XY, XZ, YZ and for the cone, which is
    named a cone with its tilt; the feed shown is the F word the program ran at."""
    assert len(campaign) == 8
    runs = list(campaign.values())
    analysis = bb.analyse(runs)
    js = analysis.to_json()["runs"]
    seen = set()
    for k, (name, run) in enumerate(campaign.items()):
        plane, direction = rs274_direction(run)
        cone = abs(run.commanded[0, 4]) > 1.0 or abs(run.commanded[0, 3]) > 1.0
        seen.add((plane, cone, direction))
        res = analysis.results[k]
        assert name.endswith(f"-{direction}.csv"), (name, plane, direction)
        assert (res.plane, res.direction) == (plane, direction), name
        assert res.gcode == {"ccw": "G3", "cw": "G2"}[direction]
        assert res.viewed_from == {"XY": "+Z", "XZ": "+Y", "YZ": "+X"}[plane]
        assert (js[k]["direction"], js[k]["gcode"]) == (direction, res.gcode)
        assert js[k]["circle"] == res.circle
        line = analysis.lines()[k]
        assert f" {direction} (" in line and "F1000:" in line, line
        if cone:
            assert name.startswith("ballbar-cone-5-") and res.tilt_deg == pytest.approx(5, abs=1e-3)
            assert res.circle == "cone 5° r20" and "cone 5° r20" in line, line
        else:
            assert res.tilt_deg < bb.CONE_MIN_TILT and res.circle == f"{plane} r20", line
    # every plane both ways, and the cone both ways
    assert len(seen) == 8
    for p in analysis.pairs:
        assert p.circle in {"XY r20", "XZ r20", "YZ r20", "cone 5° r20"}
    assert len(analysis.pairs) == 4


def test_the_plots_turn_the_way_the_runs_went(campaign: dict[str, measure.BallbarRun]) -> None:
    """On the page each run's trace turns the way the commanded samples turn seen
    from the positive end of the plane's normal, and its legend says so: a G18 G3
    run is drawn counter-clockwise although atan2(z, x) falls along it."""
    pytest.importorskip("matplotlib", reason="plots need the optional matplotlib")
    runs = list(campaign.values())
    results, _ = bb.analyse_runs(runs)
    fig = plots.ballbar_figure(results, runs)
    by_label = {}
    for ax in fig.axes:
        for line in ax.get_lines():
            if line.get_label() in ("ccw (G3)", "cw (G2)"):
                by_label.setdefault(line.get_label(), []).append(screen_turn(ax, line))
    assert len(by_label["ccw (G3)"]) == 4 and len(by_label["cw (G2)"]) == 4
    assert all(t > 0 for t in by_label["ccw (G3)"]), by_label
    assert all(t < 0 for t in by_label["cw (G2)"]), by_label
    # and the panel of each circle is the circle the runs are: titles name it
    titles = sorted(ax.get_title().split(" F")[0] for ax in fig.axes)
    assert titles == ["XY r20", "XZ r20", "YZ r20", "cone 5° r20"], titles
    import matplotlib.pyplot as plt

    plt.close(fig)


def test_direction_read_from_the_samples_not_the_name(
    campaign: dict[str, measure.BallbarRun],
) -> None:
    """A file whose name says the opposite (a hand-named export) is still analysed by
    what its samples did."""
    name = next(n for n in campaign if n.startswith("ballbar-xz") and n.endswith("-ccw.csv"))
    run = campaign[name]
    lying = measure.BallbarRun(
        "xz-cw.csv",
        "xz r20 cw",
        run.pivot,
        run.length,
        run.t,
        run.commanded,
        run.dev_um,
        run.rows,
        {},
    )
    assert bb.analyse_run(lying).direction == rs274_direction(run)[1] == "ccw"


@pytest.mark.linuxcnc
@pytest.mark.parametrize("plane", ["XY", "XZ", "YZ"])
def test_simulates_programs_turn_in_linuxcnc_as_their_files_are_named(plane: str) -> None:
    """The program simulate runs for a file named ccw is, in LinuxCNC's interpreter,
    an arc of positive rotation in that plane: RS274/NGC's ARC_FEED (NIST RS274NGC
    3, canonical machining functions) "If rotation is positive, the arc is traversed
    counterclockwise as viewed from the positive end of the coordinate axis
    perpendicular to the currently selected plane"; cw, negative."""
    if oracle.RS274 is None:
        pytest.skip("rs274 not installed: apt-get install linuxcnc-uspace to run the oracle")
    for ccw in (True, False):
        ref = oracle.run(simulate.ballbar_gcode(20.0, plane=plane, ccw=ccw))
        assert ref.error is None, ref.error
        (arc,) = [m for m in ref.motions if m.kind == "arc"]
        assert arc.plane == {"XY": 17, "XZ": 18, "YZ": 19}[plane]
        assert arc.rotation == (1 if ccw else -1)


@pytest.mark.parametrize("feed", [750.0, 2400.0])
def test_the_feed_shown_is_the_commanded_one(nominal: Profile, feed: float) -> None:
    """At F750 and F2400 the run is shown at its F word: the start and the stop (the
    mean speed over the run is below it) do not pull it down."""
    run = experiments.ballbar_run(
        nominal, nominal, np.random.default_rng(3), radius=20.0, plane="XZ", feed=feed
    )
    mean = float(
        np.sum(np.linalg.norm(np.diff(run.commanded[:, :3], axis=0), axis=1))
        / (run.t[-1] - run.t[0])
        * 60
    )
    assert round(mean) < feed  # what was shown before
    res = bb.analyse_run(run)
    assert res.feed_mm_min == pytest.approx(feed, abs=0.5)
    assert f"F{feed:.0f}" in res.label


def test_spec_cone_is_a_cone_of_five_degrees() -> None:
    cone = measure.read_ballbar((DATA / "spec" / "ballbar-cone5-ccw.csv").read_text(), "c")
    res = bb.analyse_run(cone)
    assert res.circle == "cone 5° r100"
    assert res.direction == rs274_direction(cone)[1] == "ccw"
    # its rows advance 0.133316 mm every 10 ms: F800
    assert res.feed_mm_min == pytest.approx(800, abs=0.5) and "F800" in res.label
