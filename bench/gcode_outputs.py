"""Write the corrected G-code of the programs LinuxCNC's speed table runs, one file each.

For comparing two writers' text byte for byte (the arcs port of issue 33: main's
kernel writer against the branch ``h/arcs``'s Python writer): run it from each
checkout into its own directory, then ``cmp`` the files pairwise. Programs: the
generated ones of ``tests.test_linuxcnc_motion.PROGRAMS`` at F600, F3000, F10000,
the samples and helices that turn A and B a little; machines: the nominal one and
random 11 and 13 with contract errors, without play (``bench/linuxcnc_speed.py``'s)
and with it (the tilt is then never held); each fed to the chain at once and
``--chunk`` motions at a time.

    python bench/gcode_outputs.py /tmp/out-mine
    cd /tmp/h-arcs && python /path/to/bench/gcode_outputs.py /tmp/out-arcs --root .
    for f in /tmp/out-arcs/*; do cmp -s $f /tmp/out-mine/${f##*/} || echo ${f##*/}; done
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--root", type=Path, default=Path(__file__).resolve().parent.parent)
    ap.add_argument("--chunk", type=int, default=5)
    ap.add_argument("--seeds", type=int, nargs="*", default=[11, 13])
    args = ap.parse_args()
    root = args.root.resolve()
    sys.path.insert(0, str(root))
    from tests.test_linuxcnc_motion import PROGRAMS
    from tests.test_tracking import convert, truth_machine

    jobs = [(f"{n}-F{f:g}", PROGRAMS[n](f)) for n in PROGRAMS for f in (600.0, 3000.0, 10000.0)]
    jobs += [(p.stem, p.read_text()) for p in sorted((root / "samples").glob("*.ngc"))]
    # helices that turn A a little (the held tilt must change along the arcs)
    from tests.test_linuxcnc_motion import HEAD

    for turn in (0.002, 0.01, 0.05):
        for f in (600.0, 3000.0):
            jobs.append(
                (
                    f"tilted-helix-{turn:g}-F{f:g}",
                    HEAD + f"G0 X10 Y0 Z2 A0 B0\nG1 Z0 F{f}\nG2 X10 Y0 Z-3 I-10 J0 P2 A{turn:g} "
                    f"B{-turn / 2:g}\nG0 Z2\nM2\n",
                )
            )
    # arcs in G18 and G19
    jobs.append(
        (
            "planes-F3000",
            HEAD + "G0 X3 Y0 Z2\nG1 Z0 F3000\nG18 G2 X-3 Z0 I-3 K0\nG19 G3 Y3 Z0 J1.5 K0\n"
            "G17\nG0 Z5\nM2\n",
        )
    )
    machines = [("nominal", truth_machine("nominal", None))]
    for s in args.seeds:
        machines.append((f"r{s}", truth_machine("random", s, play=False)))
        machines.append((f"r{s}play", truth_machine("random", s)))
    args.out.mkdir(parents=True, exist_ok=True)
    for mname, truth in machines:
        for pname, text in jobs:
            for chunk in (0, args.chunk):
                _, _, texts = convert(truth, text, "gcode", chunk)
                (args.out / f"{pname}.{mname}.c{chunk}.ngc").write_text(texts[0])
        print(mname, flush=True)


if __name__ == "__main__":
    main()
