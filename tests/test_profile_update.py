"""Rewriting a profile: the edits land, and everything else stays as the user wrote it.

The reference for "what the text means" is Python's own TOML reader (tomllib),
independent of tomlkit, which writes it; "as the user wrote it" is the text
itself: comment lines and unchanged lines compared byte for byte.
"""

from __future__ import annotations

import difflib
import json
import math
import random
import re
import tomllib
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from prsxy_post import profile as profile_mod
from prsxy_post.errors import ProfileError
from prsxy_post.profile.update import (
    AddProvenance,
    Remove,
    ReplaceTables,
    SetValue,
    changes_between,
    dumps,
    key_of,
    update_text,
)

from .conftest import ROOT

SHOP = (ROOT / "profiles" / "prsxy-shop.toml").read_text()

#: a shop profile as a user keeps it: comments above, beside and inside sections,
#: a hand-made axis table with its own comments, a multi-line array
COMMENTED = (
    SHOP.replace("[table]\n", "# squared by hand, March\n[table]   # from the ballbar\n")
    + """
# ---- measured tables
[[axis_comp]]   # motor 3: laser run 2024-03-02
motor = 3
positions = [
    -100.0,   # lower end
    100.0,
]
forward = [0.0, 0.001]
reverse = [0.002, 0.003]

[[axis_comp]]   # motor 5: laser run 2024-03-01
motor = 5
positions = [-200.0, 0.0, 200.0]
forward = [0.0, 0.001, 0.002]
reverse = [0.003, 0.004, 0.005]   # backlash 3 um
"""
)


def comments(text: str) -> list[str]:
    return re.findall(r"#.*", text)


def changed_lines(a: str, b: str) -> list[str]:
    """Lines of ``a`` that are not in ``b`` (removed or rewritten)."""
    return [
        ln[1:]
        for ln in difflib.unified_diff(a.splitlines(), b.splitlines(), lineterm="", n=0)
        if ln.startswith("-") and not ln.startswith("---")
    ]


# ---------------------------------------------------------------- examples


def test_no_changes_give_the_same_bytes() -> None:
    assert update_text(COMMENTED, []) == COMMENTED
    doc = tomllib.loads(COMMENTED)
    assert changes_between(doc, doc) == []


def test_a_changed_value_keeps_its_comment_and_nothing_else_moves() -> None:
    out = update_text(COMMENTED, [SetValue(("limits", "max_tilt_deg"), 25.0)])
    assert comments(out) == comments(COMMENTED)
    assert changed_lines(COMMENTED, out) == [
        "max_tilt_deg = 30.0          # largest tool-axis tilt from vertical"
    ]
    assert "max_tilt_deg = 25.0          # largest tool-axis tilt from vertical" in out
    assert profile_mod.loads(out, "out").limits.max_tilt_deg == 25.0


def test_calibrate_like_rewrite_keeps_every_comment() -> None:
    """What calibrate writes: leg parameters, tables, an error map, provenance."""
    tables = [
        {"motor": m, "positions": [-100.0, 100.0], "forward": [0.0, 0.01], "reverse": [0.0, 0.02]}
        for m in (3, 5)
    ]
    edits = [
        SetValue(("kinematics", "legs", 1, "strut_length"), np.float64(399.95)),
        SetValue(("table", "squareness"), 1.349e-4),
        SetValue(("axis_comp",), tables),
        SetValue(("error_map",), {"model": "legendre-eq5", "lo": np.zeros(5), "hi": np.ones(5)}),
        AddProvenance("calibrate", {"by": "prsxy-post", "data": ["a.csv", "b.csv"]}),
    ]
    out = update_text(COMMENTED, edits)
    assert comments(out) == comments(COMMENTED)
    doc = tomllib.loads(out)
    assert doc["kinematics"]["legs"][1]["strut_length"] == 399.95
    assert doc["table"]["squareness"] == 1.349e-4
    assert doc["axis_comp"] == tables
    assert doc["error_map"]["hi"] == [1.0] * 5
    assert doc["provenance"]["calibrate"] == [{"by": "prsxy-post", "data": ["a.csv", "b.csv"]}]
    # the sections it did not touch are line for line the user's
    for section in (
        "[limits]",
        "[start]",
        "[gcode]",
        "[work.offsets]",
        "[[tools]]",
        "[output.pmac]",
    ):
        start = COMMENTED.index(section)
        block = COMMENTED[start : COMMENTED.index("\n\n", start)]
        assert block in out, section
    prof = profile_mod.loads(out, "out")
    assert prof.table.squareness == 1.349e-4
    assert prof.kinematics.legs[1].strut_length == 399.95


