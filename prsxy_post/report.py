"""The ``diagnose --report`` folder: report.md and plots (matplotlib, an optional extra)."""

from __future__ import annotations

import io
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import UsageError

if TYPE_CHECKING:
    from .diagnose import Data, Diagnosis
    from .profile import Profile


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


def _ballbar_figure(result: Diagnosis, current: Profile, data: Data) -> bytes | None:
    from . import diagnose as dg

    if not data.runs:
        return None
    plt = pyplot()
    measured, segs = data.measured()
    before = dg.predict(current, data, want_columns=False).pred
    from .profile import profile_from_dict

    after = dg.predict(profile_from_dict(result.updated), data, want_columns=False).pred
    runs = [s for s in segs if s.kind == "ballbar"]
    n = len(runs)
    cols = min(4, n)
    rows = (n + cols - 1) // cols
    fig = plt.figure(figsize=(4 * cols, 4 * rows))
    for k, (seg, run) in enumerate(zip(runs, data.runs, strict=True)):
        ax = fig.add_subplot(rows, cols, k + 1, projection="polar")
        rel = run.commanded[:, :3] - run.pivot
        ext = np.ptp(rel, axis=0)
        a0, a1 = sorted(np.argsort(ext)[::-1][:2])
        th = np.arctan2(rel[:, a1], rel[:, a0])
        m = measured[seg.start : seg.stop] * 1000
        b = before[seg.start : seg.stop] * 1000
        a = after[seg.start : seg.stop] * 1000
        span = max(np.ptp(np.concatenate([m, b, a])), 1.0)
        base = span * 1.5  # reference circle radius on the plot [µm]
        ax.plot(th, np.full_like(th, base), color="0.7", lw=0.8, label="reference")
        ax.plot(th, base + m, lw=1.0, label="measured")
        ax.plot(th, base + b, lw=0.8, ls="--", label="simulated before")
        ax.plot(th, base + a, lw=0.8, ls=":", label="simulated after")
        ax.set_yticklabels([])
        ax.set_title(f"{seg.name}\n{span / 4:.2g} µm/div", fontsize=9)
        if k == 0:
            ax.legend(loc="lower left", fontsize=7, bbox_to_anchor=(-0.2, -0.25))
    fig.tight_layout()
    return png(fig)


def _pose_figure(result: Diagnosis, current: Profile, data: Data) -> bytes | None:
    from . import diagnose as dg
    from .profile import profile_from_dict

    if not data.poses:
        return None
    plt = pyplot()
    measured, segs = data.measured()
    before = measured - dg.predict(current, data, want_columns=False).pred
    after = measured - dg.predict(profile_from_dict(result.updated), data, want_columns=False).pred
    seg = next(s for s in segs if s.kind == "pose_tip")
    q = data.poses[0].commanded
    eb = np.linalg.norm(before[seg.start : seg.stop].reshape(-1, 3), axis=1) * 1000
    ea = np.linalg.norm(after[seg.start : seg.stop].reshape(-1, 3), axis=1) * 1000
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.5), sharex=True, sharey=True)
    vmax = float(np.nanmax(eb)) if np.isfinite(eb).any() else 1.0
    for ax, e, title in ((axes[0], eb, "before"), (axes[1], ea, "after")):
        sc = ax.scatter(q[:, 0], q[:, 1], c=e, s=14, vmin=0, vmax=vmax, cmap="viridis")
        ax.set_title(f"tip residual {title} (µm)")
        ax.set_xlabel("x (mm)")
        ax.set_aspect("equal")
    axes[0].set_ylabel("y (mm)")
    fig.colorbar(sc, ax=axes, shrink=0.8)
    return png(fig)


def diagnose_report(result: Diagnosis, current: Profile, data: Data) -> dict[str, str | bytes]:
    """Files of the report folder: report.md and the PNG plots."""
    files: dict[str, str | bytes] = {}
    bb = _ballbar_figure(result, current, data)
    if bb is not None:
        files["ballbar.png"] = bb
    pz = _pose_figure(result, current, data)
    if pz is not None:
        files["poses.png"] = pz
    lines = ["# Diagnosis", "", result.summary, ""]
    j = result.to_json()
    lines += [
        f"Residual RMS: {j['rms_before_um']:.3f} µm before, {j['rms_after_um']:.3f} µm "
        "after; estimated noise: "
        + ", ".join(f"{k} {v:.3f} {j['noise_units'][k]}" for k, v in j["noise"].items()),
        "",
    ]
    if result.effects:
        lines += [
            "| effect | estimate | std. error | unit | cannot be told apart from |",
            "|---|---:|---:|---|---|",
        ]
        for e in result.effects:
            lines.append(
                f"| `{e.name}` | {e.estimate:+.6g} | {e.stderr:.2g} | {e.unit} | "
                + (", ".join(f"`{a}`" for a in e.aliases) or "-")
                + " |"
            )
        lines.append("")
    lines += [
        "## Per run",
        "",
        "| file | kind | RMS before | RMS after | max before | max after |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for r in result.per_run:
        lines.append(
            f"| {r['source']} | {r['kind']} | {r['rms_before']:.3f} {r['unit']} | "
            f"{r['rms_after']:.3f} {r['unit']} | {r['max_before']:.3f} | "
            f"{r['max_after']:.3f} |"
        )
    lines += [
        "",
        "## Where they disagreed most (before)",
        "",
        "| file | region | RMS | × noise |",
        "|---|---|---:|---:|",
    ]
    for r in result.regions[:12]:
        unit = "arcsec" if r["kind"] == "pose_axis" else "um"
        lines.append(
            f"| {r['source']} | {r['region']} | {r[f'rms_{unit}']:.3f} {unit} | {r['ratio']:.1f} |"
        )
    if "ballbar.png" in files:
        lines += ["", "![ballbar runs: measured and simulated](ballbar.png)"]
    if "poses.png" in files:
        lines += ["", "![pose residuals](poses.png)"]
    files["report.md"] = "\n".join(lines) + "\n"
    return files
