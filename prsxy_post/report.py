"""Reports people read: one self-contained HTML page and the same in Markdown.

``diagnose --report DIR`` and ``ballbar --report DIR`` write ``report.html`` (the
plots embedded as data, nothing fetched from anywhere: it opens from a USB stick
or as a mail attachment), ``report.md`` and the PNG plots it shows (drawn by
:mod:`prsxy_post.plots`, which needs matplotlib, the optional ``plot`` extra).

A page leads with its conclusion: what was found, the findings the largest and
most significant first, one "what to do next" line (calibrate, measure again,
with which laser spacing), and where the page was written. The tables and plots
that back it follow.
"""

from __future__ import annotations

import base64
import html
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from . import plots
from .ballbar import LABELS, PLANE_CODE, describe, figure_label, findings

if TYPE_CHECKING:
    from .ballbar import Analysis, BallbarResult
    from .diagnose import Data, Diagnosis, Effect


# ---------------------------------------------------------------- the page


_CSS = """
body { font-family: sans-serif; max-width: 1100px; margin: 1.5em auto; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
p.warn { background: #fff3cd; border-left: 4px solid #e0a800; padding: 0.5em 0.8em; }
p.lead { font-size: 1.1em; background: #e8f1fb; border-left: 4px solid #1f77b4;
         padding: 0.6em 0.9em; }
p.next { font-size: 1.05em; background: #e9f7ec; border-left: 4px solid #2ca02c;
         padding: 0.5em 0.9em; }
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

    def para(self, text: str, warn: bool = False, cls: str = "") -> None:
        """A paragraph; ``warn`` or ``cls`` "lead" (the conclusion), "next" (what
        to do next) or "small" mark it out."""
        cls = "warn" if warn else cls
        attr = f' class="{cls}"' if cls else ""
        self.html.append(f"<p{attr}>{html.escape(text)}</p>")
        prefix = {"warn": "**Warning:** ", "lead": "**", "next": "**"}.get(cls, "")
        suffix = "**" if cls in ("lead", "next") else ""
        self.md += [prefix + text + suffix, ""]

    def items(self, texts: Sequence[str]) -> None:
        """A numbered list, in the order given."""
        lis = "".join(f"<li>{html.escape(t)}</li>" for t in texts)
        self.html.append(f"<ol>{lis}</ol>")
        self.md += [f"{k}. {t}" for k, t in enumerate(texts, 1)] + [""]

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


def written_to(page: Page, where: str | Path | None) -> None:
    """Say on the page where it was written (the folder given to ``--report``)."""
    if where is not None:
        path = Path(where).resolve() / "report.html"
        page.para(f"This report: {path} (report.md and the plots beside it).", cls="small")


# ---------------------------------------------------------------- diagnose

#: How many findings the summary lists before pointing at the table.
TOP_FINDINGS = 5
_CYCLIC = re.compile(r"cyclic\[(\d+)\]")


def ordered_effects(result: Diagnosis) -> list[Effect]:
    """The effects by what they explain: the drop of the whitened sum of squares each
    gives (χ², the residual it takes away in units of the noise: size and
    significance in one), largest first; ties by p-value."""
    return sorted(result.effects, key=lambda e: (-e.chi2, e.p_value))


def _laser_spacing(data: Data, motor: int) -> float | None:
    """The widest spacing of a motor's laser targets [mm], None without laser data."""
    parts = [a.target[a.motor == motor] for a in data.axis]
    targets = np.unique(np.concatenate(parts)) if parts else np.zeros(0)
    if len(targets) < 2:
        return None
    return float(np.max(np.diff(targets)))


def laser_needs(data: Data, pitches: Sequence[tuple[int, float]]) -> dict[int, float]:
    """The finest laser target spacing [mm] each motor needs to see its cyclic errors
    of these pitches (two targets a pitch, the Nyquist rule ``calibrate`` applies),
    for the motors whose laser data do not already hold it."""
    out: dict[int, float] = {}
    for motor, pitch in pitches:
        spacing = _laser_spacing(data, motor)
        if spacing is None or spacing > pitch / 2:
            out[motor] = min(out.get(motor, np.inf), pitch / 2)
    return dict(sorted(out.items()))


def _laser_clause(data: Data, need: Mapping[int, float]) -> str:
    parts = []
    for motor, step in need.items():
        spacing = _laser_spacing(data, motor)
        now = f"now {spacing:g} mm" if spacing is not None else "no laser run now"
        parts.append(f"for motor {motor} at most {step:g} mm apart ({now})")
    return (
        "measure with the laser at targets "
        + ", ".join(parts)
        + " (two targets a pitch of the cyclic errors, so that the laser runs show them)"
    )


