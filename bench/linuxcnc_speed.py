"""How fast LinuxCNC's own planner runs corrected G-code: the table.

Each program is converted to corrected G-code for its machine and run on LinuxCNC 2.9
itself, headless (tests/linuxcnc_motion.py: its trajectory planner and 1 ms servo
cycle), as is the uncorrected program (under the same ``G64 P``). The true machine
follows what LinuxCNC commanded and is judged against the G-code's geometry
(tests/test_linuxcnc_motion.py's run_on_linuxcnc). Programs: the generated ones
of :data:`PROGRAMS` at F600, F3000 and F10000, and the samples as written; machines:
the nominal one and random machines with contract errors (no play). LinuxCNC runs in
real time: a few minutes.

    python bench/linuxcnc_speed.py                 # all of them
    python bench/linuxcnc_speed.py --seeds 11      # one machine with errors
    python bench/linuxcnc_speed.py --feeds 3000 --programs arcs helix
    python bench/linuxcnc_speed.py --markdown      # docs/measurements.md's section
"""

from __future__ import annotations

import argparse
import re
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mdsection  # noqa: E402

from tests import controllers as ctl  # noqa: E402
from tests import linuxcnc_motion as lm  # noqa: E402
from tests.test_linuxcnc_motion import run_on_linuxcnc  # noqa: E402
from tests.test_tracking import convert, truth_machine  # noqa: E402

HEAD = "G21 G90 G17 G40 G49 G94\n"


def _lines(f: float) -> str:
    return HEAD + (
        f"G0 X-20 Y-20 Z2\nG1 Z0 F{f}\nG1 X20 Y-18\nG1 X22 Y15\nG1 X-15 Y20\n"
        "G1 X-20 Y-20\nG0 Z2\nM2\n"
    )


def _arcs(f: float) -> str:
    return HEAD + (
        f"G0 X20 Y0 Z2\nG1 Z0 F{f}\nG3 X0 Y20 R20\nG3 X-20 Y0 R20\nG2 X-40 Y0 R10\n"
        "G2 X-20 Y0 R10\nG3 X20 Y0 I20 J0\nG0 Z2\nM2\n"
    )


def _helix(f: float) -> str:
    return HEAD + (f"G0 X10 Y0 Z2\nG1 Z0 F{f}\nG2 X10 Y0 Z-3 I-10 J0 P2\nG0 Z2\nM2\n")


def _five_axis(f: float) -> str:
    return HEAD + (
        f"G0 X-20 Y-20 Z2 A0 B0\nG1 Z0 F{f}\nG1 X20 Y-20 A5 B-3\nG1 X20 Y20 A-5 B3\n"
        "G1 X-20 Y20 A-8 B8\nG1 X-20 Y-20 A0 B0\nG0 Z2\nM2\n"
    )


#: the generated programs, by name: G-code text at a feed [mm/min]
PROGRAMS: dict[str, Callable[[float], str]] = {
    "lines": _lines,
    "arcs": _arcs,
    "helix": _helix,
    "five-axis": _five_axis,
}
FEEDS = (600.0, 3000.0, 10000.0)
SEEDS = (11, 12, 13)


def uncorrected(text: str, blend_mm: float) -> str:
    """The program under the corrected program's ``G64 P`` (LinuxCNC's G64 without P
    may cut corners by any amount)."""
    return f"G64 P{blend_mm:g}\n" + text


def measure(truth, text: str) -> dict[str, float]:
    """Run the corrected and the uncorrected program on LinuxCNC: times, speed, path."""
    motions, res, texts = convert(truth, text, "gcode")
    written = ctl.run_gcode(texts[0])
    tr, run, _ = run_on_linuxcnc(truth, motions, res, texts[0])
    plain = lm.run(
        uncorrected(text, written.blend or 0.0),
        truth.limits,
        written.q[0],
        timeout_s=3.0 * written.t[-1] + 30.0,
    )
    assert not plain.errors, plain.errors
    # the plan's own time, which the writer records at the end (a chord's G93 time
    # is its length at its fastest piece's rate, shorter than the plan's)
    planned = float(re.findall(r"\(end: \d+ points, ([0-9.]+) s\)", texts[0])[-1])
    return {
        "planned": planned,
        "lcnc": float(run.t[-1]),
        "plain": float(plain.t[-1]),
        "speed": tr.speed_ratio,
        "path_um": tr.path_mm * 1e3,
        "axis_arcsec": tr.ab_deg * 3600.0,
        "lines": float(texts[0].count("\nG1 ")),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=list(SEEDS))
    ap.add_argument("--no-nominal", action="store_true")
    ap.add_argument("--feeds", type=float, nargs="*", default=list(FEEDS))
    ap.add_argument("--programs", nargs="*", default=[*PROGRAMS, "samples"])
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args()
    if not lm.available():
        sys.exit("LinuxCNC is not installed (apt-get install linuxcnc-uspace)")
    if args.markdown:
        print(mdsection.header("LinuxCNC's planner speed on corrected G-code"))
    machines = ([] if args.no_nominal else [("nominal", None)]) + [
        (f"random {s}", s) for s in args.seeds
    ]
    jobs: list[tuple[str, str]] = []
    for name in args.programs:
        if name == "samples":
            jobs += [(p.name, p.read_text()) for p in sorted((ROOT / "samples").glob("*.ngc"))]
        else:
            jobs += [(f"{name} F{f:g}", PROGRAMS[name](f)) for f in args.feeds]
    print(
        "| program | machine | lines | planned s | LinuxCNC s | uncorrected s "
        "| / planned | / uncorrected | speed / F | path µm | tool axis arcsec |"
    )
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    worst = np.zeros(5)
    for mname, seed in machines:
        truth = (
            truth_machine("nominal", None)
            if seed is None
            else truth_machine("random", seed, play=False)
        )
        for pname, text in jobs:
            m = measure(truth, text)
            r_plan, r_plain = m["lcnc"] / m["planned"], m["lcnc"] / m["plain"]
            row = [r_plan, r_plain, m["speed"], m["path_um"], m["axis_arcsec"]]
            worst = np.maximum(worst, row)
            print(
                f"| {pname} | {mname} | {m['lines']:.0f} | {m['planned']:.3f} | {m['lcnc']:.3f} "
                f"| {m['plain']:.3f} | {r_plan:.3f} | {r_plain:.3f} | {m['speed']:.4f} "
                f"| {m['path_um']:.3f} | {m['axis_arcsec']:.3f} |",
                flush=True,
            )
    print(
        f"| **worst** | | | | | | {worst[0]:.3f} | {worst[1]:.3f} | {worst[2]:.4f} "
        f"| {worst[3]:.3f} | {worst[4]:.3f} |"
    )


if __name__ == "__main__":
    main()
