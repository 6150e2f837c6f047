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

import os
from collections.abc import Callable, Generator, Iterable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from . import gcode
from .files import inspect_source
from .gcode import FileLines, InterpreterConfig, ToolEntry

if TYPE_CHECKING:
    from .gcode import Motion
    from .profile import Profile


def file_batches(path: str | Path) -> Generator[list[str], None, None]:
    """The lines of a program file (without their ends), a list per block read:
    bounded memory on programs of millions of lines. A binary file (a NUL byte)
    is refused with its line before any is read."""
    inspect_source(str(path))
    yield from iter_program_batches(str(path))


def iter_program_batches(
    path: str, progress: Callable[[int], None] | None = None
) -> Generator[list[str], None, None]:
    """The program's lines without their ends (CR, LF or CRLF), read as a stream,
    a list per block read.

    Bytes that are not UTF-8 become lone surrogates: harmless in comments, and
    rejected by the parser anywhere else.
    """
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        if fh.read(1) != "\ufeff":
            fh.seek(0)

        def pieces() -> Iterator[str]:
            chars = 0
            while piece := fh.read(1 << 17):
                chars += len(piece)
                if progress is not None:
                    progress(chars)
                yield piece

        yield from gcode.iter_line_batches(pieces())


def interpreter_config(
    profile: Profile,
    start: Sequence[float] | None = None,
    on_message: Callable[[str, int, str, str], None] | None = None,
) -> InterpreterConfig:
    """The G-code interpreter's settings from a profile (offsets, tools, G28/G30,
    start, [gcode] subroutine path relative to the profile's folder, loop limit,
    user M codes); ``on_message`` receives the program's (MSG/DEBUG/PRINT)."""
    st = tuple(float(x) for x in (profile.start if start is None else start))
    g = profile.gcode
    src = profile.source
    here = os.path.dirname(os.path.abspath(src)) if os.path.isfile(src) else "."
    return InterpreterConfig(
        work_offsets=dict(profile.work_offsets),
        g28_position=tuple(profile.g28),
        g30_position=tuple(profile.g30),
        tool_table={n: ToolEntry(length=ln, diameter=d) for n, (ln, d) in profile.tools.items()},
        start=st,
        subroutine_path=tuple(os.path.join(here, d) for d in g.get("subroutine_path", [])),
        max_loop_passes=int(g.get("max_loop_passes", 10_000_000)),
        user_m_codes=frozenset(g.get("user_m_codes", [])),
        on_message=on_message,
    )


def lines_of(path: str | Path) -> FileLines | None:
    """The program's lines read again from its file when a loop or a call jumps
    back (``None`` for standard input, ``-``, which is held in memory instead)."""
    return None if str(path) == "-" else gcode.FileLines(str(path))


def text_batches(text: str) -> Generator[list[str], None, None]:
    """The lines of program text, in the lists :func:`motions` takes."""
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
    if profile is not None:
        cfg = interpreter_config(profile, start, on_message=on_message)
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
