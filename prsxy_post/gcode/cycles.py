"""Canned cycles (G73, G74, G81-G86, G89) as LinuxCNC expands them into moves.

Tapping (G74, G84) and boring with a stopped retract (G86) turn the spindle
about within the cycle; those functions are events among the cycle's moves
(functions.py word forms), as LinuxCNC's cycle issues them."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .codes import CYCLE_SHAPE
from .motion import MM_PER_INCH
from .read import Word

if TYPE_CHECKING:
    from .execute import Interpreter


#: G73/G83 back-off before the next peck (LinuxCNC's G83_RAPID_DELTA, inch).
G83_RAPID_DELTA_INCH = 0.010


def cycle(
    it: Interpreter,
    motion: int,
    axis_words: dict[str, Word],
    seen: dict[str, Word],
    line: int,
    new: bool,
) -> None:
    """One block of canned cycle ``motion`` (G73, G74, G81-G86, G89): its words
    checked and read as LinuxCNC does (convert_cycle), then its holes, each the
    cycle's own moves (interp_cycles.cc has a function per cycle, and so has this
    module)."""
    st = it.st
    gw = next(iter(axis_words.values()), None)
    first = st.motion != motion
    repeats = _words(it, motion, axis_words, seen, line, gw, first)
    lv = _levels(it, axis_words, seen, line)
    moves = _Moves(it, line, lv.iu, lv.iv, lv.iw, lv.sc, lv.off)
    # LinuxCNC (interp_internal.hh, CYCLE_MACRO): below the R plane (judged by the
    # level the cycles started at), rise straight up to it first; the first hole is
    # gone to across at the tool's height where that is above R, every other one at
    # the clearance level. The level the cycles started at is kept as a number, so
    # after G20/G21 it is read in the new units while the tool's height is not: the
    # first hole then goes across at the tool's height, not at that level
    cur, off, sc, r = lv.cur, lv.off, lv.sc, lv.r
    current_cc = lv.cur_w
    old_cc = lv.old_cc
    if old_cc < r:
        moves.traverse((cur[lv.iu] - off[lv.iu]) / sc, (cur[lv.iv] - off[lv.iv]) / sc, r)
        old_cc = r
        current_cc = r
    clear = r if st.retract_r else old_cc
    aa, bb = lv.aa, lv.bb
    first = True
    for _ in range(repeats):
        aa, bb = _next_hole(it, lv, aa, bb, seen, line)
        first_w = current_cc if (first and current_cc > r) else clear
        first = False
        moves.traverse(aa, bb, first_w)
        if first_w != r:
            moves.traverse(aa, bb, r)
        HOLES[motion](moves, motion, aa, bb, r, lv.cc, clear)
        current_cc = clear


def _words(
    it: Interpreter,
    motion: int,
    axis_words: dict[str, Word],
    seen: dict[str, Word],
    line: int,
    gw: Word | None,
    first: bool,
) -> int:
    """The block's words checked in LinuxCNC's order, the sticky Q and P kept;
    the number of repeats (L)."""
    st = it.st
    if st.inverse_time:
        raise it.err("canned cycle in inverse time mode (G93)", line, gw, "G94")
    if st.feed <= 0:
        raise it.err(
            "canned cycle with no feed rate",
            line,
            gw or seen.get("R"),
            "an F word before the cycle",
        )
    for a in ("A", "B"):
        if a in axis_words:
            raise it.err(
                "A/B words in a canned cycle",
                line,
                axis_words[a],
                "X Y Z R only: rotary axes may not move in a cycle",
            )
    sc = it.scale()
    name_w = "XYZ"[{17: 2, 18: 1, 19: 0}[st.plane]]
    if first and name_w not in axis_words:
        raise it.err(
            f"{name_w} missing in the first block of a canned cycle",
            line,
            gw,
            f"{name_w}<bottom> with G{motion} in G{st.plane}",
        )
    if "R" not in seen and first:
        raise it.err("R missing in the first block of a canned cycle", line, gw, "R<retract plane>")
    if "L" in seen:
        lv = seen["L"].value
        if lv != int(lv) or lv < 1:
            raise it.err("L must be a positive integer", line, seen["L"], "L1, L2, ...")
        repeats = int(lv)
    else:
        repeats = 1
    if motion in (73, 83):
        if "Q" in seen:
            st.cycle_q = seen["Q"].value * sc
        elif first:
            raise it.err(f"Q missing with G{motion}", line, gw, "Q<peck depth>")
        if st.cycle_q <= 0:
            raise it.err("Q must be positive", line, seen.get("Q"), "Q > 0")
    if motion in (74, 82, 84, 86, 89):
        if "P" in seen:
            st.cycle_p = seen["P"].value
        elif first and motion not in (74, 84):
            raise it.err(f"P (dwell) missing with G{motion}", line, gw, "P<seconds>")
    if motion == 84 and st.spindle_dir != 1:
        raise it.err("G84 with the spindle not turning clockwise", line, gw, "M3 first")
    if motion == 74 and st.spindle_dir != -1:
        raise it.err("G74 with the spindle not turning counterclockwise", line, gw, "M4 first")
    if motion == 86 and st.spindle_dir == 0:
        raise it.err("G86 with the spindle not turning", line, gw, "M3 or M4 first")
    if motion in (74, 84) and st.plane != 17:
        # LinuxCNC 2.9 (and master) feed these along the wrong axes outside G17:
        # convert_cycle_g74_g84 permutes the coordinates before cycle_feed, which
        # permutes them again (interp_cycles.cc), so G84 in G18 taps along X
        # (its own tests/interp/g84/g18 record it); the tap would go sideways
        raise it.err(
            f"G{motion} in G{st.plane} is not supported (LinuxCNC feeds the tap along "
            "the wrong axis there)",
            line,
            gw,
            f"G{motion} in G17",
        )
    return repeats


@dataclass(frozen=True)
class _Levels:
    """Where a cycle works, in program units of its plane's axes (u, v the plane,
    w the drilling axis): the retract plane r, the bottom cc, the first hole's
    aa, bb and what each repeat adds (inc_a, inc_b; polar inc_r, inc_t), the tool's
    height cur_w and the level the cycles started at old_cc; cur, off, sc: the
    position [mm], the offset and the units' scale to turn them back."""

    iu: int
    iv: int
    iw: int
    sc: float
    off: Sequence[float]
    cur: list[float]
    cur_w: float
    old_cc: float
    r: float
    cc: float
    aa: float
    bb: float
    inc_a: float
    inc_b: float
    inc_r: float
    inc_t: float


