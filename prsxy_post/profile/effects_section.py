"""The ``[effects]`` section: physical effects beyond the contract's terms.

Read here, in the profile package, so that loading a profile needs none of the
physics: :mod:`prsxy_post.effects` (the registry) says what each key means, how the
simulator applies it and the conversion compensates it. Every key is owned by one
family of the registry (``Family.effects_keys``; a test holds the two equal).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .types import MOTORS, Cyclic, Effects

#: Each key, the number of values and the largest magnitude a value may have
#: (guide bow mm at 100 mm, straightness mm/m², lag ms).
VECTOR_KEYS: Mapping[str, tuple[int, float]] = {
    "guide_bow": (3, 1.0),
    "table_straightness": (2, 1.0),
    "servo_lag_ms": (len(MOTORS), 100.0),
}
KEYS = (*VECTOR_KEYS, "cyclic")


def _bounded_vector(
    checker: Any, section: Mapping[str, Any], key: str, n: int, limit: float
) -> tuple[float, ...]:
    v = checker.vector(section, key, "effects", n, [0.0] * n)
    if np.any(np.abs(v) > limit):
        raise checker.fail(f"effects.{key}", f"is {v.tolist()}", f"values within ±{limit:g}")
    return tuple(float(x) for x in v)


def _cyclic(checker: Any, section: Mapping[str, Any]) -> tuple[Cyclic, ...]:
    """``[[effects.cyclic]]``: motor, amplitude [mm or deg], period, phase [deg]."""
    c = checker
    raw = section.get("cyclic", [])
    if not isinstance(raw, list) or not all(isinstance(x, dict) for x in raw):
        raise c.fail("effects.cyclic", "is not an array of tables", "[[effects.cyclic]] tables")
    out = []
    for i, e in enumerate(raw):
        p = f"effects.cyclic[{i + 1}]"
        c.unknown(e, {"motor", "amplitude", "period", "phase"}, p)
        m = c.integer(e, "motor", p)
        if m not in MOTORS:
            raise c.fail(f"{p}.motor", f"is {m}", "one of 1, 2, 3, 5, 6")
        out.append(
            Cyclic(
                m,
                c.number(e, "amplitude", p, lo=-1.0, hi=1.0),
                c.number(e, "period", p, positive=True),
                c.number(e, "phase", p, 0.0),
            )
        )
    return tuple(out)


def parse_effects(checker: Any, doc: Mapping[str, Any]) -> Effects:
    """The ``[effects]`` section of a profile document, every key checked."""
    section = checker.table(doc, "effects", "", False) or {}
    checker.unknown(section, set(KEYS), "effects")
    fields: dict[str, Any] = {
        key: _bounded_vector(checker, section, key, n, limit)
        for key, (n, limit) in VECTOR_KEYS.items()
    }
    return Effects(**fields, cyclic=_cyclic(checker, section))
