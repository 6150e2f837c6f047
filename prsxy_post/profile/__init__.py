"""Machine profiles: read and validate the TOML profile into typed sections.

The contract (``docs/contract/machine-model.md``, ``docs/contract/data-formats.md``)
fixes the sections ``[machine]``, ``[work]``, ``[kinematics]`` (three ``legs``),
``[table]``, ``[[axis_comp]]`` and ``[controller_kinematics]``. Everything else is
this project's and optional; a profile holding only the contract's keys is valid.
The project's sections, with their defaults, are documented in
``profiles/README.md`` and in the section dataclasses (:class:`MachineLimits`,
:class:`Interpolation`, …).

Reading is :func:`loads` (``tomllib``); the tool changes a profile file only
through :mod:`prsxy_post.profile.update`, which keeps the user's comments and
layout.

Angles are degrees in the file and in :class:`Profile`; :mod:`kinematics` turns
them into radians.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import re
import tomllib
from collections.abc import Mapping
from dataclasses import fields
from typing import Any

import numpy as np

from ..errors import ProfileError
from .effects_section import parse_effects
from .output import OUTPUT_SETTINGS
from .types import (
    DEFAULT_AXIS_NAMES,
    DEFAULT_MOTOR_LIMITS,
    DEFAULT_TABLE_LIMITS,
    DEFAULTS,
    KIN_OPTIONAL,
    KIN_REQUIRED,
    LEG_OPTIONAL,
    LEG_REQUIRED,
    MOTORS,
    TABLE_KEYS,
    AxisComp,
    Cyclic,
    Effects,
    Interpolation,
    KinematicParams,
    Leg,
    MachineLimits,
    MotorConfig,
    Profile,
    TableParams,
    Tool,
)

# ---------------------------------------------------------------- validation


#: No number in a profile is larger than this (lengths in mm, counts, limits):
#: larger ones are typos, and squaring 1e154 overflows.
MAX_MAGNITUDE = 1e12


class _Checker:
    """Reads typed values out of a TOML table, naming the key in every error."""

    def __init__(self, source: str) -> None:
        self.source = source

    def fail(self, key: str, message: str, expected: str | None = None) -> ProfileError:
        return ProfileError(message, source=self.source, key=key, expected=expected)

    def table(self, doc: Mapping[str, Any], name: str, path: str, required: bool) -> dict | None:
        if name not in doc:
            if required:
                raise self.fail(_join(path, name), "missing section", "a TOML table")
            return None
        value = doc[name]
        if not isinstance(value, dict):
            raise self.fail(_join(path, name), f"is a {_tname(value)}", "a TOML table")
        return value

    def number(
        self,
        doc: Mapping[str, Any],
        name: str,
        path: str,
        default: float | None = None,
        lo: float | None = None,
        hi: float | None = None,
        positive: bool = False,
    ) -> float:
        key = _join(path, name)
        if name not in doc:
            if default is None:
                raise self.fail(key, "missing key", "a number")
            return float(default)
        value = doc[name]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(key, f"is a {_tname(value)} ({value!r})", "a number")
        try:
            x = float(value)
        except OverflowError:
            raise self.fail(
                key,
                "is an integer beyond any float",
                f"a number of magnitude at most {MAX_MAGNITUDE:g}",
            ) from None
        if not math.isfinite(x):
            raise self.fail(key, f"is {value!r}", "a finite number")
        if abs(x) > MAX_MAGNITUDE:
            raise self.fail(key, f"is {x:g}", f"a number of magnitude at most {MAX_MAGNITUDE:g}")
        if positive and x <= 0:
            raise self.fail(key, f"is {x:g}", "a number > 0")
        if (lo is not None and x < lo) or (hi is not None and x > hi):
            raise self.fail(key, f"is {x:g}", f"a number in [{lo}, {hi}]")
        return x

    def integer(
        self,
        doc: Mapping[str, Any],
        name: str,
        path: str,
        default: int | None = None,
        lo: int | None = None,
    ) -> int:
        key = _join(path, name)
        if name not in doc:
            if default is None:
                raise self.fail(key, "missing key", "an integer")
            return default
        value = doc[name]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.fail(key, f"is a {_tname(value)} ({value!r})", "an integer")
        if lo is not None and value < lo:
            raise self.fail(key, f"is {value}", f"an integer >= {lo}")
        if abs(value) > MAX_MAGNITUDE:
            shown = (
                str(value)
                if len(str(value)) <= 20
                else f"{str(value)[:12]}… ({len(str(value))} digits)"
            )
            raise self.fail(
                key, f"is {shown}", f"an integer of magnitude at most {MAX_MAGNITUDE:g}"
            )
        return value

    def string(
        self, doc: Mapping[str, Any], name: str, path: str, default: str | None = None
    ) -> str:
        key = _join(path, name)
        if name not in doc:
            if default is None:
                raise self.fail(key, "missing key", "a string")
            return default
        value = doc[name]
        if not isinstance(value, str):
            raise self.fail(key, f"is a {_tname(value)}", "a string")
        return value

    def vector(
        self, doc: Mapping[str, Any], name: str, path: str, n: int | None, default: Any = None
    ) -> np.ndarray:
        key = _join(path, name)
        if name not in doc:
            if default is None:
                raise self.fail(key, "missing key", f"an array of {n or 'some'} numbers")
            return np.array(default, dtype=float)
        value = doc[name]
        want = f"an array of {n} numbers" if n else "an array of numbers"
        if not isinstance(value, list):
            raise self.fail(key, f"is a {_tname(value)}", want)
        if n is not None and len(value) != n:
            raise self.fail(key, f"has {len(value)} values", want)
        for i, v in enumerate(value):
            if isinstance(v, bool) or not isinstance(v, int | float):
                raise self.fail(f"{key}[{i}]", f"is {v!r}", "a finite number")
            if not abs(v) <= MAX_MAGNITUDE:  # NaN and infinities too; no float(v) of a huge int
                shown = repr(v) if len(repr(v)) <= 20 else f"{repr(v)[:12]}…"
                raise self.fail(
                    f"{key}[{i}]",
                    f"is {shown}",
                    f"a finite number of magnitude at most {MAX_MAGNITUDE:g}",
                )
        return np.array(value, dtype=float)

    def unknown(self, doc: Mapping[str, Any], allowed: set[str], path: str) -> None:
        for k in doc:
            if k not in allowed:
                raise self.fail(
                    _join(path, k), "unknown key", "one of " + ", ".join(sorted(allowed))
                )


def _join(path: str, name: str) -> str:
    return f"{path}.{name}" if path else name


def _tname(value: Any) -> str:
    return {dict: "table", list: "array", str: "string", bool: "boolean"}.get(
        type(value), type(value).__name__
    )


def _kinematics(c: _Checker, sec: dict, path: str) -> KinematicParams:
    c.unknown(sec, set(KIN_REQUIRED + KIN_OPTIONAL) | {"legs"}, path)
    tool_length = c.number(sec, "tool_length", path)
    ox = c.number(sec, "tool_offset_x", path, 0.0)
    oy = c.number(sec, "tool_offset_y", path, 0.0)
    legs_raw = sec.get("legs")
    if not isinstance(legs_raw, list) or not all(isinstance(x, dict) for x in legs_raw):
        raise c.fail(
            f"{path}.legs",
            "missing or not an array of tables",
            "three [[" + path + ".legs]] tables, for motors 1, 2, 3",
        )
    if len(legs_raw) != 3:
        raise c.fail(
            f"{path}.legs", f"has {len(legs_raw)} legs", "exactly three, for motors 1, 2, 3"
        )
    legs = []
    for i, leg in enumerate(legs_raw):
        lp = f"{path}.legs[{i + 1}]"
        c.unknown(leg, set(LEG_REQUIRED + LEG_OPTIONAL), lp)
        vals = {k: c.number(leg, k, lp) for k in LEG_REQUIRED}
        for k in ("guide_radius", "strut_length", "platform_radius"):
            if vals[k] <= 0:
                raise c.fail(f"{lp}.{k}", f"is {vals[k]:g}", "a length > 0")
        vals.update(
            {
                k: c.number(leg, k, lp, 0.0, lo=-45.0, hi=45.0)
                if k != "platform_z"
                else c.number(leg, k, lp, 0.0)
                for k in LEG_OPTIONAL
            }
        )
        legs.append(Leg(**vals))
    return KinematicParams(tool_length, (legs[0], legs[1], legs[2]), ox, oy)


def _axis_comp(c: _Checker, entries: Any) -> tuple[AxisComp, ...]:
    if not isinstance(entries, list) or not all(isinstance(x, dict) for x in entries):
        raise c.fail("axis_comp", "is not an array of tables", "[[axis_comp]] tables")
    out: list[AxisComp] = []
    seen: set[int] = set()
    for i, e in enumerate(entries):
        p = f"axis_comp[{i + 1}]"
        c.unknown(e, {"motor", "positions", "forward", "reverse", "note"}, p)
        m = c.integer(e, "motor", p)
        if m not in MOTORS:
            raise c.fail(f"{p}.motor", f"is {m}", "one of 1, 2, 3, 5, 6")
        if m in seen:
            raise c.fail(f"{p}.motor", f"motor {m} has a second table", "one table per motor")
        seen.add(m)
        pos = c.vector(e, "positions", p, None)
        fwd = c.vector(e, "forward", p, len(pos))
        rev = c.vector(e, "reverse", p, len(pos))
        if len(pos) < 1:
            raise c.fail(f"{p}.positions", "is empty", "at least one position")
        if np.any(np.diff(pos) <= 0):
            raise c.fail(f"{p}.positions", "is not strictly ascending", "ascending positions")
        # The play model needs lo(p) and hi(p) increasing in p, or compensation
        # could not invert them: an error slope below -1 would be a machine that
        # moves backwards when commanded forwards.
        for name, err in (("forward", fwd), ("reverse", rev)):
            if len(pos) > 1 and np.any(np.diff(err) / np.diff(pos) <= -0.5):
                raise c.fail(
                    f"{p}.{name}",
                    "changes faster than -0.5 mm per mm",
                    "a positioning error table (small, slowly varying)",
                )
        out.append(AxisComp(m, pos, fwd, rev))
    return tuple(sorted(out, key=lambda a: a.motor))


def _motors(c: _Checker, entries: Any) -> tuple[MotorConfig, ...]:
    given: dict[int, dict] = {}
    if entries is not None:
        if not isinstance(entries, list) or not all(isinstance(x, dict) for x in entries):
            raise c.fail("motors", "is not an array of tables", "[[motors]] tables")
        for i, e in enumerate(entries):
            p = f"motors[{i + 1}]"
            c.unknown(e, {"motor", "axis", "counts_per_mm", "min", "max"}, p)
            m = c.integer(e, "motor", p)
            if m not in MOTORS:
                raise c.fail(f"{p}.motor", f"is {m}", "one of 1, 2, 3, 5, 6")
            if m in given:
                raise c.fail(f"{p}.motor", f"motor {m} given twice", "each motor once")
            given[m] = {"_path": p, **e}
    out = []
    names: set[str] = set()
    for m in MOTORS:
        e = given.get(m, {"_path": "motors"})
        p = e["_path"]
        lo_d, hi_d = DEFAULT_MOTOR_LIMITS.get(m, DEFAULT_TABLE_LIMITS)
        axis = c.string(e, "axis", p, DEFAULT_AXIS_NAMES[m])
        if len(axis) != 1 or axis not in "ABCUVWXYZ":
            raise c.fail(f"{p}.axis", f"is {axis!r}", "one PMAC axis letter A B C U V W X Y Z")
        if axis in names:
            raise c.fail(f"{p}.axis", f"axis {axis} is used twice", "a letter per motor")
        names.add(axis)
        cpm = c.number(e, "counts_per_mm", p, 10000.0, positive=True)
        lo = c.number(e, "min", p, lo_d)
        hi = c.number(e, "max", p, hi_d)
        if hi <= lo:
            raise c.fail(f"{p}.max", f"is {hi:g}, not above min {lo:g}", "max > min")
        out.append(MotorConfig(m, axis, cpm, lo, hi))
    return tuple(out)


def _output(c: _Checker, doc: Mapping[str, Any]) -> tuple[dict[str, dict[str, Any]], list[str]]:
    """``[output.<dialect>]`` for every registered dialect, with the keys it declares;
    the old flat ``[output]`` keys are still read, with a note saying where they go."""
    sec = c.table(doc, "output", "", False) or {}
    legacy: dict[str, list[str]] = {}
    for name, d in OUTPUT_SETTINGS.items():
        for key, st in d.items():
            if st.legacy:
                legacy.setdefault(st.legacy, []).append(f"output.{name}.{key}")
    c.unknown(sec, set(OUTPUT_SETTINGS) | set(legacy), "output")
    out: dict[str, dict[str, Any]] = {}
    for name, d in OUTPUT_SETTINGS.items():
        path = f"output.{name}"
        sub = c.table(sec, name, "output", False) or {}
        c.unknown(sub, set(d), path)
        vals: dict[str, Any] = {}
        for key, st in d.items():
            src, where, k = sub, path, key
            if key not in sub and st.legacy and st.legacy in sec:
                src, where, k = sec, "output", st.legacy
            if isinstance(st.default, int):
                v: float | int = c.integer(src, k, where, st.default, lo=int(st.lo))
                if v > st.hi:
                    raise c.fail(
                        f"{where}.{k}", f"is {v}", f"an integer from {st.lo:g} to {st.hi:g}"
                    )
            else:
                v = c.number(src, k, where, st.default, lo=st.lo, hi=st.hi)
            vals[key] = v
        out[name] = vals
    notes = [
        f"output.{old}: deprecated key, read as {' and '.join(new)} (write it there)"
        for old, new in legacy.items()
        if old in sec
    ]
    return out, notes


def _section_with_defaults(c: _Checker, doc: Mapping[str, Any], name: str) -> dict[str, Any]:
    defaults = DEFAULTS[name]
    sec = c.table(doc, name, "", False) or {}
    c.unknown(sec, set(defaults), name)
    out: dict[str, Any] = {}
    for k, d in defaults.items():
        if isinstance(d, list) and not d:  # a list of any length, of strings or codes
            out[k] = _any_length_list(c, sec, k, name)
        elif isinstance(d, list):
            out[k] = [float(x) for x in c.vector(sec, k, name, len(d), d)]
        elif isinstance(d, int) and not isinstance(d, bool):
            out[k] = c.integer(sec, k, name, d, lo=0)
        else:
            out[k] = c.number(sec, k, name, d, lo=0.0)
    return out


def _any_length_list(c: _Checker, sec: Mapping[str, Any], k: str, path: str) -> list[Any]:
    """[gcode] subroutine_path (strings) and user_m_codes (100..199)."""
    key = _join(path, k)
    value = sec.get(k, [])
    if not isinstance(value, list):
        raise c.fail(key, f"is a {_tname(value)}", "an array")
    if k == "subroutine_path":
        for i, v in enumerate(value):
            if not isinstance(v, str) or not v:
                raise c.fail(f"{key}[{i}]", f"is {v!r}", "a folder name")
        return list(value)
    for i, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, int) or not 100 <= v <= 199:
            raise c.fail(f"{key}[{i}]", f"is {v!r}", "an M code from 100 to 199")
    return list(value)


def profile_from_dict(doc: Mapping[str, Any], source: str = "<profile>") -> Profile:
    """Validate a parsed profile document and fill in the defaults.

    Raises
    ------
    ProfileError
        Naming the offending key (``kinematics.legs[2].strut_length``) and what
        was expected.
    """
    c = _Checker(source)
    known = {
        "machine",
        "work",
        "kinematics",
        "table",
        "axis_comp",
        "controller_kinematics",
        "motors",
        "tools",
        "error_map",
        "provenance",
        "effects",
        "output",
        *DEFAULTS,
    }
    c.unknown(doc, known, "")
    machine = c.table(doc, "machine", "", False) or {}
    name = c.string(machine, "name", "machine", "unnamed machine")
    c.unknown(machine, {"name", "note"}, "machine")
    origin, offsets = _work(c, doc)
    kin = _kinematics(c, c.table(doc, "kinematics", "", True) or {}, "kinematics")
    ck_sec = c.table(doc, "controller_kinematics", "", False)
    ckin = _kinematics(c, ck_sec, "controller_kinematics") if ck_sec is not None else None
    tsec = c.table(doc, "table", "", False) or {}
    c.unknown(tsec, set(TABLE_KEYS), "table")
    table = TableParams(*(c.number(tsec, k, "table", 0.0, lo=-0.01, hi=0.01) for k in TABLE_KEYS))
    axis_comp = _axis_comp(c, doc["axis_comp"]) if "axis_comp" in doc else ()
    effects = parse_effects(c, doc)
    motors = _motors(c, doc.get("motors"))

    sections = {name_: _section_with_defaults(c, doc, name_) for name_ in DEFAULTS}
    limits = _limits(c, sections["limits"])
    interp = _interpolation(c, sections["interpolation"])
    out_sec, notes = _output(c, doc)

    tools = _tools(c, doc.get("tools", []))
    if "error_map" in doc and not isinstance(doc["error_map"], dict):
        raise c.fail("error_map", "is not a table", "an [error_map] table")

    raw = copy.deepcopy(dict(doc))
    g = sections["gcode"]
    prof = Profile(
        name=name,
        origin=origin,
        kinematics=kin,
        table=table,
        axis_comp=axis_comp,
        controller_kinematics=ckin,
        effects=effects,
        motors=motors,
        limits=limits,
        period_ms=interp["period_ms"],
        start=np.array(sections["start"]["pose"], dtype=float),
        work_offsets=offsets,
        g28=tuple(g["g28"]),
        g30=tuple(g["g30"]),
        tools=tools,
        output=out_sec,
        raw=raw,
        source=source,
        interpolation=Interpolation(
            **{f.name: float(interp[f.name]) for f in fields(Interpolation)}
        ),
        notes=tuple(notes),
        gcode=g,
    )
    return prof


def _work(
    c: _Checker, doc: Mapping[str, Any]
) -> tuple[np.ndarray, dict[int, tuple[float, float, float, float, float]]]:
    """``[work]``: the work origin [mm] and the G54-G59 offsets [mm, mm, mm, deg, deg]."""
    work = c.table(doc, "work", "", True) or {}
    c.unknown(work, {"origin", "offsets"}, "work")
    origin = c.vector(work, "origin", "work", 3)
    offsets: dict[int, tuple[float, float, float, float, float]] = {}
    off_sec = c.table(work, "offsets", "work", False) or {}
    for k in off_sec:
        if k not in {f"G{n}" for n in range(54, 60)}:
            raise c.fail(f"work.offsets.{k}", "unknown work offset", "G54 ... G59")
        v = c.vector(off_sec, k, "work.offsets", 5)
        offsets[int(k[1:])] = (v[0], v[1], v[2], v[3], v[4])
    return origin, offsets


def _limits(c: _Checker, section: dict[str, Any]) -> MachineLimits:
    """``[limits]`` (defaults filled in): every rate, acceleration and time > 0."""
    limits = MachineLimits(**section)
    for k in (
        "max_feed_mm_min",
        "rapid_mm_min",
        "rapid_deg_min",
        "max_accel_mm_s2",
        "max_accel_deg_s2",
        "max_time_s",
    ):
        if getattr(limits, k) <= 0:
            raise c.fail(f"limits.{k}", f"is {getattr(limits, k):g}", "a number > 0")
    return limits


def _interpolation(c: _Checker, interp: dict[str, Any]) -> dict[str, Any]:
    """``[interpolation]`` (defaults filled in), each value within its range."""
    period = interp["period_ms"]
    if not 0.1 <= period <= 1000.0:
        raise c.fail("interpolation.period_ms", f"is {period:g}", "0.1 to 1000 ms")
    for key, lo, hi, unit in (
        ("path_tolerance_mm", 1e-6, 10.0, "mm"),
        ("path_tolerance_arcsec", 0.001, 36000.0, "arcsec"),
        ("reversal_ms", 0.05, 100.0, "ms"),
    ):
        if not lo <= interp[key] <= hi:
            raise c.fail(f"interpolation.{key}", f"is {interp[key]:g}", f"{lo:g} to {hi:g} {unit}")
    return interp


def _tools(c: _Checker, tools_raw: Any) -> dict[int, Tool]:
    """``[[tools]]``: each tool's length and diameter by its number (each once)."""
    tools: dict[int, Tool] = {}
    if not isinstance(tools_raw, list) or not all(isinstance(x, dict) for x in tools_raw):
        raise c.fail("tools", "is not an array of tables", "[[tools]] tables")
    for i, t in enumerate(tools_raw):
        p = f"tools[{i + 1}]"
        c.unknown(t, {"number", "length", "diameter", "note"}, p)
        n = c.integer(t, "number", p, lo=1)
        if n in tools:
            raise c.fail(f"{p}.number", f"tool {n} given twice", "each tool once")
        tools[n] = Tool(c.number(t, "length", p), c.number(t, "diameter", p, 0.0, lo=0.0))
    return tools


