"""Running the interpreter over a program's lines as they come.

Lines are read in batches; within a batch the common CAM block takes the fast
path (:mod:`.fast`), everything else is parsed (:func:`.read.parse`, cached by
text, so the lines of a loop or a subroutine are parsed once), evaluated and
executed. O-word lines go to :class:`.control.Control`, which may send the
reading elsewhere: back to a loop's line or a subroutine, into another file
(``name.ngc``), or to the line after a call. A program without control flow is
read once, front to back, in constant memory; one with it is read again from
the lines it jumps to (:class:`.lines.ProgramLines`).
"""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable, Iterator

from ..errors import GCodeError
from . import fast as fastpath
from .config import InterpreterConfig
from .control import Control, Jump
from .execute import Interpreter
from .lines import BATCH, ProgramLines, split_lines
from .motion import Motion
from .read import BLANK, PERCENT, Block, OWord, Parsed, evaluate, fail, parse
from .rows import Item

#: parsed lines kept for reuse (by text); cleared when full, so memory stays flat
_CACHE_SIZE = 20_000
#: motions handed on at least this often, even in the middle of a long loop
_YIELD_EVERY = 4096


def iter_motions(
    lines: Iterable[str],
    config: InterpreterConfig | None = None,
    source: str = "<string>",
    fast: bool = True,
) -> Iterator[Motion]:
    """Interpret lines (without their line ends) and yield motions as they come.

    The common straight-move block takes a fast path (``fast=False`` turns it
    off: the tests check both give the same motions and errors). Motions are
    yielded in groups, and all of them before the error a line raises.

    Raises
    ------
    GCodeError
        Located at ``source:line:column`` with the offending word.
    """
    seq = lines if isinstance(lines, list) else list(lines)
    return _run(ProgramLines.of(seq), config, source, fast)  # type: ignore[return-value]


def iter_motions_batched(
    batches: Iterable[list[str]],
    config: InterpreterConfig | None = None,
    source: str = "<string>",
    fast: bool = True,
    lines_from: Callable[[int], Iterable[list[str]]] | None = None,
) -> Generator[Motion, None, None]:
    """:func:`iter_motions` over lines that come in lists (:func:`iter_line_batches`).

    ``lines_from(k)`` reads the program again from its line ``k`` (0-based), for
    programs whose loops and calls jump back (:class:`~.lines.FileLines` for a
    file); without it the lines from the first O-word on are kept in memory.
    """
    return _run(ProgramLines(batches, lines_from), config, source, fast)  # type: ignore[return-value]


def iter_motion_items(
    batches: Iterable[list[str]],
    config: InterpreterConfig | None = None,
    source: str = "<string>",
    lines_from: Callable[[int], Iterable[list[str]]] | None = None,
) -> Generator[Item, None, None]:
    """:func:`iter_motions_batched` in rows mode: the moves the compiled fast path
    takes come as runs of rows (``(n, WIDTH)`` arrays, :mod:`.rows`), every other
    motion as a Motion, in program order; :func:`.rows.chunks` and
    :func:`.rows.table` make them into tables. (The reference fast path gives
    Motions only.)"""
    return _run(ProgramLines(batches, lines_from), config, source, True, rows=True)


def interpret(
    text: str, config: InterpreterConfig | None = None, source: str = "<string>"
) -> list[Motion]:
    """All motions of a program text."""
    return list(iter_motions(split_lines(text), config, source))


def _rebatch(batches: Iterator[list[str]]) -> Iterator[list[str]]:
    for b in batches:
        if len(b) <= BATCH:
            yield b
        else:
            for j in range(0, len(b), BATCH):
                yield b[j : j + BATCH]


