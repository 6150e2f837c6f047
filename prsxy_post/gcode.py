"""G-code in: RS274/NGC as LinuxCNC reads it, the milling subset.

Two layers, kept apart:

- :func:`parse_line` turns one line into a :class:`Block`: the words as written,
  each with its column, comments and block-delete removed. It knows nothing of
  modes.
- :func:`iter_motions` runs the modal interpreter over blocks and yields
  :class:`Motion` s: what the machine does, in the workpiece frame (LinuxCNC's
  machine coordinates: program coordinates plus the work offset), always mm and
  degrees.

What LinuxCNC rejects is rejected here too, with ``file:line:column`` and the
offending word; what is outside this tool's subset (parameters, expressions,
O-words, cutter compensation, G92, G10, splines, polar coordinates, a C, U, V or W
axis) is rejected the same way. The behaviour follows LinuxCNC 2.9's interpreter
(``rs274 -g`` is the test oracle): canned cycles expand into its moves, G28/G30
go through the intermediate point, arcs obey its radius tolerances.

Choices where LinuxCNC depends on settings: block delete ``/`` is off (the line
runs, as in LinuxCNC's default); the first ``%`` line starts the program and a
second one ends it; M2/M30 end the program (nothing after them is read).
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Generator, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

from .errors import GCodeError

MM_PER_INCH = 25.4
#: LinuxCNC's arc tolerances (interp_internal.hh), per unit system.
RADIUS_TOLERANCE = {"mm": 0.00005 * MM_PER_INCH, "inch": 0.00005}
SPIRAL_ABS_TOLERANCE = {"mm": 2 * 0.01 * math.sqrt(2), "inch": 2 * 0.001 * math.sqrt(2)}
SPIRAL_REL_TOLERANCE = 0.001
#: G73/G83 back-off before the next peck (LinuxCNC's G83_RAPID_DELTA, inch).
G83_RAPID_DELTA_INCH = 0.010

Pose = tuple[float, ...]  # (x, y, z, A, B)


@dataclass(frozen=True)
class ToolEntry:
    """A tool of the profile's tool table."""

    length: float  # mm, the G43 H<n> length offset
    diameter: float = 0.0


@dataclass(frozen=True)
class InterpreterConfig:
    """What the interpreter needs from the machine profile.

    work_offsets : G54..G59 → (x, y, z, a, b) [mm, deg]; missing ones are zero
    g28_position, g30_position : stored positions, workpiece frame
    tool_table : tool number → ToolEntry
    start : initial position, workpiece frame
    """

    work_offsets: Mapping[int, Pose] = field(default_factory=dict)
    g28_position: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    g30_position: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    tool_table: Mapping[int, ToolEntry] = field(default_factory=dict)
    start: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    active_work_offset: int = 54


class Motion(NamedTuple):
    """One move, arc or dwell the machine makes (a named tuple: cheap to make by
    the hundred thousand).

    start, end : (x, y, z, A, B) [mm, deg], workpiece frame
    feed : mm/min along the XYZ path; deg/min when only A/B move; for G93 the
        rate LinuxCNC derives (length × F); NaN for rapids
    plane, center, rotation : arcs only: 17/18/19, centre [mm], signed turns as in
        LinuxCNC's ARC_FEED (+ counter-clockwise seen from the plane normal's + end)
    duration : dwell seconds
    tool_length : active tool length offset [mm] (G43 / G43.1), 0 after G49
    path_tol : path control mode in effect (LinuxCNC group 13) [mm]: None when the
        program set none or gave G64 without P (the profile's default tolerance
        applies), the G64 P tolerance, 0.0 for G61 (exact path), −1.0 for G61.1
        (exact stop at every block end)
    words : kind ``"function"`` only: the machine functions of the block, in
        LinuxCNC's order of execution, as (letter, value) pairs: S, T, M6,
        M3/M4/M5, M7/M8/M9, M48/M49 before the block's motion; M0, M1, M60, M2,
        M30 after it
    """

    line: int
    kind: str
    start: Pose
    end: Pose
    feed: float = math.nan
    plane: int = 0
    center: tuple[float, float, float] | None = None
    rotation: int = 0
    duration: float = 0.0
    tool_length: float = 0.0
    tool: int = 0
    spindle: float = 0.0
    inverse_time: bool = False
    path_tol: float | None = None
    words: tuple[tuple[str, float], ...] = ()


#: path_tol of G61.1 (exact stop)
EXACT_STOP = -1.0


def motion_to_json(m: Motion) -> dict[str, object]:
    """The ``inspect --json`` object of a motion."""
    d: dict[str, object] = {
        "line": m.line,
        "kind": m.kind,
        "end": [round(v, 9) + 0.0 for v in m.end],
    }
    d["feed"] = None if m.kind in ("rapid", "dwell") else round(m.feed, 9)
    if m.kind == "arc":
        assert m.center is not None
        d["plane"] = m.plane
        d["center"] = [round(v, 9) + 0.0 for v in m.center]
        d["rotation"] = m.rotation
    if m.kind == "dwell":
        d["duration"] = m.duration
    if m.kind == "function":
        d["words"] = [f"{letter}{value:g}" for letter, value in m.words]
    return d


# ---------------------------------------------------------------- parsing


class Word(NamedTuple):
    """One word as written (a named tuple: made for every word of every line)."""

    letter: str  # upper case
    value: float
    text: str  # as written (without spaces)
    column: int  # 1-based column of the letter in the line


@dataclass(frozen=True, slots=True)
class Block:
    """One line as written: its words (with columns), nothing interpreted."""

    line: int
    words: tuple[Word, ...]
    percent: bool = False
    has_text: bool = False  # anything but blanks, comments included


_WORD = re.compile(r"([A-Z])([+-]?(?:\d+\.?\d*|\.\d+))")
_PLAIN = re.compile(r"(?:[A-Z][+-]?(?:\d+\.?\d*|\.\d+))*")


def split_lines(text: str) -> list[str]:
    """Lines without their ends; CR, LF and CRLF (mixed too) each end a line."""
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n") if text else []


def iter_line_batches(pieces: Iterable[str]) -> Iterator[list[str]]:
    """Lines without their ends from text that arrives in pieces (a file read in
    blocks), a list per piece: the same lines as :func:`split_lines` of the whole
    text, except that a final line end does not start an empty line (as a file's
    lines are counted). A CR at the end of a piece waits for the next one, which
    may start with LF.
    """
    tail = ""
    for piece in pieces:
        text = tail + piece
        cut = max(text.rfind("\n"), text.rfind("\r", 0, len(text) - 1))
        if cut < 0:
            tail = text
            continue
        lines = split_lines(text[: cut + 1])
        lines.pop()  # the empty string after the last line end
        yield lines
        tail = text[cut + 1 :]
    if tail:
        lines = split_lines(tail)
        if lines[-1] == "":
            lines.pop()
        yield lines


