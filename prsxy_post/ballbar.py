"""Ballbar analysis: ISO 230-4 circular deviation and the classic diagnostics.

A run is read as the radial deviation Δr(θ) = dev_um along the angle θ of the
commanded tip about the pivot in the run's plane (X-Y: θ = atan2(y, x); X-Z:
atan2(z, x); Y-Z: atan2(z, y); cones are X-Y circles with a tilted spindle).

**Names** (``docs/data-formats.md``): the direction is RS274/NGC's, ``ccw`` the
way G3 turns and ``cw`` the way G2 turns in that plane, seen from the positive
end of the plane's normal (+Z, +Y, +X for G17, G18, G19). In X-Z that is the
opposite of θ's sense (X × Z = −Y): a G18 G3 run has θ falling. A run whose tool
axis is tilted from Z is a cone test, named with its tilt; the feed is the
commanded one, the speed the commanded samples hold for most of the run.

The small-error model fitted by linear least squares, for a circle of radius r:

    Δr(θ) = c0                                     mean radius error
          + c1 cos θ + s1 sin θ                    centre offset (set-up)
          + c2 cos 2θ + s2 sin 2θ                  scale mismatch, squareness (+ servo)
          − (b_1/2) sgn(v_1) cos θ − (b_2/2) sgn(v_2) sin θ      backlash of each axis
          + k_1 r² cos²θ sin θ + k_2 r² sin²θ cos θ              straightness of each axis

Derivation for the X-Y table of the contract (D = (P5(1+s_x) + σ P6, P6(1+s_y))):
the tip ends at (x(1+s_x) + σ y, y(1+s_y)), so

    Δr = r [ (s_x + s_y)/2 + (s_x − s_y)/2 · cos 2θ + (σ/2) · sin 2θ ]

hence **squareness** σ = 2 s2 / r (reported ×1000 in mm/m, sign as the profile's
``table.squareness``: positive when the Y motion leans towards +X) and **scale
mismatch** (s_x − s_y)·r = 2 c2 (reported in mm at the test radius, as a ballbar
report gives it). A servo lag τ_1 on the first axis adds (τ_1 r ω / 2) sin 2θ with
the sign of θ's sense; the pair (ccw, cw) separates it from squareness:
**servo mismatch** Δτ = o (s2_ccw − s2_cw) / (r ω) with ω = v / r, in ms, o the
plane's :data:`ORIENTATION` (−1 in X-Z, where the ccw run has θ falling).

**Circular deviation** G (ISO 230-4): the radial range of the path about its
least-squares centre, max Δr − min Δr after removing c1, s1. **Circular
hysteresis** H of a pair: the largest radial difference between the two
directions at the same angle. **Cyclic error**: the largest harmonic of order ≥ 3
left after the model. **Reversal spikes**: the largest residual within 3° of an
axis reversal beyond the run's residual scatter.

**Significance.** Each diagnostic figure carries its standard error from the fit
(σ̂² (XᵀX)⁻¹, σ̂ the scatter the whole model leaves) and is *reported* only when it
stands above the noise: its p-value (two-sided; the cyclic term's from the χ²
with two degrees of freedom of its sine and cosine, over the 58 orders searched)
times the number of figures is below :data:`ALPHA` (Bonferroni). Pure noise
then reports nothing, where the largest of 58 harmonics of noise alone is always
a few tenths of a µm.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from .errors import MeasurementError
from .measure import BallbarRun

PLANES = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}
#: RS274/NGC (LinuxCNC's G2/G3): "the direction (CW, CCW) is as viewed from the
#: positive end of the axis about which the circular motion occurs", the axis
#: normal to the plane G17, G18 or G19 selects.
VIEWED_FROM = {"XY": "+Z", "XZ": "+Y", "YZ": "+X"}
PLANE_CODE = {"XY": "G17", "XZ": "G18", "YZ": "G19"}
GCODE = {"ccw": "G3", "cw": "G2"}
#: (e_first × e_second) · n of each plane's axes in :data:`PLANES` order: +1 when θ
#: growing is counter-clockwise seen from :data:`VIEWED_FROM` (X-Z: X × Z = −Y).
ORIENTATION = {"XY": 1, "XZ": -1, "YZ": 1}
#: A run whose tool axis is tilted more than this from Z [deg] is a cone test.
CONE_MIN_TILT = 0.01
TERMS = ("c0", "c1", "s1", "c2", "s2", "backlash_1", "backlash_2", "straight_1", "straight_2")
#: Significance level of a reported figure (Bonferroni over the figures of a run).
ALPHA = 1e-3
#: Harmonic orders searched for a cyclic error.
CYCLIC_ORDERS = range(3, 61)
#: The diagnostic figures that are tested (set-up terms, radius and centre, are not).
FIGURES = (
    "squareness",
    "scale_mismatch",
    "backlash_x",
    "backlash_y",
    "straightness_x",
    "straightness_y",
    "cyclic",
)


@dataclass(frozen=True)
class Figure:
    """A diagnostic figure with its standard error and significance.

    value, stderr : in the figure's unit (mm/m, mm, µm, ms); z : |value| / stderr
    (for the cyclic term the square root of its χ²); p_value : after the
    Bonferroni correction; significant : p_value < :data:`ALPHA`.
    """

    value: float
    stderr: float
    z: float
    p_value: float
    significant: bool


def _figure(value: float, stderr: float, tests: int, chi2_2dof: float | None = None) -> Figure:
    from scipy import stats

    if chi2_2dof is not None:
        p = float(stats.chi2.sf(chi2_2dof, 2))
        z = math.sqrt(max(chi2_2dof, 0.0))
    else:
        z = abs(value) / stderr if stderr > 0 else math.inf
        p = float(2 * stats.norm.sf(z))
    p = min(1.0, p * tests)
    return Figure(float(value), float(stderr), float(z), p, p < ALPHA)


@dataclass(frozen=True)
class BallbarResult:
    """One run's figures (µm unless named otherwise)."""

    name: str
    source: str
    plane: str
    direction: str
    radius: float
    feed_mm_min: float
    circular_deviation_um: float
    centre_offset_um: tuple[float, float]
    mean_radius_error_um: float
    squareness_mm_per_m: float
    scale_mismatch_mm: float
    backlash_um: tuple[float, float]
    straightness_um: tuple[float, float]
    cyclic_um: float
    cyclic_order: int
    reversal_spike_um: float
    residual_rms_um: float
    terms: dict[str, float]
    noise_um: float = 0.0
    figures: dict[str, Figure] = field(default_factory=dict)
    #: the tool axis' tilt from Z [deg]; a cone test when above CONE_MIN_TILT
    tilt_deg: float = 0.0
    #: the G-code that runs this direction in this plane (G3 ccw, G2 cw)
    gcode: str = ""
    #: where the direction is seen from (:data:`VIEWED_FROM`)
    viewed_from: str = ""

    def reported(self) -> dict[str, Figure]:
        """The figures that stand above the noise."""
        return {k: f for k, f in self.figures.items() if f.significant}

    @property
    def circle(self) -> str:
        """The circle by what it is: ``XZ r50``, or ``cone 15° r100`` for a tilted XY run."""
        return circle_label(self.plane, self.radius, self.tilt_deg)

    @property
    def label(self) -> str:
        """Circle, direction as RS274 names it, and the commanded feed:
        ``XZ r50 ccw (G18 G3, seen from +Y) F1000``."""
        return (
            f"{self.circle} {self.direction} ({PLANE_CODE[self.plane]} {self.gcode}, seen from "
            f"{self.viewed_from}) F{self.feed_mm_min:.0f}"
        )


