"""Reports people read: one self-contained HTML page and the same in Markdown.

``diagnose --report DIR`` and ``ballbar --report DIR`` write ``report.html`` (the
plots embedded as data, nothing fetched from anywhere: it opens from a USB stick
or as a mail attachment), ``report.md`` and the PNG plots it shows. Plots need
matplotlib (the optional ``plot`` extra); each panel has its own scale, since a
model's residual before and after differ by orders of magnitude.
"""

from __future__ import annotations

import base64
import html
import io
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import UsageError

if TYPE_CHECKING:
    from .ballbar import Analysis
    from .diagnose import Data, Diagnosis


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
    import matplotlib.pyplot as plt

    plt.close(fig)
    return buf.getvalue()


# ---------------------------------------------------------------- the page


_CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 1.5em auto; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
p.warn { background: #fff3cd; border-left: 4px solid #e0a800; padding: 0.5em 0.8em; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.4em 0; }
.small { color: #555; font-size: 0.85em; }
"""


class Page:
    """A report built once and written both as self-contained HTML and as Markdown."""

    def __init__(self, title: str) -> None:
        self.title = title
        self.html: list[str] = []
        self.md: list[str] = [f"# {title}", ""]
        self.images: dict[str, bytes] = {}

    def heading(self, text: str) -> None:
        self.html.append(f"<h2>{html.escape(text)}</h2>")
        self.md += [f"## {text}", ""]

    def para(self, text: str, warn: bool = False) -> None:
        cls = ' class="warn"' if warn else ""
        self.html.append(f"<p{cls}>{html.escape(text)}</p>")
        self.md += [("**Warning:** " if warn else "") + text, ""]

    def table(self, head: Sequence[str], rows: Sequence[Sequence[Any]]) -> None:
        def cell(v: Any) -> tuple[str, bool]:
            if isinstance(v, float):
                return (f"{v:.4g}" if abs(v) < 1e5 else f"{v:.3e}"), True
            return str(v), isinstance(v, int)

        h = "".join(f"<th>{html.escape(x)}</th>" for x in head)
        body = []
        md = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for r in rows:
            cells = [cell(v) for v in r]
            tds = [
                f'<td class="num">{html.escape(t)}</td>' if num else f"<td>{html.escape(t)}</td>"
                for t, num in cells
            ]
            body.append("<tr>" + "".join(tds) + "</tr>")
            md.append("| " + " | ".join(t.replace("|", "\\|") for t, _ in cells) + " |")
        self.html.append(f"<table><tr>{h}</tr>{''.join(body)}</table>")
        self.md += [*md, ""]

    def image(self, name: str, data: bytes, caption: str) -> None:
        self.images[name] = data
        b64 = base64.b64encode(data).decode("ascii")
        self.html.append(
            f'<figure><img id="{html.escape(name)}" alt="{html.escape(caption)}" '
            f'src="data:image/png;base64,{b64}"><figcaption class="small">'
            f"{html.escape(caption)}</figcaption></figure>"
        )
        self.md += [f"![{caption}]({name})", ""]

    def files(self) -> dict[str, str | bytes]:
        page = (
            '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
            f"<title>{html.escape(self.title)}</title><style>{_CSS}</style></head><body>"
            f"<h1>{html.escape(self.title)}</h1>" + "\n".join(self.html) + "</body></html>\n"
        )
        out: dict[str, str | bytes] = {"report.html": page, "report.md": "\n".join(self.md) + "\n"}
        out.update(self.images)
        return out


# ---------------------------------------------------------------- diagnose


def _ballbar_figure(result: Diagnosis, data: Data) -> bytes | None:
    """Per run, on its own scale: measured (grey), simulated with the profile as it
    was (orange, dashed) and with the effects added (blue, on top)."""
    from .ballbar import _centred, angles, nice_division, polar_panel

    if not data.runs:
        return None
    plt = pyplot()
    measured, segs = data.measured()
    before = measured - result.residual_before
    after = measured - result.residual_after
    runs = [s for s in segs if s.kind == "ballbar"]
    n = len(runs)
    cols = min(4, n)
    rows = (n + cols - 1) // cols
    fig = plt.figure(figsize=(3.9 * cols, 4.3 * rows))
    for k, (seg, run) in enumerate(zip(runs, data.runs, strict=True)):
        ax = fig.add_subplot(rows, cols, k + 1, projection="polar")
        _, th, _ = angles(run)
        m, b, a = (_centred(th, v[seg.start : seg.stop] * 1000) for v in (measured, before, after))
        div = nice_division(max(np.ptp(m), np.ptp(b), np.ptp(a), 1e-3))
        polar_panel(
            ax,
            [
                (th, m, {"color": "0.55", "lw": 2.4, "alpha": 0.6, "label": "measured"}),
                (th, b, {"color": "tab:orange", "lw": 1.0, "ls": "--", "label": "model before"}),
                (th, a, {"color": "tab:blue", "lw": 1.0, "label": "model after"}),
            ],
            div,
        )
        ax.set_title(f"{seg.name}\n{div:g} µm/div", fontsize=8)
        if k == 0:
            ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.25, -0.3))
    fig.tight_layout()
    return png(fig, dpi=90)


def _pose_figure(result: Diagnosis, data: Data) -> bytes | None:
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


def _residual_figure(result: Diagnosis) -> bytes:
    """RMS per file before and after, on a logarithmic scale."""
    plt = pyplot()
    runs = result.per_run
    labels = [f"{r['name'] if r['kind'] == 'ballbar' else r['kind']} [{r['unit']}]" for r in runs]
    y = np.arange(len(runs))
    fig, ax = plt.subplots(figsize=(8, 0.32 * len(runs) + 1.2))
    ax.barh(y + 0.2, [r["rms_before"] for r in runs], 0.4, color="tab:orange", label="before")
    ax.barh(y - 0.2, [r["rms_after"] for r in runs], 0.4, color="tab:blue", label="after")
    ax.set_yticks(y, labels, fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("RMS residual (µm or arcsec, as labelled)")
    ax.invert_yaxis()
    ax.legend(fontsize=8)
    fig.tight_layout()
    return png(fig, dpi=90)


def diagnose_report(result: Diagnosis, data: Data) -> dict[str, str | bytes]:
    """Files of the report folder: report.html, report.md and the plots."""
    j = result.to_json()
    page = Page("Diagnosis")
    page.heading("Summary")
    for e in result.effects:
        page.para(e.sentence())
    if not result.effects:
        page.para(
            "No effect of the library is missing."
            if not result.unexplained
            else "No effect of the library explains the disagreement."
        )
    for u in result.unexplained:
        page.para(u["sentence"], warn=True)
    page.para(
        f"Residual RMS (lengths): {j['rms_before_um']:.3f} µm before, "
        f"{j['rms_after_um']:.3f} µm after. Estimated noise: "
        + ", ".join(f"{k} {v:.3f} {j['noise_units'][k]}" for k, v in j["noise"].items())
        + "."
    )
    if result.map_note is not None:
        page.para(f"Error map: {result.map_note['action']}: {result.map_note['reason']}.")
    if result.effects:
        page.heading("Effects")
        page.table(
            [
                "effect",
                "estimate",
                "std. error",
                "unit",
                "period mm",
                "χ²",
                "cannot be told apart from",
                "moves without",
            ],
            [
                [
                    e.name,
                    e.estimate,
                    e.stderr,
                    e.unit,
                    f"{e.period:g}" if e.period else "-",
                    e.chi2,
                    ", ".join(e.aliases) or "-",
                    ", ".join(
                        f"{d['name']} ({d['shift']:+.3g}, {d['in_stderr']:+.1f} SE)"
                        for d in e.depends_on
                    )
                    or "-",
                ]
                for e in result.effects
            ],
        )
    if result.unexplained:
        page.heading("Left unexplained")
        page.table(
            ["data", "RMS", "noise", "× noise", "where (most)", "library could take"],
            [
                [
                    u["kind"],
                    f"{u['rms']:.3f} {u['unit']}",
                    f"{u['noise']:.3f} {u['unit']}",
                    u["ratio"],
                    "; ".join(f"{r['source']} {r['region']}" for r in u["regions"]) or "-",
                    f"{u.get('library_share', float('nan')):.0%}",
                ]
                for u in result.unexplained
            ],
        )
    page.heading("Plots")
    bb = _ballbar_figure(result, data)
    if bb is not None:
        page.image(
            "ballbar.png",
            bb,
            "Ballbar runs, each on its own scale (µm/div): measured (grey), the model "
            "before (orange, dashed) and after (blue) the effects were added.",
        )
    pz = _pose_figure(result, data)
    if pz is not None:
        page.image(
            "poses.png",
            pz,
            "Pose residuals over the table (x, y), before and after; each panel has its "
            "own colour scale.",
        )
    page.image("residuals.png", _residual_figure(result), "RMS residual per file, log scale.")
    page.heading("Per file")
    page.table(
        ["file", "kind", "RMS before", "RMS after", "max before", "max after", "unit"],
        [
            [
                r["source"],
                r["kind"],
                r["rms_before"],
                r["rms_after"],
                r["max_before"],
                r["max_after"],
                r["unit"],
            ]
            for r in result.per_run
        ],
    )
    page.heading("Where they disagreed most (before)")
    page.table(
        ["file", "region", "RMS", "× noise"],
        [
            [
                r["source"],
                r["region"],
                f"{r[f'rms_{u}']:.3f} {u}",
                r["ratio"],
            ]
            for r in result.regions[:12]
            for u in ["arcsec" if r["kind"] == "pose_axis" else "um"]
        ],
    )
    return page.files()


# ---------------------------------------------------------------- ballbar


def ballbar_report(analysis: Analysis) -> dict[str, str | bytes]:
    """report.html, report.md and the polar plots of a ballbar analysis."""
    from .ballbar import LABELS, describe, plot_runs

    page = Page("Ballbar analysis")
    page.heading("Summary")
    for line in analysis.lines():
        page.para(line)
    page.para(
        "A figure is reported when it stands above the noise: its p-value, "
        "Bonferroni-corrected over the figures of a run, below 0.001; σ is its "
        "distance from zero in standard errors."
    )
    page.image(
        "ballbar.png",
        plot_runs(analysis.results, analysis.runs, analysis.predicted),
        "Polar plots, one per circle: ccw (blue) and cw (red) overlaid on one scale "
        "(µm/div in each title); dashed: the fitted terms"
        + ("; dotted: the model's simulation." if analysis.predicted else "."),
    )
    page.heading("Runs")
    keys = list(LABELS)[:-1]
    page.table(
        ["file", "direction", "G µm", "noise µm"] + [LABELS[k][0] for k in keys],
        [
            [r.source, r.direction, r.circular_deviation_um, r.noise_um]
            + [
                f"{r.figures[k].value:{LABELS[k][2]}} {LABELS[k][1]}"
                + (f" ({r.figures[k].z:.0f} σ)" if r.figures[k].significant else " (noise)")
                for k in keys
            ]
            for r in analysis.results
        ],
    )
    if analysis.pairs:
        page.heading("Pairs (ccw and cw of one circle)")
        page.table(
            ["circle", "radius mm", "hysteresis µm", "reported"],
            [
                [p.name, p.radius, p.circular_hysteresis_um, describe(p.figures)]
                for p in analysis.pairs
            ],
        )
    return page.files()