def _fail(
    msg: str, source: str, line: int, column: int | None, expected: str | None = None
) -> GCodeError:
    return GCodeError(msg, source=source, line=line, column=column, expected=expected)


def _strip_comments(raw: str, source: str, lineno: int) -> tuple[str, list[int]]:
    """Text outside comments, without spaces, and the original column of each kept char."""
    out: list[str] = []
    cols: list[int] = []
    depth_start = -1
    for i, ch in enumerate(raw):
        if depth_start >= 0:
            if ch == ")":
                depth_start = -1
            elif ch == "(":
                raise _fail(
                    "nested comment",
                    source,
                    lineno,
                    i + 1,
                    "a ')' before another '(' (LinuxCNC does not nest comments)",
                )
            continue
        if ch == "(":
            depth_start = i
        elif ch == ";":
            break
        elif ch in " \t":
            continue
        else:
            out.append(ch)
            cols.append(i + 1)
    if depth_start >= 0:
        raise _fail("comment not closed", source, lineno, depth_start + 1, "a ')' on the line")
    return "".join(out), cols


_REJECT_CHAR = {
    "#": "parameters (#) are not supported",
    "[": "expressions ([ ]) are not supported",
    "]": "expressions ([ ]) are not supported",
    "O": "O-words (subroutines and control flow) are not supported",
    "C": "a C axis is not supported on this machine",
    "U": "a U axis is not supported on this machine",
    "V": "a V axis is not supported on this machine",
    "W": "a W axis is not supported on this machine",
    "@": "polar coordinates (@, ^) are not supported",
    "^": "polar coordinates (@, ^) are not supported",
    "$": "spindle selection ($) is not supported",
}
_LETTERS = set("ABDFGHIJKLMNPQRSTXYZ")


_ASCII_UPPER = str.maketrans("abcdefghijklmnopqrstuvwxyz", "ABCDEFGHIJKLMNOPQRSTUVWXYZ")


def parse_line(raw: str, lineno: int, source: str = "<string>") -> Block:
    """Words of one line, each with its column; errors are located.

    Comments in ``( )`` and after ``;`` and all spaces are removed first (so
    ``X 1 0.5`` is X10.5, as LinuxCNC reads it); letters are case-insensitive.
    """
    s = raw.strip()
    if s.startswith("%"):
        if s.strip("% \t"):
            raise _fail(
                "text after '%'", source, lineno, raw.index("%") + 2, "'%' alone on its line"
            )
        return Block(lineno, (), percent=True)
    if "(" in raw or ";" in raw:
        text, cols = _strip_comments(raw, source, lineno)
    else:
        cols = [i + 1 for i, ch in enumerate(raw) if ch not in " \t"]
        text = raw.replace(" ", "").replace("\t", "")
    if not text:
        return Block(lineno, (), has_text=bool(s))
    if text[0] == "/":
        text = text[1:]
        cols = cols[1:]
    up = text.translate(_ASCII_UPPER)  # not str.upper(): "ß" would become "SS"
    m = _PLAIN.fullmatch(up)
    if m is None:
        # find the first character that does not start a valid word; a rejected
        # letter (O, C, U, V, W) or a parameter/expression says more than what follows
        pos = 0
        for wm in _WORD.finditer(up):
            if wm.start() != pos:
                break
            if wm.group(1) in _REJECT_CHAR:
                raise _fail(
                    _REJECT_CHAR[wm.group(1)],
                    source,
                    lineno,
                    cols[pos],
                    "plain words like G1 X10 (the milling subset)",
                )
            pos = wm.end()
        ch = up[pos] if pos < len(up) else ""
        col = cols[pos] if pos < len(cols) else (cols[-1] + 1 if cols else 1)
        for special in "#[":
            k = up.find(special, pos)
            if k >= 0 and (ch in _REJECT_CHAR or ch.isalpha() or ch in "+-."):
                raise _fail(
                    _REJECT_CHAR[special],
                    source,
                    lineno,
                    cols[k],
                    "plain words like G1 X10 (the milling subset)",
                )
        if ch in _REJECT_CHAR:
            raise _fail(
                _REJECT_CHAR[ch],
                source,
                lineno,
                col,
                "plain words like G1 X10 (the milling subset)",
            )
        if ch.isalpha():
            if ch not in _LETTERS:
                raise _fail(
                    f"unknown word letter '{ch}'",
                    source,
                    lineno,
                    col,
                    "one of A B D F G H I J K L M N P Q R S T X Y Z",
                )
            raise _fail(
                f"word '{ch}' has no number",
                source,
                lineno,
                col,
                f"a number after {ch}, e.g. {ch}10.5",
            )
        if ch == "/":
            raise _fail("'/' (block delete) only at the start of a line", source, lineno, col)
        raise _fail(
            f"unexpected character {ch!r}",
            source,
            lineno,
            col,
            "a word: a letter followed by a number",
        )
    words = []
    pos = 0
    for wm in _WORD.finditer(up):
        letter = wm.group(1)
        col = cols[wm.start()]
        if letter in _REJECT_CHAR:
            raise _fail(
                _REJECT_CHAR[letter],
                source,
                lineno,
                col,
                "plain words like G1 X10 (the milling subset)",
            )
        if letter not in _LETTERS:
            raise _fail(
                f"unknown word letter '{letter}'",
                source,
                lineno,
                col,
                "one of A B D F G H I J K L M N P Q R S T X Y Z",
            )
        words.append(Word(letter, float(wm.group(2)), wm.group(0), col))
        pos = wm.end()
    return Block(lineno, tuple(words), has_text=True)


# ---------------------------------------------------------------- modal groups

