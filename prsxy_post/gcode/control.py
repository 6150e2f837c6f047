"""O-word control flow as LinuxCNC runs it (``interp_o_word.cc``).

LinuxCNC does not build a tree of the program: it reads lines one after the
other and keeps a little state — which label it is skipping to, whether an
``if`` has run, the file offset of every label it has met, the call stack — and
jumps by seeking the file. This module is that state machine, with positions as
(file, line index) instead of byte offsets, so its behaviour is LinuxCNC's in the
corners too (a subroutine called before its definition is found by reading
ahead; meeting that definition later is an error there, and here).

- ``sub``/``endsub``/``return``/``call``: a definition is skipped and its line
  remembered; a call enters a new parameter scope (#1-#30 from its arguments,
  named locals of its own; :class:`~.params.Parameters`), a return comes back
  to the line after the call. Calls by name not yet defined look for
  ``name.ngc`` on the search path (:attr:`InterpreterConfig.subroutine_path`),
  then read ahead in the current file. At most 10 call levels (LinuxCNC's limit).
- ``if/elseif/else/endif``, ``while/endwhile``, ``do/while``,
  ``repeat/endrepeat``, ``break``/``continue``: skip forward by label, jump back
  to the loop's line. All loops of a program together may go round
  :attr:`InterpreterConfig.max_loop_passes` times (M98 L repeats count too);
  one more stops the program with an error at the loop's line: a program that
  would never end is refused, not run for ever (a nested loop too, where a
  limit per loop would not do).
- Fanuc-style ``M98 P… L…`` / ``O…`` / ``M99`` subprograms, as LinuxCNC 2.9
  accepts them.

Labels of ``if``, loops and their ends are local to the subroutine they are in
(LinuxCNC prefixes them with the subroutine's name); ``sub``, ``call``,
``endsub`` and ``return`` labels are global.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from ..errors import GCodeError
from .execute import Interpreter
from .expr import ExprError
from .read import OWord, fail

#: where a line is: (file key, 0-based line index)
Position = tuple[str, int]


class Offset:
    """A label met in the program (LinuxCNC's ``offset`` struct)."""

    def __init__(self, kind: str, file: str, index: int, repeat_count: int = -1) -> None:
        self.kind = kind
        self.file = file
        self.index = index  # the line's own index: jumping here reads it again
        self.repeat_count = repeat_count


class Frame:
    """One level of the call stack (LinuxCNC's ``context``)."""

    def __init__(
        self,
        name: str | None = None,
        call_type: str = "none",
        ret: Position | None = None,
        ret_line: int = 0,
        saved: list[float] | None = None,
        m98_loops: int = -1,
        context: dict[str, object] | None = None,
        restore_on_return: bool = False,
    ) -> None:
        self.name = name  # the subroutine running at this level
        self.call_type = call_type  # "none" (the program), "o" (O-word call), "m98"
        self.ret = ret  # where the caller continues
        self.ret_line = ret_line  # its line number, for motions made below
        self.saved = [] if saved is None else saved  # the caller's #1-#30
        self.m98_loops = m98_loops  # M98 L: passes left
        self.context = context  # M70/M73: the modal state saved here
        self.restore_on_return = restore_on_return  # M73


class Jump(Exception):
    """Control goes to ``position`` (read that line next)."""

    def __init__(self, position: Position) -> None:
        super().__init__()
        self.position = position


class Control:
    """The O-word state of one program run.

    The driver hands every O-word line (and every line, for the skipping test)
    here; :meth:`run` returns normally to go on with the next line or raises
    :class:`Jump` to continue elsewhere.
    """

    def __init__(self, interp: object, max_loop_passes: int) -> None:
        assert isinstance(interp, Interpreter)
        self.it = interp
        self.params = interp.params
        self.max_passes = max_loop_passes
        self.passes = 0
        self.skipping_o: str | None = None
        self.skipping_to_sub: str | None = None
        self.skipping_start = 0
        self.executed_if = False
        self.doing_break = False
        self.doing_continue = False
        self.defining_sub = False
        self.sub_name: str | None = None
        self.offsets: dict[str, Offset] = {}
        self.frames: list[Frame] = [Frame()]
        self.return_value = 0.0
        self.value_returned = False

    @property
    def call_level(self) -> int:
        return len(self.frames) - 1

    @property
    def skipping(self) -> bool:
        return self.skipping_o is not None

    # -- reading an O-word line (read_o)
    def name_of(self, o: OWord, source: str, line: int) -> str:
        """The label as LinuxCNC keys it: global for sub/call/endsub/return,
        prefixed with the enclosing subroutine's name otherwise."""
        if o.kind == "m99":
            return self.frames[-1].name or ""
        if o.number is not None:
            # read even while a sub is defined, when an undefined named parameter
            # is no error (read_named_parameter): ``o#<sub> call`` in a definition
            self.params.lenient_named = self.defining_sub
            try:
                label = str(int(o.number(self.params)))
            except ExprError as exc:
                raise fail(exc.message, source, line, exc.column, exc.expected) from None
            finally:
                self.params.lenient_named = False
        else:
            label = o.name
        if o.kind in ("sub", "bare", "endsub", "call", "return", "m98"):
            return label
        if self.call_level:
            prefix = self.frames[-1].name or ""
        elif self.defining_sub:
            prefix = self.sub_name or ""
        else:
            prefix = ""
        return f"{prefix}#{label}"

    def run(
        self,
        o: OWord,
        m98_words: dict[str, float],
        here: Position,
        line: int,
        source: str,
    ) -> None:
        """One O-word line at ``here`` (line number ``line``, for messages): what
        is read and evaluated (read_o), then what it does (convert_control_functions)."""
        name = self.name_of(o, source, line)
        values = self._read(o, name, source, line)
        if values is None:
            return
        if self.skipping_o is not None and self.skipping_o != name:
            return
        if self.skipping_to_sub is not None and o.kind not in ("sub", "bare"):
            return
        at = _At(o, name, values, m98_words, here, line, source)
        if o.kind in _OPENED_BY:
            self._check_opened(at)
        handler = _BY_KIND.get(o.kind)
        if handler is not None:
            handler(self, at)

    def _read(self, o: OWord, name: str, source: str, line: int) -> list[float] | None:
        """The values an O-word line evaluates (a call's arguments, a condition,
        a return value); None where it is skipped unread (read_o)."""
        kind = o.kind
        values: list[float] = []
        if kind in ("sub", "bare"):
            if self.defining_sub:
                raise fail(
                    "a subroutine defined inside another",
                    source,
                    line,
                    o.column,
                    "'endsub' of the one before",
                )
        elif kind in ("endsub", "return", "m99"):
            if self.skipping_o is not None and self.skipping_o != name:
                return None
            if kind != "m99":
                self._read_return(o, source, line)
        elif self.defining_sub:
            return None
        elif kind == "call":
            if self.skipping_o is not None:
                return None
            values = self._values(o, source, line)
        elif kind in ("while", "repeat", "if", "elseif"):
            if self.skipping_o is not None and self.skipping_o != name:
                return None
            values = self._values(o, source, line)
        elif o.problem is not None and self.skipping_o is None:
            self._raise_problem(o, source, line)
        return values

    def _read_return(self, o: OWord, source: str, line: int) -> None:
        """An endsub's or return's value. Read while defining, an undefined named
        parameter is no error (read_named_parameter), its value is none (here 0)."""
        self.params.lenient_named = self.defining_sub
        try:
            values = self._values(o, source, line)
        finally:
            self.params.lenient_named = False
        if values:
            self.return_value = values[0]
            self.value_returned = True
        else:
            self.return_value = 0.0
            self.value_returned = False

    def _check_opened(self, at: _At) -> None:
        """An elseif, else, endif, break, continue or loop end names a label
        opened by the right kind of line."""
        kind = at.o.kind
        op = self.offsets.get(at.name)
        if op is None:
            raise at.err(f"'{kind}' without its opening label", "the same label on an if or loop")
        want = _OPENED_BY[kind]
        if op.kind not in want:
            raise at.err(
                f"'{kind}' with the label of a '{op.kind}'",
                f"the label of a {' or '.join(want)}",
            )

    def _sub(self, at: _At) -> None:
        """``sub`` or a Fanuc ``O….`` line: a definition skipped and remembered."""
        kind, name = at.o.kind, at.name
        frame = self.frames[-1]
        if kind == "bare" and frame.call_type not in ("m98", "none"):
            raise at.err("a Fanuc-style 'O....' subprogram called with 'O.. call'", "M98 P..")
        if kind == "sub" and frame.call_type not in ("o", "none"):
            raise at.err("an 'O.. sub' subroutine called with M98", "o<name> call")
        if self.skipping_o is not None:
            self._save_offset(name, kind, at.here, at.line, at.source, at.o)
            self.skipping_o = None
        self.skipping_to_sub = None
        if kind == "bare":
            return
        if self.call_level == 0:
            self._save_offset(name, kind, at.here, at.line, at.source, at.o)
            self.skipping_o = name
            self.skipping_start = at.line
            self.defining_sub = True
            self.sub_name = name

    def _end(self, at: _At) -> None:
        """``endsub``, ``return`` or ``M99``: back to the caller."""
        kind = at.o.kind
        if self.call_level == 0 and self.sub_name is None:
            raise at.err(f"'{kind}' outside a subroutine", "o<name> sub before it")
        frame = self.frames[-1]
        if frame.call_type == "m98" and kind != "m99":
            raise at.err("a Fanuc-style subprogram ended without M99", "M99")
        if frame.call_type == "o" and kind == "m99":
            raise at.err("an 'O.. sub' subroutine ended with M99", "o<name> endsub")
        self._return(kind)

    def _call_at(self, at: _At) -> None:
        self._call(at.o, at.name, at.o.kind, at.values, at.m98_words, at.here, at.line, at.source)

    def _do(self, at: _At) -> None:
        self.skipping_o = None
        if at.name not in self.offsets:
            self._save_offset(at.name, "do", at.here, at.line, at.source, at.o)

    def _repeat(self, at: _At) -> None:
        """``repeat``: count down the passes, skip to the end after the last."""
        name = at.name
        op = self.offsets.get(name)
        if op is not None and op.index != at.here[1]:
            raise at.err(f"label '{at.o.name or name}' used twice", "a label of its own per repeat")
        if op is None:
            op = self._save_offset(name, "repeat", at.here, at.line, at.source, at.o)
        self.skipping_o = None
        if op.kind == "repeat":
            if op.repeat_count == -1:
                op.repeat_count = _round_to_int(at.values[0])
            if op.repeat_count > 0:
                op.repeat_count -= 1
            else:
                self._skip(name, at.line)
                op.repeat_count = -1

    def _while(self, at: _At) -> None:
        """``while``: a loop's head (skip to its end when false) or a do-while's
        end (back to its ``do`` when true)."""
        name = at.name
        op = self.offsets.get(name)
        if op is not None:
            if op.kind != "do" and op.index != at.here[1]:
                raise at.err(
                    f"label '{at.o.name or name}' used twice", "a label of its own per loop"
                )
        else:
            op = self._save_offset(name, "while", at.here, at.line, at.source, at.o)
        self.skipping_o = None
        if op.kind == "while":
            if at.values[0] == 0.0:
                self._skip(name, at.line)
        else:  # the end of a do-while
            if at.values[0] != 0.0 and not self.doing_break:
                self._count(at.o, at.source, at.line)
                raise Jump((op.file, op.index))
            self.doing_break = False

    def _if(self, at: _At) -> None:
        name = at.name
        op = self.offsets.get(name)
        if op is not None and op.index != at.here[1]:
            raise at.err(f"label '{at.o.name or name}' used twice", "a label of its own per if")
        if op is None:
            self._save_offset(name, "if", at.here, at.line, at.source, at.o)
        if at.values[0] != 0.0:
            self.skipping_o = None
            self.executed_if = True
        else:
            self._skip(name, at.line)
            self.executed_if = False

    def _elseif(self, at: _At) -> None:
        if self.executed_if:
            self._skip(at.name, at.line)
            return
        if at.values[0] != 0.0:
            self.skipping_o = None
            self.executed_if = True

    def _else(self, at: _At) -> None:
        if self.executed_if:
            self._skip(at.name, at.line)
            return
        if self.skipping_o == at.name:
            self.executed_if = True
            self.skipping_o = None

    def _endif(self, at: _At) -> None:
        self.skipping_o = None
        self.executed_if = True

    def _break(self, at: _At) -> None:
        self._skip(at.name, at.line)
        self.doing_break = True

    def _continue(self, at: _At) -> None:
        if self.skipping_o == at.name:
            return
        self._skip(at.name, at.line)
        self.doing_continue = True

    def _loop_end(self, at: _At) -> None:
        """``endwhile`` or ``endrepeat``: back to the loop's head, unless a break
        skipped here."""
        op = self.offsets[at.name]
        if self.skipping_o == at.name:
            self.skipping_o = None
            if self.doing_continue:
                self.doing_continue = False
                self._count(at.o, at.source, at.line)
                raise Jump((op.file, op.index))
            # LinuxCNC leaves doing_break set here (a later do-while sees it)
            return
        self._count(at.o, at.source, at.line)
        raise Jump((op.file, op.index))

    def _skip(self, name: str, line: int) -> None:
        """Skip lines up to the next with label ``name`` (from line ``line``)."""
        self.skipping_o = name
        self.skipping_start = line

    # -- pieces
    def _values(self, o: OWord, source: str, line: int) -> list[float]:
        if o.problem is not None:
            self._raise_problem(o, source, line)
        try:
            return [v(self.params) for v in o.values]
        except ExprError as exc:
            raise fail(exc.message, source, line, exc.column, exc.expected) from None

    @staticmethod
    def _raise_problem(o: OWord, source: str, line: int) -> None:
        assert o.problem is not None
        msg, column, expected = o.problem
        raise fail(msg, source, line, column, expected)

    def _save_offset(
        self, name: str, kind: str, here: Position, line: int, source: str, o: OWord
    ) -> Offset:
        op = self.offsets.get(name)
        if op is not None:
            if op.index == here[1] and op.file == here[0]:
                raise fail(
                    f"subroutine '{name}' defined where it was already found by a call "
                    "that read ahead to it",
                    source,
                    line,
                    o.column,
                    "subroutines defined before they are called",
                )
            raise fail(
                f"subroutine '{name}' defined twice", source, line, o.column, "one definition"
            )
        op = Offset(kind, here[0], here[1])
        self.offsets[name] = op
        return op

    def _count(self, o: OWord, source: str, line: int) -> None:
        """One more jump back to the top of a loop (in all the program's loops
        together): every way round, whatever the labels, so a loop that never
        ends cannot escape it."""
        self.passes += 1
        if self.passes > self.max_passes:
            raise fail(
                f"the program's loops have gone round {self.max_passes} times and would go on",
                source,
                line,
                o.column,
                "loops that end (or a higher [gcode] max_loop_passes in the profile)",
            )

    def _call(
        self,
        o: OWord,
        name: str,
        kind: str,
        args: list[float],
        words: dict[str, float],
        here: Position,
        line: int,
        source: str,
    ) -> None:
        if kind == "m98":
            if "P" not in words:
                raise fail("M98 without a P word", source, line, o.column, "M98 P<program number>")
            p = words["P"]
            n = math.floor(p)
            if p - n > 0.9999:
                n = math.ceil(p)
            elif p - n > 0.0001:
                raise fail("P of M98 not an integer", source, line, o.column, "M98 P<integer>")
            name = str(int(n))
        if self.call_level + 1 >= 10:
            raise fail(
                "too many nested subroutine calls (LinuxCNC allows 9 levels)",
                source,
                line,
                o.column,
                "at most 9 calls in progress (recursion that ends sooner)",
            )
        caller = self.frames[-1]
        frame = Frame(name=name, call_type="o" if kind == "call" else "m98")
        self.skipping_o = None
        frame.saved = self.params.enter(args if kind == "call" else None)
        ret: Position = (here[0], here[1] + 1)
        ret_line = caller.ret_line if self.call_level else line
        if kind == "m98" and "L" in words:
            if caller.m98_loops == -1:
                caller.m98_loops = _round_to_int(words["L"])
            caller.m98_loops -= 1
            if caller.m98_loops > 0:
                self._count(o, source, line)
                ret = here  # this M98 again for the next pass
            else:
                caller.m98_loops = -1
        frame.ret = ret
        frame.ret_line = ret_line
        self.frames.append(frame)
        self.it.call_line = ret_line
        if kind == "m98" and "L" in words and _round_to_int(words["L"]) == 0:
            return
        self._back_to(name, o, source, line)

    def _back_to(self, name: str, o: OWord, source: str, line: int) -> None:
        """control_back_to: jump to a known label, or open ``name.ngc``, or read
        ahead in this file until the label turns up."""
        op = self.offsets.get(name)
        if op is not None:
            raise Jump((op.file, op.index))
        path = self.it.find_subroutine(name)
        self.skipping_o = name
        self.skipping_to_sub = name
        self.skipping_start = line
        if path is not None:
            raise Jump((path, 0))

    def _return(self, kind: str) -> None:
        """execute_return: back to the caller (or the end of a definition)."""
        if self.skipping_o is not None and kind == "endsub":
            self.skipping_o = None
        if self.call_level != 0:
            frame = self.frames.pop()
            self.params.leave(frame.saved)
            if frame.restore_on_return and frame.context is not None:
                self.it.restore(frame.context, self.it.line)
            self.it.call_line = self.frames[-1].ret_line if self.call_level else 0
            assert frame.ret is not None
            raise Jump(frame.ret)
        if kind == "endsub":
            if not self.defining_sub:
                raise GCodeError("'endsub' outside a subroutine definition")
            self.defining_sub = False
            self.skipping_o = None
            self.sub_name = None


def _round_to_int(v: float) -> int:
    return math.floor(v + 0.5)


@dataclass(frozen=True)
class _At:
    """One O-word line being run: its word, label, values and place."""

    o: OWord
    name: str
    values: list[float]
    m98_words: dict[str, float]
    here: Position
    line: int
    source: str

    def err(self, msg: str, expected: str | None = None) -> GCodeError:
        return fail(msg, self.source, self.line, self.o.column, expected)


#: the kinds of line whose label an elseif, else, endif, break, continue or loop
#: end must carry
_OPENED_BY: dict[str, tuple[str, ...]] = {
    "elseif": ("if",),
    "else": ("if",),
    "endif": ("if",),
    "break": ("while", "do"),
    "continue": ("while", "do"),
    "endwhile": ("while",),
    "endrepeat": ("repeat",),
}

#: what each kind of O-word line does (convert_control_functions)
_BY_KIND: dict[str, Callable[[Control, _At], None]] = {
    "sub": Control._sub,
    "bare": Control._sub,
    "endsub": Control._end,
    "return": Control._end,
    "m99": Control._end,
    "call": Control._call_at,
    "m98": Control._call_at,
    "do": Control._do,
    "repeat": Control._repeat,
    "while": Control._while,
    "if": Control._if,
    "elseif": Control._elseif,
    "else": Control._else,
    "endif": Control._endif,
    "break": Control._break,
    "continue": Control._continue,
    "endwhile": Control._loop_end,
    "endrepeat": Control._loop_end,
}
