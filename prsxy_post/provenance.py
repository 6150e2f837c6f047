"""Provenance notes in profiles: which command changed the profile, from what.

``calibrate`` and ``diagnose`` write the same way: one table per run appended to
``[[provenance.<command>]]``, with the program and version, the profile that
commanded the machine while it was measured (name and sha256, when known), the
data files and what the command found. Notes are never rewritten, so a profile
carries its history.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import Any

from . import __version__
from .measure import CommandedWith


def record(
    doc: Mapping[str, Any],
    command: str,
    note: Mapping[str, Any],
    *,
    commanded_with: CommandedWith | None = None,
) -> dict[str, Any]:
    """A copy of profile document ``doc`` with ``note`` appended to
    ``provenance.<command>`` (a table written before this form becomes the first
    entry of the list)."""
    out = copy.deepcopy(dict(doc))
    prov = dict(out.get("provenance", {}))
    old = prov.get(command, [])
    notes = list(old) if isinstance(old, list) else [old]
    entry: dict[str, Any] = {"by": f"prsxy-post {__version__} {command}"}
    if commanded_with is not None:
        entry["commanded_with"] = str(commanded_with)
    entry.update(note)
    notes.append(entry)
    prov[command] = notes
    out["provenance"] = prov
    return out
