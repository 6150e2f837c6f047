"""Search for programs whose executed motion leaves the G-code's geometry.

Random programs from the rs274 oracle tests' generators (canned cycles,
compensated paths, single lines of the dialect), polylines that hold and move
the head at corners taken at speed (``heads``), or windows of real CAM programs
of the corpus with the tool tilting now and then (``cam``), go through the whole chain for
a truth machine; the PMAC output is run as the controller runs it and judged as
tests/test_controller_truth.py judges it (path, tool axis, speed; the
acceleration on the nominal machine), or with ``--format gcode`` the corrected
G-code, run as LinuxCNC runs it (straight lines, its own kinematics; the path
tolerance less the G64 P blend it was told). Programs the chain refuses are counted by
their message and skipped. Stops at the first program out of bounds, shrunk by
hypothesis, and prints it.

    python bench/truth_search.py --generator comp --machine 12 --examples 300
    python bench/truth_search.py --generator heads --machine 22 --format gcode
    python bench/truth_search.py --generator cam --machine 21
    python bench/truth_search.py --found   # the programs found so far, judged
"""

from __future__ import annotations

import argparse
import collections
import math
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from prsxy_post.errors import PrsxyError  # noqa: E402
from tests import test_gcode_comp, test_gcode_oracle  # noqa: E402
from tests.test_controller_truth import (  # noqa: E402
    FOUND,
    FOUND_IDS,
    assert_within,
    judge_gcode,
    judge_pmac,
)
from tests.test_tracking import TOL_MM, convert, truth_machine  # noqa: E402

HEADER = "G21 G90 G17 G94 G40 G49 G54 G80 F500\n"


@st.composite
def _heads(draw: st.DrawFn) -> str:
    """Polylines whose segments, at slight angles in XY (corners taken at speed),
    now hold the head and now move it a little in Z, A or B: its motors stand on
    one side of a corner and move on the other (reversals.corners)."""
    out = [HEADER.strip(), "G0 X-20 Y-20 Z0 A0 B0"]
    x, y, z, a, b = -20.0, -20.0, 0.0, 0.0, 0.0
    heading = draw(st.floats(0, 6.283))
    for _ in range(draw(st.integers(2, 8))):
        heading += draw(st.floats(-0.3, 0.3))
        length = draw(st.floats(0.5, 8.0))
        x = min(max(x + length * math.cos(heading), -40.0), 40.0)
        y = min(max(y + length * math.sin(heading), -40.0), 40.0)
        words = f"G1 X{x:.4f} Y{y:.4f}"
        what = draw(st.sampled_from(["hold", "z", "a", "b"]))
        if what == "z":
            z = min(max(z + draw(st.floats(-0.3, 0.3)), -2.0), 0.0)
            words += f" Z{z:.4f}"
        elif what == "a":
            a = min(max(a + draw(st.floats(-1.0, 1.0)), -5.0), 5.0)
            words += f" A{a:.4f}"
        elif what == "b":
            b = min(max(b + draw(st.floats(-1.0, 1.0)), -5.0), 5.0)
            words += f" B{b:.4f}"
        out.append(words + f" F{draw(st.sampled_from([60, 300, 1200, 3000]))}")
    return "\n".join([*out, "M2"]) + "\n"


#: CAM output and hand-written programs of the corpus (tests/data/gcode/corpus) whose
#: windows ``cam`` draws from: 3-axis V-carving, 3D finishing, contours and pockets
CAM_PROGRAMS = (
    "CAMotics/examples/vcarve/vcarve.ngc",
    "CAMotics/examples/botomata_bottom/botomata_bottom.nc",
    "CAMotics/examples/compass/compass.ngc",
    "CAMotics/examples/wave/wave.gcode",
    "Universal-G-Code-Sender/test_files/enclosure.nc",
    "cncjs/examples/gcode/tball/tball.gcode",
    "led_floor/cad/nc/1078_wall_27bit_slower_feeds_wider_light_holder_hole.nc",
    "pygcode/tests/test-files/linuxcnc/Horse2.tap",
    "pygcode/tests/test-files/linuxcnc/Circular Pocket.tap",
)
#: a window fits the search's workspace: at most this span in x and y, in z [mm]
CAM_SPAN_XY, CAM_SPAN_Z = 80.0, 30.0


def _cam_pool() -> list[tuple[str, list]]:  # type: ignore[type-arg]
    """(name, rapids, feeds and arcs) of each CAM program: the motions the
    interpreter gives up to the end or to its first refusal (tools 1-99 of
    length 0, so a tool change moves nothing)."""
    from prsxy_post import gcode

    base = ROOT / "tests" / "data" / "gcode" / "corpus"
    cfg = gcode.InterpreterConfig(tool_table={n: gcode.ToolEntry(0.0, 6.0) for n in range(1, 100)})
    pool = []
    for rel in CAM_PROGRAMS:
        text = (base / rel).read_text(errors="replace")
        ms = []
        try:
            for m in gcode.iter_motions(gcode.split_lines(text), cfg, rel):
                if m.kind in ("rapid", "feed", "arc"):
                    ms.append(m)
        except PrsxyError:
            pass
        if len(ms) > 20:
            pool.append((rel, ms))
    return pool


