"""The plots of the reports: ballbar polar plots, pose residual maps, residual bars.

Everything here draws what :mod:`prsxy_post.ballbar` and :mod:`prsxy_post.diagnose`
computed and returns PNG bytes; nothing is analysed here, so the analysis never
imports the plotting (or matplotlib, the optional ``plot`` extra).

A polar plot of a run is drawn as RS274/NGC sees the plane (``ballbar.VIEWED_FROM``):
from +Z for X-Y, +Y for X-Z, +X for Y-Z, so a ccw (G3) run turns counter-clockwise
on the page in every plane; the angular ticks name the plane's axes. Every panel
has its own scale (µm per division, a 1, 2 or 5 × 10ⁿ step), chosen from what it
shows: a residual of half a micrometre gets a scale where it is visible.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .ballbar import (
    ORIENTATION,
    PLANE_CODE,
    PLANES,
    VIEWED_FROM,
    BallbarResult,
    angles,
    centred,
    circles,
    model_deviation,
)
from .errors import UsageError
from .measure import BallbarRun

if TYPE_CHECKING:
    from .diagnose import Data, Diagnosis

Trace = tuple[np.ndarray, np.ndarray, dict[str, Any]]
DIRECTION_COLOUR = {"ccw": "tab:blue", "cw": "tab:red"}


def pyplot() -> Any:
    """matplotlib's pyplot on the file-only backend, or a usage error naming the extra."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise UsageError(
            "plots need matplotlib, which is not installed",
            expected="pip install 'prsxy-post[plot]'",
        ) from None
    return plt


