"""Executing a block in LinuxCNC's order: modes, machine functions, motion."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from ..errors import GCodeError
from .check import classify
from .codes import CYCLES
from .comp import Queue as CompQueue
from .comp import active as comp_active
from .comp import arc as comp_arc
from .comp import straight as comp_straight
from .comp import turn_off as comp_off
from .comp import turn_on as comp_on
from .config import InterpreterConfig, ToolEntry
from .expr import ExprError
from .functions import io, overrides, restore_blocks, snapshot, spindle_mode, tool_number
from .messages import expand, kind_of
from .motion import EXACT_STOP, MM_PER_INCH, Motion
from .moves import arc, home, linear
from .offsets import axis_offsets, change_frame, curve_to_work, g10, save_home, to_work
from .params import Parameters
from .read import Block, Word, evaluate, fail, parse
from .splines import bezier, nurbs_end, nurbs_point
from .state import State

if TYPE_CHECKING:
    from .control import Control


class Interpreter:
    """The modal state machine: feed it blocks, collect motions."""

    def __init__(self, config: InterpreterConfig | None = None, source: str = "<string>") -> None:
        self.cfg = config or InterpreterConfig()
        self.source = source
        self.st = State(pos=list(self.cfg.start))
        self.out: list[Motion] = []
        self.percent_seen = False
        self.started = False  # a non-blank line was read (a later '%' is an error)
        self.params = Parameters(self._system, self._position, lambda: bool(self.st.comp_side))
        self.queue = CompQueue(self)
        #: after G40 the tool is where compensation left it, not at st.pos
        self.detached: tuple[float, ...] | None = None
        #: the feed rate the last inverse-time move set (LinuxCNC's feed_rate
        #: becomes it), mm/min or deg/min
        self.inverse_rate = 0.0
        self.tools = dict(self.cfg.tool_table)
        self.user_m: frozenset[int] = frozenset(self.cfg.user_m_codes)
        #: the main program's line of the call in progress (motions made in
        #: another file carry it), 0 outside calls
        self.call_line = 0
        #: set by the control flow: the last subroutine's return value
        self.control: Control | None = None
        self.line = 0
        p = self.params.values
        for base, pos in ((5161, self.cfg.g28_position), (5181, self.cfg.g30_position)):
            for i, v in enumerate(pos[:5]):
                p[base + i] = float(v)
        for code, off in self.cfg.work_offsets.items():
            base = 5201 + 20 * _coord_index(code)
            for i, v in enumerate(off[:5]):
                p[base + i] = float(v)
        index = _coord_index(self.cfg.active_work_offset)
        p[5220] = float(index)
        self.st.coord = index
        self.st.origin = self.stored_origin(index)

    # -- helpers
    def stored_origin(self, index: int) -> list[float]:
        """The offsets of coordinate system ``index`` (1: G54 .. 9: G59.3) as the
        parameters hold them now."""
        base = 5201 + 20 * index
        return self.params.values[base : base + 5]

    def tool_parameters(self) -> None:
        """#5400-#5413 from the tool in the spindle (LinuxCNC's set_tool_parameters)."""
        p = self.params.values
        p[5400:5414] = [0.0] * 14
        n = self.st.tool
        entry = self.tools.get(n) if n > 0 else None
        if entry is not None:
            p[5400] = float(n)
            p[5403] = entry.length
            p[5410] = entry.diameter

    def offset(self) -> tuple[float, ...]:
        """Program origin in the workpiece frame: the work offset plus G92 [mm, deg]."""
        o, g = self.st.origin, self.st.g92
        return (o[0] + g[0], o[1] + g[1], o[2] + g[2], o[3] + g[3], o[4] + g[4])

    def _position(self, index: int) -> float:
        """#5420..#5428: the current position in program coordinates and units."""
        i = index - 5420
        if i >= 5:
            return 0.0
        v = self.st.pos[i] - self.offset()[i]
        return v / self.scale() if i < 3 else v

    def _system(self, name: str) -> float:
        """LinuxCNC's read-only named parameters (interp_namedparams.cc)."""
        st = self.st
        sc = self.scale()
        if name in ("_x", "_y", "_z", "_a", "_b"):
            return self._position(5420 + "xyzab".index(name[1]))
        if name in ("_c", "_u", "_v", "_w", "_abs_c", "_remap_level", "_lathe_diameter_mode"):
            return 0.0
        if name in ("_abs_x", "_abs_y", "_abs_z", "_abs_a", "_abs_b"):
            i = "xyzab".index(name[-1])
            v = to_work(st, st.pos)[i] + (st.tool_length if i == 2 else 0.0)
            return v / sc if i < 3 else v
        if name == "_line":
            return float(self.line)
        if name == "_motion_mode":
            return 800.0 if st.motion is None else round(st.motion * 10)
        if name == "_plane":
            return st.plane * 10.0
        if name == "_ccomp":
            return 400.0
        if name in ("_metric", "_imperial"):
            return float((st.units == "mm") == (name == "_metric"))
        if name in ("_absolute", "_incremental"):
            return float(st.absolute == (name == "_absolute"))
        if name in ("_inverse_time", "_units_per_minute"):
            return float(st.inverse_time == (name == "_inverse_time"))
        if name == "_units_per_rev":
            return 0.0
        if name == "_coord_system":
            k = st.coord
            return 530.0 + 10 * k if k < 7 else 584.0 + k
        if name == "_tool_offset":
            return float(st.tool_length != 0.0)
        if name in ("_retract_r_plane", "_retract_old_z"):
            return float(st.retract_r == (name == "_retract_r_plane"))
        if name == "_spindle_rpm_mode":
            return float(not st.css)
        if name == "_spindle_css_mode":
            return float(st.css)
        if name == "_ijk_absolute_mode":
            return float(st.arc_absolute)
        if name == "_lathe_radius_mode":
            return 1.0
        if name in ("_spindle_on", "_spindle_cw"):
            return float(st.spindle_dir != 0 if name == "_spindle_on" else st.spindle_dir == 1)
        if name in ("_mist", "_flood"):
            return float(st.mist if name == "_mist" else st.flood)
        if name == "_speed_override":
            return float(st.speed_override)
        if name == "_feed_override":
            return float(st.feed_override)
        if name == "_adaptive_feed":
            return float(st.adaptive_feed)
        if name == "_feed_hold":
            return float(st.feed_hold)
        if name == "_feed":
            return st.feed
        if name == "_rpm":
            return abs(st.spindle)
        if name in ("_current_tool", "_current_pocket"):
            return float(st.tool)
        if name in ("_selected_tool", "_selected_pocket"):
            return float(st.next_tool)
        if name == "_value":
            return self.control.return_value if self.control is not None else 0.0
        if name == "_value_returned":
            return float(self.control.value_returned) if self.control is not None else 0.0
        if name == "_call_level":
            return float(self.params.call_level)
        if name == "_task":
            return 1.0  # the program runs on the machine (LinuxCNC's milltask: 1)
        if name == "_vmajor":
            return 2.9
        if name == "_vminor":
            return 0.0
        if name == "_metric_machine":
            return 1.0
        raise AssertionError(name)

    def find_subroutine(self, name: str) -> str | None:
        """``name.ngc`` beside the program, then on the subroutine path."""
        dirs = list(self.cfg.subroutine_path)
        here = os.path.dirname(self.source) if os.path.isfile(self.source) else None
        if here is not None:
            dirs.insert(0, here or ".")
        return find_subroutine(name, dirs)

    def message(self, kind: str, text: str, line: int) -> None:
        """A speaking comment: to on_message (or an error for ABORT)."""
        if kind in ("DEBUG", "PRINT", "ABORT"):
            if kind == "DEBUG" and not self.params.values[5599] > 0.0:
                return

            def number(n: int) -> float | None:
                if not 0 <= n < 5602:
                    return None
                return self._position(n) if 5420 <= n <= 5428 else self.params.values[n]

            def named(name: str) -> float | None:
                try:
                    return self.params.get_named(name, 0)
                except ExprError:
                    return None

            text = expand(text, number, named)
        if kind == "ABORT":
            raise fail(f"the program aborts: {text}", self.source, line, None)
        if self.cfg.on_message is not None:
            self.cfg.on_message(self.source, line, kind, text)

    def err(
        self, msg: str, line: int, word: Word | None = None, expected: str | None = None
    ) -> GCodeError:
        text = f"{msg} ('{word.text}')" if word is not None else msg
        return fail(text, self.source, line, word.column if word else None, expected)

    def scale(self) -> float:
        return MM_PER_INCH if self.st.units == "inch" else 1.0

    def extras(self) -> dict[str, object]:
        """The state every motion carries (tool, spindle, feed mode, path control)."""
        st = self.st
        return {
            "tool_length": st.tool_length,
            "tool": st.tool,
            "spindle": st.spindle * st.spindle_dir,
            "inverse_time": st.inverse_time,
            "path_tol": st.path_tol,
        }

    def emit(self, **kw: object) -> None:
        """A motion or event out, or held behind a move cutter compensation holds
        (:class:`.comp.Queue`) so that the order stays."""
        for k, v in self.extras().items():
            kw.setdefault(k, v)
        if self.queue:
            self.queue.hold(**kw)
        else:
            self.emit_now(**kw)

    def emit_now(self, **kw: object) -> None:
        kw = {k: v for k, v in kw.items() if not k.startswith("_")}
        if self.detached is not None:
            # after G40 the tool is off the programmed point: the next move
            # starts where the tool is, events happen there
            if kw["kind"] in ("function", "dwell"):
                kw["start"] = kw["end"] = self.detached
            else:
                kw["start"] = self.detached
                self.detached = None
        if self.st.rotation:
            self._rotate_out(kw)
        self.out.append(Motion(**kw))  # type: ignore[arg-type]

    def _rotate_out(self, kw: dict[str, object]) -> None:
        """A motion's points from the unrotated frame into the workpiece frame
        (offsets.to_work): what LinuxCNC's canon does to every point it gets
        (emccanon.cc rotate_and_offset_pos)."""
        st = self.st
        for key in ("start", "end"):
            kw[key] = tuple(to_work(st, kw[key]))  # type: ignore[arg-type]
        center = kw.get("center")
        if center is not None:
            kw["center"] = tuple(to_work(st, (*center, 0.0, 0.0))[:3])  # type: ignore[misc]
        curve = kw.get("curve")
        if curve is not None:
            kw["curve"] = curve_to_work(st, curve)  # type: ignore[arg-type]

    def context(self, code: int, w: Word, line: int, pre: list[tuple[str, float]]) -> None:
        """M70 (save the modal state), M71 (forget it), M72 (restore it), M73
        (save it, restored when this subroutine returns)."""
        ctl = self.control
        assert ctl is not None
        frame = ctl.frames[-1]
        if code in (70, 73):
            frame.context = snapshot(self)
            frame.restore_on_return = code == 73 and ctl.call_level > 0
        elif code == 71:
            frame.context = None
        else:
            if frame.context is None:
                raise self.err(
                    "M72 with no saved state to restore", line, w, "M70 or M73 before it"
                )
            # functions the restore makes come after the block's own so far
            if pre:
                p = tuple(self.st.pos)
                self.emit(line=line, kind="function", start=p, end=p, words=tuple(pre))
                pre.clear()
            self.restore(frame.context, line)

    def restore(self, saved: dict[str, object], line: int) -> None:
        """Back to a saved modal state: the G and M codes LinuxCNC generates for
        it, run as blocks of this line."""
        for text in restore_blocks(snapshot(self), saved):
            blk = evaluate(parse(text), line, self.params, self.source, self.params.add_named)
            self.run(blk)

    def no_comp(self, what: str, line: int, w: Word | None) -> None:
        """What LinuxCNC refuses with cutter compensation on."""
        if self.st.comp_side:
            raise self.err(
                f"{what} with cutter compensation on", line, w, "G40 (compensation off) first"
            )

    def finish(self) -> None:
        """The end of the program: what compensation still holds goes out."""
        if self.queue:
            self.queue.flush()

    def take_position(self) -> tuple[float, ...]:
        """Where the tool is (where a move starts), leaving G40's detachment."""
        if self.detached is not None:
            pos, self.detached = self.detached, None
            return pos
        return tuple(self.st.pos)

    def feed_now(self) -> float:
        """The feed in effect, mm/min (a move cutter compensation adds): in G93 the
        rate of the last inverse-time move (inverse_time_rate_* set feed_rate)."""
        if self.st.inverse_time:
            return self.inverse_rate
        return self.st.feed * self.scale()

    # -- one block
    def run(self, blk: Block) -> None:
        """Execute a block as LinuxCNC's execute_block does: feed mode and F, the
        machine functions (S, T, M), the modal G codes, the non-modal group, the
        motion, then a stop or end."""
        st = self.st
        if st.ended:
            return
        if blk.percent:
            self._percent(blk)
            return
        if blk.words or blk.has_text:
            self.started = True
        line = blk.line
        self.line = line
        if blk.comment is not None:
            spoken = kind_of(blk.comment)
            if spoken is not None:
                self.message(spoken[0], spoken[1], line)
        if not blk.words:
            return
        w = classify(
            blk.words, st.motion, not st.absolute, st.plane, self.user_m, self.source, line
        )
        self._feed_words(w.seen, w.g)
        pre = self._functions(w.seen, w.g, w.m, line)
        if pre:
            p = tuple(st.pos)
            self.emit(line=line, kind="function", start=p, end=p, words=tuple(pre))
        mode0 = w.g[0][0] if 0 in w.g else None
        self._modes(w.seen, w.g, mode0, line)
        self._non_modal(w.seen, w.g, w.axis, mode0, line)
        self._move(w.seen, w.g, w.axis, w.motion, mode0, line)
        self._stop(w.m, line)

    def _percent(self, blk: Block) -> None:
        """A '%' line: the first starts the program, the second ends it."""
        st = self.st
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

    def _feed_words(self, seen: dict[str, Word], groups: dict[int, tuple[float, Word]]) -> None:
        """G93/G94 and the F word (convert_feed_mode, convert_feed_rate)."""
        st = self.st
        if 5 in groups:
            # convert_feed_mode: G94 sets the feed rate to 0 (in effect already or
            # not; an F in the block comes after it), G93 leaves it
            st.inverse_time = groups[5][0] == 93
            if not st.inverse_time:
                st.feed = 0.0
        if "F" in seen and not st.inverse_time:
            # convert_feed_rate runs in G94 only: in G93 the F word is the block's
            # own, and the feed rate is the rate of the last move (moves.feed_rate)
            st.feed = seen["F"].value

    def _functions(
        self,
        seen: dict[str, Word],
        groups: dict[int, tuple[float, Word]],
        mgroups: dict[int, tuple[int, Word]],
        line: int,
    ) -> list[tuple[str, float]]:
        """The machine functions before the motion (S, T, M), in LinuxCNC's order of
        execution (functions.py), as the words of the function motion they make;
        an S or T that changes nothing is no function."""
        st = self.st
        pre: list[tuple[str, float]] = []
        if 14 in groups:
            spindle_mode(self, groups[14][0], seen, pre)
        if "S" in seen:
            if seen["S"].value != st.spindle:
                pre.append(("S", seen["S"].value))
            st.spindle = seen["S"].value
        if "T" in seen:
            t = int(seen["T"].value)
            if t:
                self.tool(t, line, seen["T"])
            if t != st.next_tool:
                pre.append(("T", float(t)))
            st.next_tool = t
        if 5 in mgroups:
            io(self, mgroups[5][0], mgroups[5][1], seen, pre, line)
        if 6 in mgroups and mgroups[6][0] == 61:
            tool_number(self, mgroups[6][1], seen, pre, line)
        elif 6 in mgroups:
            self.no_comp("a tool change", line, mgroups[6][1])
            st.tool = st.next_tool
            st.spindle_dir = 0  # LinuxCNC stops the spindle for a tool change
            self.tool_parameters()
            pre.append(("M", 6.0))
        if 7 in mgroups and mgroups[7][0] >= 70:
            self.context(mgroups[7][0], mgroups[7][1], line, pre)
        elif 7 in mgroups:
            st.spindle_dir = {3: 1, 4: -1, 5: 0}[mgroups[7][0]]
            pre.append(("M", float(mgroups[7][0])))
        if 8 in mgroups:
            code = mgroups[8][0]
            st.mist = code == 7 or (st.mist and code != 9)
            st.flood = code == 8 or (st.flood and code != 9)
            pre.append(("M", float(code)))
        if 9 in mgroups:
            overrides(self, mgroups[9][0], mgroups[9][1], seen, pre, line)
        if 10 in mgroups:  # a user M code, with its P and Q (LinuxCNC passes both)
            pre.append(("M", float(mgroups[10][0])))
            for letter in ("P", "Q"):
                if letter in seen:
                    pre.append((letter, seen[letter].value))
        return pre

    def _modes(
        self,
        seen: dict[str, Word],
        groups: dict[int, tuple[float, Word]],
        mode0: float | None,
        line: int,
    ) -> None:
        """G4 and the modal G codes, in convert_g's order: plane, units, cutter
        compensation, tool length, coordinate system, path control, distance modes,
        retract mode."""
        st = self.st
        if mode0 == 4:
            p = tuple(st.pos)
            self.emit(line=line, kind="dwell", start=p, end=p, duration=seen["P"].value)
        if 2 in groups:
            if int(groups[2][0]) != st.plane:
                self.no_comp("a change of plane", line, groups[2][1])
            st.plane = round(groups[2][0])
        if 6 in groups:
            st.units = "inch" if groups[6][0] == 20 else "mm"
        if 7 in groups:
            comp_code, comp_word = groups[7]
            if comp_code == 40:
                comp_off(self, line)
            else:
                comp_on(self, comp_code, seen, comp_word, line)
        if 8 in groups:
            self.no_comp("a change of tool length offset", line, groups[8][1])
            self._tool_length(groups[8], seen, line)
        if 12 in groups:
            self.no_comp("a change of coordinate system", line, groups[12][1])
            index = _coord_index(groups[12][0])
            # the system in use again changes nothing, even when its parameters
            # did (convert_coordinate_system, interp_convert.cc:1792-1798)
            if index != st.coord:
                change_frame(self, self.stored_origin(index), self.params.values[5210 + 20 * index])
                st.coord = index
                self.params.values[5220] = float(index)
        if 13 in groups:
            self.no_comp("a change of path control mode", line, groups[13][1])
            self._path_control(groups[13], seen, line)
        if 3 in groups:
            st.absolute = groups[3][0] == 90
        if 4 in groups:
            st.arc_absolute = groups[4][0] == 90.1
        if 10 in groups:
            self.no_comp("a change of retract mode", line, groups[10][1])
            st.retract_r = groups[10][0] == 99

    def _non_modal(
        self,
        seen: dict[str, Word],
        groups: dict[int, tuple[float, Word]],
        axis_words: dict[str, Word],
        mode0: float | None,
        line: int,
    ) -> None:
        """The non-modal group 0 (G10, G28/G30, G28.1/G30.1, G52/G92, G5.3) and
        G92.1-G92.3."""
        if mode0 == 10:
            g10(self, seen, groups[0][1], line)
        elif mode0 in (28, 30):
            self.no_comp(f"G{mode0:g}", line, groups[0][1])
            home(self, mode0, axis_words, line)
        elif mode0 in (28.1, 30.1):
            self.no_comp(f"G{mode0:g}", line, groups[0][1])
            save_home(self, mode0)
        elif mode0 in (52, 92):
            self.no_comp(f"G{mode0:g}", line, groups[0][1])
            axis_offsets(self, mode0, seen)
        elif mode0 == 5.3:
            nurbs_end(self, groups[0][1], line)
        if 16 in groups:
            self.no_comp(f"G{groups[16][0]:g}", line, groups[16][1])
            axis_offsets(self, groups[16][0], seen)

    def _move(
        self,
        seen: dict[str, Word],
        groups: dict[int, tuple[float, Word]],
        axis_words: dict[str, Word],
        motion: float | None,
        mode0: float | None,
        line: int,
    ) -> None:
        """The block's motion: G53's, G80, a move or a cycle."""
        st = self.st
        if motion is None:
            return
        if mode0 == 53:
            self.no_comp("G53", line, groups[0][1])
            st.motion = motion
            # a move that is no cycle forgets the cycles' first level
            # (convert_motion, interp_convert.cc:3778-3779), G53's too
            st.cycle_il = None
            linear(self, int(motion), axis_words, seen, line, machine=True)
        elif motion == 80:
            st.motion = None
            st.cycle_il = None
        else:
            if motion not in CYCLES:
                st.cycle_il = None
            self._motion(motion, axis_words, seen, line, new=1 in groups)

    def _stop(self, mgroups: dict[int, tuple[int, Word]], line: int) -> None:
        """Program stop or end, after the motion: the move compensation holds goes
        out first (LinuxCNC's convert_stop); after a tool change the position read
        back."""
        st = self.st
        if 4 in mgroups:
            if self.queue:
                iu, iv = (0, 1) if st.plane == 17 else (2, 0)
                self.queue.move_endpoint_and_flush(st.pos[iu], st.pos[iv], line)
            p = tuple(st.pos)
            code = mgroups[4][0]
            # M99 in the main program ends it as M2 does (LinuxCNC 2.9's convert_stop;
            # nothing in 2.9 sets loop_on_main_m99, Fanuc's endless loop)
            word = 2.0 if code == 99 else float(code)
            self.emit(line=line, kind="function", start=p, end=p, words=(("M", word),))
            if code in (2, 30, 99):
                st.ended = True
        # after a tool change (M6, M61) LinuxCNC reads the position back from the
        # machine before the next block (read_inputs → refresh_actual_position):
        # a tool G40 left off the programmed point is where it is from here on
        if 6 in mgroups and self.detached is not None:
            st.pos = list(self.detached)
            self.detached = None

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
        """LinuxCNC's convert_tool_length_offset: G43 takes the length of tool H
        (H0, or no H: the tool in the spindle), G43.1 Z the length given, G49 none."""
        st = self.st
        code, w = g
        if code == 49:
            st.tool_length = 0.0
        elif code == 43:
            n = int(seen["H"].value) if "H" in seen else 0
            if n == 0:
                n = st.tool
            st.tool_length = self.tool(n, line, seen.get("H", w)).length if n else 0.0
        else:  # G43.1: the axis words are the offsets
            for a in ("X", "Y", "A", "B"):
                if a in seen and seen[a].value != 0.0:
                    raise self.err(
                        f"tool offsets in {a} (G43.1) are not supported",
                        line,
                        seen[a],
                        "a tool length (Z) only on this machine",
                    )
            if "Z" in seen:
                st.tool_length = seen["Z"].value * self.scale()

    def tool(self, n: int, line: int, w: Word | None) -> ToolEntry:
        """Tool n of the tool table (LinuxCNC's find_tool_index)."""
        entry = self.tools.get(n)
        if entry is None:
            raise self.err(
                f"tool {n} is not in the profile's tool table",
                line,
                w,
                "a [[tools]] entry for it",
            )
        return entry

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
            self.no_comp("a canned cycle", line, next(iter(axis_words.values()), None))
            from .cycles import cycle  # here: most programs have no canned cycle

            cycle(self, int(motion), axis_words, seen, line, new)
            st.motion = motion
            return
        if motion in (5, 5.1):
            st.motion = motion
            bezier(self, motion, axis_words, seen, line)
            return
        if motion == 5.2:
            nurbs_point(self, axis_words, seen, line)
            st.motion = motion
            return
        st.motion = motion
        if motion in (0, 1):
            st.arc_not_allowed = False
            if comp_active(self):
                comp_straight(self, int(motion), axis_words, seen, line)
            else:
                linear(self, int(motion), axis_words, seen, line)
        else:
            if st.arc_not_allowed:
                raise self.err(
                    "an arc as the move after G40",
                    line,
                    next(iter(axis_words.values()), None),
                    "a straight move to leave cutter compensation",
                )
            if st.rotation and st.plane != 17:
                raise self.err(
                    f"arcs in G{st.plane} in a rotated coordinate system are not supported",
                    line,
                    next(iter(axis_words.values()), None),
                    "G17 arcs, or a system without rotation (G10 L2 R0)",
                )
            if comp_active(self) and st.plane in (17, 18):
                comp_arc(self, int(motion), axis_words, seen, line)
            else:
                arc(self, int(motion), axis_words, seen, line)


def _coord_index(code: float) -> int:
    """G54..G59 → 1..6, G59.1..G59.3 → 7..9 (LinuxCNC's origin index)."""
    c = round(code * 10)
    return {540: 1, 550: 2, 560: 3, 570: 4, 580: 5, 590: 6, 591: 7, 592: 8, 593: 9}[c]


def find_subroutine(name: str, directories: list[str]) -> str | None:
    """``name.ngc`` in the first of the directories that has it."""
    for d in directories:
        path = os.path.join(d, f"{name}.ngc")
        if os.path.isfile(path):
            return path
    return None
