"""Executing a block in LinuxCNC's order: modes, machine functions, motion."""

from __future__ import annotations

from ..errors import GCodeError
from . import cycles, moves
from .codes import AXES, CYCLES, G_GROUP, G_REJECT, M_GROUP, code_of
from .config import InterpreterConfig
from .motion import EXACT_STOP, MM_PER_INCH, Motion
from .read import Block, Word, fail
from .state import State


class Interpreter:
    """The modal state machine: feed it blocks, collect motions."""

    def __init__(self, config: InterpreterConfig | None = None, source: str = "<string>") -> None:
        self.cfg = config or InterpreterConfig()
        self.source = source
        self.st = State(pos=list(self.cfg.start))
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
        return fail(text, self.source, line, word.column if word else None, expected)

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
                raise fail(
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
            code = code_of(w.value)
            if code in G_REJECT:
                raise self.err(G_REJECT[code], line, w, "the milling subset (see README)")
            if code not in G_GROUP:
                raise self.err("unknown G code", line, w, "a G code LinuxCNC knows")
            grp = G_GROUP[code]
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
            code = code_of(w.value)
            if code not in M_GROUP:
                raise self.err(
                    "unsupported M code", line, w, "M0 M1 M2 M3 M4 M5 M6 M7 M8 M9 M30 M48 M49 M60"
                )
            grp = M_GROUP[int(code)]
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
        axis_words = {a: seen[a] for a in AXES if a in seen}
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
            moves.home(self, nm, axis_words, line)
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
            moves.linear(self, int(mode), axis_words, seen, line, machine=True)
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
                    if motion not in CYCLES:
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
        if "R" in seen and motion not in CYCLES:
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
        if motion in CYCLES:
            cycles.cycle(self, int(motion), axis_words, seen, line, new)
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
            moves.linear(self, int(motion), axis_words, seen, line)
        else:
            moves.arc(self, int(motion), axis_words, seen, line)