def diagnose_next(result: Diagnosis, data: Data) -> str:
    """What to do next, in one line: calibrate (and the laser runs the cyclic errors
    found need) then measure again; or measure again where something is left
    unexplained; or nothing."""
    found = [
        (int(m.group(1)), float(e.period))
        for e in result.effects
        if (m := _CYCLIC.fullmatch(e.name)) and e.period
    ]
    if result.effects:
        need = laser_needs(data, found)
        laser = f"; {_laser_clause(data, need)}" if need else ""
        return (
            f"Calibrate: the model misses {len(result.effects)} effect(s); run `prsxy-post "
            "calibrate` on these files with this profile (or take the profile `diagnose -o` "
            f"writes){laser}; then measure again commanded with the calibrated profile and "
            "diagnose that."
        )
    if result.unexplained:
        kinds = ", ".join(u["kind"] for u in result.unexplained)
        closest = [
            (int(m.group(1)), float(c["period_mm"]))
            for u in result.unexplained
            for c in u.get("closest", [])[:1]
            if (m := _CYCLIC.fullmatch(c["name"])) and c.get("period_mm")
        ]
        need = laser_needs(data, closest)
        laser = f"; to test the closest cyclic error, {_laser_clause(data, need)}" if need else ""
        return (
            f"Re-measure: the {kinds} data are left above their noise and no effect of the "
            "library explains it; repeat those runs to see whether it repeats (set-up, "
            f"temperature, the instrument) before changing the model{laser}."
        )
    return "Nothing to do: the model explains the measurements to their noise; convert with it."


def _diagnose_summary(page: Page, result: Diagnosis, data: Data, where: Any) -> None:
    j = result.to_json()
    noise = ", ".join(f"{k} {v:.3f} {j['noise_units'][k]}" for k, v in j["noise"].items())
    effects = ordered_effects(result)
    if effects:
        lead = (
            f"{len(effects)} effect(s) missing from the model: with them the length residual "
            f"falls from {j['rms_before_um']:.3f} µm to {j['rms_after_um']:.3f} µm "
            f"(noise: {noise})."
        )
    elif result.unexplained:
        lead = "No effect of the library explains the disagreement (see the warnings)."
    else:
        lead = f"The model explains the measurements to their noise ({noise}): nothing is missing."
    page.heading("Conclusion")
    page.para(lead, cls="lead")
    page.para("What to do next: " + diagnose_next(result, data), cls="next")
    written_to(page, where)
    for u in result.unexplained:
        page.para(u["sentence"], warn=True)
    if effects:
        page.heading("Largest findings")
        page.items([e.sentence() for e in effects[:TOP_FINDINGS]])
        if len(effects) > TOP_FINDINGS:
            page.para(
                f"… and {len(effects) - TOP_FINDINGS} more in the table 'Effects', in the "
                "same order (by χ², the residual each takes away in units of the noise)."
            )
    if result.map_note is not None:
        page.para(f"Error map: {result.map_note['action']}: {result.map_note['reason']}.")


def _told_apart(e: Effect, most: int = 2) -> str:
    """What the estimate cannot be told from and, of the effects without which it
    would move, the ``most`` it moves most without."""
    parts = [f"not from {', '.join(e.aliases)}"] if e.aliases else []
    deps = sorted(e.depends_on, key=lambda d: -abs(d["in_stderr"]))
    if deps:
        shown = ", ".join(f"{d['name']} ({d['in_stderr']:+.1f} SE)" for d in deps[:most])
        more = f" and {len(deps) - most} more" if len(deps) > most else ""
        parts.append(f"moves without {shown}{more}")
    return "; ".join(parts) or "-"