def circle_label(plane: str, radius: float, tilt: float) -> str:
    """``XY r50``, ``XZ r50``, or ``cone 15° r100`` (an XY circle with the tool tilted)."""
    if plane == "XY" and tilt > CONE_MIN_TILT:
        return f"cone {tilt:.3g}° r{radius:g}"
    return f"{plane} r{radius:g}"


@dataclass(frozen=True)
class BallbarPair:
    name: str
    radius: float
    plane: str
    circular_hysteresis_um: float
    squareness_mm_per_m: float
    scale_mismatch_mm: float
    servo_mismatch_ms: float
    backlash_um: tuple[float, float]
    figures: dict[str, Figure] = field(default_factory=dict)
    tilt_deg: float = 0.0
    feed_mm_min: float = 0.0

    def reported(self) -> dict[str, Figure]:
        """The figures that stand above the noise."""
        return {k: f for k, f in self.figures.items() if f.significant}

    @property
    def circle(self) -> str:
        return circle_label(self.plane, self.radius, self.tilt_deg)


def plane_of(rel: np.ndarray) -> str:
    """The plane of a run: the two axes the commanded path about the pivot spans most."""
    ext = np.ptp(rel, axis=0)
    i, j = sorted(int(i) for i in np.argsort(ext)[::-1][:2])
    return {v: k for k, v in PLANES.items()}[(i, j)]