def png(fig: Any, dpi: int = 110) -> bytes:
    """The figure as PNG bytes (no software stamp: the same plot, the same bytes); closes it."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, metadata={"Software": None})
    pyplot().close(fig)
    return buf.getvalue()


def nice_division(span_um: float, divisions: float = 5.0) -> float:
    """A scale of 1, 2 or 5 × 10ⁿ µm per division so that ``span_um`` takes about
    ``divisions`` divisions (ballbar software's choice of plot scale)."""
    target = max(span_um, 1e-3) / divisions
    k = math.floor(math.log10(target))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10**k >= target:
            return float(m * 10**k)
    return float(10 ** (k + 1))


def polar_panel(
    ax: Any, traces: Sequence[Trace], um_per_div: float | None = None, plane: str = "XY"
) -> float:
    """Draw deviation traces (θ [rad] as :func:`ballbar.angles` gives it, Δr [µm],
    line style) on a polar axes the way ballbar software does: the reference circle
    at 5 divisions, a grid circle every division (4 inside, 4 outside), the
    deviation magnified to the scale; seen from the plane's RS274 side, the axes
    named at the quadrants. Each trace is drawn in the order of its samples with θ
    unwrapped, so the line runs round the way the machine went. Returns the scale
    [µm/div]."""
    span = max((float(np.ptp(d)) for _, d, _ in traces if len(d)), default=1.0)
    div = um_per_div or nice_division(span)
    base = 5 * div
    ring = np.linspace(0, 2 * np.pi, 361)
    for k in range(-4, 5):
        ax.plot(
            ring,
            np.full_like(ring, base + k * div),
            color="0.45" if k == 0 else "0.85",
            lw=0.9 if k == 0 else 0.5,
            zorder=1,
        )
    for th, d, style in traces:
        ax.plot(np.unwrap(th), base + np.clip(d, -4.8 * div, 4.8 * div), zorder=3, **style)
    ax.set_theta_direction(ORIENTATION.get(plane, 1))
    ax.set_ylim(0, base + 5 * div)
    ax.set_yticks([])
    ax.grid(False)
    i, j = PLANES.get(plane, (0, 1))
    names = "XYZ"
    ax.set_xticks(
        np.radians([0, 90, 180, 270]),
        [f"+{names[i]}", f"+{names[j]}", f"−{names[i]}", f"−{names[j]}"],
    )
    ax.tick_params(labelsize=7)
    return div


def _grid(plt: Any, n: int, max_cols: int, w: float, h: float) -> tuple[Any, int, int]:
    cols = max(1, min(max_cols, n))
    rows = (n + cols - 1) // cols
    return plt.figure(figsize=(w * cols, h * rows)), rows, cols


def ballbar_plot(
    results: Sequence[BallbarResult],
    runs: Sequence[BallbarRun],
    predicted: Mapping[str, np.ndarray] | None = None,
    um_per_div: float | None = None,
) -> bytes:
    """:func:`ballbar_figure` as PNG bytes."""
    return png(ballbar_figure(results, runs, predicted, um_per_div), dpi=100)


def ballbar_figure(
    results: Sequence[BallbarResult],
    runs: Sequence[BallbarRun],
    predicted: Mapping[str, np.ndarray] | None = None,
    um_per_div: float | None = None,
) -> Any:
    """Polar plots as ballbar software draws them: one per circle, its ccw (G3) and
    cw (G2) runs overlaid on one scale (µm per division in the title), the mean
    radius and the set-up centre offset removed so what is left is the machine's
    shape; the fitted terms dashed and a simulated prediction dotted. Seen from the
    plane's RS274 side: a ccw run's line turns counter-clockwise on the page."""
    plt = pyplot()
    groups = circles(results, runs)
    fig, rows, cols = _grid(plt, len(groups), 3, 4.4, 4.8)
    for k, group in enumerate(groups):
        ax = fig.add_subplot(rows, cols, k + 1, projection="polar")
        traces: list[Trace] = []
        for res, run in group:
            _, th, _ = angles(run)
            colour = DIRECTION_COLOUR[res.direction]
            label = f"{res.direction} ({res.gcode})"
            traces.append(
                (th, centred(th, run.dev_um), {"color": colour, "lw": 1.0, "label": label})
            )
            model = centred(th, model_deviation(th, res))
            traces.append((th, model, {"color": colour, "lw": 0.8, "ls": "--", "alpha": 0.7}))
            if predicted and run.source in predicted:
                sim = centred(th, predicted[run.source])
                traces.append((th, sim, {"color": "black", "lw": 0.9, "ls": ":"}))
        first = group[0][0]
        div = polar_panel(ax, traces, um_per_div, first.plane)
        gs = ", ".join(f"{r.direction} {r.circular_deviation_um:.1f}" for r, _ in group)
        ax.set_title(
            f"{first.circle} F{first.feed_mm_min:.0f}, seen from {VIEWED_FROM[first.plane]} "
            f"({PLANE_CODE[first.plane]})\n{div:g} µm/div; G [µm]: {gs}",
            fontsize=9,
        )
        ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.2, -0.2))
    note = "dashed: fitted terms" + ("; dotted: simulated" if predicted else "")
    fig.text(0.99, 0.005, note, fontsize=7, ha="right")
    fig.tight_layout(rect=(0, 0.02, 1, 0.97))
    return fig


def smooth(th: np.ndarray, y: np.ndarray, width_deg: float = 5.0) -> np.ndarray:
    """y averaged over a window of ``width_deg`` about each angle (round the circle),
    so a structure of the size of the noise stands out of it."""
    order = np.argsort(th)
    ts, ys = th[order], y[order]
    half = np.radians(width_deg) / 2
    ext_t = np.concatenate([ts - 2 * np.pi, ts, ts + 2 * np.pi])
    csum = np.concatenate([[0.0], np.cumsum(np.tile(ys, 3))])
    lo = np.searchsorted(ext_t, ts - half, side="left")
    hi = np.searchsorted(ext_t, ts + half, side="right")
    out = np.empty_like(y)
    out[order] = (csum[hi] - csum[lo]) / np.maximum(hi - lo, 1)
    return out


