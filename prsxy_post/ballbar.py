"""Ballbar analysis: ISO 230-4 circular deviation and the classic diagnostics.

A run is read as the radial deviation Δr(θ) = dev_um along the angle θ of the
commanded tip about the pivot in the run's plane (X-Y: θ = atan2(y, x); X-Z:
atan2(z, x); Y-Z: atan2(z, y); cones are X-Y circles with a tilted spindle).
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
the sign of the direction; the pair (ccw, cw) separates it from squareness:
**servo mismatch** Δτ = (s2_ccw − s2_cw) / (r ω) with ω = v / r, in ms.

**Circular deviation** G (ISO 230-4): the radial range of the path about its
least-squares centre, max Δr − min Δr after removing c1, s1. **Circular
hysteresis** H of a pair: the largest radial difference between the two
directions at the same angle. **Cyclic error**: the largest harmonic of order ≥ 3
left after the model. **Reversal spikes**: the largest residual within 3° of an
axis reversal beyond the run's residual scatter.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from .errors import MeasurementError
from .measure import BallbarRun

PLANES = {"XY": (0, 1), "XZ": (0, 2), "YZ": (1, 2)}
TERMS = ("c0", "c1", "s1", "c2", "s2", "backlash_1", "backlash_2", "straight_1", "straight_2")


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


def angles(run: BallbarRun) -> tuple[str, np.ndarray, str]:
    """Plane (the two axes the commanded path spans most), angles, direction."""
    rel = run.commanded[:, :3] - run.pivot
    ext = np.ptp(rel, axis=0)
    i0, i1 = sorted(int(i) for i in np.argsort(ext)[::-1][:2])
    two = (i0, i1)
    plane = {v: k for k, v in PLANES.items()}[two]
    i, j = PLANES[plane]
    th = np.arctan2(rel[:, j], rel[:, i])
    un = np.unwrap(th)
    if abs(un[-1] - un[0]) < 1e-9:
        raise MeasurementError(
            "the commanded path does not go round the pivot",
            source=run.source,
            expected="a circle about the pivot",
        )
    return plane, th, "ccw" if un[-1] > un[0] else "cw"


def design(th: np.ndarray, direction: str, r: float) -> np.ndarray:
    """Columns of the model (module docstring), in :data:`TERMS` order, µm per unit."""
    sgn = 1.0 if direction == "ccw" else -1.0
    v1 = -sgn * np.sin(th)  # direction of motion of the first axis
    v2 = sgn * np.cos(th)
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
    plane, th, direction = angles(run)
    r = run.length
    dev = run.dev_um
    X = design(th, direction, r)
    coef, *_ = np.linalg.lstsq(X, dev, rcond=None)
    terms = dict(zip(TERMS, (float(x) for x in coef), strict=True))
    resid = dev - X @ coef
    # ISO 230-4: about the least-squares centre
    centred = dev - coef[1] * np.cos(th) - coef[2] * np.sin(th)
    # cyclic error: harmonics of order >= 3 of the residual over one revolution
    order = np.argsort(th)
    ths, res_s = th[order], resid[order]
    best_amp, best_k = 0.0, 0
    for k in range(3, 61):
        a = 2 * np.trapezoid(res_s * np.cos(k * ths), ths) / (ths[-1] - ths[0])
        b = 2 * np.trapezoid(res_s * np.sin(k * ths), ths) / (ths[-1] - ths[0])
        amp = math.hypot(a, b)
        if amp > best_amp:
            best_amp, best_k = amp, k
    if best_k:
        # refit with the cyclic harmonic in the model: backlash steps hold harmonics
        # of every even order and would otherwise take up part of it
        Xk = np.column_stack([X, np.cos(best_k * th), np.sin(best_k * th)])
        ck, *_ = np.linalg.lstsq(Xk, dev, rcond=None)
        if np.sum((dev - Xk @ ck) ** 2) < np.sum(resid**2):
            coef = ck[: len(TERMS)]
            best_amp = float(math.hypot(ck[-2], ck[-1]))
            terms = dict(zip(TERMS, (float(x) for x in coef), strict=True))
            resid = dev - Xk @ ck
    deg = np.degrees(th) % 90.0
    near = np.minimum(deg, 90.0 - deg) < 3.0
    scatter = float(np.std(resid))
    spike = float(np.max(np.abs(resid[near])) - 2 * scatter) if near.any() else 0.0
    dist = np.sum(np.linalg.norm(np.diff(run.commanded[:, :3], axis=0), axis=1))
    feed = float(dist / (run.t[-1] - run.t[0]) * 60.0)
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
        cyclic_um=best_amp,
        cyclic_order=best_k,
        reversal_spike_um=max(spike, 0.0),
        residual_rms_um=float(np.sqrt(np.mean(resid**2))),
        terms=terms,
    )


def _pair_key(r: BallbarResult) -> tuple[str, float, str]:
    base = r.name.replace("ccw", "").replace("cw", "").strip(" -_")
    return base, round(r.radius, 6), r.plane


def analyse_runs(runs: Sequence[BallbarRun]) -> tuple[list[BallbarResult], list[BallbarPair]]:
    """Every run, and every (ccw, cw) pair of the same circle."""
    results = [analyse_run(r) for r in runs]
    pairs = []
    groups: dict[tuple[str, float, str], dict[str, tuple[BallbarResult, BallbarRun]]] = {}
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
        servo = (
            (a.terms["s2"] - b.terms["s2"]) / (a.radius * 1000.0 * omega) * 1000.0
            if omega > 0
            else math.nan
        )
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
            )
        )
    return results, pairs


def model_deviation(
    th: np.ndarray, terms: Mapping[str, float], direction: str, radius: float
) -> np.ndarray:
    """Δr [µm] of the fitted model at angles th."""
    coef = np.array([terms[k] for k in TERMS])
    return design(th, direction, radius) @ coef


def _centred(th: np.ndarray, y: np.ndarray) -> np.ndarray:
    """y less its least-squares mean and first harmonic (radius and centre offset)."""
    X = np.column_stack([np.ones_like(th), np.cos(th), np.sin(th)])
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return y - X @ coef


def result_to_json(x: BallbarResult | BallbarPair) -> dict[str, Any]:
    return asdict(x)


def plot_runs(
    results: Sequence[BallbarResult],
    runs: Sequence[BallbarRun],
    predicted: Mapping[str, np.ndarray] | None = None,
    um_per_div: float | None = None,
) -> bytes:
    """Polar plots, one per circle: measured deviation around the reference circle,
    magnified, the fitted terms dashed, a simulated prediction dotted. PNG bytes."""
    from .report import png, pyplot

    plt = pyplot()
    n = len(runs)
    cols = min(3, n)
    rows = (n + cols - 1) // cols
    fig = plt.figure(figsize=(4.2 * cols, 4.4 * rows))
    for k, (res, run) in enumerate(zip(results, runs, strict=True)):
        ax = fig.add_subplot(rows, cols, k + 1, projection="polar")
        _, th, _ = angles(run)
        # as ballbar software shows it: the mean radius and the set-up centre offset
        # removed, so what is left is the machine's shape
        dev = _centred(th, run.dev_um)
        span = max(float(np.ptp(dev)), 1.0)
        div = um_per_div or float(10 ** math.ceil(math.log10(span / 4)))
        base = 4 * div  # reference circle radius on the plot, in µm
        order = np.argsort(th)
        ax.plot(th[order], np.full(len(th), base), color="0.6", lw=0.8, label="reference")
        ax.plot(th, base + dev, lw=1.0, label="measured")
        model = model_deviation(th[order], res.terms, res.direction, res.radius)
        ax.plot(th[order], base + _centred(th[order], model), ls="--", lw=0.8, label="fitted terms")
        if predicted and run.source in predicted:
            ax.plot(
                th, base + _centred(th, predicted[run.source]), ls=":", lw=1.0, label="simulated"
            )
        ax.set_ylim(0, base + 3 * div)
        ax.set_yticks([base - 2 * div, base, base + 2 * div])
        ax.set_yticklabels([])
        ax.set_title(
            f"{res.name} ({res.direction})\n{div:g} µm/div, G = {res.circular_deviation_um:.1f} µm",
            fontsize=9,
        )
        if k == 0:
            ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.25, -0.25))
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    return png(fig, dpi=100)
