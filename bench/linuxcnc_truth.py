"""Corrected G-code as LinuxCNC's own motion controller runs it: the table.

Each program is converted to corrected G-code for its machine and run twice: as
straight lines each in its written G93 time (tests/controllers.py, what
tests/test_controller_truth.py judges), and on LinuxCNC 2.9 itself, headless
(tests/linuxcnc_motion.py: its trajectory planner, blends and 1 ms servo cycle).
Both are executed by the true machine and judged against the G-code's geometry
(tests/test_linuxcnc_motion.py's run_on_linuxcnc). LinuxCNC runs in real time:
the found programs take about eight minutes.

    python bench/linuxcnc_truth.py                      # the found programs, with play
    python bench/linuxcnc_truth.py --no-play            # the same machines without play
    python bench/linuxcnc_truth.py --programs samples   # the samples, random machine 11
    python bench/linuxcnc_truth.py --longest 10         # skip programs longer than 10 s
    python bench/linuxcnc_truth.py --blends             # the parabolic blends, measured
    python bench/linuxcnc_truth.py --g61-everywhere     # with g61_every_line = 1
    python bench/linuxcnc_truth.py --markdown           # docs/measurements.md's section,
                                                        # the counts within each bound after
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mdsection  # noqa: E402

from tests import controllers as ctl  # noqa: E402
from tests import linuxcnc_motion as lm  # noqa: E402
from tests.test_controller_truth import FOUND, FOUND_IDS, judge_gcode  # noqa: E402
from tests.test_linuxcnc_motion import _peak_speed, _plunge, run_on_linuxcnc  # noqa: E402
from tests.test_tracking import convert, truth_machine, with_output_setting  # noqa: E402


def blends() -> None:
    """A straight plunge Z2 → Z0 as forty G93 lines (the test's _plunge, at F300
    and F60), A still or turning 2e-7° a line, at the profile's acceleration limit
    and at ten times it: LinuxCNC's largest X Y Z speed over a servo cycle."""
    print("| feed | A per line | acceleration limit mm/s² | peak speed / F | LinuxCNC s |")
    print("|---|---|---|---:|---:|")
    nominal = truth_machine("nominal", None).limits
    start = np.array([0.0, 0.0, 2.0, 0.0, 0.0])
    for feed in (300.0, 60.0):
        for turn in (0.0, 2e-7):
            for accel in (nominal.max_accel_mm_s2, 10 * nominal.max_accel_mm_s2):
                limits = dataclasses.replace(nominal, max_accel_mm_s2=accel)
                run = lm.run(_plunge(turn, feed), limits, start, timeout_s=60.0)
                peak = _peak_speed(run)
                print(
                    f"| F{feed:g} | {turn:g}° | {accel:g} | {peak / feed:.4f} | {run.t[-1]:.3f} |",
                    flush=True,
                )


#: the bounds the section of docs/measurements.md counts programs within: the path
#: and tool-axis tolerance, and the speed the G-code commands (with its rounding)
BOUNDS = {"path ≤ 0.5 µm": 0.5, "tool axis ≤ 0.5 arcsec": 0.5, "speed ≤ 1.001 F": 1.001}


def counts_table(label: str, judged: list[tuple[float, float, float]]) -> str:
    """How many of the judged programs (path µm, tool axis arcsec, speed / F) hold each
    bound, and all three, as the section's table."""
    within = [[v <= b for v, b in zip(j, BOUNDS.values(), strict=True)] for j in judged]
    cells = [sum(w[k] for w in within) for k in range(len(BOUNDS))] + [sum(all(w) for w in within)]
    return "\n".join(
        [
            "| on LinuxCNC 2.9 | " + " | ".join(BOUNDS) + " | all three |",
            "|---|" + "---:|" * (len(BOUNDS) + 1),
            f"| {label} | " + " | ".join(str(c) for c in cells) + " |",
        ]
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--programs", choices=["found", "samples"], default="found")
    ap.add_argument("--no-play", action="store_true", help="the machines without play")
    ap.add_argument("--longest", type=float, default=60.0, help="skip longer programs [s]")
    ap.add_argument("--blends", action="store_true", help="the parabolic blends alone")
    ap.add_argument(
        "--g61-everywhere",
        action="store_true",
        help="write with [output.gcode] g61_every_line = 1: every line in G61 (exact "
        "path, a stop at every point)",
    )
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    if not lm.available():
        sys.exit("LinuxCNC is not installed (apt-get install linuxcnc-uspace)")
    if args.markdown:
        print(mdsection.header("Corrected G-code on LinuxCNC 2.9"))
    if args.blends:
        blends()
        return
    if args.programs == "found":
        jobs = [(name, seed, text) for name, (seed, text) in zip(FOUND_IDS, FOUND, strict=True)]
    else:
        jobs = [(p.name, 11, p.read_text()) for p in sorted((ROOT / "samples").glob("*.ngc"))]
    print(
        "| program | machine | as written: speed / F, path µm "
        "| on LinuxCNC: speed / F, path µm, tool axis arcsec | time written / LinuxCNC s "
        "| LinuxCNC's largest speed over F mm/s |"
    )
    print("|---|---|---|---|---|---:|")
    judged: list[tuple[float, float, float]] = []
    for name, seed, text in jobs:
        truth = truth_machine("random", seed, play=not args.no_play)
        if args.g61_everywhere:
            truth = with_output_setting(truth, "gcode", "g61_every_line", 1)
        motions, res, texts = convert(truth, text, "gcode")
        written = ctl.run_gcode(texts[0])
        if written.t[-1] > args.longest:
            print(f"| {name} | random {seed} | skipped: {written.t[-1]:.0f} s | | | |", flush=True)
            continue
        # the model judge reads the G64 P tolerance, which a program all in G61 has not
        as_written = "-"
        if not args.g61_everywhere:
            model, _ = judge_gcode(truth, motions, res, texts)
            as_written = f"{model.speed_ratio:.4f}, {model.path_mm * 1e3:.3f}"
        tr, run, _ = run_on_linuxcnc(truth, motions, res, texts[0])
        judged.append((tr.path_mm * 1e3, tr.ab_deg * 3600, tr.speed_ratio))
        print(
            f"| {name} | random {seed} | {as_written} "
            f"| {tr.speed_ratio:.4f}, {tr.path_mm * 1e3:.3f}, {tr.ab_deg * 3600:.2f} "
            f"| {written.t[-1]:.2f} / {run.t[-1]:.2f} | {tr.speed_excess_mm_s:.3f} |",
            flush=True,
        )
    if args.markdown:
        setting = ", `g61_every_line = 1`" if args.g61_everywhere else ""
        play = "without play" if args.no_play else "with play"
        label = f"the {len(judged)} {args.programs} programs ({play}{setting})"
        print("\n" + counts_table(label, judged))


if __name__ == "__main__":
    main()
