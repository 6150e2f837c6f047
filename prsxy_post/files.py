"""Files in and out: text for the parsers, atomic publication of outputs.

Everything that reads or writes a file for the library goes through here, so
the rules hold everywhere: binary files are refused with the line of their
first NUL byte, non-UTF-8 text is read as Latin-1, and outputs are written to
temp files beside their targets and renamed only when every one is complete
(a failed run leaves nothing half-written and never replaces an existing file).
"""

from __future__ import annotations

import hashlib
import os
import sys
from pathlib import Path

from .errors import PrsxyError, UsageError, write_failed
from .kinematics import check_reach
from .profile import Profile, loads


def read_text(path: str, kind: str = "file") -> str:
    """Read a text file for a parser: binary files and unreadable paths are errors.

    Bytes that are not UTF-8 are read as Latin-1 (G-code from older CAM systems
    has such bytes in comments; outside comments every parser rejects them).
    """
    try:
        data = Path(path).read_bytes() if path != "-" else sys.stdin.buffer.read()
    except OSError as exc:
        raise PrsxyError(
            f"cannot read {kind}: {exc.strerror}", source=path, expected=f"a readable {kind}"
        ) from None
    if b"\0" in data:
        line = data[: data.index(b"\0")].count(b"\n") + 1
        raise PrsxyError(
            f"binary data (a NUL byte) in the {kind}",
            source=path,
            line=line,
            expected=f"a text {kind}",
        )
    if data.startswith(b"\xef\xbb\xbf"):
        data = data[3:]
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        return data.decode("latin-1")


def sha256_of(path: str) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def publish(tmp: str, target: str | Path) -> None:
    """Rename a finished temp file onto its target with the mode an ordinary new
    file gets (mkstemp makes it 0600), or the mode of the file it replaces."""
    try:
        mode = os.stat(target).st_mode & 0o7777
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        mode = 0o666 & ~umask
    os.chmod(tmp, mode)
    os.replace(tmp, target)


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name one file: the same path once links and ``..`` are
    resolved, or (when both exist) the same file on disk (a hard link)."""
    pa, pb = Path(a), Path(b)
    if pa.resolve() == pb.resolve():
        return True
    try:
        return os.path.samefile(pa, pb)
    except OSError:
        return False


def clash(output: str | Path, inputs: dict[str, str]) -> tuple[str, str] | None:
    """The input ``output`` would replace, as (what it is, its path), or None.

    inputs : what each input is ("G-code program", "profile") → its path; "-"
        (standard input or output) is never a file
    """
    if str(output) == "-":
        return None
    for what, path in inputs.items():
        if path != "-" and same_file(output, path):
            return what, path
    return None


def refuse_to_overwrite(output: str | Path, inputs: dict[str, str]) -> None:
    """Raise :class:`UsageError` when ``output`` would replace one of ``inputs``
    (:func:`clash`)."""
    hit = clash(output, inputs)
    if hit is not None:
        raise UsageError(
            f"the output {output} would overwrite the {hit[0]} {hit[1]}",
            expected="an output file that is none of the inputs",
        )


def temp_beside(path: Path) -> tuple[int, str]:
    """A new temp file beside ``path`` (its directory made if need be), named
    ``.<name>.<random>.tmp`` and open for writing as ``mkstemp`` makes it (mode
    0600, :func:`publish` sets the target's): its descriptor and path."""
    # here, not at the top: tempfile (with shutil and random) is 4 ms of every
    # command's start, and only what writes a file needs it
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    return tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)


def write_atomic(files: dict[Path, str] | dict[Path, bytes] | dict[Path, str | bytes]) -> None:
    """Write every file or none: temp files beside the targets, then renames.

    An existing output is replaced only once every new file is complete on disk.
    """
    temps: list[tuple[str, Path]] = []
    try:
        for path, content in files.items():
            fd, tmp = temp_beside(path)
            temps.append((tmp, path))
            data = content.encode("utf-8") if isinstance(content, str) else content
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
                fh.flush()
                os.fsync(fh.fileno())
        for tmp, path in temps:
            publish(tmp, path)
    except OSError as exc:
        for tmp, _ in temps:
            if os.path.exists(tmp):
                os.unlink(tmp)
        raise write_failed(exc, str(exc.filename or "")) from None


def load_profile(path: str) -> Profile:
    """Read and validate a profile file: its keys and values, and that its struts
    reach the start pose (:func:`prsxy_post.kinematics.check_reach`)."""
    prof = loads(read_text(path, "profile"), path)
    check_reach(prof)
    return prof


def inspect_source(path: str) -> str:
    """sha256 of a program file, refusing binary files (a NUL byte) with its line."""
    h = hashlib.sha256()
    line = 1
    try:
        with open(path, "rb") as fh:
            while block := fh.read(1 << 20):
                if b"\0" in block:
                    line += block[: block.index(b"\0")].count(b"\n")
                    raise PrsxyError(
                        "binary data (a NUL byte) in the G-code program",
                        source=path,
                        line=line,
                        expected="a text file",
                    )
                line += block.count(b"\n")
                h.update(block)
    except OSError as exc:
        raise PrsxyError(
            f"cannot read G-code program: {exc.strerror}", source=path, expected="a readable file"
        ) from None
    return h.hexdigest()