def _levels(
    it: Interpreter, axis_words: dict[str, Word], seen: dict[str, Word], line: int
) -> _Levels:
    """The cycle's levels and first hole as LinuxCNC's convert_cycle reads them
    (absolute and incremental, polar words in G17); R below the bottom is an error."""
    st = it.st
    sc = it.scale()
    iu, iv, iw = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[st.plane]
    ax = "XYZ"
    name_w = ax[iw]
    off = it.offset()
    cur = list(st.pos)
    # work in program coordinates of the cycle axes, then add the offset back
    cur_w = (cur[iw] - off[iw]) / sc
    # positions are kept in mm: a level reached in inches comes back a rounding
    # off (38.1 / 25.4); LinuxCNC, in program units, compares it exactly
    for level in (st.cycle_r, st.cycle_z, *(w.value for w in (seen.get("R"),) if w)):
        if abs(cur_w - level) <= 1e-9 * max(1.0, abs(level)):
            cur_w = level
    if st.cycle_il is None:
        st.cycle_il = cur_w
    old_cc = st.cycle_il
    z_given = axis_words[name_w].value if name_w in axis_words else None
    if "R" in seen:
        st.cycle_r = seen["R"].value
    if z_given is not None:
        st.cycle_z = z_given
    z_num = st.cycle_z
    # polar words (G17 only): @ radius, ^ angle about the program origin; in G91
    # they add to the radius and the angle at every repeat (LinuxCNC's CYCLE_MACRO)
    d2r = math.pi / 180.0
    polar = "@" in seen or "^" in seen
    inc_r = inc_t = 0.0
    if st.absolute:
        r = st.cycle_r
        cc = z_num
        aa = axis_words[ax[iu]].value if ax[iu] in axis_words else (cur[iu] - off[iu]) / sc
        bb = axis_words[ax[iv]].value if ax[iv] in axis_words else (cur[iv] - off[iv]) / sc
        if polar:
            here_a, here_b = (cur[iu] - off[iu]) / sc, (cur[iv] - off[iv]) / sc
            radius = seen["@"].value if "@" in seen else math.hypot(here_b, here_a)
            theta = seen["^"].value * d2r if "^" in seen else math.atan2(here_b, here_a)
            aa, bb = radius * math.cos(theta), radius * math.sin(theta)
        inc_a = inc_b = 0.0
    else:
        inc_a = axis_words[ax[iu]].value if ax[iu] in axis_words else 0.0
        inc_b = axis_words[ax[iv]].value if ax[iv] in axis_words else 0.0
        inc_r = seen["@"].value if "@" in seen else 0.0
        inc_t = seen["^"].value * d2r if "^" in seen else 0.0
        r = st.cycle_r + old_cc
        cc = r + z_num
        aa = (cur[iu] - off[iu]) / sc
        bb = (cur[iv] - off[iv]) / sc
    if r < cc:
        raise it.err(
            f"R below the bottom of the cycle in G{st.plane}",
            line,
            seen.get("R") or axis_words.get(name_w),
            f"R >= {name_w} (the retract plane above the bottom)",
        )
    return _Levels(
        iu, iv, iw, sc, off, cur, cur_w, old_cc, r, cc, aa, bb, inc_a, inc_b, inc_r, inc_t
    )