_G_GROUP = {
    0: 1,
    1: 1,
    2: 1,
    3: 1,
    73: 1,
    80: 1,
    81: 1,
    82: 1,
    83: 1,
    84: 1,
    85: 1,
    86: 1,
    89: 1,
    17: 2,
    18: 2,
    19: 2,
    90: 3,
    91: 3,
    90.1: 4,
    91.1: 4,
    93: 5,
    94: 5,
    20: 6,
    21: 6,
    40: 7,
    43: 8,
    43.1: 8,
    49: 8,
    98: 10,
    99: 10,
    54: 12,
    55: 12,
    56: 12,
    57: 12,
    58: 12,
    59: 12,
    61: 13,
    61.1: 13,
    64: 13,
    4: 0,
    28: 0,
    30: 0,
    53: 0,
}
_G_REJECT = {
    41: "cutter compensation (G41/G42) is not supported",
    42: "cutter compensation (G41/G42) is not supported",
    41.1: "cutter compensation (G41/G42) is not supported",
    42.1: "cutter compensation (G41/G42) is not supported",
    92: "G92 offsets are not supported",
    92.1: "G92 offsets are not supported",
    92.2: "G92 offsets are not supported",
    92.3: "G92 offsets are not supported",
    10: "G10 (setting offsets from the program) is not supported",
    5: "splines (G5) are not supported",
    5.1: "splines (G5.1) are not supported",
    5.2: "NURBS (G5.2) are not supported",
    5.3: "NURBS (G5.3) are not supported",
    15: "polar coordinates (G15/G16) are not supported",
    16: "polar coordinates (G15/G16) are not supported",
    87: "G87 back boring is not supported",
    88: "G88 (manual retract) is not supported",
    74: "G74 left-hand tapping is not supported",
    76: "G76 threading is not supported",
    33: "G33 spindle-synchronised motion is not supported",
    33.1: "G33.1 rigid tapping is not supported",
    38.2: "probing (G38.x) is not supported",
    38.3: "probing (G38.x) is not supported",
    38.4: "probing (G38.x) is not supported",
    38.5: "probing (G38.x) is not supported",
    28.1: "G28.1 (storing the home position) is not supported",
    30.1: "G30.1 (storing the home position) is not supported",
    95: "G95 feed per revolution is not supported",
    96: "G96 constant surface speed is not supported",
    97: "G96/G97 spindle modes are not supported",
    7: "lathe diameter mode (G7) is not supported",
    8: "lathe radius mode (G8) is not supported",
    17.1: "U-V planes are not supported",
    18.1: "U-W planes are not supported",
    19.1: "V-W planes are not supported",
    59.1: "G59.1 is not supported (G54 to G59)",
    59.2: "G59.2 is not supported (G54 to G59)",
    59.3: "G59.3 is not supported (G54 to G59)",
    43.2: "G43.2 (additional offsets) is not supported",
    52: "G52 is not supported",
    64.1: "G64 variants are not supported",
    90.2: "unknown G code",
}
_M_GROUP: dict[float, int] = {
    0: 4,
    1: 4,
    2: 4,
    30: 4,
    60: 4,
    3: 7,
    4: 7,
    5: 7,
    6: 6,
    7: 8,
    8: 8,
    9: 8,
    48: 9,
    49: 9,
}
_CYCLES = {73, 81, 82, 83, 84, 85, 86, 89}
#: canned cycles of one plunge: (dwell at the bottom, retract at feed rate)
_CYCLE_SHAPE = {
    81: (False, False),
    82: (True, False),
    84: (True, True),
    86: (True, False),
    89: (True, True),
}
_AXES = "XYZAB"


def _code(v: float) -> float:
    """G/M number as a key: integers stay integers; G43.1 stays 43.1."""
    r = round(v, 1)
    return int(r) if r == int(r) else r


# ---------------------------------------------------------------- the interpreter


@dataclass
class _State:
    pos: list[float]  # workpiece frame, mm / deg
    units: str = "mm"
    plane: int = 17
    absolute: bool = True
    arc_absolute: bool = False
    inverse_time: bool = False
    motion: float | None = None  # LinuxCNC starts in G80
    feed: float = 0.0  # F as written (current units or deg per min)
    feed_units: str = "mm"
    spindle: float = 0.0
    spindle_dir: int = 0
    tool: int = 0
    next_tool: int = 0
    tool_length: float = 0.0
    coord: int = 54
    retract_r: bool = True  # G99 (LinuxCNC default) vs G98
    cycle_r: float = 0.0
    cycle_z: float = 0.0  # in the cycle's own axis, workpiece frame
    cycle_q: float = 0.0
    cycle_p: float = 0.0
    cycle_il: float | None = None
    path_tol: float | None = None
    ended: bool = False


