"""Why the five-axis square at F10000 is slower on LinuxCNC on machines with errors.

Two measurements behind docs/measurements.md's "LinuxCNC's planner speed on
corrected G-code":

1. How far the corrected points of each 40 mm side of the five-axis square
   (``PROGRAMS["five-axis"]``) depart from one straight line, as LinuxCNC would run
   one line per side (X Y Z, and A B moving in proportion to X Y Z progress,
   ``tcGetPosReal``): from the chord between the side's ends, and from the best
   line (half the spread about the chord: the Chebyshev fit where the departure is
   convex, at most that elsewhere). One line a side keeps the path only where these
   are within ``tolerance_mm`` (0.1 µm) and the tool-axis share.
2. What a side in two lines costs LinuxCNC itself: the square with each side split
   in two blocks on the nominal machine (the tilt exactly linear), as written by
   prsxy-post and run by LinuxCNC 2.9 (tests/linuxcnc_motion.py).

    python bench/linuxcnc_sides.py            # both
    python bench/linuxcnc_sides.py --no-run   # the departures only (no LinuxCNC)
"""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import kinematics  # noqa: E402
from prsxy_post.writers.cartesian import WrittenPoints  # noqa: E402
from tests.test_linuxcnc_motion import HEAD, PROGRAMS, convert, measure  # noqa: E402
from tests.test_tracking import truth_machine  # noqa: E402

#: the square's corners: X Y A B (Z 0)
CORNERS = [(-20, -20, 0, 0), (20, -20, 5, -3), (20, 20, -5, 3), (-20, 20, -8, 8), (-20, -20, 0, 0)]


def split_square(feed: float, n: int) -> str:
    """The five-axis square with each side in ``n`` blocks."""
    body = f"G0 X-20 Y-20 Z2 A0 B0\nG1 Z0 F{feed:g}\n"
    for p, q in itertools.pairwise(CORNERS):
        for k in range(1, n + 1):
            v = [p[j] + k / n * (q[j] - p[j]) for j in range(4)]
            body += f"G1 X{v[0]:.6f} Y{v[1]:.6f} A{v[2]:.6f} B{v[3]:.6f}\n"
    return HEAD + body + "G0 Z2\nM2\n"


def departures(truth) -> list[tuple[float, float, float, float]]:
    """Per side of the square: X Y Z from the chord and from the best line [µm],
    A B (the larger) from the chord and from the best line [arcsec]."""
    _, res, _ = convert(truth, PROGRAMS["five-axis"](3000.0), "gcode")
    pts = res.points
    q = WrittenPoints(kinematics.controller_geometry(truth))(pts)
    ends = np.flatnonzero(pts.block_end)
    out = []
    for s, e in itertools.pairwise(ends):
        side = q[s : e + 1]
        d = side[-1] - side[0]
        if np.hypot(*d[:2]) < 39.0:  # the plunge and the retract
            continue
        tau = (side[:, :3] - side[0, :3]) @ d[:3] / (d[:3] @ d[:3])
        off = side - (side[0] + tau[:, None] * d)
        xyz = np.linalg.norm(off[:, :3], axis=1).max() * 1e3
        half = (off.max(axis=0) - off.min(axis=0)) / 2.0
        ab = np.abs(off[:, 3:]).max() * 3600.0
        out.append((xyz, np.linalg.norm(half[:3]) * 1e3, ab, half[3:].max() * 3600.0))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="*", default=[11, 12, 13])
    ap.add_argument("--no-run", action="store_true")
    args = ap.parse_args()
    print(
        "| machine | side | X Y Z from the chord µm | from the best line µm "
        "| A B from the chord arcsec | from the best line arcsec |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    for seed in args.seeds:
        for i, row in enumerate(departures(truth_machine("random", seed, play=False))):
            print(f"| random {seed} | {i + 1} | " + " | ".join(f"{x:.3f}" for x in row) + " |")
    if args.no_run:
        return
    print()
    print("| square, nominal machine | lines | planned s | LinuxCNC s | / planned |")
    print("|---|---:|---:|---:|---:|")
    nominal = truth_machine("nominal", None)
    for feed in (3000.0, 10000.0):
        for n in (1, 2):
            m = measure(nominal, split_square(feed, n))
            own = m["lcnc"] - m["lcnc_waiting"]
            print(
                f"| F{feed:g}, {n} line{'s' if n > 1 else ''} a side | {m['lines']:.0f} "
                f"| {m['planned']:.3f} | {own:.3f} | {own / m['planned']:.3f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