def angles(run: BallbarRun) -> tuple[str, np.ndarray, str]:
    """Plane, angles θ [rad] about the pivot in :data:`PLANES` order (X-Z: atan2(z, x)),
    and the direction as RS274/NGC names it (``"ccw"`` = G3, ``"cw"`` = G2).

    The direction is the sign of the angular momentum of the commanded path about
    the pivot, seen from the positive end of the axis normal to the plane
    (:data:`VIEWED_FROM`): Σ (p_k × p_(k+1)) · n > 0 is counter-clockwise.
    """
    rel = run.commanded[:, :3] - run.pivot
    plane = plane_of(rel)
    i, j = PLANES[plane]
    th = np.arctan2(rel[:, j], rel[:, i])
    un = np.unwrap(th)
    if abs(un[-1] - un[0]) < 1e-9:
        raise MeasurementError(
            "the commanded path does not go round the pivot",
            source=run.source,
            expected="a circle about the pivot",
        )
    turn = 1 if un[-1] > un[0] else -1  # the sense of θ
    return plane, th, "ccw" if turn * ORIENTATION[plane] > 0 else "cw"


def sense(plane: str, direction: str) -> int:
    """+1 when θ of :func:`angles` grows along a run of this RS274 direction, else −1."""
    return ORIENTATION[plane] * (1 if direction == "ccw" else -1)


def tilt_deg(run: BallbarRun) -> float:
    """The tool axis' tilt from Z [deg], its median over the run: arccos(cos a · cos b),
    which holds for A and B applied in either order (the Z component of the axis)."""
    a, b = np.radians(run.commanded[:, 3]), np.radians(run.commanded[:, 4])
    return float(np.degrees(np.median(np.arccos(np.clip(np.cos(a) * np.cos(b), -1.0, 1.0)))))


def commanded_feed(run: BallbarRun) -> float:
    """The commanded feed [mm/min]: the tip speed the commanded samples hold for most
    of the run (the median over consecutive samples), not the mean over the run,
    which the start and the stop pull below the F word."""
    dist = np.linalg.norm(np.diff(run.commanded[:, :3], axis=0), axis=1)
    return float(np.median(dist / np.diff(run.t)) * 60.0)


def design(th: np.ndarray, turn: int, r: float) -> np.ndarray:
    """Columns of the model (module docstring), in :data:`TERMS` order, µm per unit;
    ``turn`` is +1 when θ grows along the run (:func:`sense`)."""
    v1 = -turn * np.sin(th)  # direction of motion of the first axis
    v2 = turn * np.cos(th)
    c, s = np.cos(th), np.sin(th)
    return np.column_stack(
        [
            np.ones_like(th),
            c,
            s,
            np.cos(2 * th),
            np.sin(2 * th),
            -0.5 * np.sign(v1) * c,
            -0.5 * np.sign(v2) * s,
            c**2 * s,
            s**2 * c,
        ]
    )