class Interpreter:
    """The modal state machine: feed it blocks, collect motions."""

    def __init__(self, config: InterpreterConfig | None = None, source: str = "<string>") -> None:
        self.cfg = config or InterpreterConfig()
        self.source = source
        self.st = _State(pos=list(self.cfg.start))
        self.out: list[Motion] = []
        self.percent_seen = False
        self.started = False  # a non-blank line was read (a later '%' is an error)

    # -- helpers
    def offset(self, code: int | None = None) -> tuple[float, ...]:
        return tuple(self.cfg.work_offsets.get(code or self.st.coord, (0.0,) * 5))

    def err(
        self, msg: str, line: int, word: Word | None = None, expected: str | None = None
    ) -> GCodeError:
        text = f"{msg} ('{word.text}')" if word is not None else msg
        return _fail(text, self.source, line, word.column if word else None, expected)

    def scale(self) -> float:
        return MM_PER_INCH if self.st.units == "inch" else 1.0

    def emit(self, **kw: object) -> None:
        st = self.st
        kw.setdefault("tool_length", st.tool_length)
        kw.setdefault("tool", st.tool)
        kw.setdefault("spindle", st.spindle * st.spindle_dir)
        kw.setdefault("inverse_time", st.inverse_time)
        kw.setdefault("path_tol", st.path_tol)
        self.out.append(Motion(**kw))  # type: ignore[arg-type]

    # -- one block
    def run(self, blk: Block) -> None:
        st = self.st
        if st.ended:
            return
        if blk.percent:
            if self.percent_seen:
                st.ended = True
                return
            if self.started:
                raise _fail(
                    "'%' after the start of the program",
                    self.source,
                    blk.line,
                    1,
                    "'%' only on the first line and to end the program",
                )
            self.percent_seen = True
            self.started = True
            return
        if blk.words or blk.has_text:
            self.started = True
        if not blk.words:
            return
        line = blk.line
        seen: dict[str, Word] = {}
        gs: list[Word] = []
        ms: list[Word] = []
        for w in blk.words:
            if w.letter == "G":
                gs.append(w)
            elif w.letter == "M":
                ms.append(w)
            elif w.letter == "N":
                if w is not blk.words[0]:
                    raise self.err(
                        "N word not at the start of the line", line, w, "the line number first"
                    )
                continue
            else:
                if w.letter in seen:
                    raise self.err(
                        f"{w.letter} word repeated", line, w, f"one {w.letter} word per block"
                    )
                seen[w.letter] = w
        groups: dict[int, tuple[float, Word]] = {}
        nonmodal: list[tuple[float, Word]] = []
        for w in gs:
            code = _code(w.value)
            if code in _G_REJECT:
                raise self.err(_G_REJECT[code], line, w, "the milling subset (see README)")
            if code not in _G_GROUP:
                raise self.err("unknown G code", line, w, "a G code LinuxCNC knows")
            grp = _G_GROUP[code]
            if grp == 1 and grp in groups and 80 in (code, groups[grp][0]):
                # LinuxCNC lets G80 stand beside another motion code; the other wins
                if code == 80:
                    continue
                groups[grp] = (code, w)
                continue
            if grp == 0:
                if nonmodal:
                    raise self.err(
                        "two G codes of the non-modal group in one block",
                        line,
                        w,
                        "one of G4, G28, G30, G53 per block",
                    )
                nonmodal.append((code, w))
                continue
            if grp in groups:
                raise self.err(
                    "two G codes of the same modal group",
                    line,
                    w,
                    f"one of them (already {groups[grp][1].text})",
                )
            groups[grp] = (code, w)
        mgroups: dict[int, tuple[float, Word]] = {}
        for w in ms:
            code = _code(w.value)
            if code not in _M_GROUP:
                raise self.err(
                    "unsupported M code", line, w, "M0 M1 M2 M3 M4 M5 M6 M7 M8 M9 M30 M48 M49 M60"
                )
            grp = _M_GROUP[int(code)]
            if grp in mgroups:
                raise self.err(
                    "two M codes of the same modal group",
                    line,
                    w,
                    f"one of them (already {mgroups[grp][1].text})",
                )
            mgroups[grp] = (code, w)
        if len(ms) > 4:
            raise self.err("too many M codes in one block", line, ms[4], "at most four")
        if "D" in seen:
            raise self.err(
                "D words (cutter radius) are not supported",
                line,
                seen["D"],
                "no cutter compensation",
            )
        for key in ("F", "S", "T", "P", "Q", "R", "L", "H"):
            if key in seen and seen[key].value < 0:
                if key in ("R",):
                    continue
                raise self.err(f"negative {key} word", line, seen[key], f"{key} >= 0")
        # feed mode, F, S, T
        if 5 in groups:
            g = groups[5][0]
            new_it = g == 93
            if new_it != st.inverse_time:
                st.feed = 0.0
            st.inverse_time = new_it
        if "F" in seen:
            st.feed = seen["F"].value
            st.feed_units = st.units
        # machine functions before the motion, in LinuxCNC's order of execution
        # (S, T, M6, M3/M4/M5, M7/M8/M9, M48/M49): an S or T that changes nothing
        # is no function
        pre: list[tuple[str, float]] = []
        if "S" in seen:
            if seen["S"].value != st.spindle:
                pre.append(("S", seen["S"].value))
            st.spindle = seen["S"].value
        if "T" in seen:
            t = seen["T"].value
            if t != int(t):
                raise self.err("tool number not an integer", line, seen["T"], "T<n>")
            if int(t) != st.next_tool:
                pre.append(("T", float(int(t))))
            st.next_tool = int(t)
        if 6 in mgroups:
            st.tool = st.next_tool
            pre.append(("M", 6.0))
        if 7 in mgroups:
            st.spindle_dir = {3: 1, 4: -1, 5: 0}[int(mgroups[7][0])]
            pre.append(("M", float(mgroups[7][0])))
        for grp in (8, 9):
            if grp in mgroups:
                pre.append(("M", float(mgroups[grp][0])))
        if pre:
            p = tuple(st.pos)
            self.emit(line=line, kind="function", start=p, end=p, words=tuple(pre))
        # dwell
        if nonmodal and nonmodal[0][0] == 4:
            if "P" not in seen:
                raise self.err("G4 without a dwell time", line, nonmodal[0][1], "G4 P<seconds>")
            p = tuple(st.pos)
            self.emit(line=line, kind="dwell", start=p, end=p, duration=seen["P"].value)
        # plane, units
        if 2 in groups:
            st.plane = int(groups[2][0])
        if 6 in groups:
            st.units = "inch" if groups[6][0] == 20 else "mm"
        if 7 in groups:
            pass  # G40: cutter compensation off (it is never on)
        if 8 in groups:
            self._tool_length(groups[8], seen, line)
        if 12 in groups:
            st.coord = int(groups[12][0])
        if 3 in groups:
            st.absolute = groups[3][0] == 90
        if 4 in groups:
            st.arc_absolute = groups[4][0] == 90.1
        if 10 in groups:
            st.retract_r = groups[10][0] == 99
        if 13 in groups:
            self._path_control(groups[13], seen, line)
        axis_words = {a: seen[a] for a in _AXES if a in seen}
        nm = nonmodal[0][0] if nonmodal else None
        motion = groups[1][0] if 1 in groups else None
        if nm in (28, 30):
            if motion is not None and motion != 80 and axis_words:
                raise self.err(
                    "two G codes that both use axis words",
                    line,
                    groups[1][1],
                    f"G{nm} or a motion, not both",
                )
            self._home(nm, axis_words, line)
        elif nm == 53:
            mode = motion if motion is not None else st.motion
            if mode not in (0, 1):
                raise self.err(
                    "G53 with a motion other than G0 or G1",
                    line,
                    nonmodal[0][1],
                    "G53 G0 or G53 G1",
                )
            if not st.absolute:
                raise self.err("G53 in incremental mode", line, nonmodal[0][1], "G90 with G53")
            if motion is not None:
                st.motion = motion
            self._linear(int(mode), axis_words, seen, line, machine=True)
        else:
            if motion is not None:
                if motion == 80:
                    if axis_words:
                        w = next(iter(axis_words.values()))
                        raise self.err(
                            "axis words with G80", line, w, "no X Y Z A B with G80 (motion off)"
                        )
                    st.motion = None
                    st.cycle_il = None
                else:
                    if motion not in _CYCLES:
                        st.cycle_il = None
                    self._motion(motion, axis_words, seen, line, new=True)
            elif axis_words:
                if st.motion is None:
                    w = next(iter(axis_words.values()))
                    raise self.err(
                        "axis words with no motion mode",
                        line,
                        w,
                        "a G0, G1, G2, G3 or canned cycle in effect (not G80)",
                    )
                self._motion(st.motion, axis_words, seen, line, new=False)
            else:
                self._check_unused(seen, line, st.motion if motion is None else motion)
        # program stop / end, after the motion
        if 4 in mgroups:
            p = tuple(st.pos)
            code = mgroups[4][0]
            self.emit(line=line, kind="function", start=p, end=p, words=(("M", float(code)),))
            if code in (2, 30):
                st.ended = True

    def _path_control(self, g: tuple[float, Word], seen: dict[str, Word], line: int) -> None:
        """G61 (exact path), G61.1 (exact stop), G64 [P tolerance] [Q]: the blend
        tolerance the planner may use at corners (:attr:`Motion.path_tol`)."""
        code = g[0]
        st = self.st
        if code == 61:
            st.path_tol = 0.0
        elif code == 61.1:
            st.path_tol = EXACT_STOP
        elif "P" in seen:
            st.path_tol = seen["P"].value * self.scale()
        else:
            st.path_tol = None  # "best possible speed": the profile's tolerance

    # -- pieces
    def _check_unused(self, seen: dict[str, Word], line: int, motion: float | None) -> None:
        for letter in ("I", "J", "K"):
            if letter in seen:
                raise self.err(
                    f"{letter} word with no arc to use it",
                    line,
                    seen[letter],
                    "I, J, K only with G2/G3",
                )
        if "R" in seen and motion not in _CYCLES:
            raise self.err(
                "R word with no arc or canned cycle to use it",
                line,
                seen["R"],
                "R only with G2/G3 or a canned cycle",
            )

    def _tool_length(self, g: tuple[float, Word], seen: dict[str, Word], line: int) -> None:
        """G43/G43.1/G49. The spindle does not move when the offset changes, so the
        tip's program position moves by the difference (as in LinuxCNC)."""
        st = self.st
        old = st.tool_length
        self._set_tool_length(g, seen, line)
        st.pos[2] += old - st.tool_length

    def _set_tool_length(self, g: tuple[float, Word], seen: dict[str, Word], line: int) -> None:
        st = self.st
        code, w = g
        if code == 49:
            st.tool_length = 0.0
        elif code == 43:
            n = int(seen["H"].value) if "H" in seen else st.tool
            if "H" in seen and seen["H"].value != int(seen["H"].value):
                raise self.err("H not an integer", line, seen["H"], "H<tool number>")
            if n == 0:
                st.tool_length = 0.0
            elif n not in self.cfg.tool_table:
                raise self.err(
                    f"tool {n} is not in the profile's tool table",
                    line,
                    seen.get("H", w),
                    "a [[tools]] entry for it",
                )
            else:
                st.tool_length = self.cfg.tool_table[n].length
        else:  # G43.1
            if "Z" not in seen:
                raise self.err("G43.1 without a Z length", line, w, "G43.1 Z<length>")
            st.tool_length = seen["Z"].value * self.scale()
            del seen["Z"]

    def _target(self, axis_words: dict[str, Word], machine: bool = False) -> list[float]:
        """End point of a move; ``machine`` (G53): LinuxCNC machine coordinates are of
        the gauge point, so the tip lies the tool length below them in Z."""
        st = self.st
        off = (0.0, 0.0, -st.tool_length, 0.0, 0.0) if machine else self.offset()
        out = list(st.pos)
        sc = self.scale()
        for i, a in enumerate(_AXES):
            if a in axis_words:
                v = axis_words[a].value * (sc if i < 3 else 1.0)
                out[i] = (v + off[i]) if (st.absolute or machine) else st.pos[i] + v
        return out

    def _feed_rate(
        self,
        start: list[float],
        end: list[float],
        length: float | None,
        line: int,
        word: Word | None,
    ) -> float:
        """Feed in mm/min (deg/min for rotary-only moves), as LinuxCNC derives it."""
        st = self.st
        lin = math.dist(start[:3], end[:3]) if length is None else length
        if st.inverse_time:
            if "F" not in self._seen:
                raise self.err(
                    "feed move without F in inverse time mode (G93)",
                    line,
                    word,
                    "an F word on every G1/G2/G3 block in G93",
                )
            if st.feed <= 0:
                raise self.err("zero feed rate", line, self._seen["F"], "F > 0")
            if lin > 1e-12:
                return st.feed * lin
            return st.feed * math.dist(start[3:], end[3:])
        if st.feed <= 0:
            raise self.err(
                "feed move with no feed rate",
                line,
                word,
                "an F word before (or on) the first G1/G2/G3",
            )
        if lin > 1e-12 or math.dist(start[3:], end[3:]) == 0:
            return st.feed * (MM_PER_INCH if st.units == "inch" else 1.0)
        return st.feed  # rotary-only: degrees per minute in either unit system

    def _motion(
        self,
        motion: float,
        axis_words: dict[str, Word],
        seen: dict[str, Word],
        line: int,
        new: bool,
    ) -> None:
        st = self.st
        self._seen = seen
        if motion in _CYCLES:
            self._cycle(int(motion), axis_words, seen, line, new)
            st.motion = motion
            return
        st.motion = motion
        if motion in (0, 1):
            for letter in ("I", "J", "K", "R"):
                if letter in seen:
                    raise self.err(
                        f"{letter} word with G{int(motion)}",
                        line,
                        seen[letter],
                        "I, J, K, R only with arcs or canned cycles",
                    )
            self._linear(int(motion), axis_words, seen, line)
        else:
            self._arc(int(motion), axis_words, seen, line)

    def _linear(
        self,
        motion: int,
        axis_words: dict[str, Word],
        seen: dict[str, Word],
        line: int,
        machine: bool = False,
    ) -> None:
        st = self.st
        self._seen = seen
        start = list(st.pos)
        end = self._target(axis_words, machine)
        if motion == 0:
            self.emit(line=line, kind="rapid", start=tuple(start), end=tuple(end))
        else:
            w = next(iter(axis_words.values()), None)
            f = self._feed_rate(start, end, None, line, w)
            self.emit(line=line, kind="feed", start=tuple(start), end=tuple(end), feed=f)
        st.pos = end

    def _arc(
        self, motion: int, axis_words: dict[str, Word], seen: dict[str, Word], line: int
    ) -> None:
        st = self.st
        gw = next(iter(axis_words.values()), None)
        iu, iv, iw = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[st.plane]
        off_letters = {17: ("I", "J"), 18: ("K", "I"), 19: ("J", "K")}[st.plane]
        start = list(st.pos)
        end = self._target(axis_words)
        sc = self.scale()
        turns = 1
        if "P" in seen:
            p = seen["P"].value
            if p != int(p) or p < 1:
                raise self.err(
                    "P (turns) must be a positive integer", line, seen["P"], "P1, P2, ..."
                )
            turns = int(p)
        unit = st.units
        u0, v0 = start[iu] / sc, start[iv] / sc
        u1, v1 = end[iu] / sc, end[iv] / sc
        if "R" in seen:
            for letter in ("I", "J", "K"):
                if letter in seen:
                    raise self.err(
                        "R and I/J/K in one arc",
                        line,
                        seen[letter],
                        "either R or the centre offsets",
                    )
            r = seen["R"].value
            if u0 == u1 and v0 == v1:
                raise self.err(
                    "R arc whose end point is its start point",
                    line,
                    seen["R"],
                    "a different end point (a full circle needs I/J/K)",
                )
            mu, mv = (u0 + u1) / 2.0, (v0 + v1) / 2.0
            half = math.hypot(mu - u1, mv - v1)
            ar = abs(r)
            if half - ar > RADIUS_TOLERANCE[unit]:
                raise self.err(
                    "arc radius too small to reach the end point",
                    line,
                    seen["R"],
                    f"|R| >= {half:.4f} (half the chord)",
                )
            if ar == 0 or half / ar > 1 - 1e-12:
                half = ar
            if (motion == 2 and r > 0) or (motion == 3 and r < 0):
                theta = math.atan2(v1 - v0, u1 - u0) - math.pi / 2
            else:
                theta = math.atan2(v1 - v0, u1 - u0) + math.pi / 2
            turn2 = math.asin(half / ar) if ar > 0 else 0.0
            d = ar * math.cos(turn2)
            cu, cv = mu + d * math.cos(theta), mv + d * math.sin(theta)
        else:
            la, lb = off_letters
            if la not in seen and lb not in seen:
                raise self.err(
                    "arc with neither R nor centre offsets",
                    line,
                    gw,
                    f"{la} and/or {lb} (or R) with G{motion} in G{st.plane}",
                )
            third = {"I", "J", "K"} - {la, lb}
            for letter in third:
                if letter in seen:
                    raise self.err(
                        f"{letter} word in a G{st.plane} arc",
                        line,
                        seen[letter],
                        f"{la} and {lb} in G{st.plane}",
                    )
            a = seen[la].value if la in seen else 0.0
            b = seen[lb].value if lb in seen else 0.0
            if st.arc_absolute:
                off = self.offset()
                cu = a + off[iu] / sc
                cv = b + off[iv] / sc
            else:
                cu, cv = u0 + a, v0 + b
            r1 = math.hypot(cu - u0, cv - v0)
            r2 = math.hypot(cu - u1, cv - v1)
            rt = RADIUS_TOLERANCE[unit]
            if r1 < rt or r2 < rt:
                raise self.err(
                    "zero-radius arc",
                    line,
                    seen.get(la) or seen.get(lb),
                    "a centre away from the start and end points",
                )
            ae = abs(r1 - r2)
            re_ = ae / max(r1, r2)
            sa = SPIRAL_ABS_TOLERANCE[unit]
            if ae > sa * 100.0 or (re_ > SPIRAL_REL_TOLERANCE and ae > sa):
                raise self.err(
                    f"the end point is not on the arc's circle (radius {r1:.4f} at the start, "
                    f"{r2:.4f} at the end)",
                    line,
                    seen.get(la) or seen.get(lb),
                    f"radii equal within {sa:.4f} {'mm' if unit == 'mm' else 'in'}",
                )
        center = [0.0, 0.0, 0.0]
        center[iu], center[iv] = cu * sc, cv * sc
        center[iw] = end[iw]
        rotation = turns if motion == 3 else -turns
        # helix length for feed: the arc's sweep in the plane and the axial travel
        th0 = math.atan2(v0 - cv, u0 - cu)
        th1 = math.atan2(v1 - cv, u1 - cu)
        if rotation > 0:
            sweep = (th1 - th0) % (2 * math.pi)
        else:
            sweep = (th0 - th1) % (2 * math.pi)
        if sweep <= 1e-12:
            sweep = 2 * math.pi
        sweep += 2 * math.pi * (turns - 1)
        rad = math.hypot(u0 - cu, v0 - cv) * sc
        length = math.hypot(rad * sweep, end[iw] - start[iw])
        f = self._feed_rate(start, end, length, line, gw)
        self.emit(
            line=line,
            kind="arc",
            start=tuple(start),
            end=tuple(end),
            feed=f,
            plane=st.plane,
            center=tuple(center),
            rotation=rotation,
        )
        st.pos = end

    def _home(self, code: float, axis_words: dict[str, Word], line: int) -> None:
        st = self.st
        inter = self._target(axis_words)
        self.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(inter))
        st.pos = inter
        home = list(self.cfg.g28_position if code == 28 else self.cfg.g30_position)
        home[2] -= st.tool_length  # a stored machine position is of the gauge point
        end = list(st.pos)
        for i, a in enumerate(_AXES):
            if not axis_words or a in axis_words:
                end[i] = home[i]
        self.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(end))
        st.pos = end

    def _cycle(
        self, motion: int, axis_words: dict[str, Word], seen: dict[str, Word], line: int, new: bool
    ) -> None:
        st = self.st
        gw = next(iter(axis_words.values()), None)
        if st.inverse_time:
            raise self.err("canned cycle in inverse time mode (G93)", line, gw, "G94")
        if st.feed <= 0:
            raise self.err(
                "canned cycle with no feed rate",
                line,
                gw or seen.get("R"),
                "an F word before the cycle",
            )
        for a in ("A", "B"):
            if a in axis_words:
                raise self.err(
                    "A/B words in a canned cycle",
                    line,
                    axis_words[a],
                    "X Y Z R only: rotary axes may not move in a cycle",
                )
        first = st.motion != motion
        sc = self.scale()
        iu, iv, iw = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[st.plane]
        ax = "XYZ"
        name_w = ax[iw]
        if first and name_w not in axis_words:
            raise self.err(
                f"{name_w} missing in the first block of a canned cycle",
                line,
                gw,
                f"{name_w}<bottom> with G{motion} in G{st.plane}",
            )
        if "R" not in seen and first:
            raise self.err(
                "R missing in the first block of a canned cycle", line, gw, "R<retract plane>"
            )
        if "L" in seen:
            lv = seen["L"].value
            if lv != int(lv) or lv < 1:
                raise self.err("L must be a positive integer", line, seen["L"], "L1, L2, ...")
            repeats = int(lv)
        else:
            repeats = 1
        if motion in (73, 83):
            if "Q" in seen:
                st.cycle_q = seen["Q"].value * sc
            elif first:
                raise self.err(f"Q missing with G{motion}", line, gw, "Q<peck depth>")
            if st.cycle_q <= 0:
                raise self.err("Q must be positive", line, seen.get("Q"), "Q > 0")
        if motion in (82, 84, 86, 89):
            if "P" in seen:
                st.cycle_p = seen["P"].value
            elif first and motion != 84:
                raise self.err(f"P (dwell) missing with G{motion}", line, gw, "P<seconds>")
        if motion == 84 and st.spindle_dir != 1:
            raise self.err("G84 with the spindle not turning clockwise", line, gw, "M3 first")
        if motion == 86 and st.spindle_dir == 0:
            raise self.err("G86 with the spindle not turning", line, gw, "M3 or M4 first")
        off = self.offset()
        cur = list(st.pos)
        # work in program coordinates of the cycle axes, then add the offset back
        cur_w = (cur[iw] - off[iw]) / sc
        if st.cycle_il is None:
            st.cycle_il = cur_w
        old_cc = st.cycle_il
        z_given = axis_words[name_w].value if name_w in axis_words else None
        if "R" in seen:
            st.cycle_r = seen["R"].value
        if z_given is not None:
            st.cycle_z = z_given
        z_num = st.cycle_z
        if st.absolute:
            r = st.cycle_r
            cc = z_num
            aa = axis_words[ax[iu]].value if ax[iu] in axis_words else (cur[iu] - off[iu]) / sc
            bb = axis_words[ax[iv]].value if ax[iv] in axis_words else (cur[iv] - off[iv]) / sc
            inc_a = inc_b = 0.0
        else:
            inc_a = axis_words[ax[iu]].value if ax[iu] in axis_words else 0.0
            inc_b = axis_words[ax[iv]].value if ax[iv] in axis_words else 0.0
            r = st.cycle_r + old_cc
            cc = r + z_num
            aa = (cur[iu] - off[iu]) / sc
            bb = (cur[iv] - off[iv]) / sc
        if r < cc:
            raise self.err(
                f"R below the bottom of the cycle in G{st.plane}",
                line,
                seen.get("R") or axis_words.get(name_w),
                f"R >= {name_w} (the retract plane above the bottom)",
            )

        def pt(a: float, b: float, w: float) -> list[float]:
            p = list(st.pos)
            p[iu], p[iv], p[iw] = a * sc + off[iu], b * sc + off[iv], w * sc + off[iw]
            return p

        def traverse(a: float, b: float, w: float) -> None:
            end = pt(a, b, w)
            self.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(end))
            st.pos = end

        def feed(a: float, b: float, w: float) -> None:
            end = pt(a, b, w)
            f = st.feed * (MM_PER_INCH if st.units == "inch" else 1.0)
            self.emit(line=line, kind="feed", start=tuple(st.pos), end=tuple(end), feed=f)
            st.pos = end

        def dwell(t: float) -> None:
            p = tuple(st.pos)
            self.emit(line=line, kind="dwell", start=p, end=p, duration=t)

        # LinuxCNC: below the R plane (judged by the level the cycles started at),
        # rise straight up to it first; the first move of each hole goes across at
        # the higher of where the tool is and the clearance level
        current_cc = cur_w
        if old_cc < r:
            traverse((cur[iu] - off[iu]) / sc, (cur[iv] - off[iv]) / sc, r)
            old_cc = r
            current_cc = r
        clear = r if st.retract_r else old_cc
        delta = G83_RAPID_DELTA_INCH * (1.0 if st.units == "inch" else MM_PER_INCH)
        for _ in range(repeats):
            aa += inc_a
            bb += inc_b
            first_w = max(current_cc, clear)
            traverse(aa, bb, first_w)
            if first_w != r:
                traverse(aa, bb, r)
            if motion in (73, 83):
                q = st.cycle_q / sc
                depth = r - q
                while depth > cc:
                    feed(aa, bb, depth)
                    if motion == 83:
                        traverse(aa, bb, r)
                    traverse(aa, bb, depth + delta)
                    depth -= q
                feed(aa, bb, cc)
                traverse(aa, bb, clear)
            elif motion == 85:
                feed(aa, bb, cc)
                feed(aa, bb, r)
                traverse(aa, bb, clear)
            else:
                # feed to the bottom, dwell or not, retract at rapid or at feed
                # (G84 taps out, G89 bores out; G86 stops the spindle, which the
                # motion does not see)
                dwells, feed_out = _CYCLE_SHAPE[motion]
                feed(aa, bb, cc)
                if dwells:
                    dwell(st.cycle_p)
                (feed if feed_out else traverse)(aa, bb, clear)
            current_cc = clear