def _next_hole(
    it: Interpreter, lv: _Levels, aa: float, bb: float, seen: dict[str, Word], line: int
) -> tuple[float, float]:
    """The next repeat's hole: the increments added (in G91), and the polar ones
    about the program origin (LinuxCNC's CYCLE_MACRO)."""
    aa += lv.inc_a
    bb += lv.inc_b
    inc_r, inc_t = lv.inc_r, lv.inc_t
    if inc_r or inc_t:
        if aa == 0 and bb == 0:
            raise it.err(
                "incremental polar motion at the origin",
                line,
                seen.get("@") or seen.get("^"),
                "G90 or a start off the origin",
            )
        if inc_r:
            theta = math.atan2(bb, aa)
            radius = math.hypot(bb, aa) + inc_r
            aa, bb = radius * math.cos(theta), radius * math.sin(theta)
        if inc_t:
            theta = math.atan2(bb, aa) + inc_t
            radius = math.hypot(bb, aa)
            aa, bb = radius * math.cos(theta), radius * math.sin(theta)
    return aa, bb


class _Moves:
    """A cycle's moves in its plane's program units, emitted as motions at the
    block's line."""

    def __init__(
        self, it: Interpreter, line: int, iu: int, iv: int, iw: int, sc: float, off: Sequence[float]
    ) -> None:
        self.it, self.st, self.line = it, it.st, line
        self.iu, self.iv, self.iw, self.sc, self.off = iu, iv, iw, sc, off

    def pt(self, a: float, b: float, w: float) -> list[float]:
        p = list(self.st.pos)
        sc, off = self.sc, self.off
        p[self.iu], p[self.iv], p[self.iw] = (
            a * sc + off[self.iu],
            b * sc + off[self.iv],
            w * sc + off[self.iw],
        )
        return p

    def traverse(self, a: float, b: float, w: float) -> None:
        end = self.pt(a, b, w)
        self.it.emit(line=self.line, kind="rapid", start=tuple(self.st.pos), end=tuple(end))
        self.st.pos = end

    def feed(self, a: float, b: float, w: float) -> None:
        st = self.st
        end = self.pt(a, b, w)
        f = st.feed * (MM_PER_INCH if st.units == "inch" else 1.0)
        self.it.emit(line=self.line, kind="feed", start=tuple(st.pos), end=tuple(end), feed=f)
        st.pos = end

    def dwell(self, t: float) -> None:
        p = tuple(self.st.pos)
        self.it.emit(line=self.line, kind="dwell", start=p, end=p, duration=t)

    def function(self, *words: tuple[str, float]) -> None:
        p = tuple(self.st.pos)
        self.it.emit(line=self.line, kind="function", start=p, end=p, words=words)