def analyse_run(run: BallbarRun) -> BallbarResult:
    """The figures of one run, each with its significance (module docstring)."""
    plane, th, direction = angles(run)
    r = run.length
    dev = run.dev_um
    X = design(th, sense(plane, direction), r)
    coef, *_ = np.linalg.lstsq(X, dev, rcond=None)
    resid = dev - X @ coef
    # ISO 230-4: about the least-squares centre
    centred = dev - coef[1] * np.cos(th) - coef[2] * np.sin(th)
    # cyclic error: harmonics of order >= 3 of the residual over one revolution
    order = np.argsort(th)
    ths, res_s = th[order], resid[order]
    best_amp, best_k = 0.0, 0
    for k in CYCLIC_ORDERS:
        a = 2 * np.trapezoid(res_s * np.cos(k * ths), ths) / (ths[-1] - ths[0])
        b = 2 * np.trapezoid(res_s * np.sin(k * ths), ths) / (ths[-1] - ths[0])
        amp = math.hypot(a, b)
        if amp > best_amp:
            best_amp, best_k = amp, k
    Xf = X
    if best_k:
        # refit with the cyclic harmonic in the model: backlash steps hold harmonics
        # of every even order and would otherwise take up part of it
        Xk = np.column_stack([X, np.cos(best_k * th), np.sin(best_k * th)])
        ck, *_ = np.linalg.lstsq(Xk, dev, rcond=None)
        if np.sum((dev - Xk @ ck) ** 2) < np.sum(resid**2):
            coef = ck
            best_amp = float(math.hypot(ck[-2], ck[-1]))
            resid = dev - Xk @ ck
            Xf = Xk
        else:
            best_k = 0
    terms = dict(zip(TERMS, (float(x) for x in coef[: len(TERMS)]), strict=True))
    # standard errors: σ̂² (XᵀX)⁻¹ with σ̂ what the whole model leaves
    dof = max(len(dev) - Xf.shape[1], 1)
    sigma2 = float(resid @ resid) / dof
    cov = np.linalg.pinv(Xf.T @ Xf) * sigma2
    se = np.sqrt(np.maximum(np.diag(cov), 0.0))
    n_fig = len(FIGURES)
    figs = {
        "squareness": _figure(2 * coef[4] / r, 2 * se[4] / r, n_fig),
        "scale_mismatch": _figure(2 * coef[3] / 1000.0, 2 * se[3] / 1000.0, n_fig),
        "backlash_x": _figure(coef[5], se[5], n_fig),
        "backlash_y": _figure(coef[6], se[6], n_fig),
        "straightness_x": _figure(coef[7], se[7], n_fig),
        "straightness_y": _figure(coef[8], se[8], n_fig),
    }
    if best_k and Xf.shape[1] > len(TERMS):
        ab = coef[-2:]
        chi = float(ab @ np.linalg.solve(cov[-2:, -2:], ab))
        amp_se = float(math.sqrt(max((ab / best_amp) @ cov[-2:, -2:] @ (ab / best_amp), 0.0)))
        figs["cyclic"] = _figure(best_amp, amp_se, n_fig * len(CYCLIC_ORDERS), chi)
    else:
        figs["cyclic"] = Figure(0.0, 0.0, 0.0, 1.0, False)
    deg = np.degrees(th) % 90.0
    near = np.minimum(deg, 90.0 - deg) < 3.0
    scatter = float(np.std(resid))
    spike = float(np.max(np.abs(resid[near])) - 2 * scatter) if near.any() else 0.0
    feed = commanded_feed(run)
    return BallbarResult(
        name=run.name,
        source=run.source,
        plane=plane,
        direction=direction,
        radius=r,
        feed_mm_min=feed,
        circular_deviation_um=float(centred.max() - centred.min()),
        centre_offset_um=(float(coef[1]), float(coef[2])),
        mean_radius_error_um=float(coef[0]),
        squareness_mm_per_m=float(2 * coef[4] / r),  # µm / mm = mm / m
        scale_mismatch_mm=float(2 * coef[3] / 1000.0),
        backlash_um=(float(coef[5]), float(coef[6])),
        straightness_um=(float(coef[7]), float(coef[8])),
        cyclic_um=best_amp if best_k else 0.0,
        cyclic_order=best_k,
        reversal_spike_um=max(spike, 0.0),
        residual_rms_um=float(np.sqrt(np.mean(resid**2))),
        terms=terms,
        noise_um=math.sqrt(sigma2),
        figures=figs,
        tilt_deg=tilt_deg(run),
        gcode=GCODE[direction],
        viewed_from=VIEWED_FROM[plane],
    )


def _pair_key(r: BallbarResult) -> tuple[str, float, str, float]:
    base = r.name.replace("ccw", "").replace("cw", "").strip(" -_")
    return base, round(r.radius, 6), r.plane, round(r.tilt_deg, 1)