#: The common CAM block: an optional N, an optional G0/G1/G2/G3, axis words in the
#: order X Y Z A B, arc words I J K R, an optional F (each at most once), nothing
#: else. Matched over a whole batch of lines at once (one match per line: the last
#: group takes any other line).
#: Possessive quantifiers (nothing is given back: the last group takes whatever is
#: left, so no match ever needs to backtrack) make it a third faster; only the
#: zeros of G00 must be able to give one back.
_NUM = r"[ \t]*+([-+]?+(?:[0-9]++\.?+[0-9]*+|\.[0-9]++))[ \t]*+"
_FAST_LINE = re.compile(
    r"^[ \t]*+(?:[Nn][ \t]*+[0-9]++[ \t]*+)?+(?:[Gg][ \t]*+0*([0-3])(?![0-9.])[ \t]*+)?+"
    + "".join(f"(?:[{c}{c.lower()}]{_NUM})?+" for c in "XYZABIJKRF")
    + r"(.*)$",
    re.M,
)
_ZERO5 = (0.0, 0.0, 0.0, 0.0, 0.0)
_ARC_LETTERS = ("X", "Y", "Z", "A", "B", "I", "J", "K", "R", "F")
#: lines matched at once: large enough that the regex runs in C for most of the
#: time, small enough that what a batch makes stays in the CPU's caches (measured:
#: 256 lines are 30 % faster than 4096)
_BATCH = 256