@st.composite
def _cam(draw: st.DrawFn, pool: list) -> str:  # type: ignore[type-arg]
    """A window of a real CAM program's motions, moved into the workspace and
    written as explicit moves (arcs in XY with I J, others as lines); the tool
    tilts now and then, as a five-axis finish does (A, B a small random walk)."""
    name, ms = pool[draw(st.integers(0, len(pool) - 1))]
    i0 = draw(st.integers(0, len(ms) - 2))
    window = [ms[i0]]
    lo = list(ms[i0].start[:3])
    hi = list(lo)
    for m in ms[i0 : i0 + draw(st.integers(2, 40))]:
        lo2 = [min(a, b) for a, b in zip(lo, m.end[:3], strict=True)]
        hi2 = [max(a, b) for a, b in zip(hi, m.end[:3], strict=True)]
        if max(hi2[0] - lo2[0], hi2[1] - lo2[1]) > CAM_SPAN_XY or hi2[2] - lo2[2] > CAM_SPAN_Z:
            break
        lo, hi = lo2, hi2
        if m is not ms[i0]:
            window.append(m)
    # the window's box centred at x = y = 0, its top at z = 0
    shift = (-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -hi[2])
    tilt = draw(st.sampled_from(["none", "walk"]))
    a = b = 0.0
    s0 = window[0].start
    out = [
        f"({name} line {window[0].line})",
        HEADER.strip(),
        "G0 "
        + " ".join(f"{w}{v + d:.6f}" for w, v, d in zip("XYZ", s0[:3], shift, strict=True))
        + " A0 B0",
    ]
    for m in window:
        xyz = " ".join(f"{w}{v + d:.6f}" for w, v, d in zip("XYZ", m.end[:3], shift, strict=True))
        if tilt == "walk" and m.kind != "rapid":
            a = min(max(a + draw(st.floats(-0.5, 0.5)), -10.0), 10.0)
            b = min(max(b + draw(st.floats(-0.5, 0.5)), -10.0), 10.0)
            xyz += f" A{a:.4f} B{b:.4f}"
        if m.kind == "rapid":
            out.append("G0 " + xyz)
            continue
        feed = f" F{min(max(m.feed, 30.0), 6000.0):.1f}"
        if m.kind == "arc" and m.plane == 17 and m.center is not None:
            code = "G3" if m.rotation > 0 else "G2"
            turns = f" P{abs(m.rotation)}" if abs(m.rotation) > 1 else ""
            ij = f" I{m.center[0] - m.start[0]:.6f} J{m.center[1] - m.start[1]:.6f}"
            out.append(f"{code} {xyz}{ij}{turns}{feed}")
        else:
            out.append(f"G1 {xyz}{feed}")
    return "\n".join([*out, "M2"]) + "\n"


def generator(name: str) -> st.SearchStrategy[str]:
    if name == "heads":
        return _heads()
    if name == "cam":
        return _cam(_cam_pool())
    if name == "cycles":
        return test_gcode_oracle._cycles()
    if name == "comp":
        return test_gcode_comp._compensated_path()
    return st.lists(test_gcode_oracle._LINE, min_size=1, max_size=20).map(
        lambda lines: HEADER + "\n".join(lines) + "\nM2\n"
    )


def trace(truth, text: str, fmt: str):  # type: ignore[no-untyped-def]
    """Convert ``text`` for ``fmt`` and run it as its controller does: the judged
    trace and the path tolerance it is held to (less the G64 P blend for G-code)."""
    motions, res, texts = convert(truth, text, fmt)
    if fmt == "gcode":
        tr, blend = judge_gcode(truth, motions, res, texts)
        return tr, TOL_MM - blend
    return judge_pmac(truth, motions, res, texts), TOL_MM


def found(fmt: str) -> None:
    """The programs the searches found (test_controller_truth.FOUND), each on its
    machine, as the test judges them: one Markdown table."""
    print("| program | machine | path µm | tool axis arcsec | speed / F |")
    print("|---|---:|---:|---:|---:|")
    for name, (seed, text) in zip(FOUND_IDS, FOUND, strict=True):
        tr = trace(truth_machine("random", seed), text, fmt)[0]
        print(
            f"| {name} | {seed} | {tr.path_mm * 1000:.3f} | {tr.ab_deg * 3600:.3f} "
            f"| {tr.speed_ratio:.5f} |"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument(
        "--generator", choices=["cycles", "comp", "lines", "heads", "cam"], default="comp"
    )
    ap.add_argument("--machine", default="21", help="a random machine's seed, or 'nominal'")
    ap.add_argument("--examples", type=int, default=300)
    ap.add_argument("--format", choices=["pmac", "gcode"], default="pmac")
    ap.add_argument("--found", action="store_true", help="judge the programs found so far")
    args = ap.parse_args()
    if args.found:
        found(args.format)
        return
    seed = None if args.machine == "nominal" else int(args.machine)
    truth = truth_machine("random" if seed is not None else "nominal", seed)
    accel = truth.limits.max_accel_mm_s2 if seed is None else None
    seen: collections.Counter[str] = collections.Counter()

    @settings(
        max_examples=args.examples,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(generator(args.generator))
    def search(text: str) -> None:
        try:
            tr, tol = trace(truth, text, args.format)
        except PrsxyError as e:
            seen["refused: " + str(e).split(": ", 1)[-1][:60]] += 1
            return
        seen["judged (shrinking included)"] += 1
        assert_within(tr, accel, tol)

    try:
        search()
    finally:
        for what, n in seen.most_common(10):
            print(f"{n:6d}  {what}")


if __name__ == "__main__":
    main()
