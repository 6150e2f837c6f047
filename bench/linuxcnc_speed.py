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
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mdsection  # noqa: E402

from tests import linuxcnc_motion as lm  # noqa: E402
from tests.test_linuxcnc_motion import PROGRAMS, measure  # noqa: E402
from tests.test_tracking import truth_machine  # noqa: E402

FEEDS = (600.0, 3000.0, 10000.0)
SEEDS = (11, 12, 13)


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
        "| program | machine | lines | planned s | LinuxCNC s (queue empty) "
        "| uncorrected s (queue empty) | / planned | / uncorrected | speed / F | path µm "
        "| tool axis arcsec |"
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
            # the planner's own time: less the cycles its queue stood empty, waiting
            # for LinuxCNC's task on this shared host (MotionRun.waiting_s)
            own, plain = m["lcnc"] - m["lcnc_waiting"], m["plain"] - m["plain_waiting"]
            r_plan, r_plain = own / m["planned"], own / plain
            row = [r_plan, r_plain, m["speed"], m["path_um"], m["axis_arcsec"]]
            worst = np.maximum(worst, row)
            print(
                f"| {pname} | {mname} | {m['lines']:.0f} | {m['planned']:.3f} "
                f"| {m['lcnc']:.3f} ({m['lcnc_waiting']:.3f}) "
                f"| {m['plain']:.3f} ({m['plain_waiting']:.3f}) | {r_plan:.3f} | {r_plain:.3f} "
                f"| {m['speed']:.4f} | {m['path_um']:.3f} | {m['axis_arcsec']:.3f} |",
                flush=True,
            )
    print(
        f"| **worst** | | | | | | {worst[0]:.3f} | {worst[1]:.3f} | {worst[2]:.4f} "
        f"| {worst[3]:.3f} | {worst[4]:.3f} |"
    )


if __name__ == "__main__":
    main()