def _run(
    main: ProgramLines,
    config: InterpreterConfig | None,
    source: str,
    fast: bool,
    rows: bool = False,
) -> Generator[Item, None, None]:
    cfg = config or InterpreterConfig()
    it = Interpreter(cfg, source)
    ctl = Control(it, cfg.max_loop_passes)
    it.control = ctl
    params = it.params
    out = it.out
    files: dict[str, ProgramLines] = {source: main}
    cache: dict[str, Parsed] = {}
    here_file = source
    here_lines = main
    in_main = True
    feed = _rebatch(main.batches(0))
    batch: list[str] = []
    matches: list[tuple[str, ...]] = []
    start = 0  # index of batch[0] in its file
    i = 0
    last_text = 0
    remembered = False
    add_named = params.add_named
    path = fastpath.SELECTED
    fast_matches, fast_run = path.matches, path.run_rows if rows else path.run
    while True:
        if i >= len(batch):
            if out:
                yield from out
                out.clear()
            start += len(batch)
            nxt = next(feed, None)
            if nxt is None:
                break
            batch = nxt
            i = 0
            if fast and in_main:
                matches = fast_matches(batch)
            else:
                matches = []
        if matches and ctl.skipping_o is None:
            k = fast_run(it, matches, i, start)
            if k > i:
                i = k
                last_text = start + k
                continue
        raw = batch[i]
        index = start + i
        i += 1
        n = index + 1  # line number in its file
        where = source if in_main else here_file
        mark = len(out)
        try:
            parsed = cache.get(raw)
            if parsed is None:
                if len(cache) >= _CACHE_SIZE:
                    cache.clear()
                parsed = cache[raw] = parse(raw)
            if parsed.always is not None:
                msg, column, expected = parsed.always
                raise fail(msg, where, n, column, expected)
            kind = parsed.kind
            if kind == BLANK and not parsed.has_text:
                continue
            o: OWord | None = parsed.oword
            if o is None and parsed.m99 and ctl.call_level > 0:
                o = _M99
            if o is not None:
                if not remembered and in_main:
                    here_lines.remember(index)
                    remembered = True
                if in_main:
                    last_text = n
                words = {}
                if o.kind == "m98" and ctl.skipping_o is None and not ctl.defining_sub:
                    blk = evaluate(parsed, n, params, where, add_named)
                    words = {w.letter: w.value for w in blk.words}
                it.started = True
                ctl.run(o, words, (here_file, index), n, where)
                continue
            if ctl.skipping_o is not None:
                continue
            if in_main:
                last_text = n
            if kind == PERCENT:
                it.run(Block(n, (), percent=True))
            elif kind == BLANK:
                it.started = True
            else:
                blk = evaluate(parsed, n, params, where, add_named)
                if blk.sets:
                    for target, _ in blk.sets:
                        why = params.check_writable(target)
                        if why is not None:
                            raise fail(why, where, n, None, "a parameter a program may set")
                    params.assign(blk.sets)
                if not in_main:
                    blk.line = it.call_line or n
                it.source = where
                it.run(blk)
                it.source = source
            if it.st.ended:
                it.finish()
                yield from out
                return
            if len(out) >= _YIELD_EVERY:
                yield from out
                out.clear()
        except Jump as jump:
            to_file, to_index = jump.position
            if to_file != here_file:
                if to_file not in files:
                    files[to_file] = _sub_file(to_file)
                here_file = to_file
                here_lines = files[to_file]
                in_main = to_file == source
                batch, start, i = [], to_index, 0
                feed = _rebatch(here_lines.batches(to_index))
            elif start <= to_index < start + len(batch):
                i = to_index - start
            else:
                batch, start, i = [], to_index, 0
                feed = _rebatch(here_lines.batches(to_index))
        except GCodeError as exc:
            del out[mark:]
            yield from out
            raise exc from None
        except (ValueError, OverflowError, ZeroDivisionError) as exc:
            del out[mark:]
            yield from out
            raise fail(
                f"cannot interpret this block ({exc})", where, n, None, "numbers within range"
            ) from None
    yield from out
    out.clear()
    where = source if in_main else here_file
    if ctl.skipping_to_sub is not None:
        raise fail(
            f"the end of the file while looking for subroutine '{ctl.skipping_to_sub}'",
            where,
            max(ctl.skipping_start, 1),
            None,
            f"o<{ctl.skipping_to_sub}> sub ... endsub in this file or a file "
            f"{ctl.skipping_to_sub}.ngc on the subroutine path",
        )
    raise fail(
        "the program ends without M2, M30 or a closing '%'",
        source,
        max(last_text, 1),
        None,
        "M2 or M30 at the end (LinuxCNC rejects it too)",
    )


_M99 = OWord("m99", "", None, 1)


def _sub_file(path: str) -> ProgramLines:
    """A subroutine file, read whole (they are small)."""
    with open(path, encoding="utf-8", errors="surrogateescape", newline="") as fh:
        text = fh.read()
    if text.startswith("\ufeff"):
        text = text[1:]
    lines = split_lines(text)
    if lines and lines[-1] == "":
        lines.pop()
    return ProgramLines.of(lines)
