"""What every output dialect shares: its settings, its registry entry, the header.

A dialect turns the chain's points (:class:`~prsxy_post.points.PointChunk`) into
the text a controller runs. It is one module with a :class:`Dialect` entry; the
registry (:mod:`prsxy_post.writers`) lists them. Each has its profile section
``[output.<name>]`` whose keys it declares as :class:`Setting` s (the profile
validates them, naming the key in errors).

Writers stream: ``begin()``, then ``feed(chunk)`` for every chunk in order, then
``finish()``. Each returns text pieces tagged with the output part they belong to
(a program split into parts writes parts 0, 1, ...); the caller decides where they
go. Nothing here touches files.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, Protocol

from .. import __version__
from ..points import Written
from ..profile.output import Setting

if TYPE_CHECKING:
    from ..points import PointChunk
    from ..profile import Profile

Piece = tuple[int, str]  # (output part, text)


class Provenance(NamedTuple):
    """What a program was made from, for its header."""

    source: str
    source_sha256: str
    profile_name: str
    profile_source: str
    profile_sha256: str
    options: str
    #: the real-axis tables stage ran: the motors' real-axis errors are in the
    #: program (else the controller's own tables must compensate them)
    axis_comp: bool = True


class Writer(Protocol):
    def begin(self) -> list[Piece]: ...

    def feed(self, chunk: PointChunk) -> list[Piece]: ...

    def finish(self) -> list[Piece]: ...


class Dialect(NamedTuple):
    """A registry entry.

    name : the ``--format`` value and the profile section ``[output.<name>]``
    extension : of the output file (".pmc")
    summary : one line for ``--help``
    segment : how the controller moves between points: "cubic" (a cubic through
        positions and velocities) or "chord" (a straight line); the planner makes
        points dense enough for it
    settings : the section's keys
    make : (profile, settings, provenance) → Writer
    parts : settings → the most points a part may hold (0: one part); the chain
        ends each part at rest at a block end
    space : what its numbers are: "motor" positions or the tip's "pose" (rounded
        to the setting ``decimals``: :meth:`written`)
    interpreter_apart : whether a large program converted in parallel is read,
        interpreted and planned, and its points' map and IK solved, in a process of
        its own (three processes: that one, the chain's and the writer's) or in the
        chain's (two). Each dialect's by measurement (``bench/process_layout.py``,
        docs/measurements.md, "Conversion speed"): a third process costs CPU (its
        points cross a pipe), which a light writer leaves room for on a second core
        and a heavy one does not
    """

    name: str
    extension: str
    summary: str
    segment: str
    settings: Mapping[str, Setting]
    make: Callable[[Profile, Mapping[str, Any], Provenance], Writer]
    parts: Callable[[Mapping[str, Any]], int] = lambda s: 0
    space: str = "motor"
    interpreter_apart: bool = True

    def written(self, settings: Mapping[str, Any]) -> Written:
        """How the chain's numbers are rounded on the way out (:class:`points.Written`)."""
        return Written(self.space, 10.0 ** -int(settings["decimals"]))


def header(prov: Provenance, profile: Profile, extra: Sequence[str]) -> list[str]:
    """The lines every output starts with (each dialect comments them its way)."""
    ip = profile.interpolation
    return [
        f"prsxy-post {__version__}",
        f"source: {prov.source}",
        f"source sha256: {prov.source_sha256}",
        f"profile: {prov.profile_name} ({prov.profile_source})",
        f"profile sha256: {prov.profile_sha256}",
        f"options: {prov.options}",
        f"interpolation period: {profile.period_ms:g} ms; path tolerance "
        f"{ip.path_tolerance_mm:g} mm and "
        f"{ip.path_tolerance_arcsec:g} arcsec where the program sets "
        "none (a G64 P in the program sets its own)",
        *extra,
    ]


def words_text(words: Sequence[tuple[str, float]]) -> str:
    """Machine-function words as G-code writes them: ``S12000 M3``."""
    return " ".join(f"{letter}{value:g}" for letter, value in words)
