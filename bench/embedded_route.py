"""The two routes to the calibrated machine, side by side: the path error of the
baked PVT program (prsxy-post convert --format pmac: the chain's compensated
motor points, Turbo PMAC's cubics at its servo clock) and of the embedded route
(the G-code's moves as a Cartesian program, Turbo PMAC segmenting them every
Isx13, running the exported inverse kinematics at each segment end and splining
the motors between), on the same programs and machines.

Both run on the true machine (forward kinematics of the machine the profile
describes) and are judged against the G-code's geometry by the same code as the
tests (tests/controllers.py, tests/pmac_segmented.py). By default the machines
have no play; with --play every motor has backlash (the controller-truth
machines): the PVT route crosses it in the chain's windows, the embedded route
leaves it to the controller's own tables (``tables export --format pmac``, applied
at the servo clock as tests/test_controller_tables_pmac.py's Turbo PMAC applies
them: COMP tables, Ixx86 + BLCOMP taken up at Ixx85 per cycle past the
hysteresis).

    python bench/embedded_route.py                 # Markdown table
    python bench/embedded_route.py --seg-ms 10 5 2 # Isx13 values (default 10 5)
    python bench/embedded_route.py --play          # machines with backlash
    python bench/embedded_route.py --blending 2000 # blended against stop-and-go
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import gcode, program, simulate, writers  # noqa: E402
from prsxy_post.controller_tables import pmac as pmac_tables  # noqa: E402
from prsxy_post.profile import MOTORS  # noqa: E402
from prsxy_post.writers import pmac_cartesian  # noqa: E402
from tests import controllers as ctl  # noqa: E402
from tests.pmac_segmented import run_segmented  # noqa: E402
from tests.test_controller_tables_pmac import TurboPmac  # noqa: E402
from tests.test_tracking import _tool_of_segments, convert, truth_machine  # noqa: E402

MACHINES = [("nominal", None), ("random", 11), ("random", 12), ("effects", 13)]
PROV = writers.Provenance("x.ngc", "0" * 64, "p", "p.toml", "0" * 64, "")


def machine(kind: str, seed: int | None, play: bool = False):
    if kind == "effects":
        base = truth_machine("nominal", None, play=False)
        return simulate.random_machine(
            base, np.random.default_rng(seed), effects=True, axis_errors=play
        )
    return truth_machine(kind, seed, play=play)


def through_tables(truth, P: np.ndarray) -> np.ndarray:
    """The motors' desired positions (servo samples, mm) as Turbo PMAC commands them
    with the profile's tables downloaded (``tables export --format pmac``)."""
    if not truth.axis_comp:
        return P
    pmac = TurboPmac()
    pmac.download(pmac_tables.export(truth).text)
    out = P.copy()
    for col, m in enumerate(MOTORS):
        cpm = truth.motor(m).counts_per_mm
        out[:, col] = pmac.motor_positions(m, cpm, P[:, col])[: len(P)]
    return out


def pvt(truth, text: str) -> tuple[float, float, float]:
    """Path µm, tool axis arcsec, program time s of the PVT route at the servo clock."""
    motions, res, texts = convert(truth, text, "pmac")
    run = ctl.run_pmac(texts, servo_ms=ctl.SERVO_MS)
    tool = _tool_of_segments(res, run.line, run.seg)
    q = ctl.machine_executes(truth, run.t_dense, run.P_dense, tool)
    tr = ctl.judge(motions, q, run.t_dense, run.seg, run.line, tool, truth.limits.rapid_mm_min)
    return tr.path_mm * 1e3, tr.ab_deg * 3600, float(run.t[-1])


def embedded(truth, text: str, seg_ms: float, blend: bool = True) -> tuple[float, float, float]:
    """The same for the embedded route with Isx13 = seg_ms, the program written for
    it (blends judged for that Isx13, arcs slowed for its spline); ``blend=False``
    ends every move at rest."""
    motions = list(gcode.iter_motions(gcode.split_lines(text), program.interpreter_config(truth)))
    prog = pmac_cartesian.write_program(motions, truth, PROV, motions[0].start, seg_ms, blend)
    run = run_segmented(prog, truth, seg_ms)
    P = through_tables(truth, run.P_dense)
    q = ctl.machine_executes(truth, run.t_dense, P, run.tool_dense)
    tr = ctl.judge(
        motions, q, run.t_dense, run.jseg, run.jline, run.tool_dense, truth.limits.rapid_mm_min
    )
    return tr.path_mm * 1e3, tr.ab_deg * 3600, float(run.t[-1])


def junctions(truth, text: str, seg_ms: float) -> tuple[int, int]:
    """How many junctions between moves blend and how many stop."""
    motions = list(gcode.iter_motions(gcode.split_lines(text), program.interpreter_config(truth)))
    w = pmac_cartesian.fed(motions, truth, PROV, motions[0].start, seg_ms)
    return w.blended, w.blended + w.stopped


def blending(seg_ms: list[float], lines: int) -> None:
    """Blended against every move at rest: path error and time (second table)."""
    from bench import generate

    print()
    print("| program | machine | Isx13 | every move at rest | blended | junctions blended |")
    print("|---|---|---:|---:|---:|---:|")
    progs = [(p.name, p.read_text()) for p in sorted((ROOT / "samples").glob("*.ngc"))]
    progs.append((f"generated finishing, {lines} lines", generate(lines, 0)))
    for name, text in progs:
        for kind, seed in [("nominal", None), ("random", 11)]:
            truth = machine(kind, seed)
            label = kind if seed is None else f"{kind} {seed}"
            for h in seg_ms:
                cells = []
                for blend in (False, True):
                    p_um, a_s, t = embedded(truth, text, h, blend)
                    cells.append(f"{p_um:.3f} µm / {a_s:.2f}″ / {t:.2f} s")
                nb, nj = junctions(truth, text, h)
                print(
                    f"| {name} | {label} | {h:g} ms | {cells[0]} | {cells[1]} | {nb} of {nj} |",
                    flush=True,
                )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seg-ms", type=float, nargs="+", default=[10.0, 5.0])
    ap.add_argument("--play", action="store_true", help="machines with backlash in every motor")
    ap.add_argument(
        "--blending",
        type=int,
        metavar="LINES",
        help="instead: blended against every move at rest, on the samples and a "
        "generated finishing program of LINES lines",
    )
    args = ap.parse_args()
    if args.blending:
        blending(args.seg_ms, args.blending)
        return
    heads = ["PVT, servo 0.442 ms"] + [f"embedded, Isx13 = {s:g} ms" for s in args.seg_ms]
    print("| program | machine | " + " | ".join(heads) + " |")
    print("|---|---|" + "---:|" * len(heads))
    worst = [[0.0, 0.0] for _ in heads]
    for path in sorted((ROOT / "samples").glob("*.ngc")):
        text = path.read_text()
        for kind, seed in MACHINES:
            truth = machine(kind, seed, args.play)
            rows = [pvt(truth, text)] + [embedded(truth, text, s) for s in args.seg_ms]
            for w, r in zip(worst, rows, strict=True):
                w[0], w[1] = max(w[0], r[0]), max(w[1], r[1])
            cells = [f"{p:.3f} µm / {a:.2f}″ / {t:.1f} s" for p, a, t in rows]
            label = kind if seed is None else f"{kind} {seed}"
            print(f"| {path.name} | {label} | " + " | ".join(cells) + " |", flush=True)
    print("| largest | | " + " | ".join(f"{p:.3f} µm / {a:.2f}″" for p, a in worst) + " |")


if __name__ == "__main__":
    main()