def analyse_runs(runs: Sequence[BallbarRun]) -> tuple[list[BallbarResult], list[BallbarPair]]:
    """Every run, and every (ccw, cw) pair of the same circle."""
    results = [analyse_run(r) for r in runs]
    pairs = []
    groups: dict[tuple[str, float, str, float], dict[str, tuple[BallbarResult, BallbarRun]]] = {}
    for res, run in zip(results, runs, strict=True):
        groups.setdefault(_pair_key(res), {})[res.direction] = (res, run)
    for key, g in groups.items():
        if "ccw" not in g or "cw" not in g:
            continue
        (a, ra), (b, rb) = g["ccw"], g["cw"]
        _, tha, _ = angles(ra)
        _, thb, _ = angles(rb)
        grid = np.linspace(-np.pi, np.pi, 721)[:-1]
        fa = np.interp(grid, np.sort(tha), ra.dev_um[np.argsort(tha)], period=2 * np.pi)
        fb = np.interp(grid, np.sort(thb), rb.dev_um[np.argsort(thb)], period=2 * np.pi)
        omega = (a.feed_mm_min / 60.0) / a.radius  # rad/s
        # the lag's sin 2θ term takes the sign of θ's sense, which the plane's
        # orientation gives for the ccw run
        servo = (
            ORIENTATION[a.plane]
            * (a.terms["s2"] - b.terms["s2"])
            / (a.radius * 1000.0 * omega)
            * 1000.0
            if omega > 0
            else math.nan
        )
        fa_, fb_ = a.figures, b.figures

        def avg(k: str, fa_: dict = fa_, fb_: dict = fb_) -> Figure:
            return _figure(
                (fa_[k].value + fb_[k].value) / 2,
                math.hypot(fa_[k].stderr, fb_[k].stderr) / 2,
                4,
            )

        # s2 = squareness · r / 2 [µm]: the servo term's error from the two squareness errors
        se_s2 = math.hypot(fa_["squareness"].stderr, fb_["squareness"].stderr) * a.radius / 2
        pair_figs = {
            "squareness": avg("squareness"),
            "scale_mismatch": avg("scale_mismatch"),
            "backlash_x": avg("backlash_x"),
            "backlash_y": avg("backlash_y"),
            "servo_mismatch": _figure(
                servo, se_s2 / (a.radius * 1000.0 * omega) * 1000.0 if omega > 0 else math.inf, 4
            ),
        }
        pairs.append(
            BallbarPair(
                name=key[0],
                radius=a.radius,
                plane=a.plane,
                circular_hysteresis_um=float(np.max(np.abs(fa - fb))),
                squareness_mm_per_m=(a.squareness_mm_per_m + b.squareness_mm_per_m) / 2,
                scale_mismatch_mm=(a.scale_mismatch_mm + b.scale_mismatch_mm) / 2,
                servo_mismatch_ms=float(servo),
                backlash_um=(
                    (a.backlash_um[0] + b.backlash_um[0]) / 2,
                    (a.backlash_um[1] + b.backlash_um[1]) / 2,
                ),
                figures=pair_figs,
                tilt_deg=a.tilt_deg,
                feed_mm_min=a.feed_mm_min,
            )
        )
    return results, pairs


def model_deviation(th: np.ndarray, res: BallbarResult) -> np.ndarray:
    """Δr [µm] of a run's fitted model at angles th."""
    coef = np.array([res.terms[k] for k in TERMS])
    return design(th, sense(res.plane, res.direction), res.radius) @ coef


def centred(th: np.ndarray, y: np.ndarray) -> np.ndarray:
    """y less its least-squares mean and first harmonic (radius and centre offset)."""
    X = np.column_stack([np.ones_like(th), np.cos(th), np.sin(th)])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return y - X @ coef


def result_to_json(x: BallbarResult | BallbarPair) -> dict[str, Any]:
    """The fields, and the circle's name (``XZ r50``, ``cone 15° r100``)."""
    return {**asdict(x), "circle": x.circle}