def test_replacing_one_motors_table_keeps_the_others_and_its_header_comment() -> None:
    new5 = {"motor": 5, "positions": [-100.0, 100.0], "forward": [0.0, 0.0], "reverse": [0.0, 0.0]}
    new1 = {"motor": 1, "positions": [0.0, 10.0], "forward": [0.0, 0.0], "reverse": [0.0, 0.0]}
    out = update_text(COMMENTED, [ReplaceTables(("axis_comp",), [new5, new1], match="motor")])
    doc = tomllib.loads(out)
    assert [t["motor"] for t in doc["axis_comp"]] == [1, 3, 5]  # sorted, as it was
    assert doc["axis_comp"][2] == new5
    assert doc["axis_comp"][1] == tomllib.loads(COMMENTED)["axis_comp"][0]
    assert "[[axis_comp]]   # motor 5: laser run 2024-03-01" in out
    assert "    -100.0,   # lower end" in out  # motor 3's table is untouched
    # a changed value keeps the comment on its line (the user's words, not ours)
    assert comments(out) == comments(COMMENTED)


def test_a_whole_array_of_tables_pairs_tables_by_motor() -> None:
    """Setting [[axis_comp]] as a whole (as calibrate's document does) keeps the
    comments of each motor's table wherever it ends up."""
    old = tomllib.loads(COMMENTED)["axis_comp"]
    out = update_text(COMMENTED, [SetValue(("axis_comp",), [old[1], old[0]])])
    assert [t["motor"] for t in tomllib.loads(out)["axis_comp"]] == [5, 3]
    assert comments(out) == [
        *comments(COMMENTED)[:-4],
        "# motor 5: laser run 2024-03-01",
        "# backlash 3 um",
        "# motor 3: laser run 2024-03-02",
        "# lower end",
    ]


def test_remove_a_table_and_a_missing_key() -> None:
    text = update_text(COMMENTED, [SetValue(("error_map",), {"model": "x"})])
    out = update_text(text, [Remove(("error_map",)), Remove(("no", "such", "key"))])
    assert out.rstrip("\n") == COMMENTED.rstrip("\n")  # (a blank line added before it stays)


def test_provenance_appends_and_takes_over_an_old_single_record() -> None:
    text = SHOP + '\n[provenance.calibrate]\nby = "prsxy-post 0.0.9"\n'
    out = update_text(text, [AddProvenance("calibrate", {"by": "prsxy-post 0.1.0"})])
    out = update_text(out, [AddProvenance("calibrate", {"by": "prsxy-post 0.1.1"})])
    got = tomllib.loads(out)["provenance"]["calibrate"]
    assert [r["by"] for r in got] == ["prsxy-post 0.0.9", "prsxy-post 0.1.0", "prsxy-post 0.1.1"]
    profile_mod.loads(out, "out")


