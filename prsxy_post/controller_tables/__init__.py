"""Real-axis tables in the files controllers load: LinuxCNC comp files, Turbo PMAC tables.

A profile's ``[[axis_comp]]`` tables (:class:`prsxy_post.profile.AxisComp`, the
contract's play model) become controller tables that make a motor commanded to p
end at p from either side, as each controller applies them. What a table must hold
is in :mod:`._common`. How each controller reads and applies its table is in
:mod:`.linuxcnc` and :mod:`.pmac`. Each module returns file texts and reads them
back; writing files is the caller's job.

Example::

    from prsxy_post.files import load_profile
    from prsxy_post.controller_tables import linuxcnc, pmac

    prof = load_profile("shop.toml")
    lc = linuxcnc.export(prof, file_type=1)      # lc.files[i].text, lc.ini
    pm = pmac.export(prof)                       # pm.text: one file to download
    back = pmac.read(pm.text, pm.name, prof)     # [AxisComp, ...]
"""

from __future__ import annotations

from typing import Any

from ..profile import AxisComp
from . import linuxcnc, pmac


def with_tables(doc: dict[str, Any], tables: list[AxisComp]) -> dict[str, Any]:
    """A profile document with ``tables`` replacing those motors' ``[[axis_comp]]``."""
    out = dict(doc)
    merged = {int(c["motor"]): c for c in out.get("axis_comp", [])}
    for t in tables:
        merged[t.motor] = {
            "motor": t.motor,
            "positions": [float(x) for x in t.positions],
            "forward": [float(x) for x in t.forward],
            "reverse": [float(x) for x in t.reverse],
        }
    out["axis_comp"] = [merged[m] for m in sorted(merged)]
    return out


__all__ = ["linuxcnc", "pmac", "with_tables"]