def _fast_run(it: Interpreter, matches: list[tuple[str, ...]], i: int, n0: int) -> int:
    """Interpret matched lines from ``i`` on while they are common moves, without
    building Blocks; return the index of the first line not taken.

    ``matches[k]``: the groups of :data:`_FAST_LINE` (G, X, Y, Z, A, B, I, J, K, R,
    F, rest) of line ``n0 + k + 1``. Only blocks the full path would accept the
    same way are taken: G0/G1 without arc words, or G2/G3 (given or in effect),
    in G94, with F positive for a feed move; anything else, and every error,
    goes the full way, which reports it with its column. The modal state lives
    in locals over the run and is written back at its end.
    """
    st = it.st
    if st.ended or st.inverse_time:
        return i
    x, y, z, a, b = st.pos
    motion = st.motion
    feed = st.feed
    sc = MM_PER_INCH if st.units == "inch" else 1.0
    absolute = st.absolute
    ox, oy, oz, oa, ob = it.cfg.work_offsets.get(st.coord, _ZERO5)
    extra = (st.tool_length, st.tool, st.spindle * st.spindle_dir, False, st.path_tol, ())
    append = it.out.append
    new_motion = new_feed = False
    k = i
    for words in itertools.islice(matches, i, None):
        g, xs, ys, zs, as_, bs, is_, js, ks, rs, fs, rest = words
        if rest or not (xs or ys or zs or as_ or bs):
            break
        m = int(g) if g else motion
        if m not in (0, 1, 2, 3):
            break
        if fs:
            f = float(fs)
            if f < 0 or (f == 0 and m):
                break
        elif m and feed <= 0:
            break
        else:
            f = feed
        if m >= 2:
            st.pos, st.motion, st.feed = [x, y, z, a, b], motion, feed
            if not _fast_arc(it, int(m), words, n0 + k + 1):
                break
            x, y, z, a, b = st.pos
            motion, feed = st.motion, st.feed
            k += 1
            continue
        if is_ or js or ks or rs:
            break
        if absolute:
            ex = float(xs) * sc + ox if xs else x
            ey = float(ys) * sc + oy if ys else y
            ez = float(zs) * sc + oz if zs else z
            ea = float(as_) + oa if as_ else a
            eb = float(bs) + ob if bs else b
        else:
            ex = x + float(xs) * sc if xs else x
            ey = y + float(ys) * sc if ys else y
            ez = z + float(zs) * sc if zs else z
            ea = a + float(as_) if as_ else a
            eb = b + float(bs) if bs else b
        if fs:
            feed = f
            new_feed = True
        if g:
            motion = m
            new_motion = True
        if m == 0:
            kind, rate = "rapid", math.nan
        else:
            kind = "feed"
            moved = (ex - x) ** 2 + (ey - y) ** 2 + (ez - z) ** 2 > 1e-24
            rate = f * sc if (moved or (ea == a and eb == b)) else f
        append(
            _motion_of(
                (
                    n0 + k + 1,
                    kind,
                    (x, y, z, a, b),
                    (ex, ey, ez, ea, eb),
                    rate,
                    0,
                    None,
                    0,
                    0.0,
                    *extra,
                )
            )
        )
        x, y, z, a, b = ex, ey, ez, ea, eb
        k += 1
    if k > i:
        st.pos = [x, y, z, a, b]
        st.motion = motion
        st.feed = feed
        if new_feed:
            st.feed_units = st.units
        if new_motion:
            st.cycle_il = None
        it.started = True
    return k