def test_values_inside_inline_tables_and_arrays() -> None:
    text = (
        "[work]\norigin = [0.0, 0.0, -150.0]  # fixture\n"
        "offsets = {G55 = [1.0, 0.0, 0.0, 0.0, 0.0]}\n"
    )
    out = update_text(
        text,
        [
            SetValue(("work", "origin", 2), -149.5),
            SetValue(("work", "offsets", "G56"), [2.0, 0.0, 0.0, 0.0, 0.0]),
        ],
    )
    assert tomllib.loads(out)["work"] == {
        "origin": [0.0, 0.0, -149.5],
        "offsets": {"G55": [1.0, 0.0, 0.0, 0.0, 0.0], "G56": [2.0, 0.0, 0.0, 0.0, 0.0]},
    }
    assert "# fixture" in out


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (SetValue(("machine", "name", "x"), 1), "p.toml: machine.name: cannot be changed"),
        (SetValue(("table", "scale_x"), math.nan), "p.toml: table.scale_x: would be set to nan"),
        (
            SetValue(("kinematics", "legs", 7, "strut_length"), 1.0),
            "p.toml: kinematics.legs[8]: cannot be changed: has no table 8",
        ),
    ],
)
def test_impossible_edits_name_the_key(edit: Any, message: str) -> None:
    with pytest.raises(ProfileError) as exc:
        update_text(SHOP, [edit], "p.toml")
    assert str(exc.value).startswith(message)


def test_not_toml_is_located() -> None:
    with pytest.raises(ProfileError, match="not valid TOML"):
        update_text("[table\n", [], "p.toml")


def test_key_of_reads_the_paths_errors_and_diagnose_print() -> None:
    assert key_of("kinematics.legs[2].strut_length") == ("kinematics", "legs", 1, "strut_length")
    assert key_of("table.squareness") == ("table", "squareness")
    assert key_of("effects.guide_bow[3]") == ("effects", "guide_bow", 2)
    for bad in ("backlash[5", "legs[0].x", "a..b", ""):
        with pytest.raises(ValueError):
            key_of(bad)
    out = update_text(SHOP, [SetValue(key_of("kinematics.legs[3].hinge_twist"), 0.01)])
    assert profile_mod.loads(out, "o").kinematics.legs[2].hinge_twist == 0.01


def test_dumps_writes_a_profile_that_reads_back() -> None:
    prof = profile_mod.loads(SHOP, "shop")
    again = profile_mod.loads(dumps(prof.raw), "again")
    assert again.raw == prof.raw
    assert again.tools == prof.tools and again.limits == prof.limits


# ---------------------------------------------------------------- properties


def typed(x: Any) -> Any:
    """A value with its kind spelled out: Python has 0 == False. (1 and 1.0 are the
    same number here: an edit that gives an equal number keeps the user's form,
    so an integer key stays an integer.)"""
    if isinstance(x, dict):
        return {k: typed(v) for k, v in x.items()}
    if isinstance(x, list):
        return [typed(v) for v in x]
    if isinstance(x, bool):
        return ("bool", x)
    return ("number" if isinstance(x, int | float) else type(x).__name__, x)


KEYS = st.sampled_from(["a", "b", "c", "d", "e", "x y", "é"])
SCALARS = st.one_of(
    st.integers(-(2**63), 2**63 - 1),
    st.floats(allow_nan=False, allow_infinity=False),
    st.booleans(),
    st.text(st.characters(blacklist_categories=["Cs"]), max_size=8),
)
ARRAYS = st.lists(SCALARS, max_size=4)


def tables(depth: int) -> st.SearchStrategy[dict[str, Any]]:
    values: st.SearchStrategy[Any] = st.one_of(SCALARS, ARRAYS)
    if depth > 0:
        values = st.one_of(
            values, tables(depth - 1), st.lists(tables(depth - 1), min_size=1, max_size=3)
        )
    return st.dictionaries(KEYS, values, max_size=4)


