"""Running the interpreter over a program's lines as they come."""

from __future__ import annotations

from collections.abc import Generator, Iterable, Iterator

from ..errors import GCodeError
from .config import InterpreterConfig
from .execute import Interpreter
from .fast import _FAST_LINE, fast_run
from .lines import BATCH, batches_of, split_lines
from .motion import Motion
from .read import fail, parse_line


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
    for batch in (b[j : j + BATCH] for b in batches for j in range(0, len(b), BATCH)):
        matches = _FAST_LINE.findall("\n".join(batch)) if fast else []
        if len(matches) != len(batch):  # a line with a character that ends lines
            matches = [("",) * 11 + ("-",)] * len(batch)
        n0 = n
        i = 0
        while i < len(batch):
            k = fast_run(it, matches, i, n0) if fast else i
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
                raise fail(
                    f"cannot interpret this block ({exc})", source, n, None, "numbers within range"
                ) from None
            if it.st.ended:
                yield from out
                return
            if blk.has_text or blk.percent:
                last_text = n
        yield from out
        out.clear()
    raise fail(
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
