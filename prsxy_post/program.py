"""A G-code program as the library reads it: its lines, streamed, and its motions
under a profile's settings (work offsets, tools, G28/G30, start pose).

What ``prsxy-post inspect`` prints, and what :mod:`prsxy_post.check` and
:mod:`prsxy_post.convert` feed into the compensation chain.

Example
-------
>>> from prsxy_post import program
>>> for m in program.motions_of_text("G1 X10 F600\\nM2\\n"):
...     print(m.line, m.kind, m.end)
1 feed (10.0, 0.0, 0.0, 0.0, 0.0)
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from .files import inspect_source

if TYPE_CHECKING:
    from .gcode import FileLines, Motion
    from .profile import Profile


def file_batches(path: str | Path) -> Generator[list[str], None, None]:
    """The lines of a program file (without their ends), a list per block read:
    bounded memory on programs of millions of lines. A binary file (a NUL byte)
    is refused with its line before any is read."""
    from .convert import iter_program_batches

    inspect_source(str(path))
    yield from iter_program_batches(str(path))


def lines_of(path: str | Path) -> FileLines | None:
    """The program's lines read again from its file when a loop or a call jumps
    back (``None`` for standard input, ``-``, which is held in memory instead)."""
    from . import gcode

    return None if str(path) == "-" else gcode.FileLines(str(path))


def text_batches(text: str) -> Generator[list[str], None, None]:
    """The lines of program text, in the lists :func:`motions` takes."""
    from . import gcode

    yield from gcode.batches_of(gcode.split_lines(text))


def motions(
    batches: Iterable[list[str]],
    profile: Profile | None = None,
    *,
    start: Sequence[float] | None = None,
    source: str = "<string>",
    on_message: Callable[[str, int, str, str], None] | None = None,
    lines_from: FileLines | None = None,
) -> Generator[Motion, None, None]:
    """Interpret a program's lines into motions, as they come.

    Parameters
    ----------
    batches : lists of lines (:func:`file_batches`, :func:`text_batches`)
    profile : work offsets, tool table, G28/G30 positions and start pose; without
        one, none of these and the start at the workpiece origin
    start : (x, y, z, A, B) [mm, deg] start pose instead of the profile's
    source : the program's name in error messages
    on_message : receives the program's (MSG,…), (DEBUG,…), (PRINT,…) as
        ``on_message(source, line, kind, text)``; without it they are ignored
    lines_from : the program's lines read again by position (:func:`lines_of`)
        when a loop or a call jumps back; without it the lines already read
        are kept in memory from the first O-word on

    Raises
    ------
    GcodeError
        At the line (and column) the interpreter cannot take, after every
        motion before it.
    """
    from . import chain, gcode

    if profile is not None:
        cfg = chain.interpreter_config(profile, start, on_message=on_message)
    elif start is not None:
        cfg = gcode.InterpreterConfig(start=tuple(float(x) for x in start), on_message=on_message)
    else:
        cfg = gcode.InterpreterConfig(on_message=on_message)
    yield from gcode.iter_motions_batched(batches, cfg, source, lines_from=lines_from)


def motions_of_file(
    path: str | Path, profile: Profile | None = None, *, start: Sequence[float] | None = None
) -> Generator[Motion, None, None]:
    """:func:`motions` of a program file, streamed."""
    yield from motions(
        file_batches(path), profile, start=start, source=str(path), lines_from=lines_of(path)
    )


def motions_of_text(
    text: str,
    profile: Profile | None = None,
    *,
    start: Sequence[float] | None = None,
    source: str = "<string>",
) -> Generator[Motion, None, None]:
    """:func:`motions` of program text."""
    yield from motions(text_batches(text), profile, start=start, source=source)
