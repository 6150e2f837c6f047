"""Turbo PMAC motion programs in PVT mode (motor space).

Each line gives every motor's end position and end velocity; Turbo PMAC computes
the unique cubic between consecutive points (Software Reference, "PVT{data}": "the
unique cubic position profile (parabolic velocity profile)"), so the trajectory
passes through every point with the planned velocity, and the segment time may
change on the fly. SPLINE1 would move the points by (Dist(n+1) − Dist(n)) / 6 and
cannot change its segment time without a stop. The chain gives each point the
velocity of the planned motion there (:mod:`prsxy_post.chain`), so the cubics stay
on the programmed path between points too.

What the controller must be set to is written in the header, each setting with
the manual's section (see ``docs/turbo-pmac.md``).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import LimitError
from ..kernel import text as ktext
from ..profile import MOTORS
from ..profile.output import OUTPUT_SETTINGS
from .base import Dialect, Piece, Provenance, header, words_text
from .numbers import pvt_segment_text, round_clean

if TYPE_CHECKING:
    from ..points import PointChunk
    from ..profile import Profile

#: "PVT{data}": with I42 = 0 the segment time is 0 to 4095.9998 ms (Software
#: Reference, PVT{data}); a longer stay is a DWELL.
PVT_MAX_MS = 4095.9998
#: With I42 = 0 Turbo PMAC keeps a PVT time as a 24-bit value, 12 bits of integer
#: and 12 of fraction of a ms (User Manual, "PVT-Mode Moves"): it runs whole
#: 1/4096 ms. The manual does not say whether it rounds or truncates a time between
#: two (truncated, led-floor-tiny-arc-as-lines' 0.2 ms segments ran 1.0017 x F), so
#: times are written as whole quanta, each rounded up (never faster than planned):
#: the controller runs exactly the written time.
PVT_QUANTA_PER_MS = 4096
# the kernel writes a quantum as QUANTUM_E12 x 1e-12 ms
assert ktext.QUANTUM_E12 * PVT_QUANTA_PER_MS == 10**12
#: A PVT time of ``quanta`` / 4096 ms, exactly, as decimal text with at least four
#: decimals: 40960 → ``10.0000``, 1000 → ``0.244140625`` (the kernel's definition,
#: which the points' text follows, :func:`prsxy_post.kernel.text.pvt_ms_text`).
pvt_ms_text = ktext.pvt_ms_text
#: DWELL{data}: 0 to 8,388,607 ms (Software Reference, DWELL{data}); longer dwells
#: are written as several.
DWELL_MAX_MS = 8_388_607.0
#: Words a PVT line takes in a rotary buffer: each value is a word (User Manual,
#: "Rotary Motion Program Buffers": "Each value in a program (e.g. X1250) takes one
#: word of memory"), a position and a velocity per motor; two more for a PVT time.
WORDS_PER_LINE = 2 * len(MOTORS) + 2
#: Motion programs Turbo PMAC calls for G, M, T and D codes (Software Reference,
#: "D{data}", "M{data}", "T{data}"; User Manual, "Implementing a Machine-Tool Style
#: Program"): a split program must not number its parts into them.
RESERVED_PROGRAMS = range(1000, 1004)

SETTINGS = OUTPUT_SETTINGS["pmac"]


class PmacWriter:
    """A Turbo PMAC PVT motion program, streamed (module docstring)."""

    #: the point fields :meth:`feed` reads: a writer in a process of its own is
    #: sent only these (:class:`prsxy_post.sinks.WriterProcess`)
    reads = ("P_cmd", "V_cmd", "dt", "dwell", "line", "split", "fn")

    def __init__(self, profile: Profile, settings: Mapping[str, Any], prov: Provenance) -> None:
        self.profile = profile
        self.prov = prov
        self.dec = int(settings["decimals"])
        self.cs = int(settings["coordinate_system"])
        self.prog = int(settings["program"])
        self.rot = int(settings["rotary_buffer_points"])
        self.max_pts = 0 if self.rot else int(settings["max_points_per_program"])
        self.names = [profile.motor(m).axis for m in MOTORS]
        self.part = 0
        self.n = 0  # points written in all
        self.t_total = 0.0
        #: the PVT time in force [1/4096 ms]
        self.tm_cur: int | None = None
        self.last_line: int | None = None
        self.last_P: np.ndarray | None = None
        self.open = False
        self.functions: dict[str, str] = {}  # code → what it calls, for the trailer
        self.splits: list[int] = []  # lines where a part ended

    # -- the part around the points
    def _settings_lines(self) -> list[str]:
        motors = " ".join(str(m) for m in MOTORS)
        return [
            "Controller settings (Turbo PMAC Software Reference, I-variables):",
            "  I42=0: PVT times in ms with fractions, 0-4095.9998 ms (I42; PVT{data});",
            "    written in whole 1/4096 ms, the steps it keeps them in, so it runs them",
            "    exactly",
            "  I10: a servo cycle of 442 us or shorter (the default; I10 in 1/8,388,608",
            "    ms): the trajectory is commanded once a cycle, and a motor turning",
            "    between two commands is commanded short of its turn; the path",
            "    tolerance was measured at 442 us (docs/measurements.md, At the servo clock)",
            f"  I{50 + self.cs}90=1000 (Isx90 of &{self.cs}): velocities in mm/s (time units",
            "    of 1000 ms);",
            "    positions in mm (the axis definitions below: counts per mm)",
            f"  I{50 + self.cs}50=0 (Isx50 of &{self.cs}): no kinematic subroutines; the",
            "    motors are commanded directly",
            *(self._tables_lines(motors)),
            "Machine functions (S, T, M, G, D words) run at rest: DWELL0 first (it waits",
            "for the motion to finish), then the words: M n calls PROG 1001 at N(n*1000),",
            "T n PROG 1002, D n PROG 1003, G n PROG 1000: the controller must hold",
            "those programs and labels (this program's are listed at its end); S puts",
            "the speed in Q127 (Software Reference, M{data}, T{data}, D{data},",
            "S{data}; User Manual, Implementing a Machine-Tool Style Program).",
        ]

    def _tables_lines(self, motors: str) -> list[str]:
        """What the controller's own real-axis tables must do with this program."""
        if not self.prov.axis_comp:
            return [
                f"  motors {motors} do NOT carry their real-axis errors in this program",
                "  (converted without the real-axis tables stage): the controller's own",
                "  tables must compensate them: download the file of `prsxy-post tables",
                "    export --format pmac` (axis-tables.pmc: DEFINE COMP, DEFINE BLCOMP",
                "    and each motor's Ixx85, Ixx86) and set I51=1 (I51, global:",
                "    leadscrew compensation tables on)",
            ]
        return [
            f"  motors {motors} carry their real-axis errors in this program; the",
            "  controller's own tables would compensate them twice:",
            "    I51=0 (I51, global: leadscrew compensation tables off), then each",
            "    motor's compensation correction register cleared: Mxx69=0 with the",
            "    manual's suggested M-variables (with I51=0 the last correction stays",
            "    in it and is still added every servo cycle; DELETE COMP is not said",
            "    to clear it) (User Manual, Active Calculation of Corrections)",
            "    Ixx86=0 on each (Ixx86: backlash size; Ixx85 then does nothing)",
        ]

    def _open_part(self, P0: np.ndarray) -> list[str]:
        extra = self._settings_lines()
        if self.max_pts:
            extra += [
                f"Part {self.part + 1} of a split program (at most {self.max_pts} points a",
                "part): run the parts in order. Each part ends at rest at a block end (at a",
                "stop the program makes, or at a stop inserted for the split: its end says",
                "which), and the next starts exactly there (its RAPID moves nothing when",
                "the previous part has run).",
            ]
        if self.rot:
            extra += [
                f"Rotary buffer of {self.rot} lines: DEFINE ROT {self.rot * WORDS_PER_LINE} words",
                f"({WORDS_PER_LINE} per line: a position and a velocity per motor, and a PVT",
                "time). Send the lines up to OPEN ROT once; then stream the lines after it,",
                f"start with &{self.cs} R once the first ones are in, and keep the buffer",
                "fed ahead of execution (PR reports the lines not yet executed; I16/I17",
                "set when the buffer asks for more) (User Manual, Rotary Motion Program",
                "Buffers; Software Reference, DEFINE ROT, OPEN ROT, B{constant}).",
            ]
        lines = ["; " + x for x in header(self.prov, self.profile, extra)]
        lines.append("CLOSE")
        if self.rot:
            # no data-gathering buffer may exist when a rotary buffer is defined
            lines.append("DELETE GATHER")
        lines.append(f"&{self.cs}")
        lines += [
            f"#{m}->{self.profile.motor(m).counts_per_mm:g}{self.profile.motor(m).axis}"
            for m in MOTORS
        ]
        if self.rot:
            lines += [
                f"DEFINE ROT {self.rot * WORDS_PER_LINE}",
                # B0 points the coordinate system at its rotary buffer; inside an
                # open buffer it would be a B-axis move
                "B0",
                "OPEN ROT",
            ]
        else:
            prog = self.prog + self.part
            if prog in RESERVED_PROGRAMS:
                raise LimitError(
                    f"part {self.part + 1} would be PROG {prog}, which Turbo PMAC calls for "
                    "G, M, T or D codes",
                    expected="output.pmac.program far enough from 1000-1003, or fewer parts",
                )
            lines.append(f"OPEN PROG {prog} CLEAR")
        lines += ["ABS", "RAPID " + self._pos(P0), "DWELL0"]
        self.tm_cur = None
        self.last_line = None
        self.open = True
        return lines

    def _pos(self, P: np.ndarray) -> str:
        d = self.dec
        return " ".join(f"{a}{v:.{d}f}" for a, v in zip(self.names, round_clean(P, d), strict=True))

    def begin(self) -> list[Piece]:
        return []

    # -- the points
    def feed(self, chunk: PointChunk) -> list[Piece]:
        n = len(chunk)
        if n == 0:
            return []
        P = round_clean(chunk.P_cmd, self.dec)
        V = round_clean(chunk.V_cmd, 4)
        # the path and the motors stand (a dwell, a function): no PVT segment; the
        # rows compared only where the path stands (a few), each with the row before
        # (the chunk's first with the last one written)
        still = np.array(chunk.dwell, dtype=bool)
        at = np.flatnonzero(still)
        if at.size:
            prev = np.take(P, np.maximum(at - 1, 0), axis=0)
            if at[0] == 0 and self.last_P is not None:
                prev[0] = self.last_P
            still[at] = np.all(np.take(P, at, axis=0) == prev, axis=1)
        # the segment times in PMAC's quanta, rounded up; 1e-6 of one for the
        # rounding of dt itself (10 ms is 40960 quanta, not 40961)
        quanta = np.ceil(chunk.dt * (1000.0 * PVT_QUANTA_PER_MS) - 1e-6).astype(np.int64)
        pieces: list[Piece] = []
        out: list[str] = []
        k = 0
        if self.n == 0:
            # the program's first point is where the machine starts: the RAPID's
            out += [x + "\n" for x in self._open_part(P[0])]
            self.n = 1
            k = 1
        elif not self.open:
            # a part ended at rest at the last point: the next starts exactly there
            assert self.last_P is not None
            out += [x + "\n" for x in self._open_part(self.last_P)]
        while k < n:
            stop = n
            splits = np.flatnonzero(chunk.split[k:] > 0) if not self.rot else np.zeros(0, int)
            if splits.size:
                stop = k + int(splits[0]) + 1
            out.append(self._segment(chunk, P, V, quanta, still, k, stop))
            self.n += stop - k
            k = stop
            if splits.size:
                # a part ends at rest here
                why = (
                    "a stop the program makes"
                    if chunk.split[stop - 1] == 1
                    else "a stop inserted for the split (the program does not stop here)"
                )
                out.append(
                    f"; end of part {self.part + 1}: at rest after line "
                    f"{int(chunk.line[stop - 1])}, {why}\nCLOSE\n"
                )
                pieces.append((self.part, "".join(out)))
                out = []
                self.splits.append(int(chunk.line[stop - 1]))
                self.part += 1
                self.open = False
                if stop < n:
                    out += [x + "\n" for x in self._open_part(P[stop - 1])]
        self.last_P = P[-1]
        if out:
            pieces.append((self.part, "".join(out)))
        return pieces

    def _segment(
        self,
        pts: PointChunk,
        P: np.ndarray,
        V: np.ndarray,
        quanta: np.ndarray,
        still: np.ndarray,
        k0: int,
        k1: int,
    ) -> str:
        """Points k0..k1: each with its line comment when the G-code line changes, a
        PVT time when the segment time changes, and its row (or a DWELL where the
        machine stands, or the machine functions): the text made in one kernel call
        (:func:`prsxy_post.kernel.text.pvt_segment_text`)."""
        if not self.open:
            return ""
        m = k1 - k0
        line = pts.line[k0:k1]
        stand = still[k0:k1]
        # the time as written: the PVT quanta, the dwells' own; one running sum in
        # order (accumulate is sequential, unlike sum): the same bits however the
        # program was chunked
        dt = np.where(stand, pts.dt[k0:k1], quanta[k0:k1] / (1000.0 * PVT_QUANTA_PER_MS))
        self.t_total = float(np.add.accumulate(np.concatenate([[self.t_total], dt]))[-1])
        prev_line = np.concatenate([[-1 if self.last_line is None else self.last_line], line[:-1]])
        self.last_line = int(line[-1])
        fn = pts.fn[k0:k1]
        new_time = np.zeros(m, dtype=bool)
        moving = np.flatnonzero(~stand)
        if moving.size:
            mv = quanta[k0 + moving]
            before = np.concatenate([[-1 if self.tm_cur is None else self.tm_cur], mv[:-1]])
            new_time[moving[mv != before]] = True
            self.tm_cur = int(mv[-1])
        others = np.flatnonzero(stand)
        other_text = []
        for i in others.tolist():
            words = fn[i]
            if words is not None:
                # DWELL0 waits for the motion to end, so the function runs at rest
                other_text.append("DWELL0\n" + self._function(words) + "\n")
            else:
                other_text.append(self._dwell(float(pts.dt[k0 + i]) * 1000.0))
        columns = [
            col
            for i, a in enumerate(self.names)
            for col in (
                (f"{' ' if i else ''}{a}", P[k0:k1, i], self.dec),
                (":", V[k0:k1, i], 4),
            )
        ]
        return pvt_segment_text(
            columns, line, line != prev_line, quanta[k0:k1], new_time, others, other_text
        )

    def _dwell(self, ms: float) -> str:
        out = []
        while ms > DWELL_MAX_MS:
            out.append(f"DWELL{DWELL_MAX_MS:.0f}\n")
            ms -= DWELL_MAX_MS
        out.append(f"DWELL{ms:.4f}\n")
        return "".join(out)

    def _function(self, words: tuple[tuple[str, float], ...]) -> str:
        for letter, value in words:
            code = f"{letter}{value:g}"
            if letter in "GMTD":
                prog = {"G": 1000, "M": 1001, "T": 1002, "D": 1003}[letter]
                self.functions[code] = f"PROG {prog} N{round(value * 1000)}"
            elif letter == "S":
                self.functions["S"] = "Q127"
        return words_text(words)

    def finish(self) -> list[Piece]:
        tail = [f"; end: {self.n} points, {self.t_total:.3f} s"]
        if self.splits:
            tail.append(
                f"; {self.part + 1} parts, ended at rest after lines "
                + ", ".join(str(x) for x in self.splits)
            )
        if self.functions:
            tail.append(
                "; machine functions this program calls: "
                + ", ".join(f"{k} ({v})" for k, v in sorted(self.functions.items()))
            )
        text = "\n".join(tail) + "\n"
        if self.open:
            text += "CLOSE\n"
        return [(self.part, text)]


def _make(profile: Profile, settings: Mapping[str, Any], prov: Provenance) -> PmacWriter:
    return PmacWriter(profile, settings, prov)


DIALECT = Dialect(
    name="pmac",
    extension=".pmc",
    summary="Turbo PMAC PVT motion program in motor space",
    segment="cubic",
    settings=SETTINGS,
    make=_make,
    parts=lambda s: 0 if int(s["rotary_buffer_points"]) else int(s["max_points_per_program"]),
)