def _motion_of(fields: tuple[object, ...]) -> Motion:
    return tuple.__new__(Motion, fields)


def _fast_arc(it: Interpreter, motion: int, words: tuple[str, ...], n: int) -> bool:
    """G2/G3 from matched words through the interpreter's own arc code. Words carry
    no columns here, so an arc the interpreter refuses goes the full way (with
    the state as it was) to be reported with its column."""
    st = it.st
    seen = {
        letter: Word(letter, float(text), text, 0)
        for letter, text in zip(_ARC_LETTERS, words[1:11], strict=True)
        if text
    }
    axis_words = {a: seen[a] for a in _AXES if a in seen}
    saved = (st.feed, st.feed_units, st.motion, st.cycle_il)
    if "F" in seen:
        st.feed = seen["F"].value
        st.feed_units = st.units
    it._seen = seen
    try:
        it._arc(motion, axis_words, seen, n)
    except GCodeError:
        st.feed, st.feed_units, st.motion, st.cycle_il = saved
        return False
    if words[0]:
        st.cycle_il = None
    st.motion = motion
    it.started = True
    return True


def batches_of(lines: Iterable[str]) -> Generator[list[str], None, None]:
    """Lines in lists of :data:`_BATCH`."""
    batch: list[str] = []
    for raw in lines:
        batch.append(raw)
        if len(batch) == _BATCH:
            yield batch
            batch = []
    if batch:
        yield batch