def diagnose_ballbar(result: Diagnosis, data: Data) -> bytes | None:
    """Per run, on its own scale: measured (grey), simulated with the profile as it
    was (orange, dashed) and with the effects added (blue, on top)."""
    if not data.runs:
        return None
    plt = pyplot()
    measured, segs = data.measured()
    before = measured - result.residual_before
    after = measured - result.residual_after
    runs = [s for s in segs if s.kind == "ballbar"]
    fig, rows, cols = _grid(plt, len(runs), 4, 3.9, 4.3)
    for k, (seg, run) in enumerate(zip(runs, data.runs, strict=True)):
        ax = fig.add_subplot(rows, cols, k + 1, projection="polar")
        plane, th, _ = angles(run)
        m, b, a = (centred(th, v[seg.start : seg.stop] * 1000) for v in (measured, before, after))
        div = nice_division(max(np.ptp(m), np.ptp(b), np.ptp(a), 1e-3))
        polar_panel(
            ax,
            [
                (th, m, {"color": "0.55", "lw": 2.4, "alpha": 0.6, "label": "measured"}),
                (th, b, {"color": "tab:orange", "lw": 1.0, "ls": "--", "label": "model before"}),
                (th, a, {"color": "tab:blue", "lw": 1.0, "label": "model after"}),
            ],
            div,
            plane,
        )
        ax.set_title(f"{seg.name}\n{div:g} µm/div", fontsize=8)
        if k == 0:
            ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.25, -0.3))
    fig.tight_layout()
    return png(fig, dpi=90)


def residual_scale(smoothed_um: np.ndarray, noise_um: float) -> float:
    """The scale [µm/div] of a residual panel: the span of its average, or ± 2 σ of
    the noise when that is more, in about five divisions. A structure of the noise's
    size then spans two divisions or more, and the samples' own scatter stays
    inside the plot."""
    span = float(np.ptp(smoothed_um)) if smoothed_um.size else 0.0
    return nice_division(max(span, 4 * noise_um, 1e-3))


def residual_panels(
    panels: Sequence[tuple[str, str, np.ndarray, np.ndarray, float]], ring_label: str
) -> Any:
    """Polar residual panels (title, plane, θ [rad], residual [µm], σ [µm]), each on
    a scale of its own (:func:`residual_scale`): the samples (grey), their 5° average
    (blue) and dashed rings at ± σ, so a residual of the noise's size is visible."""
    plt = pyplot()
    fig, rows, cols = _grid(plt, len(panels), 4, 3.9, 4.3)
    for k, (title, plane, th, resid, sigma) in enumerate(panels):
        ax = fig.add_subplot(rows, cols, k + 1, projection="polar")
        ok = np.isfinite(resid)
        th, r = th[ok], centred(th[ok], resid[ok])
        sm = smooth(th, r)
        ring = np.full_like(th, sigma)
        traces: list[Trace] = [
            (th, r, {"color": "0.6", "lw": 0.5, "alpha": 0.7, "label": "residual"}),
            (th, ring, {"color": "0.2", "lw": 0.8, "ls": "--", "label": ring_label}),
            (th, -ring, {"color": "0.2", "lw": 0.8, "ls": "--"}),
            (th, sm, {"color": "tab:blue", "lw": 1.4, "label": "5° average"}),
        ]
        div = residual_scale(sm, sigma)
        polar_panel(ax, traces, div, plane)
        ax.set_title(f"{title}\n{div:g} µm/div", fontsize=8)
        if k == 0:
            ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.25, -0.3))
    fig.tight_layout()
    return fig


def diagnose_ballbar_residual(result: Diagnosis, data: Data) -> bytes | None:
    """Per run, what the model after leaves (measured − model after), with the
    estimated noise: :func:`residual_panels`."""
    if not data.runs:
        return None
    _, segs = data.measured()
    noise_um = float(result.noise.get("ballbar", 0.0)) * 1000.0
    runs = [s for s in segs if s.kind == "ballbar"]
    panels = []
    for seg, run in zip(runs, data.runs, strict=True):
        plane, th, _ = angles(run)
        resid = result.residual_after[seg.start : seg.stop] * 1000
        panels.append((seg.name, plane, th, resid, noise_um))
    return png(residual_panels(panels, "± noise"), dpi=90)


