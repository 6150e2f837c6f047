"""The one way the tool changes a profile file: edits applied to its TOML text.

``calibrate -o``, ``diagnose -o`` and ``tables import`` rewrite a user's profile.
They describe what they change as a list of edits (:class:`SetValue`,
:class:`ReplaceTables`, :class:`Remove`, :class:`AddProvenance`) and
:func:`update_text` applies them to the original text with tomlkit, a
style-preserving TOML library: every comment, the order of the sections and the
layout of everything the edits did not change survive. A changed value keeps the
comment on its line; a table set to new contents changes only the keys that
differ. (``tomllib`` stays the reader: :func:`prsxy_post.profile.loads`.)

What is written is checked: the text is read back with ``tomllib`` and must
equal the original document with the edits applied, key for key; anything else
is a bug here and raises.

Key paths name tables by their keys and arrays of tables by a 0-based index:
``("kinematics", "legs", 1, "strut_length")`` is the second leg's strut length
(``kinematics.legs[2].strut_length`` in error messages, which count from 1).

Example
-------
>>> text = "[table]\\nscale_x = 0.0   # from the ballbar\\nscale_y = 0.0\\n"
>>> print(update_text(text, [SetValue(("table", "scale_x"), 3e-4)]), end="")
[table]
scale_x = 0.0003   # from the ballbar
scale_y = 0.0
"""

from __future__ import annotations

import copy
import itertools
import math
import re
import tomllib
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import tomlkit
from tomlkit import items
from tomlkit.container import Container, OutOfOrderTableProxy

from ..errors import ProfileError

#: A path into a profile: table keys (str) and array indices (int, from 0).
Key = tuple[str | int, ...]

#: How the tables of the profile's arrays of tables are told apart: a table that
#: keeps its ``motor`` (or ``number``) is the same table, updated in place with
#: its comments, wherever it moves in the array. Other arrays pair by position.
MATCH_KEYS: dict[str, str] = {"axis_comp": "motor", "motors": "motor", "tools": "number"}

#: Arrays whose one-line form is longer than this are written one value per line.
LINE_WIDTH = 100


@dataclass(frozen=True)
class SetValue:
    """Make the value at ``key`` equal to ``value``.

    ``value`` is a number, string, boolean, array, table (a mapping) or array of
    tables (a sequence of mappings); numpy numbers and arrays are accepted.
    Tables missing on the way are created. Where the old value is a table, only
    the keys that differ change (keys it lacks are added, keys the new table
    lacks removed); an array of tables is paired table by table (by
    :data:`MATCH_KEYS`, else by position) and each pair updated the same way.
    Examples: ``SetValue(("table", "squareness"), 1.3e-4)``,
    ``SetValue(("error_map",), emap.to_dict())``.
    """

    key: Key
    value: Any


@dataclass(frozen=True)
class ReplaceTables:
    """Replace tables of an array of tables such as ``[[axis_comp]]``.

    With ``match`` (e.g. ``"motor"``): each of ``tables`` replaces the table
    with the same value of ``match`` (in place, keeping that table's comments)
    or joins the array (sorted by ``match`` when the array was); tables it does
    not name stay as they are. Without ``match``: the array becomes ``tables``.
    """

    key: Key
    tables: Sequence[Mapping[str, Any]]
    match: str | None = None


@dataclass(frozen=True)
class Remove:
    """Remove the key (a value, a table such as ``[error_map]``, or an array of
    tables). Removing a key the profile does not have changes nothing."""

    key: Key


@dataclass(frozen=True)
class AddProvenance:
    """Append ``record`` to ``[[provenance.<tool>]]``, the profile's history of
    what ``tool`` (``"calibrate"``, ``"diagnose"``, ``"tables import"``…) changed.

    An older single ``[provenance.<tool>]`` table becomes the first record.
    """

    tool: str
    record: Mapping[str, Any] = field(default_factory=dict)


Change = SetValue | ReplaceTables | Remove | AddProvenance


def update_text(text: str, changes: Iterable[Change], source: str = "<profile>") -> str:
    """The profile text with ``changes`` applied, in order.

    Parameters
    ----------
    text : the profile's TOML text as the user wrote it
    changes : edits; each sees the result of the ones before
    source : the profile's name for error messages

    Returns
    -------
    str
        The new text. Comments, order and layout of what was not changed are
        the original's; ``tomllib.loads`` of it equals ``tomllib.loads(text)``
        with the changes applied.

    Raises
    ------
    ProfileError
        The text is not TOML, a key path runs through a value that is not a
        table or array, or a value is not finite (a profile holds no NaN).
    """
    plain = _read(text, source)
    try:
        doc = tomlkit.parse(text)
    except tomlkit.exceptions.TOMLKitError as exc:  # tomllib read it: tomlkit should too
        raise ProfileError(f"cannot be rewritten: {exc}", source=source) from None
    for ch in changes:
        _apply_plain(plain, ch, source)
        _apply_doc(doc, ch, source)
    out = tomlkit.dumps(doc)
    again = tomllib.loads(out)
    if not _same(again, plain):
        raise RuntimeError(
            f"rewriting {source} gave a document other than the one asked for "
            "(a bug in prsxy_post.profile.update)"
        )
    return out


