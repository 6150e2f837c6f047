"""Reading one line into a :class:`Block`: the words as written, each with its
column; comments and block delete removed. It knows nothing of modes."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import NamedTuple

from ..errors import GCodeError


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


def fail(
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
                raise fail(
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
        raise fail("comment not closed", source, lineno, depth_start + 1, "a ')' on the line")
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


_NUMBER_CHARS = frozenset("0123456789.+-")


def _letter_o(up: str, pos: int, cols: list[int], source: str, lineno: int) -> None:
    """A letter O where a digit 0 belongs (``Y1O``, ``X.O5``, ``GO``) is a typing
    slip, not an O-word: say so, with the word it spoils. ``pos`` is where a word
    (a letter) or the O itself starts; after an N word an O starts an O-word."""
    if up[pos] == "O":
        if pos == 0 or not (up[pos - 1].isdigit() or up[pos - 1] == "."):
            return
        start = pos - 1
        while start > 0 and not up[start].isalpha():
            start -= 1
        if up[start] == "N":
            return
    elif up[pos].isalpha():
        start = pos
        end = pos + 1
        while end < len(up) and up[end] in _NUMBER_CHARS:
            end += 1
        if end >= len(up) or up[end] != "O":
            return
        pos = end
    else:
        return
    end = pos + 1
    while end < len(up) and (up[end].isdigit() or up[end] in ".O"):
        end += 1
    what = "inside the number" if pos - start > 1 else "as the number"
    raise fail(
        f"the letter O {what} of '{up[start]}' ('{up[start:end]}')",
        source,
        lineno,
        cols[pos],
        "the digit 0 (zero), not the letter O",
    )


def parse_line(raw: str, lineno: int, source: str = "<string>") -> Block:
    """Words of one line, each with its column; errors are located.

    Comments in ``( )`` and after ``;`` and all spaces are removed first (so
    ``X 1 0.5`` is X10.5, as LinuxCNC reads it); letters are case-insensitive.
    """
    s = raw.strip()
    if s.startswith("%"):
        if s.strip("% \t"):
            raise fail(
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
            _letter_o(up, pos, cols, source, lineno)
            if wm.group(1) in _REJECT_CHAR:
                raise fail(
                    _REJECT_CHAR[wm.group(1)],
                    source,
                    lineno,
                    cols[pos],
                    "plain words like G1 X10 (the milling subset)",
                )
            pos = wm.end()
        ch = up[pos] if pos < len(up) else ""
        col = cols[pos] if pos < len(cols) else (cols[-1] + 1 if cols else 1)
        if ch:
            _letter_o(up, pos, cols, source, lineno)
        for special in "#[":
            k = up.find(special, pos)
            if k >= 0 and (ch in _REJECT_CHAR or ch.isalpha() or ch in "+-."):
                raise fail(
                    _REJECT_CHAR[special],
                    source,
                    lineno,
                    cols[k],
                    "plain words like G1 X10 (the milling subset)",
                )
        if ch in _REJECT_CHAR:
            raise fail(
                _REJECT_CHAR[ch],
                source,
                lineno,
                col,
                "plain words like G1 X10 (the milling subset)",
            )
        if ch.isalpha():
            if ch not in _LETTERS:
                raise fail(
                    f"unknown word letter '{ch}'",
                    source,
                    lineno,
                    col,
                    "one of A B D F G H I J K L M N P Q R S T X Y Z",
                )
            raise fail(
                f"word '{ch}' has no number",
                source,
                lineno,
                col,
                f"a number after {ch}, e.g. {ch}10.5",
            )
        if ch == "/":
            raise fail("'/' (block delete) only at the start of a line", source, lineno, col)
        raise fail(
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
        if letter == "O":
            _letter_o(up, wm.start(), cols, source, lineno)
        if letter in _REJECT_CHAR:
            raise fail(
                _REJECT_CHAR[letter],
                source,
                lineno,
                col,
                "plain words like G1 X10 (the milling subset)",
            )
        if letter not in _LETTERS:
            raise fail(
                f"unknown word letter '{letter}'",
                source,
                lineno,
                col,
                "one of A B D F G H I J K L M N P Q R S T X Y Z",
            )
        words.append(Word(letter, float(wm.group(2)), wm.group(0), col))
        pos = wm.end()
    return Block(lineno, tuple(words), has_text=True)