def _peck(mv: _Moves, motion: int, aa: float, bb: float, r: float, cc: float, clear: float) -> None:
    """G73 (chip break) and G83 (peck out to R): pecks of Q, each backed off by
    G83_RAPID_DELTA before the next (convert_cycle_g73, convert_cycle_g83)."""
    st = mv.st
    delta = G83_RAPID_DELTA_INCH * (1.0 if st.units == "inch" else MM_PER_INCH)
    q = st.cycle_q / mv.sc
    depth = r - q
    while depth > cc:
        mv.feed(aa, bb, depth)
        if motion == 83:
            mv.traverse(aa, bb, r)
        mv.traverse(aa, bb, depth + delta)
        depth -= q
    mv.feed(aa, bb, cc)
    mv.traverse(aa, bb, clear)


def _g85(mv: _Moves, motion: int, aa: float, bb: float, r: float, cc: float, clear: float) -> None:
    """G85: feed in, feed out to R, then to the clearance level (convert_cycle_g85)."""
    mv.feed(aa, bb, cc)
    mv.feed(aa, bb, r)
    mv.traverse(aa, bb, clear)


def _tap(mv: _Moves, motion: int, aa: float, bb: float, r: float, cc: float, clear: float) -> None:
    """G74 and G84, tapping (convert_cycle_g74_g84): overrides off, in, reverse the
    spindle, dwell, out, turn it back, overrides back on."""
    st = mv.st
    forward = 1 if motion == 84 else -1
    f_on, s_on = st.feed_override, st.speed_override
    mv.function(("M", 49.0))
    mv.feed(aa, bb, cc)
    st.spindle_dir = -forward
    mv.function(("M", 5.0), ("M", 4.0 if motion == 84 else 3.0))
    mv.dwell(st.cycle_p)
    mv.feed(aa, bb, clear)
    st.spindle_dir = forward
    mv.function(("M", 5.0), ("M", 3.0 if motion == 84 else 4.0))
    st.feed_override, st.speed_override = f_on, s_on
    if f_on and s_on:
        mv.function(("M", 48.0))
    elif f_on or s_on:
        mv.function(("M", 50.0 if f_on else 51.0), ("P", 1.0))


def _g86(mv: _Moves, motion: int, aa: float, bb: float, r: float, cc: float, clear: float) -> None:
    """G86, boring, the spindle stopped for the way out (convert_cycle_g86)."""
    st = mv.st
    turning = st.spindle_dir
    mv.feed(aa, bb, cc)
    mv.dwell(st.cycle_p)
    st.spindle_dir = 0
    mv.function(("M", 5.0))
    mv.traverse(aa, bb, clear)
    st.spindle_dir = turning
    mv.function(("M", 3.0 if turning > 0 else 4.0))


def _drill(
    mv: _Moves, motion: int, aa: float, bb: float, r: float, cc: float, clear: float
) -> None:
    """G81, G82, G89: feed to the bottom, dwell or not, retract at rapid or at feed
    (G89 bores out) (convert_cycle_g81, _g82, _g89)."""
    dwells, feed_out = CYCLE_SHAPE[motion]
    mv.feed(aa, bb, cc)
    if dwells:
        mv.dwell(mv.st.cycle_p)
    (mv.feed if feed_out else mv.traverse)(aa, bb, clear)


#: each cycle's hole, by its G number
HOLES = {
    73: _peck,
    83: _peck,
    85: _g85,
    74: _tap,
    84: _tap,
    86: _g86,
    81: _drill,
    82: _drill,
    89: _drill,
}