DOCS = tables(2)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(DOCS, DOCS)
def test_any_document_becomes_any_other(old: dict[str, Any], new: dict[str, Any]) -> None:
    """update_text(text of A, changes A → B) reads back as B, whatever A and B are."""
    text = dumps(old)
    assert typed(tomllib.loads(text)) == typed(old)
    out = update_text(text, changes_between(old, new))
    assert typed(tomllib.loads(out)) == typed(new)
    assert update_text(out, changes_between(new, new)) == out


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(
                [
                    ("limits", "max_tilt_deg"),
                    ("limits", "rapid_mm_min"),
                    ("start", "pose"),
                    ("table", "scale_y"),
                    ("kinematics", "legs", 2, "platform_angle"),
                    ("axis_comp", 1, "forward"),
                    ("tools", 0, "length"),
                    ("output", "pmac", "decimals"),
                ]
            ),
            st.floats(-1e-3, 1e-3, allow_nan=False) | st.lists(st.floats(0, 1e-3), max_size=3),
        ),
        max_size=6,
    )
)
def test_value_edits_keep_every_comment_and_touch_only_their_lines(edits: list) -> None:
    changes = [SetValue(k, v) for k, v in edits]
    out = update_text(COMMENTED, changes)
    assert comments(out) == comments(COMMENTED)
    # one line per edited key at most; every other line is the user's
    assert len(changed_lines(COMMENTED, out)) <= len({k for k, _ in edits})
    final = {k: v for k, v in edits}
    doc = tomllib.loads(out)
    for k, v in final.items():
        node: Any = doc
        for part in k:
            node = node[part]
        assert node == v


def _key(k: str) -> str:
    return k if re.fullmatch(r"[A-Za-z0-9_-]+", k) else _string(k)


def _string(s: str) -> str:
    return json.dumps(s, ensure_ascii=False).replace("\x7f", "\\u007f")


def _inline(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | float):
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, list):
        return "[" + ", ".join(_inline(x) for x in v) + "]"
    return "{" + ", ".join(f"{_key(k)} = {_inline(x)}" for k, x in v.items()) + "}"


def render(doc: dict[str, Any], r: random.Random) -> str:
    """TOML as a person might write it, written here without tomlkit: some tables
    inline, some with headers, comments after values, between tables and inside
    multi-line arrays."""
    out: list[str] = []

    def body(d: dict[str, Any], path: list[str]) -> None:
        later = []
        for k, v in d.items():
            if (isinstance(v, dict) or _tables(v)) and r.random() < 0.7:
                later.append((k, v))
                continue
            if isinstance(v, list) and v and not _tables(v) and r.random() < 0.3:
                items = "".join(f"    {_inline(x)},  # item\n" for x in v)
                out.append(f"{_key(k)} = [  # opens\n{items}]")
            else:
                out.append(f"{_key(k)} = {_inline(v)}" + ("  # note" if r.random() < 0.5 else ""))
        for k, v in later:
            p = [*path, _key(k)]
            if r.random() < 0.3:
                out.append("# between tables")
            if isinstance(v, dict):
                out.append(f"[{'.'.join(p)}]" + ("  # header" if r.random() < 0.5 else ""))
                body(v, p)
            else:
                for t in v:
                    out.append(f"[[{'.'.join(p)}]]")
                    body(t, p)
            out.append("")

    body(doc, [])
    return "\n".join(out) + "\n"


def _tables(v: Any) -> bool:
    return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(DOCS, DOCS, st.randoms(use_true_random=False))
def test_hand_written_text_becomes_any_other_document(
    old: dict[str, Any], new: dict[str, Any], r: random.Random
) -> None:
    text = render(old, r)
    assert typed(tomllib.loads(text)) == typed(old)  # the renderer is right
    out = update_text(text, changes_between(old, new))
    assert typed(tomllib.loads(out)) == typed(new)
    assert update_text(text, changes_between(old, old)) == text
    # what stayed equal at the top stays as written, comments included
    for k in old:
        if k in new and typed(old[k]) == typed(new[k]) and not isinstance(old[k], dict | list):
            line = next(ln for ln in text.splitlines() if ln.startswith(f"{_key(k)} = "))
            assert line in out.splitlines()
