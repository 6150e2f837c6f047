"""Output dialects: one module each, behind one registry.

======  =========================================================  =========
name    what                                                       extension
======  =========================================================  =========
pmac    Turbo PMAC PVT motion program in motor space (:mod:`.pmac`)  .pmc
gcode   corrected Cartesian G-code for LinuxCNC (:mod:`.linuxcnc`)  .ngc
======  =========================================================  =========

Adding a dialect is one module with a :class:`~.base.Dialect` entry and one line
in :data:`DIALECTS` (``docs/architecture.md``, "Adding a dialect").
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from ..errors import UsageError
from . import linuxcnc, pmac
from .base import Dialect, Piece, Provenance, Setting, Writer

if TYPE_CHECKING:
    from ..profile import Profile

#: Every output dialect, by its ``--format`` name.
DIALECTS: dict[str, Dialect] = {d.name: d for d in (pmac.DIALECT, linuxcnc.DIALECT)}


def dialect(name: str) -> Dialect:
    """The registry entry of a dialect name; a :class:`UsageError` naming the choices."""
    try:
        return DIALECTS[name]
    except KeyError:
        raise UsageError(
            f"unknown output format {name!r}", expected="one of " + ", ".join(sorted(DIALECTS))
        ) from None


def settings_of(profile: Profile, name: str) -> Mapping[str, Any]:
    """The validated ``[output.<name>]`` section of a profile, with its defaults."""
    return profile.output[name]


def writer_for(profile: Profile, name: str, prov: Provenance) -> Writer:
    d = dialect(name)
    return d.make(profile, settings_of(profile, name), prov)


__all__ = [
    "DIALECTS",
    "Dialect",
    "Piece",
    "Provenance",
    "Setting",
    "Writer",
    "dialect",
    "settings_of",
    "writer_for",
]