def ballbar_residual(results: Sequence[BallbarResult], runs: Sequence[BallbarRun]) -> bytes:
    """Per run, what the fitted terms leave (measured − fitted model), with the
    scatter the fit leaves: :func:`residual_panels`. Cyclic errors and reversal
    spikes the terms do not take show here."""
    panels = []
    for res, run in zip(results, runs, strict=True):
        _, th, _ = angles(run)
        resid = run.dev_um - model_deviation(th, res)
        panels.append((f"{res.circle} {res.direction}", res.plane, th, resid, res.noise_um))
    return png(residual_panels(panels, "± the fit's scatter"), dpi=90)


def diagnose_poses(result: Diagnosis, data: Data) -> bytes | None:
    """Tip [µm] and axis [arcsec] residual at each pose, before and after; every
    panel on its own colour scale (the after panel would be one colour on the
    before panel's)."""
    if not data.poses:
        return None
    plt = pyplot()
    _, segs = data.measured()
    q = np.vstack([p.commanded for p in data.poses])

    def magnitudes(resid: np.ndarray, kind: str, width: int, scale: float) -> np.ndarray:
        parts = [resid[s.start : s.stop].reshape(-1, width) for s in segs if s.kind == kind]
        return np.linalg.norm(np.vstack(parts), axis=1) * scale

    panels = [
        ("tip residual before [µm]", magnitudes(result.residual_before, "pose_tip", 3, 1000)),
        ("tip residual after [µm]", magnitudes(result.residual_after, "pose_tip", 3, 1000)),
        ("axis residual before [arcsec]", magnitudes(result.residual_before, "pose_axis", 2, 3600)),
        ("axis residual after [arcsec]", magnitudes(result.residual_after, "pose_axis", 2, 3600)),
    ]
    fig, axes = plt.subplots(2, 2, figsize=(10, 8.5), sharex=True, sharey=True)
    for ax, (title, e) in zip(axes.ravel(), panels, strict=True):
        ok = np.isfinite(e)
        vmax = float(np.max(e[ok])) if ok.any() else 1.0
        sc = ax.scatter(q[ok, 0], q[ok, 1], c=e[ok], s=14, vmin=0, vmax=vmax, cmap="viridis")
        fig.colorbar(sc, ax=ax, shrink=0.85)
        ax.set_title(title, fontsize=10)
        ax.set_aspect("equal")
    for ax in axes[1]:
        ax.set_xlabel("x [mm]")
    for ax in axes[:, 0]:
        ax.set_ylabel("y [mm]")
    fig.tight_layout()
    return png(fig, dpi=90)


def noise_of(result: Diagnosis, kind: str) -> float:
    """The estimated noise of a data kind in the unit the report shows (µm, arcsec)."""
    v = float(result.noise.get(kind, float("nan")))
    return v * (3600.0 if kind == "pose_axis" else 1000.0)


def diagnose_residuals(result: Diagnosis) -> bytes:
    """:func:`residuals_figure` as PNG bytes."""
    return png(residuals_figure(result), dpi=90)


def residuals_figure(result: Diagnosis) -> Any:
    """RMS per file before and after, on a logarithmic scale, with each file's
    estimated noise (black dashes): a bar that ends at its dash is explained."""
    plt = pyplot()
    runs = result.per_run
    labels = [f"{r['name'] if r['kind'] == 'ballbar' else r['kind']} [{r['unit']}]" for r in runs]
    y = np.arange(len(runs))
    fig, ax = plt.subplots(figsize=(8, 0.32 * len(runs) + 1.4))
    ax.barh(y + 0.2, [r["rms_before"] for r in runs], 0.4, color="tab:orange", label="before")
    ax.barh(y - 0.2, [r["rms_after"] for r in runs], 0.4, color="tab:blue", label="after")
    noise = np.array([noise_of(result, r["kind"]) for r in runs])
    ok = np.isfinite(noise) & (noise > 0)
    ax.vlines(
        noise[ok],
        y[ok] - 0.45,
        y[ok] + 0.45,
        colors="black",
        linestyles="--",
        lw=1.2,
        label="noise",
    )
    ax.set_yticks(y, labels, fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("RMS residual (µm or arcsec, as labelled)")
    ax.invert_yaxis()
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig
