"""What the controller executes: the table of docs/measurements.md, measured.

Every sample is converted for the nominal machine and for machines with random
errors in every contract term and backlash in every motor (seeds 11-13), in both
formats; the written program is run as its controller runs it (the PVT cubics of
Turbo PMAC; LinuxCNC's straight lines between the written points), densely
sampled between the points, executed by the true machine (play model, forward
kinematics) and held against the G-code's geometry (tests/controllers.py, the
same code the tests use).

    python bench/controller_truth.py            # the table, Markdown
    python bench/controller_truth.py --servo-ms 0.442 0.884 --found
        # PMAC at the servo clock (Turbo PMAC commands each cubic at its ticks
        # only; 0.442 ms is its default cycle): the samples and the programs the
        # search found (tests/test_controller_truth.py FOUND), a column per cycle
    python bench/controller_truth.py --servo-ms 0.442 --found --phases 4
        # each cell the worst over the clock's ticks moved by 0, 1/4, 1/2, 3/4 of a
        # cycle: how much a figure owes to where the ticks fall
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mdsection  # noqa: E402

from prsxy_post import kinematics  # noqa: E402
from tests import controllers as ctl  # noqa: E402
from tests.test_tracking import (  # noqa: E402
    _tool_of_lines,
    _tool_of_segments,
    convert,
    path_distance,
    truth_machine,
)

MACHINES = [("nominal", None), ("random", 11), ("random", 12), ("random", 13)]


def at_points(motions, q: np.ndarray, line: np.ndarray) -> float:
    """Largest distance of the executed points themselves from their lines' paths."""
    worst = 0.0
    for ln in np.unique(line):
        ms = [m for m in motions if m.line == ln and m.kind not in ("dwell", "function")]
        if not ms:
            continue
        sel = line == ln
        d = np.min([path_distance(m, q[sel])[0] for m in ms], axis=0)
        worst = max(worst, float(d.max()))
    return worst


def measure(
    text: str,
    fmt: str,
    kind: str,
    seed: int | None,
    servo_ms: float | None = None,
    phases: int = 1,
) -> dict[str, float]:
    truth = truth_machine(kind, seed)
    motions, res, texts = convert(truth, text, fmt)
    rapid = truth.limits.rapid_mm_min
    if fmt == "pmac":
        trs = []
        for k in range(phases if servo_ms else 1):
            run = ctl.run_pmac(texts, servo_ms=servo_ms, servo_phase=k / phases)
            tool = _tool_of_segments(res, run.line, run.seg)
            q = ctl.machine_executes(truth, run.t_dense, run.P_dense, tool)
            trs.append(ctl.judge(motions, q, run.t_dense, run.seg, run.line, tool, rapid))
        # the worst of each figure over the phases
        tr = ctl.Trace(
            max(x.path_mm for x in trs),
            max(x.ab_deg for x in trs),
            max(x.speed_ratio for x in trs),
            max(x.accel_mm_s2 for x in trs),
            max(trs, key=lambda x: x.path_mm).worst_line,
        )
        pts = ctl.machine_executes(truth, run.t, run.P, _tool_of_lines(res, run.line))
        point = at_points(motions, pts, run.line)
        blend = 0.0
    else:
        grun = ctl.run_gcode(texts[0])
        tool = _tool_of_segments(res, grun.line, grun.seg)
        cgeo = kinematics.controller_geometry(truth)
        P = kinematics.inverse(cgeo, grun.q_dense).P
        q = ctl.machine_executes(truth, grun.t_dense, P, tool)
        tr = ctl.judge(motions, q, grun.t_dense, grun.seg, grun.line, tool, rapid)
        Pp = kinematics.inverse(cgeo, grun.q).P
        pts = ctl.machine_executes(truth, grun.t, Pp, _tool_of_lines(res, grun.line))
        point = at_points(motions, pts, grun.line)
        blend = grun.blend or 0.0
    return {
        "path_um": tr.path_mm * 1000.0,
        "points_um": point * 1000.0,
        "ab_arcsec": tr.ab_deg * 3600.0,
        "speed": tr.speed_ratio,
        "blend_um": blend * 1000.0,
    }


def servo_table(periods: list[float], found: bool, phases: int) -> None:
    """PMAC at the servo clock: worst path µm / tool axis arcsec / speed over F, per
    cycle, over the four machines for a sample, on its machine for a found program,
    over ``phases`` positions of the ticks."""
    cases: list[tuple[str, list[tuple[str, int | None]], str]] = [
        (p.name, MACHINES, p.read_text()) for p in sorted((ROOT / "samples").glob("*.ngc"))
    ]
    if found:
        from tests.test_controller_truth import FOUND, FOUND_IDS

        cases += [(n, [("random", sd)], t) for n, (sd, t) in zip(FOUND_IDS, FOUND, strict=True)]
    heads = ["even 16 a segment"] + [f"servo {ms:g} ms" for ms in periods]
    print("| program | " + " | ".join(heads) + " |")
    print("|---|" + "---:|" * len(heads))
    worst = [[0.0, 0.0, 0.0] for _ in heads]
    for name, machines, text in cases:
        cells = []
        for k, ms in enumerate([None, *periods]):
            rows = [measure(text, "pmac", kind, sd, ms, phases) for kind, sd in machines]
            w = [max(r[key] for r in rows) for key in ("path_um", "ab_arcsec", "speed")]
            worst[k] = [max(a, b) for a, b in zip(worst[k], w, strict=True)]
            cells.append(f"{w[0]:.3f} µm / {w[1]:.2f}″ / {w[2]:.4f}")
        print(f"| {name} | " + " | ".join(cells) + " |", flush=True)
    print(
        "| largest | "
        + " | ".join(f"{w[0]:.3f} µm / {w[1]:.2f}″ / {w[2]:.4f}" for w in worst)
        + " |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--servo-ms", type=float, nargs="+", help="PMAC at these servo cycles")
    ap.add_argument("--found", action="store_true", help="with --servo-ms: the found programs too")
    ap.add_argument(
        "--phases",
        type=int,
        default=1,
        help="with --servo-ms: the worst over this many tick phases",
    )
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    if args.markdown:
        title = "At the servo clock" if args.servo_ms else "What the controller executes"
        print(mdsection.header(title))
    if args.servo_ms:
        servo_table(args.servo_ms, args.found, args.phases)
        return
    print(
        "| program | format | largest path error between points µm (nominal / random 11, "
        "12, 13) | at the points µm | tool axis arcsec | speed / F |"
    )
    print("|---|---|---|---:|---:|---:|")
    for path in sorted((ROOT / "samples").glob("*.ngc")):
        for fmt in ("pmac", "gcode"):
            rows = [measure(path.read_text(), fmt, k, s) for k, s in MACHINES]
            between = " / ".join(f"{r['path_um']:.3f}" for r in rows)
            extra = f" + G64 P {rows[0]['blend_um']:.2f}" if fmt == "gcode" else ""
            print(
                f"| {path.name} | {fmt} | {between}{extra} | "
                f"{max(r['points_um'] for r in rows):.3f} | "
                f"{max(r['ab_arcsec'] for r in rows):.3f} | "
                f"{max(r['speed'] for r in rows):.4f} |"
            )


if __name__ == "__main__":
    main()
