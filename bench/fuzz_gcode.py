"""Fuzz the G-code reader: mutated real programs must give motions or a located GCodeError.

    python bench/fuzz_gcode.py --seconds 20      # what CI runs
    python bench/fuzz_gcode.py --seconds 3600    # a long run

Mutations: byte flips, inserted G-code fragments, deleted and duplicated lines, cut
files, random unicode. Any other exception, or a hang (each case has a time
budget), is a finding: the case is written to fuzz-failures/ and the run fails.
"""

from __future__ import annotations

import argparse
import random
import re
import signal
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from prsxy_post import gcode  # noqa: E402
from prsxy_post.errors import GCodeError  # noqa: E402

#: a low limit on loop passes: a mutated loop that never ends must be stopped
#: by it, well within the time budget of a case
FUZZ_CONFIG = gcode.InterpreterConfig(max_loop_passes=20_000)

FRAGMENTS = [
    "G2",
    "G3",
    "G81",
    "G83 Q",
    "R-",
    "X1e9",
    "#1",
    "[",
    "(",
    ")",
    ";",
    "%",
    "G20",
    "G91",
    "G93",
    "F0",
    "P0",
    "L0",
    "G43 H1",
    "G28",
    "G53",
    "M2",
    "N",
    ".",
    "-",
    "G4",
    "I0 J0",
    "Z",
    "\r",
    "\n",
    "\t",
    "\x00",
    "é",
    "G18",
    "G19",
    "G90.1",
    "#1=",
    "#<a>=",
    "#<_b>",
    "[#1+",
    "]",
    "**",
    " mod ",
    " eq ",
    "sin[",
    "atan[1]/[",
    "exists[#<a>]",
    "#5420",
    "o100 while [#1 lt 3]",
    "o100 endwhile",
    "o100 sub",
    "o100 endsub",
    "o100 call [1] [2]",
    "o100 if [1]",
    "o100 elseif [0]",
    "o100 else",
    "o100 endif",
    "o<x> repeat [2]",
    "o<x> endrepeat",
    "o1 do",
    "o1 while [#1]",
    "o1 break",
    "o1 continue",
    "o1 return [2]",
    "(DEBUG,#1 %d#2)",
    "(PRINT,#<a>)",
    "(MSG,hi)",
    "M98 P1 L2",
    "M99",
    "O1",
    "G5 X1 Y1 I1 J0 P1 Q0",
    "G5.1 X1 I1 J1",
    "G5.2 X1 Y1 P1 L3",
    "G5.3",
    "G41 D1",
    "G42.1 D2 L3",
    "G40",
    "G10 L2 P1 X1",
    "G10 L1 P1 R2",
    "G10 L20 P0 X0",
    "G92 X0",
    "G92.1",
    "G52 X1",
    "@1 ^45",
    "M61 Q1",
    "M62 P0",
    "M66 P0 L0",
    "M67 E0 Q1",
    "M70",
    "M72",
    "G96 S100 D1000",
    "M100",
]


def mutate(text: str, rng: random.Random) -> str:
    lines = text.splitlines() or [""]
    for _ in range(rng.randint(1, 6)):
        op = rng.random()
        k = rng.randrange(len(lines))
        if op < 0.3:
            s = lines[k]
            p = rng.randint(0, len(s))
            lines[k] = s[:p] + rng.choice(FRAGMENTS) + s[p:]
        elif op < 0.5 and lines[k]:
            s = lines[k]
            p = rng.randrange(len(s))
            lines[k] = s[:p] + chr(rng.randint(1, 0x2FF)) + s[p + 1 :]
        elif op < 0.65 and len(lines) > 1:
            del lines[k]
        elif op < 0.8:
            lines.insert(k, lines[rng.randrange(len(lines))])
        else:
            lines = lines[: rng.randint(1, len(lines))]
    return "\n".join(lines)


class Hang(Exception):
    pass


def _alarm(signum: int, frame: object) -> None:
    raise Hang


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seconds", type=float, default=20.0)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    seeds = [
        p.read_text(errors="surrogateescape")
        for p in sorted((ROOT / "tests" / "data" / "gcode").rglob("*"))
        if p.suffix in (".ngc", ".nc", ".tap", ".gcode")
    ]
    # programs LinuxCNC would run to the end (an M2/M30 or '%' near the end): a
    # mutation of one explores what the interpreter accepts, not only refusals
    seeds = [s for s in seeds if re.search(r"(?i)(m0*2|m30|%)[^\n]*\s*$", s[-200:])]
    # the first 20 000 characters of a long one, ended as it was
    seeds = [s if len(s) <= 20000 else s[: s.rfind("\n", 0, 20000)] + "\nM2\n" for s in seeds]
    rng = random.Random(args.seed)
    signal.signal(signal.SIGALRM, _alarm)
    end = time.monotonic() + args.seconds
    n = ok = rejected = 0
    failures = ROOT / "fuzz-failures"
    while time.monotonic() < end:
        text = mutate(rng.choice(seeds), rng)
        n += 1
        signal.alarm(5)
        try:
            gcode.interpret(text, FUZZ_CONFIG, source="fuzz.ngc")
            ok += 1
        except GCodeError as exc:
            if not str(exc).startswith("fuzz.ngc:"):
                raise AssertionError(f"error without location: {exc}") from None
            rejected += 1
        except Exception as exc:  # a finding
            failures.mkdir(exist_ok=True)
            path = failures / f"case-{args.seed}-{n}.ngc"
            path.write_text(text, errors="surrogateescape")
            print(f"FAIL {type(exc).__name__}: {exc} ({path})")
            return 1
        finally:
            signal.alarm(0)
    print(
        f"fuzz: {n} mutated programs, {ok} accepted, {rejected} rejected with a location, 0 crashes"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