def key_of(path: str) -> Key:
    """The key path of a dotted profile path as errors and diagnose name it (arrays
    counted from 1): ``"kinematics.legs[2].strut_length"`` →
    ``("kinematics", "legs", 1, "strut_length")``.

    Raises
    ------
    ValueError
        For a path that is not of that form.
    """
    out: list[str | int] = []
    for part in path.split("."):
        m = re.fullmatch(r"([A-Za-z0-9_-]+)((?:\[[1-9][0-9]*\])*)", part)
        if m is None:
            raise ValueError(f"{path!r} is not a profile path like kinematics.legs[2].hinge_twist")
        out.append(m.group(1))
        out += [int(i) - 1 for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return tuple(out)


def changes_between(old: Mapping[str, Any], new: Mapping[str, Any]) -> list[Change]:
    """Edits that turn document ``old`` into ``new`` (one per top-level key that differs).

    For code that builds the new document as a whole (a copy of
    :attr:`Profile.raw` with sections replaced): :func:`update_text` with these
    edits keeps the layout of every part that is equal in both.
    """
    out: list[Change] = []
    for k in old:
        if k not in new:
            out.append(Remove((k,)))
    for k, v in new.items():
        if k not in old or not _same(old[k], _plain(v)):
            out.append(SetValue((k,), v))
    return out


def dumps(doc: Mapping[str, Any]) -> str:
    """A whole new profile text for a document (key order as given), for profiles
    the tool makes from scratch (a simulated machine); a user's profile is
    changed with :func:`update_text` instead."""
    tdoc = tomlkit.document()
    for k, v in _plain(dict(doc)).items():
        _check_finite(v, (k,), "<profile>")
        tdoc[k] = _new_item(v)
    out = tomlkit.dumps(tdoc)
    return out if out.endswith("\n") else out + "\n"


# ---------------------------------------------------------------- plain documents


def _read(text: str, source: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ProfileError(
            f"not valid TOML: {exc}", source=source, expected="a TOML profile"
        ) from None


def _plain(x: Any) -> Any:
    """Python values for numpy ones, lists for tuples and arrays, dicts for mappings."""
    if isinstance(x, Mapping):
        return {str(k): _plain(v) for k, v in x.items()}
    if isinstance(x, np.ndarray):
        return [_plain(v) for v in x.tolist()]
    if isinstance(x, list | tuple):
        return [_plain(v) for v in x]
    if isinstance(x, np.bool_):
        return bool(x)
    if isinstance(x, np.integer):
        return int(x)
    if isinstance(x, np.floating):
        return float(x)
    return x


def _same(a: Any, b: Any) -> bool:
    """Equal as TOML values: 1 and 1.0 are the same number, True is not 1."""
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, int | float) and isinstance(b, int | float):
        return a == b
    return type(a) is type(b) and a == b


def _is_tables(v: Any) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def _shown(key: Key) -> str:
    s = ""
    for k in key:
        s += f"[{k + 1}]" if isinstance(k, int) else (f".{k}" if s else str(k))
    return s


def _check_finite(v: Any, key: Key, source: str) -> None:
    if isinstance(v, float) and not math.isfinite(v):
        raise ProfileError(
            f"would be set to {v!r}", source=source, key=_shown(key), expected="a finite number"
        )
    if isinstance(v, dict):
        for k, x in v.items():
            _check_finite(x, (*key, k), source)
    elif isinstance(v, list):
        for i, x in enumerate(v):
            _check_finite(x, (*key, i), source)


def _walk_plain(doc: dict[str, Any], key: Key, source: str, create: bool) -> Any:
    """The container holding ``key[-1]`` (None when absent and not ``create``)."""
    node: Any = doc
    for i, k in enumerate(key[:-1]):
        if isinstance(node, dict) and isinstance(k, str):
            if k not in node:
                if not create:
                    return None
                node[k] = {}
            node = node[k]
        elif isinstance(node, list) and isinstance(k, int):
            if not -len(node) <= k < len(node):
                if not create:
                    return None
                raise _bad_path(key[: i + 1], source, f"has no table {k + 1}")
            node = node[k]
        else:
            raise _bad_path(key[: i + 1], source, "is not a table")
    if not isinstance(node, dict | list):
        raise _bad_path(key[:-1], source, "is not a table")
    return node


def _bad_path(key: Key, source: str, what: str) -> ProfileError:
    return ProfileError(
        f"cannot be changed: {what}", source=source, key=_shown(key), expected="a table"
    )


def _apply_plain(doc: dict[str, Any], ch: Change, source: str) -> None:
    """The change on the plain document (what the rewritten text must read as)."""
    if isinstance(ch, AddProvenance):
        prov = doc.setdefault("provenance", {})
        if not isinstance(prov, dict):
            raise _bad_path(("provenance",), source, "is not a table")
        old = prov.get(ch.tool)
        rec = _plain(dict(ch.record))
        _check_finite(rec, ("provenance", ch.tool), source)
        if old is None:
            prov[ch.tool] = [rec]
        elif isinstance(old, dict):
            prov[ch.tool] = [old, rec]
        elif _is_tables(old):
            old.append(rec)
        else:
            raise _bad_path(("provenance", ch.tool), source, "is not a table or array of tables")
        return
    if not ch.key:
        raise ProfileError("an edit with an empty key path", source=source)
    if isinstance(ch, Remove):
        parent = _walk_plain(doc, ch.key, source, create=False)
        last = ch.key[-1]
        if isinstance(parent, dict) and isinstance(last, str):
            parent.pop(last, None)
        elif isinstance(parent, list) and isinstance(last, int) and _has(parent, last):
            del parent[last]
        return
    parent = _walk_plain(doc, ch.key, source, create=True)
    last = ch.key[-1]
    if isinstance(ch, SetValue):
        value = _plain(ch.value)
    else:
        value = _merged_tables(
            _get(parent, last), _plain(list(ch.tables)), ch.match, ch.key, source
        )
    _check_finite(value, ch.key, source)
    if isinstance(parent, dict) and isinstance(last, str):
        parent[last] = value
    elif isinstance(parent, list) and isinstance(last, int) and _has(parent, last):
        parent[last] = value
    else:
        raise _bad_path(ch.key, source, "is not a key of a table or an index of an array")


def _get(parent: Any, last: str | int) -> Any:
    if isinstance(parent, dict):
        return parent.get(last)
    return parent[last] if isinstance(last, int) and -len(parent) <= last < len(parent) else None


def _merged_tables(
    old: Any, new: list[dict[str, Any]], match: str | None, key: Key, source: str
) -> list[dict[str, Any]]:
    if not all(isinstance(t, dict) for t in new):
        raise ProfileError(
            "ReplaceTables needs tables", source=source, key=_shown(key), expected="mappings"
        )
    if match is None or old is None:
        return copy.deepcopy(new)
    if not (isinstance(old, list) and all(isinstance(t, dict) for t in old)):
        raise _bad_path(key, source, "is not an array of tables")
    for t in new:
        if match not in t:
            raise ProfileError(
                f"a new table has no {match!r}", source=source, key=_shown(key), expected=match
            )
    out = [dict(t) for t in old]
    for t in new:
        at = next((i for i, o in enumerate(out) if o.get(match) == t[match]), None)
        if at is None:
            out.append(copy.deepcopy(t))
        else:
            out[at] = copy.deepcopy(t)
    if _sorted_by(old, match):
        out.sort(key=lambda t: t[match])
    return out


def _sorted_by(tables: list[dict[str, Any]], match: str) -> bool:
    vals = [t.get(match) for t in tables]
    try:
        return all(a <= b for a, b in itertools.pairwise(vals))  # type: ignore[operator]
    except TypeError:
        return False


# ---------------------------------------------------------------- tomlkit documents


def _is_table_item(x: Any) -> bool:
    return isinstance(x, Container | items.Table | items.InlineTable | OutOfOrderTableProxy)


def _walk_doc(doc: Any, key: Key, create: bool) -> Any:
    """The tomlkit container holding ``key[-1]`` (paths were checked on the plain
    document first, so every step exists or may be created)."""
    node = doc
    for k in key[:-1]:
        if isinstance(k, str) and k not in node:
            if not create:
                return None
            node[k] = _new_table({}, implicit=True)
        node = node[k]
    return node


def _apply_doc(doc: Any, ch: Change, source: str) -> None:
    if isinstance(ch, AddProvenance):
        rec = _plain(dict(ch.record))
        if "provenance" not in doc:
            doc["provenance"] = _new_table({}, implicit=True)
        prov = doc["provenance"]
        old = prov.get(ch.tool)
        if old is None:
            prov[ch.tool] = _new_item([rec])
        elif isinstance(old, items.AoT):
            old.append(_new_table(rec))
        else:
            prov[ch.tool] = _new_item([old.unwrap(), rec])
        return
    if isinstance(ch, Remove):
        parent = _walk_doc(doc, ch.key, create=False)
        last = ch.key[-1]
        if parent is None:
            return
        if isinstance(last, str) and last in parent:
            del parent[last]
        elif isinstance(last, int) and -len(parent) <= last < len(parent):
            del parent[last]
        return
    parent = _walk_doc(doc, ch.key, create=True)
    last = ch.key[-1]
    if isinstance(ch, SetValue):
        value = _plain(ch.value)
        match = _match_for(ch.key)
    else:
        old_plain = _unwrap(parent[last]) if _has(parent, last) else None
        value = _merged_tables(old_plain, _plain(list(ch.tables)), ch.match, ch.key, source)
        match = ch.match or _match_for(ch.key)
    _assign(parent, last, value, match)


def _has(parent: Any, last: str | int) -> bool:
    if isinstance(last, int):
        return -len(parent) <= last < len(parent)
    return last in parent


def _unwrap(x: Any) -> Any:
    return x.unwrap() if hasattr(x, "unwrap") else x


def _match_for(key: Key) -> str | None:
    names = [k for k in key if isinstance(k, str)]
    return MATCH_KEYS.get(names[-1]) if len(names) == 1 and isinstance(key[-1], str) else None


def _assign(parent: Any, last: str | int, value: Any, match: str | None) -> None:
    """parent[last] = value, touching as little of the old text as possible."""
    inline = _inline(parent)
    if not _has(parent, last):
        parent[last] = _new_item(value, inline)
        return
    old = parent[last]
    if isinstance(value, dict) and _is_table_item(old):
        for k in [k for k in old if k not in value]:
            del old[k]
        for k, v in value.items():
            _assign(old, k, v, None)
        if isinstance(old, items.Table) and old._is_super_table:
            # a headerless parent ([a] of [a.b]) that lost its sub-tables or got
            # keys of its own needs its header: let tomlkit decide again
            old._is_super_table = None
        return
    if isinstance(old, items.AoT) and _is_tables(value):
        _assign_tables(parent, last, old, value, match)
        return
    if _same(_unwrap(old), value):
        return  # equal: keep it as the user wrote it
    if isinstance(old, items.Array) and isinstance(value, list):
        arr = _new_item(value, inline=True)
        if "\n" in old.as_string():
            arr.multiline(True)
        parent[last] = arr
        return
    parent[last] = _new_item(value, inline)


def _assign_tables(
    parent: Any, last: str | int, old: items.AoT, new: list[dict[str, Any]], match: str | None
) -> None:
    tables = list(old)
    keep: list[Any] = []
    used: set[int] = set()
    for i, t in enumerate(new):
        j: int | None
        if match is not None:
            j = next(
                (
                    k
                    for k, o in enumerate(tables)
                    if k not in used and match in o and _same(_unwrap(o[match]), t.get(match))
                ),
                None,
            )
        else:
            j = i if i < len(tables) else None
        if j is None:
            keep.append(_new_table(t))
        else:
            used.add(j)
            for k in [k for k in tables[j] if k not in t]:
                del tables[j][k]
            for k, v in t.items():
                _assign(tables[j], k, v, None)
            keep.append(tables[j])
    if len(keep) != len(tables) or any(a is not b for a, b in zip(keep, tables, strict=True)):
        old.clear()
        for t in keep:
            old.append(t)


def _new_table(value: Mapping[str, Any], implicit: bool = False) -> Any:
    """A new [table], its keys before its sub-tables, a blank line after its keys
    (``implicit``: made on the way to a deeper key, given a header only if it gets
    keys of its own)."""
    t = tomlkit.table()
    plain = {k: v for k, v in value.items() if not (isinstance(v, dict) or _is_tables(v))}
    for k, v in plain.items():
        t[k] = _new_item(v)
    if plain or not (value or implicit):
        t.add(tomlkit.nl())
    for k, v in value.items():
        if k not in plain:
            t[k] = _new_item(v)
    return t


def _new_item(value: Any, inline: bool = False) -> Any:
    """A tomlkit item for a plain value; ``inline`` inside inline tables and arrays."""
    if isinstance(value, dict):
        if not inline:
            return _new_table(value)
        it = tomlkit.inline_table()
        for k, v in value.items():
            it[k] = _new_item(v, inline=True)
        return it
    if _is_tables(value) and not inline:
        aot = tomlkit.aot()
        for t in value:
            aot.append(_new_table(t))
        return aot
    if isinstance(value, list):
        arr = tomlkit.array()
        for v in value:
            arr.append(_new_item(v, inline=True))
        if len(arr.as_string()) > LINE_WIDTH:
            arr.multiline(True)
        return arr
    return tomlkit.item(value)


def _inline(container: Any) -> bool:
    return isinstance(container, items.InlineTable | items.Array)
