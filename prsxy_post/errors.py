"""Error types of prsxy-post.

Every failure a user can cause is a :class:`PrsxyError` subclass carrying where it
happened (file, line, column or profile key) and what was expected. The CLI turns
them into one line ``file:line:column: what is wrong (expected ...)`` and an exit
code; only a bug (anything else) gives exit code 3.

Exit codes: 0 success, 1 bad input (:class:`PrsxyError`), 2 bad usage
(:class:`UsageError`, click usage errors), 3 internal error.
"""

from __future__ import annotations

EXIT_OK = 0
EXIT_BAD_INPUT = 1
EXIT_USAGE = 2
EXIT_INTERNAL = 3


class PrsxyError(Exception):
    """Base of all user-facing errors.

    Parameters
    ----------
    message : str
        What is wrong, in the user's terms.
    source : str, optional
        File name (or ``<stdin>``, ``<string>``).
    line, column : int, optional
        1-based position in ``source``.
    key : str, optional
        Dotted path of a profile key (``kinematics.legs[2].strut_length``) or a
        column / option name.
    expected : str, optional
        What would have been accepted.
    """

    exit_code = EXIT_BAD_INPUT

    def __init__(
        self,
        message: str,
        *,
        source: str | None = None,
        line: int | None = None,
        column: int | None = None,
        key: str | None = None,
        expected: str | None = None,
    ) -> None:
        super().__init__(message)
        self.message = message
        self.source = source
        self.line = line
        self.column = column
        self.key = key
        self.expected = expected

    def located(self, source: str | None = None, line: int | None = None) -> PrsxyError:
        """Fill in a location not yet known (the caller knows the file or line)."""
        if self.source is None and source is not None:
            self.source = source
        if self.line is None and line is not None:
            self.line = line
        return self

    def __str__(self) -> str:
        parts = []
        if self.source is not None:
            parts.append(self.source)
        if self.line is not None:
            parts.append(str(self.line))
            if self.column is not None:
                parts.append(str(self.column))
        prefix = ":".join(parts)
        text = self.message
        if self.key is not None:
            text = f"{self.key}: {text}"
        if self.expected is not None:
            text = f"{text} (expected {self.expected})"
        return f"{prefix}: {text}" if prefix else text


def write_failed(exc: OSError, source: str | None) -> PrsxyError:
    """The error of an output that could not be written (disk full, no permission),
    worded the same wherever the writing happens."""
    return PrsxyError(
        f"cannot write output: {exc.strerror}", source=source, expected="a writable location"
    )


class GCodeError(PrsxyError):
    """The G-code program cannot be read or is outside the supported dialect."""


class ProfileError(PrsxyError):
    """A machine profile is malformed or describes an impossible machine."""


class MeasurementError(PrsxyError):
    """A measurement file (poses, ballbar, axis) is malformed."""


class ReachError(PrsxyError):
    """A pose is out of the machine's reach or a motor beyond its travel."""


class LimitError(PrsxyError):
    """A program exceeds a limit of the profile (feed, tilt, points, time)."""


class FitError(PrsxyError):
    """A calibration or fit failed or cannot identify what it was asked for."""


class ProcessFailed(PrsxyError):
    """A process the work was handed to (the interpreter, the writer, a ``--jobs``
    worker) died or sent what cannot be read: not the user's input, so exit 3."""

    exit_code = EXIT_INTERNAL


class UsageError(PrsxyError):
    """The command line asks for something inconsistent."""

    exit_code = EXIT_USAGE