def _diagnose_tables(page: Page, result: Diagnosis) -> None:
    if result.effects:
        page.heading("Effects (largest first)")
        page.table(
            ["#", "finding", "effect", "estimate ± std. error", "χ²", "depends on"],
            [
                [
                    k,
                    e.sentence(),
                    e.name + (f" @ {e.period:g} mm" if e.period else ""),
                    f"{e.estimate:+.4g} ± {e.stderr:.2g} {e.unit}",
                    e.chi2,
                    _told_apart(e),
                ]
                for k, e in enumerate(ordered_effects(result), 1)
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


def _diagnose_plots(page: Page, result: Diagnosis, data: Data) -> None:
    page.heading("Plots")
    page.image(
        "residuals.png",
        plots.diagnose_residuals(result),
        "RMS residual per file before and after, log scale; black dashes: the estimated "
        "noise of that kind of data (a bar that ends at its dash is explained).",
    )
    res = plots.diagnose_ballbar_residual(result, data)
    if res is not None:
        page.image(
            "ballbar-residual.png",
            res,
            "What the model after leaves of each ballbar run, on a scale of its own "
            "(µm/div): the samples (grey), their 5° average (blue) and ± the estimated "
            "noise (dashed). Seen as RS274/NGC names the directions.",
        )
    bb = plots.diagnose_ballbar(result, data)
    if bb is not None:
        page.image(
            "ballbar.png",
            bb,
            "Ballbar runs, each on its own scale (µm/div): measured (grey), the model "
            "before (orange, dashed) and after (blue) the effects were added.",
        )
    pz = plots.diagnose_poses(result, data)
    if pz is not None:
        page.image(
            "poses.png",
            pz,
            "Pose residuals over the table (x, y), before and after; each panel has its "
            "own colour scale.",
        )


def diagnose_report(
    result: Diagnosis, data: Data, where: str | Path | None = None
) -> dict[str, str | bytes]:
    """Files of the report folder: report.html, report.md and the plots; ``where``
    is the folder they go to, named on the page."""
    page = Page("Diagnosis")
    _diagnose_summary(page, result, data, where)
    _diagnose_tables(page, result)
    _diagnose_plots(page, result, data)
    page.heading("Per file")
    page.table(
        ["file", "kind", "RMS before", "RMS after", "noise", "max before", "max after", "unit"],
        [
            [
                r["source"],
                r["kind"],
                r["rms_before"],
                r["rms_after"],
                plots.noise_of(result, r["kind"]),
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
            [r["source"], r["region"], f"{r[f'rms_{u}']:.3f} {u}", r["ratio"]]
            for r in result.regions[:12]
            for u in ["arcsec" if r["kind"] == "pose_axis" else "um"]
        ],
    )
    return page.files()


# ---------------------------------------------------------------- ballbar


def ballbar_next(analysis: Analysis) -> list[str]:
    """What to do next after a ballbar test."""
    found = [r for r in analysis.results if r.reported()]
    out = []
    if found:
        out.append(
            "Calibrate or diagnose: the figures above the noise are the machine's; run "
            "`prsxy-post diagnose` (or `calibrate`) on these runs with the profile that "
            "commanded them to name the profile terms behind them."
        )
    dirs: dict[tuple[str, float, float], set[str]] = {}
    for r in analysis.results:
        dirs.setdefault((r.plane, round(r.radius, 6), round(r.tilt_deg, 1)), set()).add(r.direction)
    single = [k for k, d in dirs.items() if len(d) < 2]
    if single:
        out.append(
            f"Re-measure: {len(single)} circle(s) ran one way only; run each both ways "
            "(G2 and G3) to tell servo mismatch from squareness and to see the hysteresis."
        )
    if not out:
        out.append("Nothing to do: no figure stands above the noise of these runs.")
    return out


def _run_row(r: BallbarResult) -> list[Any]:
    found = findings(r.figures)
    return [
        Path(r.source).name,
        r.circle,
        f"{r.direction} ({PLANE_CODE[r.plane]} {r.gcode}, from {r.viewed_from})",
        f"F{r.feed_mm_min:.0f}",
        r.circular_deviation_um,
        r.noise_um,
        "; ".join(
            f"{figure_label(k, r.plane)} {f.value:{LABELS[k][2]}} {LABELS[k][1]} ({f.z:.0f} σ)"
            for k, f in found
        )
        or "nothing above the noise",
    ]


def ballbar_report(analysis: Analysis, where: str | Path | None = None) -> dict[str, str | bytes]:
    """report.html, report.md and the polar plots of a ballbar analysis; ``where``
    is the folder they go to, named on the page."""
    page = Page("Ballbar analysis")
    page.heading("Conclusion")
    worst = max(analysis.results, key=lambda r: r.circular_deviation_um)
    n_found = sum(bool(r.reported()) for r in analysis.results)
    page.para(
        f"{len(analysis.results)} run(s); the largest circular deviation G is "
        f"{worst.circular_deviation_um:.2f} µm ({worst.label}); {n_found} run(s) show a "
        "figure above the noise.",
        cls="lead",
    )
    page.para("What to do next: " + " ".join(ballbar_next(analysis)), cls="next")
    written_to(page, where)
    page.heading("Polar plots")
    page.image(
        "ballbar.png",
        plots.ballbar_plot(analysis.results, analysis.runs, analysis.predicted),
        "Polar plots, one per circle, seen from the side RS274/NGC names the direction "
        "from: ccw (G3, blue) and cw (G2, red) overlaid on one scale (µm/div in each "
        "title); dashed: the fitted terms"
        + ("; dotted: the model's simulation." if analysis.predicted else "."),
    )
    page.heading("Runs")
    page.table(
        ["file", "circle", "direction", "feed", "G µm", "noise µm", "above the noise"],
        [_run_row(r) for r in analysis.results],
    )
    page.image(
        "ballbar-residual.png",
        plots.ballbar_residual(analysis.results, analysis.runs),
        "What the fitted terms leave of each run, on a scale of its own (µm/div): the "
        "samples (grey), their 5° average (blue), ± the fit's scatter (dashed); cyclic "
        "errors and reversal spikes show here.",
    )
    if analysis.pairs:
        page.heading("Pairs (ccw and cw of one circle)")
        page.table(
            ["circle", "feed", "hysteresis µm", "above the noise"],
            [
                [
                    p.circle,
                    f"F{p.feed_mm_min:.0f}",
                    p.circular_hysteresis_um,
                    describe(p.figures, plane=p.plane),
                ]
                for p in analysis.pairs
            ],
        )
    page.para(
        "A figure is above the noise when its p-value, Bonferroni-corrected over the "
        "figures of a run, is below 0.001; σ is its distance from zero in standard "
        "errors. Directions as RS274/NGC names G2 (cw) and G3 (ccw): seen from the "
        "positive end of the axis normal to the plane (+Z for XY, +Y for XZ, +X for YZ).",
        cls="small",
    )
    return page.files()
