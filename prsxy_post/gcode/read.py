"""Reading one line, as LinuxCNC's ``interp_read.cc`` does, into words and
parameter references.

Two steps, kept apart so that a line read again (a loop, a subroutine) is
parsed once:

- :func:`parse` turns the text into a :class:`Parsed`: words whose values are
  numbers or compiled expressions (:mod:`.expr`), parameter assignments, the
  O-word, the comment; each with its column. It depends on nothing but the text
  (parses are cached by text), and a syntax error is kept, not raised: LinuxCNC
  does not read the lines it skips (a false ``if``, a subroutine being defined),
  so an error there is no error.
- :func:`evaluate` reads the values with the parameters as they are before the
  line (all of a line's assignments take effect together, after it is read) and
  gives the :class:`Block` the interpreter executes; errors are raised here, in
  the order of the line.

The text is read as LinuxCNC reads it: spaces and tabs are removed and letters
lower-cased outside comments (``X 1 0.5`` is X10.5); a comment runs to ``)`` and
may not contain ``(``; ``;`` comments out the rest of the line; numbers have no
exponent (``1e3`` is 1 followed by an E word).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import NamedTuple

from ..errors import GCodeError
from .expr import (
    FUNCTIONS,
    PRECEDENCE,
    ExprError,
    Params,
    Value,
    atan,
    binary,
    constant,
    finite,
    negate,
    unary,
)


class Word(NamedTuple):
    """One word of a block (a named tuple: made for every word of every line)."""

    letter: str  # upper case; "@" and "^" for polar radius and angle
    value: float
    text: str  # as written (without spaces)
    column: int  # 1-based column of the letter in the line


def fail(
    msg: str, source: str, line: int, column: int | None, expected: str | None = None
) -> GCodeError:
    return GCodeError(msg, source=source, line=line, column=column, expected=expected)


#: (message, column, expected) of an error found while reading a line
Problem = tuple[str, int, str | None]


# ---------------------------------------------------------------- what a line holds


class WordItem(NamedTuple):
    letter: str  # upper case
    value: float | Value
    text: str
    column: int


class SetItem(NamedTuple):
    """``#n=value`` or ``#<name>=value``: ``target`` is an int, an expression for
    the number, or the name (a str)."""

    target: int | Value | str
    value: float | Value
    column: int
    value_column: int


class OWord(NamedTuple):
    """An O-word line (or M98 / M99 acting as one).

    kind : sub endsub call do while repeat if elseif else endif break continue
        endwhile endrepeat return; "bare" for a Fanuc-style ``O1000`` label;
        "m98" / "m99" for the Fanuc-style call and return
    name : the label as written (lower case), "" when it is a number expression
    number : the expression of a numbered label (``o100``, ``o#1``)
    values : the call's arguments, the condition of if/elseif/while/repeat, the
        value of endsub/return (a list of one) — read only when the line runs
    problem : an error in what follows the label, raised only if the line runs
    """

    kind: str
    name: str
    number: Value | None
    column: int
    values: tuple[Value, ...] = ()
    value_columns: tuple[int, ...] = ()
    problem: Problem | None = None


BLANK, PERCENT, BLOCK = 0, 1, 2
#: LinuxCNC's longest line: fgets into LINELEN (255) bytes, and a line that
#: fills 254 of them is "too long" (interp_read.cc, read_text)
MAX_LINE = 252


class Parsed(NamedTuple):
    """A line read but not evaluated (depends on the text only)."""

    kind: int
    items: tuple[WordItem | SetItem, ...] = ()
    problem: Problem | None = None  # raised when the line is executed
    comment: str | None = None  # the last ( ) comment, as LinuxCNC keeps it
    oword: OWord | None = None
    m99: bool = False  # starts with M99: a return when in a subroutine
    has_text: bool = False  # anything but blanks, comments included
    always: Problem | None = None  # an error even where the line is skipped
    block_delete: bool = False
    #: the words of a line of plain words (:func:`_parse_plain`), ready as they
    #: are (``items`` is then empty)
    words: tuple[Word, ...] | None = None


class Block:
    """One line's words with their values, ready to execute."""

    __slots__ = ("comment", "has_text", "line", "percent", "sets", "words")

    def __init__(
        self,
        line: int,
        words: tuple[Word, ...],
        sets: tuple[tuple[int | str, float], ...] = (),
        comment: str | None = None,
        has_text: bool = True,
        percent: bool = False,
    ) -> None:
        self.line = line
        self.words = words
        self.sets = sets
        self.comment = comment
        self.has_text = has_text
        self.percent = percent


# ---------------------------------------------------------------- the text


def _close_and_downcase(raw: str) -> tuple[str, list[int]]:
    """LinuxCNC's close_and_downcase: blanks out, letters lower-cased, comments
    kept as written; the 1-based column of every kept character."""
    out: list[str] = []
    cols: list[int] = []
    comment = -1
    semi = False
    for i, ch in enumerate(raw):
        if semi:
            out.append(ch)
            cols.append(i + 1)
            continue
        if comment >= 0:
            out.append(ch)
            cols.append(i + 1)
            if ch == ")":
                comment = -1
            elif ch == "(":
                raise _Bad(
                    "nested comment",
                    i + 1,
                    "a ')' before another '(' (LinuxCNC does not nest comments)",
                )
            continue
        if ch == ";":
            semi = True
            out.append(ch)
            cols.append(i + 1)
        elif ch in " \t\r":
            continue
        elif "A" <= ch <= "Z":
            out.append(chr(ord(ch) + 32))
            cols.append(i + 1)
        else:
            if ch == "(":
                comment = i
            out.append(ch)
            cols.append(i + 1)
    if comment >= 0:
        raise _Bad("comment not closed", comment + 1, "a ')' on the line")
    return "".join(out), cols


_OUT_OF_SCOPE = {
    "c": "a C axis is not supported on this machine",
    "u": "a U axis is not supported on this machine",
    "v": "a V axis is not supported on this machine",
    "w": "a W axis is not supported on this machine",
    "$": "spindle selection ($) is not supported (one spindle)",
}
_WORD_LETTERS = frozenset("abdefghijklmpqrstxyz@^")
_O_KEYWORDS = (
    "sub",
    "endsub",
    "call",
    "do",
    "while",
    "repeat",
    "if",
    "elseif",
    "else",
    "endif",
    "break",
    "continue",
    "endwhile",
    "endrepeat",
    "return",
)
_DIGITS = frozenset("0123456789")
_NUMBER_CHARS = frozenset("0123456789.")


class _Bad(Exception):
    """A syntax error at a column (the reader stops there)."""

    def __init__(self, message: str, column: int, expected: str | None = None) -> None:
        super().__init__(message)
        self.problem: Problem = (message, column, expected)


class _Reader:
    """Reads values off a downcased line from position ``i`` (LinuxCNC's read_*)."""

    def __init__(self, s: str, cols: list[int]) -> None:
        self.s = s + "\0"
        self.cols = [*cols, cols[-1] + 1 if cols else 1]
        self.i = 0

    def col(self, i: int | None = None) -> int:
        return self.cols[self.i if i is None else i]

    def bad(self, message: str, expected: str | None = None, i: int | None = None) -> _Bad:
        return _Bad(message, self.col(i), expected)

    # -- values
    def real_value(self) -> float | Value:
        """read_real_value: a number, a parameter, an expression, a function, or a
        sign before any of them; checked for NaN/infinity where it is read."""
        s = self.s
        c = s[self.i]
        start = self.i
        if c == "\0":
            raise self.bad("a value is missing", "a number, a parameter or an expression")
        c1 = s[self.i + 1]
        if c == "[":
            return finite(self.expression(), self.col(start))
        if c == "#":
            return self.parameter()
        if c in "+-" and c1 != "\0" and c1 not in _NUMBER_CHARS:
            self.i += 1
            v = self.real_value()
            if c == "+":
                return v
            if isinstance(v, float):
                return -v
            return negate(v)
        if "a" <= c <= "z":
            return finite(self.function(), self.col(start))
        return self.number()

    def number(self) -> float:
        """read_real_number: [+-] then digits and points, all of it a number."""
        s = self.s
        start = j = self.i
        if s[j] in "+-":
            j += 1
        while s[j] in _NUMBER_CHARS:
            j += 1
        text = s[start:j]
        body = text.lstrip("+-")
        if body.count(".") > 1 or not any(ch in _DIGITS for ch in body):
            if body.count(".") > 1:
                raise self.bad(f"bad number '{text}'", "one decimal point in a number", start)
            ch = s[start]
            what = "end of line" if ch in "\0;(" else f"'{ch}'"
            if ch == "o" and start > 0:
                raise self.bad(
                    "the letter O where a number should be",
                    "the digit 0 (zero), not the letter O",
                    start,
                )
            raise self.bad(
                f"a number is missing ({what} found)",
                "a number, a parameter or an expression",
                start,
            )
        self.i = j
        return float(text)

    def integer(self, what: str) -> int | Value:
        """read_integer_value: a value within 0.0001 of an integer."""
        start = self.i
        v = self.real_value()
        column = self.col(start)
        if isinstance(v, float):
            try:
                return _to_integer(v, what, column)
            except ExprError as exc:
                raise _Bad(exc.message, column, exc.expected) from None
        f = v

        def as_integer(p: Params) -> float:
            return float(_to_integer(f(p), what, column))

        return as_integer

    def expression(self) -> Value:
        """read_real_expression: ``[v op v op ... v]``, LinuxCNC's precedence,
        left-associative within a level."""
        s = self.s
        assert s[self.i] == "["
        self.i += 1
        operands: list[Value] = [_as_value(self.real_value())]
        operators: list[tuple[str, int]] = []
        while True:
            op_col = self.col()
            op = self.operator()
            if op == "]":
                break
            # reduce while the operator on the stack binds at least as tightly
            while operators and PRECEDENCE[operators[-1][0]] >= PRECEDENCE[op]:
                _reduce(operands, operators)
            operators.append((op, op_col))
            operands.append(_as_value(self.real_value()))
        while operators:
            _reduce(operands, operators)
        return operands[0]

    def operator(self) -> str:
        s = self.s
        c = s[self.i]
        self.i += 1
        if c in "+-/]":
            return c
        if c == "*":
            if s[self.i] == "*":
                self.i += 1
                return "**"
            return "*"
        for name in ("and", "mod", "or", "xor", "eq", "ne", "ge", "gt", "le", "lt"):
            if s.startswith(name, self.i - 1):
                self.i += len(name) - 1
                return name
        if c == "\0":
            raise self.bad("expression not closed", "a ']' to close the '['", self.i - 1)
        raise self.bad(
            f"unknown operation starting with '{c}'",
            "+ - * / ** MOD AND OR XOR EQ NE GT GE LT LE or ]",
            self.i - 1,
        )

    def function(self) -> Value:
        """read_unary: NAME[expression], ATAN[y]/[x], EXISTS[#<name>]."""
        s = self.s
        start = self.i
        for name in FUNCTIONS:
            if s.startswith(name, self.i):
                break
        else:
            word = s[self.i : self.i + 5].rstrip("\0")
            raise self.bad(
                f"unknown function or word where a value should be ('{word}')",
                "a number, a parameter, an expression or a function such as SIN[..]",
            )
        self.i += len(name)
        if s[self.i] != "[":
            raise self.bad(f"'[' missing after {name.upper()}", f"{name.upper()}[...]")
        column = self.col(start)
        if name == "exists":
            return self.exists()
        arg = finite(self.expression(), column)
        if name == "atan":
            if s[self.i] != "/":
                raise self.bad("'/' missing after the first ATAN argument", "ATAN[y]/[x]")
            self.i += 1
            if s[self.i] != "[":
                raise self.bad("'[' missing after ATAN[y]/", "ATAN[y]/[x]")
            x = finite(self.expression(), column)
            return atan(arg, x)
        return unary(name, arg, column)

    def exists(self) -> Value:
        """EXISTS[#<name>] (1 if the parameter exists), EXISTS[#n] (1 if n is a
        valid parameter number)."""
        s = self.s
        self.i += 1
        if s[self.i] != "#":
            raise self.bad("'#' expected in EXISTS", "EXISTS[#<name>]")
        self.i += 1
        if s[self.i] == "<":
            name = self.name()
            result: Value = lambda p: 1.0 if p.exists_named(name) else 0.0  # noqa: E731
        else:
            n = self.integer("a parameter number")
            if isinstance(n, int):
                ok = 1.0 if 1 <= n < 5602 else 0.0
                result = constant(ok)
            else:
                nf = n
                result = lambda p: 1.0 if 1 <= nf(p) < 5602 else 0.0  # noqa: E731
        if s[self.i] != "]":
            raise self.bad("']' expected after the parameter in EXISTS", "EXISTS[#<name>]")
        self.i += 1
        return result

    def name(self) -> str:
        """read_name: ``<...>`` (blanks already removed, lower case)."""
        s = self.s
        assert s[self.i] == "<"
        start = self.i
        end = s.find(">", self.i + 1)
        if end < 0:
            raise self.bad("named parameter not terminated", "a '>' after the name", start)
        self.i = end + 1
        return s[start + 1 : end]

    def parameter(self) -> Value:
        """read_parameter: ``#n`` (n a value), ``#<name>``."""
        s = self.s
        column = self.col()
        self.i += 1
        if s[self.i] == "<":
            name = self.name()
            return lambda p: p.get_named(name, column)
        n = self.integer("a parameter number")
        if isinstance(n, int):
            if not 1 <= n < 5602:
                raise self.bad(f"parameter number {n} out of range", "#1 to #5601", self.i - 1)
            k = n
            return lambda p: p.get(k, column)
        nf = n
        return lambda p: p.get(int(nf(p)), column)


def _as_value(v: float | Value) -> Value:
    return constant(v) if isinstance(v, float) else v


def _reduce(operands: list[Value], operators: list[tuple[str, int]]) -> None:
    right = operands.pop()
    left = operands.pop()
    op, column = operators.pop()
    operands.append(binary(op, left, right, column))


def _to_integer(v: float, what: str, column: int) -> int:
    import math

    n = math.floor(v)
    if v - n > 0.9999:
        return math.ceil(v)
    if v - n > 0.0001:
        raise ExprError(f"{what} must be an integer (it is {v:g})", column, "a whole number")
    return int(n)


# ---------------------------------------------------------------- a line


#: a word of the plainest kind: a letter this machine reads and a number with
#: no blanks in it (``G1``, ``X-12.5``, ``F.5``)
_PLAIN_WORD = r"([abdefghijklmpqrstxyzABDEFGHIJKLMPQRSTXYZ])([+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+))"
_PLAIN_LINE = re.compile(rf"[ \t]*(?:{_PLAIN_WORD}[ \t]*)+")
_PLAIN_ITEM = re.compile(_PLAIN_WORD)
_UPPER = {c: c.upper() for c in "abdefghijklmpqrstxyzABDEFGHIJKLMPQRSTXYZ"}


def parse(raw: str) -> Parsed:
    """Read one line's text (without its end) into a :class:`Parsed`."""
    if len(raw) <= MAX_LINE and _PLAIN_LINE.fullmatch(raw) is not None:
        plain = _parse_plain(raw)
        if plain is not None:
            return plain
    return _parse(raw)


def _parse_plain(raw: str) -> Parsed | None:
    """A line of plain words only (most of what CAM writes), read by a regular
    expression into what :func:`_parse` reads from it character by character
    (tests/test_gcode.py checks they agree); None for an M98, an O-word."""
    words = []
    for m in _PLAIN_ITEM.finditer(raw):
        letter, number = m.groups()
        letter = _UPPER[letter]
        words.append(Word(letter, float(number), letter + number, m.start() + 1))
    first = words[0]
    m99 = False
    if first.letter == "M":
        v = first.value
        if abs(v - round(v)) <= 0.0001:
            if round(v) == 98:
                return None
            m99 = round(v) == 99
    return Parsed(BLOCK, m99=m99, has_text=True, words=tuple(words))


def _parse(raw: str) -> Parsed:
    """:func:`parse` of any line, as LinuxCNC reads it (read_text, read_items)."""
    stripped = raw.strip()
    if not stripped:
        return Parsed(BLANK)
    if len(raw) > MAX_LINE:
        return Parsed(
            BLOCK,
            always=(
                f"line of {len(raw)} characters",
                MAX_LINE + 1,
                f"at most {MAX_LINE} (LinuxCNC reads lines into 255 bytes, line end included)",
            ),
            has_text=True,
        )
    try:
        s, cols = _close_and_downcase(raw)
    except _Bad as exc:
        return Parsed(BLOCK, always=exc.problem, has_text=True)
    if s == "%":
        return Parsed(PERCENT, has_text=True)
    if not s:
        return Parsed(BLANK, has_text=True)
    r = _Reader(s, cols)
    delete = False
    if s[0] == "/":
        r.i = 1
        delete = True
    always = None
    if r.s[r.i] == "n":
        try:
            _read_n(r)
        except _Bad as exc:
            always = exc.problem
            return Parsed(BLOCK, always=always, has_text=True, block_delete=delete)
    # M98, and M99 in a subroutine, are O-words (read_items)
    m = _plain_m(r)
    if r.s[r.i] == "o" or m == 98:
        return _parse_oword(r, delete, m)
    items, problem, comment = _read_items(r)
    return Parsed(
        BLOCK,
        tuple(items),
        problem,
        comment,
        m99=m == 99,
        has_text=True,
        block_delete=delete,
    )


def _read_n(r: _Reader) -> None:
    """read_n_number: digits, and a fraction LinuxCNC accepts and ignores."""
    r.i += 1
    j = r.i
    while r.s[j] in _DIGITS:
        j += 1
    if j == r.i:
        raise r.bad("N word without a number", "N followed by digits")
    r.i = j
    if r.s[r.i] == ".":
        r.i += 1
        j = r.i
        while r.s[j] in _DIGITS:
            j += 1
        if j == r.i:
            raise r.bad("N word with a point and no digits after it", "N10 or N10.1")
        r.i = j


def _plain_m(r: _Reader) -> int | None:
    """The M code that starts what follows, when it is a plain number."""
    s = r.s
    if s[r.i] != "m":
        return None
    j = r.i + 1
    while s[j] in _NUMBER_CHARS:
        j += 1
    try:
        v = float(s[r.i + 1 : j])
    except ValueError:
        return None
    return round(v) if abs(v - round(v)) <= 0.0001 else None


def _read_items(r: _Reader) -> tuple[list[WordItem | SetItem], Problem | None, str | None]:
    """read_one_item until the end of the line; a syntax error ends the reading."""
    s = r.s
    items: list[WordItem | SetItem] = []
    comment = None
    try:
        while s[r.i] != "\0":
            c = s[r.i]
            start = r.i
            if c == "(":
                end = s.index(")", r.i)
                comment = s[r.i + 1 : end]
                r.i = end + 1
                continue
            if c == ";":
                break
            if c == "#":
                items.append(_read_setting(r))
                continue
            if c in _OUT_OF_SCOPE:
                raise r.bad(_OUT_OF_SCOPE[c], "X Y Z A B on this machine (one spindle)")
            if c not in _WORD_LETTERS:
                if c == "o" and start > 0 and (s[start - 1] in _NUMBER_CHARS):
                    raise _letter_o(r, start)
                if c == "n":
                    raise r.bad("N word not at the start of the line", "the line number first")
                if c == "o":
                    raise r.bad(
                        "O-word not at the start of the line",
                        "an O-word first on its line (after an optional N word)",
                    )
                if c == "/":
                    raise r.bad("'/' (block delete) only at the start of a line")
                shown = repr(c) if c.isprintable() and not c.isspace() else f"\\{ord(c):03o}"
                raise r.bad(f"bad character {shown}", "a word: a letter followed by a number")
            r.i += 1
            j = r.i
            while s[j] in "+-0123456789.":
                j += 1
            if s[j] == "o":
                raise _letter_o(r, start)
            if "a" <= s[r.i] <= "z" and not any(s.startswith(f, r.i) for f in FUNCTIONS):
                raise r.bad(
                    f"word '{c.upper()}' has no number",
                    f"a number after {c.upper()}, e.g. {c.upper()}10.5",
                    start,
                )
            value = r.real_value()
            letter = c.upper()
            items.append(WordItem(letter, value, s[start : r.i].upper(), r.col(start)))
    except _Bad as exc:
        return items, exc.problem, comment
    return items, None, comment


def _letter_o(r: _Reader, start: int) -> _Bad:
    """A letter O where a digit 0 belongs (``Y1O``, ``GO``) is a typing slip, not
    an O-word: say so, with the word it spoils."""
    s = r.s
    while start > 0 and s[start] in _NUMBER_CHARS | {"+", "-", "o"}:
        start -= 1
    end = start + 1
    while s[end] in _NUMBER_CHARS | {"+", "-", "o"}:
        end += 1
    o = s.index("o", start + 1)
    word = s[start:end].upper()
    what = "as the number" if o == start + 1 else "inside the number"
    return _Bad(
        f"the letter O {what} of '{word[0]}' ('{word}')",
        r.col(o),
        "the digit 0 (zero), not the letter O",
    )


def _read_setting(r: _Reader) -> SetItem:
    """read_parameter_setting: ``#n=value``, ``#<name>=value``."""
    s = r.s
    column = r.col()
    r.i += 1
    target: int | Value | str
    if s[r.i] == "<":
        target = r.name()
    else:
        n = r.integer("a parameter number")
        if isinstance(n, int) and not 1 <= n < 5602:
            raise _Bad(f"parameter number {n} out of range", column, "#1 to #5601")
        target = n
    if s[r.i] != "=":
        raise r.bad("'=' missing in a parameter setting", "#<n>=<value>")
    r.i += 1
    value_column = r.col()
    return SetItem(target, r.real_value(), column, value_column)


def _parse_oword(r: _Reader, delete: bool, m: int | None) -> Parsed:
    """read_o: the label, the keyword, and what follows it."""
    s = r.s
    column = r.col()
    if m == 98:
        # the rest of the line is words (P, L) read as items
        r.i += 1
        while s[r.i] in _NUMBER_CHARS:
            r.i += 1
        items, m98_problem, comment = _read_items(r)
        return Parsed(
            BLOCK,
            tuple(items),
            m98_problem,
            comment,
            OWord("m98", "", None, column),
            has_text=True,
            block_delete=delete,
        )
    r.i += 1
    name = ""
    number: Value | None = None
    try:
        if s[r.i] == "<":
            name = r.name()
        else:
            n = r.integer("an O-word number")
            number = constant(float(n)) if isinstance(n, int) else n
    except _Bad as exc:
        return Parsed(BLOCK, always=exc.problem, has_text=True, block_delete=delete)
    kind = ""
    for kw in _O_KEYWORDS:
        if s.startswith(kw, r.i):
            # "else" must not take "elseif", "end..." are whole words: the
            # longest keyword that matches wins
            if len(kw) > len(kind):
                kind = kw
    if kind:
        r.i += len(kind)
    elif s[r.i] in "(;\0":
        kind = "bare"
    else:
        word = s[r.i : r.i + 8].rstrip("\0")
        return Parsed(
            BLOCK,
            always=(
                f"unknown O-word command '{word}'",
                r.col(),
                "sub, endsub, call, do, while, repeat, if, elseif, else, endif, break, "
                "continue, endwhile, endrepeat or return",
            ),
            has_text=True,
            block_delete=delete,
        )
    values: list[Value] = []
    value_columns: list[int] = []
    problem: Problem | None = None
    comment = None
    try:
        if kind == "call":
            while s[r.i] in "[(":
                if s[r.i] == "(":
                    end = s.index(")", r.i)
                    comment = s[r.i + 1 : end]
                    r.i = end + 1
                    continue
                if len(values) >= 30:
                    raise r.bad("too many subroutine arguments", "at most 30")
                value_columns.append(r.col())
                values.append(finite(r.expression(), r.col()))
        elif kind in ("while", "repeat", "if", "elseif"):
            if s[r.i] != "[":
                raise r.bad(f"'[' missing after '{kind}'", f"o... {kind} [condition]")
            value_columns.append(r.col())
            values.append(finite(r.expression(), r.col()))
        elif kind in ("endsub", "return") and s[r.i] == "[":
            value_columns.append(r.col())
            values.append(finite(r.expression(), r.col()))
        while s[r.i] != "\0":
            if s[r.i] == ";":
                break
            if s[r.i] == "(":
                end = s.index(")", r.i)
                comment = s[r.i + 1 : end]
                r.i = end + 1
                continue
            raise r.bad("unexpected text after the O-word", "only a comment after it")
    except _Bad as exc:
        problem = exc.problem
    o = OWord(kind, name, number, column, tuple(values), tuple(value_columns), problem)
    return Parsed(BLOCK, comment=comment, oword=o, has_text=True, block_delete=delete)


# ---------------------------------------------------------------- evaluation


def value_of(v: float | Value, params: Params) -> float:
    return v if isinstance(v, float) else v(params)


def evaluate(
    parsed: Parsed,
    line: int,
    params: Params,
    source: str,
    add_named: Callable[[str], None],
) -> Block:
    """The block of a parsed line: values read with the parameters as they are
    before the line; ``add_named`` is called for each ``#<name>=`` as it is read
    (LinuxCNC creates the parameter then, so a later reference on the same line
    reads 0, not an error)."""
    if parsed.words is not None:
        return Block(line, parsed.words)
    words: list[Word] = []
    sets: list[tuple[int | str, float]] = []
    try:
        for item in parsed.items:
            if type(item) is WordItem:
                v = item.value
                words.append(
                    Word(
                        item.letter,
                        v if isinstance(v, float) else v(params),
                        item.text,
                        item.column,
                    )
                )
            else:
                assert isinstance(item, SetItem)
                target = item.target
                if isinstance(target, str):
                    add_named(target)
                    sets.append((target, value_of(item.value, params)))
                    continue
                index = target if isinstance(target, int) else int(target(params))
                if not 1 <= index < 5602:
                    raise ExprError(
                        f"parameter number {index} out of range", item.column, "#1 to #5601"
                    )
                sets.append((index, value_of(item.value, params)))
    except ExprError as exc:
        raise fail(exc.message, source, line, exc.column, exc.expected) from None
    if parsed.problem is not None:
        msg, column, expected = parsed.problem
        raise fail(msg, source, line, column, expected)
    return Block(line, tuple(words), tuple(sets), parsed.comment)


def raise_problem(problem: Problem, source: str, line: int) -> GCodeError:
    msg, column, expected = problem
    return fail(msg, source, line, column, expected)
