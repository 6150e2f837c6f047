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
    """The items of a program, in groups; every item made before a line's error is
    yielded before the error is raised, none of that line's."""
    r = _Reading(main, config or InterpreterConfig(), source, fast, rows)
    out = r.it.out
    while True:
        if r.i >= len(r.batch):
            if out:
                yield from out
                out.clear()
            if not r.next_batch():
                break
        if r.fast_lines():
            continue
        mark = len(out)
        try:
            ran = r.line()
        except Jump as jump:
            r.jump(jump.position)
            continue
        except GCodeError as exc:
            del out[mark:]
            yield from out
            raise exc from None
        except (ValueError, OverflowError, ZeroDivisionError) as exc:
            del out[mark:]
            yield from out
            raise fail(
                f"cannot interpret this block ({exc})", r.where, r.n, None, "numbers within range"
            ) from None
        if ran and r.it.st.ended:
            r.it.finish()
            yield from out
            return
        if ran and len(out) >= _YIELD_EVERY:
            yield from out
            out.clear()
    yield from out
    out.clear()
    raise r.no_end()


class _Reading:
    """Where the interpreter reads: the file and batch of lines, the line in it
    (``i``), the fast path's matches for the batch, the parsed lines by text."""

    def __init__(
        self, main: ProgramLines, cfg: InterpreterConfig, source: str, fast: bool, rows: bool
    ) -> None:
        self.it = Interpreter(cfg, source)
        self.ctl = Control(self.it, cfg.max_loop_passes)
        self.it.control = self.ctl
        self.source, self.fast = source, fast
        self.files: dict[str, ProgramLines] = {source: main}
        self.cache: dict[str, Parsed] = {}
        self.here_file, self.here_lines, self.in_main = source, main, True
        self.feed = _rebatch(main.batches(0))
        self.batch: list[str] = []
        self.matches: list[tuple[str, ...]] = []
        self.start = 0  # index of batch[0] in its file
        self.i = 0
        self.n = 0  # the line being run, 1-based in its file
        self.where = source
        self.last_text = 0
        self.remembered = False
        path = fastpath.SELECTED
        self.fast_matches, self.fast_run = path.matches, path.run_rows if rows else path.run

    def next_batch(self) -> bool:
        """Read on to the next batch; False at the end of the file."""
        self.start += len(self.batch)
        nxt = next(self.feed, None)
        if nxt is None:
            return False
        self.batch, self.i = nxt, 0
        self.matches = self.fast_matches(nxt) if self.fast and self.in_main else []
        return True

    def fast_lines(self) -> bool:
        """Run the lines from ``i`` on that the fast path takes; True if any."""
        if not self.matches or self.ctl.skipping_o is not None:
            return False
        k = self.fast_run(self.it, self.matches, self.i, self.start)
        if k <= self.i:
            return False
        self.i = k
        self.last_text = self.start + k
        return True

    def line(self) -> bool:
        """Read, evaluate and run line ``i``; False where no block ran (a blank
        line, an O-word, a line skipped by a false condition)."""
        raw = self.batch[self.i]
        index = self.start + self.i
        self.i += 1
        n = self.n = index + 1
        where = self.where = self.source if self.in_main else self.here_file
        parsed = self._parsed(raw)
        if parsed.always is not None:
            msg, column, expected = parsed.always
            raise fail(msg, where, n, column, expected)
        kind = parsed.kind
        if kind == BLANK and not parsed.has_text:
            return False
        o: OWord | None = parsed.oword
        if o is None and parsed.m99 and self.ctl.call_level > 0:
            o = _M99
        if o is not None:
            self._oword(o, parsed, index)
            return False
        if self.ctl.skipping_o is not None:
            return False
        if self.in_main:
            self.last_text = n
        if kind == PERCENT:
            self.it.run(Block(n, (), percent=True))
        elif kind == BLANK:
            self.it.started = True
        else:
            self._block(parsed)
        return True

    def _parsed(self, raw: str) -> Parsed:
        parsed = self.cache.get(raw)
        if parsed is None:
            if len(self.cache) >= _CACHE_SIZE:
                self.cache.clear()
            parsed = self.cache[raw] = parse(raw)
        return parsed

    def _oword(self, o: OWord, parsed: Parsed, index: int) -> None:
        """An O-word line (or M99 in a subroutine) to the control flow."""
        if not self.remembered and self.in_main:
            self.here_lines.remember(index)
            self.remembered = True
        if self.in_main:
            self.last_text = self.n
        words = {}
        ctl = self.ctl
        if o.kind == "m98" and ctl.skipping_o is None and not ctl.defining_sub:
            blk = evaluate(parsed, self.n, self.it.params, self.where, self.it.params.add_named)
            words = {w.letter: w.value for w in blk.words}
        self.it.started = True
        ctl.run(o, words, (self.here_file, index), self.n, self.where)

    def _block(self, parsed: Parsed) -> None:
        """A block's parameter settings, then the block."""
        it, params, n, where = self.it, self.it.params, self.n, self.where
        blk = evaluate(parsed, n, params, where, params.add_named)
        if blk.sets:
            for target, _ in blk.sets:
                why = params.check_writable(target)
                if why is not None:
                    raise fail(why, where, n, None, "a parameter a program may set")
            params.assign(blk.sets)
        if not self.in_main:
            blk.line = it.call_line or n
        it.source = where
        it.run(blk)
        it.source = self.source

    def jump(self, position: tuple[str, int]) -> None:
        """Read on from ``position`` (file, 0-based line), as the control flow says."""
        to_file, to_index = position
        if to_file != self.here_file:
            if to_file not in self.files:
                self.files[to_file] = _sub_file(to_file)
            self.here_file = to_file
            self.here_lines = self.files[to_file]
            self.in_main = to_file == self.source
            self._read_from(to_index)
        elif self.start <= to_index < self.start + len(self.batch):
            self.i = to_index - self.start
        else:
            self._read_from(to_index)

    def _read_from(self, index: int) -> None:
        self.batch, self.start, self.i = [], index, 0
        self.feed = _rebatch(self.here_lines.batches(index))

    def no_end(self) -> GCodeError:
        """The error for a program that ends without M2, M30 or '%'."""
        ctl = self.ctl
        if ctl.skipping_to_sub is not None:
            return fail(
                f"the end of the file while looking for subroutine '{ctl.skipping_to_sub}'",
                self.source if self.in_main else self.here_file,
                max(ctl.skipping_start, 1),
                None,
                f"o<{ctl.skipping_to_sub}> sub ... endsub in this file or a file "
                f"{ctl.skipping_to_sub}.ngc on the subroutine path",
            )
        return fail(
            "the program ends without M2, M30 or a closing '%'",
            self.source,
            max(self.last_text, 1),
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
