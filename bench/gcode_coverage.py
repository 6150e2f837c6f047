"""Coverage: the real programs LinuxCNC's ``rs274`` runs that our interpreter runs the same.

Usage::

    python bench/gcode_coverage.py                # tests/data/gcode/corpus + ../shared/corpus
    python bench/gcode_coverage.py PATH...        # other programs (e.g. LinuxCNC's nc_files)
    python bench/gcode_coverage.py --list         # a line per program

Every program (``.ngc .nc .gcode .tap .cnc .gc``; a file whose content was seen
already is skipped) is run through ``rs274 -g`` and through
:func:`prsxy_post.gcode.iter_motions` with the same work offsets, G28/G30
positions and tool table, and compared as ``tests/test_gcode_oracle.py`` does
(:func:`tests.test_gcode_oracle.verdict`): ends, arc centres and turns, feeds,
dwells, tool length offsets, curves and the machine functions. The figure is

    coverage = programs run with the same motions
               / (programs rs274 runs to the end − those that stop at a feature
                  out of scope for this machine: G7/G8, G33/G33.1/G76, G38.x, C/U/V/W)

and, apart, how many of the programs rs274 refuses we refuse too. Needs
LinuxCNC's ``rs274`` (``apt-get install linuxcnc-uspace``).
"""

from __future__ import annotations

import argparse
import collections
import hashlib
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

import mdsection  # noqa: E402

from tests import oracle  # noqa: E402
from tests.conftest import SHARED  # noqa: E402
from tests.test_gcode_oracle import Verdict, verdict  # noqa: E402

EXTENSIONS = (".ngc", ".nc", ".gcode", ".tap", ".cnc", ".gc")
CORPUS = ROOT / "tests" / "data" / "gcode" / "corpus"
#: folders of programs in a folder per project
CORPORA = [CORPUS] + ([SHARED / "corpus"] if SHARED is not None else [])


def programs(roots: list[Path]) -> list[tuple[str, Path]]:
    """(project, path) of every program under the roots, each content once; the
    project is the first folder under one of the :data:`CORPORA` (else the
    folder's name)."""
    seen: set[str] = set()
    out: list[tuple[str, Path]] = []
    for root in roots:
        files = [root] if root.is_file() else sorted(p for p in root.rglob("*") if p.is_file())
        for p in files:
            if p.suffix.lower() not in EXTENSIONS:
                continue
            digest = hashlib.sha1(p.read_bytes()).hexdigest()
            if digest in seen:
                continue
            seen.add(digest)
            if root in CORPORA:
                project = p.relative_to(root).parts[0]
            else:
                project = root.name if root.is_dir() else root.parent.name
            out.append((project, p))
    return out


def markdown(
    programs: int, projects: int, figures: tuple[int, int, int, int, int], motions: int
) -> str:
    """The section of docs/measurements.md: the totals as one row."""
    ran, in_scope, same, refused, both = figures
    pct = 100 * same / max(in_scope, 1)
    return "\n".join(
        [
            mdsection.header("The LinuxCNC dialect over real programs"),
            "| programs | projects | rs274 runs to the end | of them in scope "
            "| we run with the same motions | rs274 refuses | we refuse too |",
            "|---:|---:|---:|---:|---:|---:|---:|",
            f"| {programs} | {projects} | {ran} | {in_scope} "
            f"| {same} ({pct:.1f} %, {f'{motions:,}'.replace(',', ' ')} motions) "
            f"| {refused} | {both} |",
        ]
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("paths", nargs="*", type=Path, help="folders or files (default: the corpora)")
    ap.add_argument("--list", action="store_true", help="print the verdict of every program")
    ap.add_argument(
        "--markdown", action="store_true", help="print the section of docs/measurements.md"
    )
    args = ap.parse_args()
    if oracle.RS274 is None:
        sys.exit("rs274 not found: apt-get install linuxcnc-uspace")
    roots = [p.resolve() for p in args.paths] or CORPORA
    found = programs(roots)
    by_project: dict[str, collections.Counter[str]] = collections.defaultdict(collections.Counter)
    verdicts: list[tuple[str, Path, Verdict]] = []
    t0 = time.perf_counter()
    for project, path in found:
        v = verdict(path.read_bytes().decode("utf-8", errors="surrogateescape"))
        verdicts.append((project, path, v))
        by_project[project][v.status] += 1
        if args.list:
            print(f"{v.status:18s} {path}  {v.detail[:160]}", flush=True)
    seconds = time.perf_counter() - t0

    def figures(c: collections.Counter[str]) -> tuple[int, int, int, int, int]:
        ran = sum(n for s, n in c.items() if s not in ("both refuse", "only rs274 refuses"))
        in_scope = ran - c["out of scope"]
        refused = c["both refuse"] + c["only rs274 refuses"]
        return ran, in_scope, c["same"], refused, c["both refuse"]

    cols = ("same", "different", "not supported", "we refuse", "out of scope")
    if args.markdown:
        every = sum(by_project.values(), collections.Counter())
        motions = sum(v.motions for _, _, v in verdicts if v.status == "same")
        print(markdown(len(verdicts), len(by_project), figures(every), motions))
        return
    print(
        f"| project | programs | rs274 runs | {' | '.join(cols)} | coverage | rs274 refuses "
        "| we refuse too |"
    )
    print("|---|" + "---:|" * (len(cols) + 5))
    total: collections.Counter[str] = collections.Counter()
    for project in sorted(by_project, key=str.lower):
        c = by_project[project]
        total += c
        ran, in_scope, same, refused, both = figures(c)
        pct = f"{100 * same / in_scope:.0f} %" if in_scope else "–"
        print(
            f"| {project} | {c.total()} | {ran} | {' | '.join(str(c[s]) for s in cols)} | "
            f"{pct} | {refused} | {both} |"
        )
    ran, in_scope, same, refused, both = figures(total)
    motions = sum(v.motions for _, _, v in verdicts if v.status == "same")
    print(
        f"| **all** | {total.total()} | {ran} | {' | '.join(str(total[s]) for s in cols)} | "
        f"**{100 * same / max(in_scope, 1):.1f} %** | {refused} | {both} |"
    )
    print(
        f"\n{total.total()} programs from {len(by_project)} projects; rs274 runs {ran} to the "
        f"end, {in_scope} of them without a feature out of scope; we run {same} of those with "
        f"the same motions ({100 * same / max(in_scope, 1):.1f} %, {motions} motions); "
        f"rs274 refuses {refused}, we refuse {both} of them too; {seconds:.0f} s"
    )
    for status in ("different", "we refuse", "only rs274 refuses", "not supported"):
        rows = [(p, v) for _, p, v in verdicts if v.status == status]
        if rows:
            print(f"\n{status}:")
            for p, v in rows:
                print(f"  {p}: {v.detail[:200]}")


if __name__ == "__main__":
    main()