def circles(
    results: Sequence[BallbarResult], runs: Sequence[BallbarRun]
) -> list[list[tuple[BallbarResult, BallbarRun]]]:
    """The runs grouped by circle: a ccw and a cw run of the same circle together
    (ccw first), every other run on its own, in the order they came."""
    groups: dict[tuple[str, float, str, float], list[tuple[BallbarResult, BallbarRun]]] = {}
    for res, run in zip(results, runs, strict=True):
        groups.setdefault(_pair_key(res), []).append((res, run))
    out = []
    for g in groups.values():
        dirs = [r.direction for r, _ in g]
        if sorted(dirs) == ["ccw", "cw"]:
            out.append(sorted(g, key=lambda x: x[0].direction != "ccw"))
        else:
            out += [[x] for x in g]
    return out


#: How each figure is printed: label, unit, format.
LABELS = {
    "squareness": ("squareness", "mm/m", "+.4f"),
    "scale_mismatch": ("scale mismatch", "mm", "+.4f"),
    "backlash_x": ("backlash, first axis", "um", "+.2f"),
    "backlash_y": ("backlash, second axis", "um", "+.2f"),
    "straightness_x": ("straightness, first axis", "um", "+.2f"),
    "straightness_y": ("straightness, second axis", "um", "+.2f"),
    "cyclic": ("cyclic error", "um", ".2f"),
    "servo_mismatch": ("servo mismatch", "ms", "+.3f"),
}


def figure_label(key: str, plane: str = "") -> str:
    """A figure's name, with the plane's axes for "first axis" and "second axis"."""
    label = LABELS[key][0]
    if plane in PLANES:
        label = label.replace(", first axis", f" {plane[0]}").replace(
            ", second axis", f" {plane[1]}"
        )
    return label


def findings(fig: Mapping[str, Figure]) -> list[tuple[str, Figure]]:
    """The figures standing above the noise, the most significant first."""
    return sorted(((k, f) for k, f in fig.items() if f.significant), key=lambda kf: -kf[1].z)


def describe(fig: Mapping[str, Figure], cyclic_order: int = 0, plane: str = "") -> str:
    """The figures standing above the noise, the most significant first, each with
    its significance."""
    parts = []
    for k, f in findings(fig):
        _, unit, fmt = LABELS[k]
        extra = f" (order {cyclic_order})" if k == "cyclic" and cyclic_order else ""
        parts.append(f"{figure_label(k, plane)} {f.value:{fmt}} {unit}{extra} ({f.z:.0f} σ)")
    return "; ".join(parts) if parts else "nothing above the noise"


@dataclass
class Analysis:
    """Every run and every (ccw, cw) pair analysed; a model's simulation of each run
    [µm] by source file when one was given."""

    runs: list[BallbarRun]
    results: list[BallbarResult]
    pairs: list[BallbarPair]
    predicted: dict[str, np.ndarray] | None = None

    def to_json(self) -> dict[str, Any]:
        return {
            "runs": [result_to_json(r) for r in self.results],
            "pairs": [result_to_json(p) for p in self.pairs],
        }

    def lines(self) -> list[str]:
        """The text report: per run and pair, only what stands above the noise."""
        out = []
        for r in self.results:
            out.append(
                f"{r.source}: {r.label}: "
                f"circular deviation {r.circular_deviation_um:.2f} um, noise "
                f"{r.noise_um:.2f} um; {describe(r.figures, r.cyclic_order, r.plane)}"
            )
        for p in self.pairs:
            out.append(
                f"pair {p.circle} ccw + cw: hysteresis {p.circular_hysteresis_um:.2f} um; "
                f"{describe(p.figures, plane=p.plane)}"
            )
        return out


def analyse(runs: Sequence[BallbarRun], model: Any = None, commanded: Any = None) -> Analysis:
    """Analyse ballbar runs; with a ``model`` profile, also simulate each run as the
    model predicts it (the machine commanded by ``commanded``, default the model).

    Example
    -------
    >>> a = analyse([measure.read_ballbar(text, "r50-ccw.csv")])  # doctest: +SKIP
    >>> print("\\n".join(a.lines()))  # doctest: +SKIP
    """
    results, pairs = analyse_runs(runs)
    predicted = None
    if model is not None:
        from . import diagnose

        d = diagnose.Data.build(commanded or model, [], list(runs), [])
        pred = diagnose.predict(model, d, []).pred
        _, segs = d.measured()
        predicted = {s.source: pred[s.start : s.stop] * 1000.0 for s in segs}
    return Analysis(list(runs), results, pairs, predicted)
