"""Program text into lines, and lines into batches: what the interpreter reads."""

from __future__ import annotations

from collections.abc import Callable, Generator, Iterable, Iterator

#: lines matched at once: large enough that the fast path's regex runs in C for
#: most of the time, small enough that what a batch makes stays in the CPU's caches
#: (measured: 256 lines are 30 % faster than 4096)
BATCH = 256


def split_lines(text: str) -> list[str]:
    """Lines without their ends; CR, LF and CRLF (mixed too) each end a line."""
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n") if text else []


def iter_line_batches(pieces: Iterable[str]) -> Iterator[list[str]]:
    """Lines without their ends from text that arrives in pieces (a file read in
    blocks), a list per piece: the same lines as :func:`split_lines` of the whole
    text, except that a final line end does not start an empty line (as a file's
    lines are counted). A CR at the end of a piece waits for the next one, which
    may start with LF.
    """
    tail = ""
    for piece in pieces:
        text = tail + piece
        cut = max(text.rfind("\n"), text.rfind("\r", 0, len(text) - 1))
        if cut < 0:
            tail = text
            continue
        lines = split_lines(text[: cut + 1])
        lines.pop()  # the empty string after the last line end
        yield lines
        tail = text[cut + 1 :]
    if tail:
        lines = split_lines(tail)
        if lines[-1] == "":
            lines.pop()
        yield lines


def batches_of(lines: Iterable[str]) -> Generator[list[str], None, None]:
    """Lines in lists of :data:`BATCH`."""
    batch: list[str] = []
    for raw in lines:
        batch.append(raw)
        if len(batch) == BATCH:
            yield batch
            batch = []
    if batch:
        yield batch


_BOM = b"\xef\xbb\xbf"


def _decoded_lines(chunk: bytes) -> list[str]:
    """The lines of bytes that end with a line end (the last empty one dropped)."""
    lines = split_lines(chunk.decode("utf-8", "surrogateescape"))
    lines.pop()
    return lines


class FileLines:
    """A file's lines read again from any line on (a program's loops and calls jump
    back): ``file_lines(k)`` gives the lines from index ``k`` (0-based) in lists,
    the same lines :func:`iter_line_batches` gives for the whole file read as
    UTF-8 (undecodable bytes as lone surrogates, a leading BOM dropped).

    The byte offset of a line start is remembered at every piece read, so a jump
    reads from the nearest mark before its line, not from the top of the file;
    memory is a pair of integers per 128 KiB of program.
    """

    PIECE = 1 << 17

    def __init__(self, path: str) -> None:
        self.path = path
        self._lines = [0]
        self._bytes = [0]
        with open(path, "rb") as fh:
            if fh.read(3) == _BOM:
                self._bytes[0] = 3

    def __call__(self, start: int) -> Iterator[list[str]]:
        import bisect

        k = bisect.bisect_right(self._lines, start) - 1
        line, offset = self._lines[k], self._bytes[k]
        with open(self.path, "rb") as fh:
            fh.seek(offset)
            tail = b""
            tail_at = offset
            while piece := fh.read(self.PIECE):
                data = tail + piece
                cut = max(data.rfind(b"\n"), data.rfind(b"\r", 0, len(data) - 1))
                if cut < 0:
                    tail = data
                    continue
                lines = _decoded_lines(data[: cut + 1])
                tail = data[cut + 1 :]
                next_line = line + len(lines)
                next_at = tail_at + cut + 1
                if next_line > self._lines[-1]:
                    self._lines.append(next_line)
                    self._bytes.append(next_at)
                if next_line > start:
                    yield lines[max(0, start - line) :]
                line, tail_at = next_line, next_at
            if tail:
                lines = split_lines(tail.decode("utf-8", "surrogateescape"))
                if lines[-1] == "":
                    lines.pop()
                if line + len(lines) > start:
                    yield lines[max(0, start - line) :]


class ProgramLines:
    """A program's lines as the interpreter reads them: the stream of batches it is
    given, read once, and any line before the furthest one read again on request
    (:meth:`batches` from a line).

    ``lines_from(k)`` reads the program again from line ``k`` (a
    :class:`FileLines`, or slices of a list). Without it, the lines from the
    first one the interpreter may come back to (:meth:`remember`) on are kept in
    memory.
    """

    def __init__(
        self,
        batches: Iterable[list[str]],
        lines_from: Callable[[int], Iterable[list[str]]] | None = None,
    ) -> None:
        self._stream = iter(batches)
        self._lines_from = lines_from
        self.frontier = 0  # lines taken from the stream
        self._last: list[str] = []
        self._last_start = 0
        self._kept: list[str] | None = None
        self._kept_from = 0

    @classmethod
    def of(cls, lines: list[str]) -> ProgramLines:
        """A program held in a list."""
        return cls(
            (lines[i : i + BATCH] for i in range(0, len(lines), BATCH)),
            lambda k: (lines[i : i + BATCH] for i in range(k, len(lines), BATCH)),
        )

    def remember(self, start: int) -> None:
        """The interpreter may come back to line ``start`` or any after it."""
        if self._lines_from is not None or self._kept is not None:
            return
        self._kept = self._last[max(0, start - self._last_start) :]
        self._kept_from = max(start, self._last_start)

    def batches(self, start: int) -> Iterator[list[str]]:
        """The lines from ``start`` on (``start`` at most :attr:`frontier`)."""
        line = start
        if line < self.frontier:
            if self._lines_from is not None:
                for batch in self._lines_from(line):
                    if line + len(batch) >= self.frontier:
                        yield batch[: self.frontier - line]
                        line = self.frontier
                        break
                    yield batch
                    line += len(batch)
            else:
                assert self._kept is not None and line >= self._kept_from
                while line < self.frontier:
                    i = line - self._kept_from
                    batch = self._kept[i : min(i + BATCH, self.frontier - self._kept_from)]
                    yield batch
                    line += len(batch)
        assert line == self.frontier, "a jump past the lines read so far"
        for batch in self._stream:
            self._last, self._last_start = batch, self.frontier
            self.frontier += len(batch)
            if self._kept is not None:
                self._kept.extend(batch)
            yield batch