#: the documents parsed last, by their text (at most :data:`PARSED_KEEP`): a batch
#: converts every program with one profile, and parsing its TOML (error maps and
#: tables of thousands of numbers) was about a third of a small program's
#: conversion. :func:`profile_from_dict` only reads a document (what it keeps, it
#: deep-copies), so one parse serves every load of the same text
_PARSED: dict[str, dict[str, Any]] = {}
PARSED_KEEP = 4


def _parsed(text: str) -> dict[str, Any]:
    """``tomllib.loads(text)``, parsed once per text (:data:`_PARSED`)."""
    doc = _PARSED.get(text)
    if doc is None:
        doc = tomllib.loads(text)
        if len(_PARSED) >= PARSED_KEEP:
            del _PARSED[next(iter(_PARSED))]
        _PARSED[text] = doc
    return doc


def loads(text: str, source: str = "<profile>") -> Profile:
    """Parse and validate profile TOML text."""
    try:
        doc = _parsed(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        line = col = None
        # tomllib says "... (at line 3, column 7)"
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        if m:
            line, col = int(m.group(1)), int(m.group(2))
            msg = msg[: m.start()].strip()
        raise ProfileError(
            f"not valid TOML: {msg}",
            source=source,
            line=line,
            column=col,
            expected="a TOML profile",
        ) from None
    return dataclasses.replace(profile_from_dict(doc, source), text=text)


def dumps(doc: Mapping[str, Any]) -> str:
    """A new profile text for a whole document (key order as given), for profiles
    made from scratch; a user's profile is changed with
    :func:`prsxy_post.profile.update.update_text`, which keeps its comments."""
    from .update import dumps as new_text

    return new_text(doc)


def kinematics_to_dict(kp: KinematicParams) -> dict[str, Any]:
    """The ``[kinematics]`` section for a parameter set (all keys written)."""
    return {
        "tool_length": kp.tool_length,
        "tool_offset_x": kp.tool_offset_x,
        "tool_offset_y": kp.tool_offset_y,
        "legs": [{k: getattr(leg, k) for k in LEG_REQUIRED + LEG_OPTIONAL} for leg in kp.legs],
    }


def nominal_kinematics() -> KinematicParams:
    """The contract's nominal design (machine-model.md)."""
    h = math.sqrt(400.0**2 - 150.0**2)
    l1, l2, l3 = (Leg(250.0, a, h, 400.0, 100.0, a) for a in (90.0, 210.0, 330.0))
    return KinematicParams(150.0, (l1, l2, l3))


__all__ = [
    "DEFAULTS",
    "DEFAULT_AXIS_NAMES",
    "DEFAULT_MOTOR_LIMITS",
    "DEFAULT_TABLE_LIMITS",
    "KIN_OPTIONAL",
    "KIN_REQUIRED",
    "LEG_OPTIONAL",
    "LEG_REQUIRED",
    "MAX_MAGNITUDE",
    "MOTORS",
    "TABLE_KEYS",
    "AxisComp",
    "Cyclic",
    "Effects",
    "Interpolation",
    "KinematicParams",
    "Leg",
    "MachineLimits",
    "MotorConfig",
    "Profile",
    "TableParams",
    "Tool",
    "dumps",
    "kinematics_to_dict",
    "loads",
    "nominal_kinematics",
    "profile_from_dict",
]