def iter_motions(
    lines: Iterable[str],
    config: InterpreterConfig | None = None,
    source: str = "<string>",
    fast: bool = True,
) -> Iterator[Motion]:
    """Interpret lines (without their line ends) and yield motions as they come.

    Lines are read in batches; the common straight-move block takes a fast path
    (``fast=False`` turns it off: the tests check both give the same motions and
    errors). Motions of a batch are yielded when the batch is done, or before
    the error a line of it raises.

    Raises
    ------
    GCodeError
        Located at ``source:line:column`` with the offending word.
    """
    return iter_motions_batched(batches_of(lines), config, source, fast)


def iter_motions_batched(
    batches: Iterable[list[str]],
    config: InterpreterConfig | None = None,
    source: str = "<string>",
    fast: bool = True,
) -> Generator[Motion, None, None]:
    """:func:`iter_motions` over lines that come in lists (:func:`iter_line_batches`)."""
    it = Interpreter(config, source)
    out = it.out
    n = 0
    last_text = 0
    for batch in (b[j : j + _BATCH] for b in batches for j in range(0, len(b), _BATCH)):
        matches = _FAST_LINE.findall("\n".join(batch)) if fast else []
        if len(matches) != len(batch):  # a line with a character that ends lines
            matches = [("",) * 11 + ("-",)] * len(batch)
        n0 = n
        i = 0
        while i < len(batch):
            k = _fast_run(it, matches, i, n0) if fast else i
            if k > i:
                n = n0 + k
                last_text = n
                i = k
                continue
            raw = batch[i]
            i += 1
            n = n0 + i
            mark = len(out)
            try:
                blk = parse_line(raw, n, source)
                it.run(blk)
            except GCodeError as exc:
                del out[mark:]
                yield from out
                raise exc from None
            except (ValueError, OverflowError, ZeroDivisionError) as exc:
                del out[mark:]
                yield from out
                raise _fail(
                    f"cannot interpret this block ({exc})", source, n, None, "numbers within range"
                ) from None
            if it.st.ended:
                yield from out
                return
            if blk.has_text or blk.percent:
                last_text = n
        yield from out
        out.clear()
    raise _fail(
        "the program ends without M2, M30 or a closing '%'",
        source,
        max(last_text, 1),
        None,
        "M2 or M30 at the end (LinuxCNC rejects it too)",
    )


def interpret(
    text: str, config: InterpreterConfig | None = None, source: str = "<string>"
) -> list[Motion]:
    """All motions of a program text."""
    return list(iter_motions(split_lines(text), config, source))
