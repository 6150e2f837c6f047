"""Mutated profiles never crash the reader: a result or a ProfileError naming a key."""

from __future__ import annotations

import tomllib

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from prsxy_post import kinematics
from prsxy_post import profile as profile_mod
from prsxy_post.errors import ProfileError

from .conftest import ROOT

TEXT = (ROOT / "profiles" / "prsxy-shop.toml").read_text()
DOC = tomllib.loads(TEXT)

values = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(10**6), 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
    st.lists(st.floats(-1e3, 1e3), max_size=6),
)


def _paths(doc: object, prefix: tuple = ()) -> list[tuple]:
    out = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            out.append((*prefix, k))
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


PATHS = _paths(DOC)


def _set(doc: object, path: tuple, value: object) -> None:
    for k in path[:-1]:
        doc = doc[k]  # type: ignore[index]
    if value is None and isinstance(doc, dict):
        del doc[path[-1]]
    else:
        doc[path[-1]] = value  # type: ignore[index]


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.sampled_from(PATHS), values), min_size=1, max_size=3))
# found by this test in CI: squaring the height overflowed in the reach check
@example([(("kinematics", "legs", 0, "guide_height"), 1.3407807929942597e154)])
@example([(("kinematics", "tool_length"), 10**400)])
@example([(("work", "origin"), [0, 0, 10**400])])  # float() of it would overflow
@example([(("output", "decimals"), 10**30)])
def test_mutated_documents_give_a_profile_or_a_keyed_error(edits: list) -> None:
    import copy

    doc = copy.deepcopy(DOC)
    for path, value in edits:
        try:
            _set(doc, path, value)
        except (KeyError, IndexError, TypeError):
            continue
    try:
        p = profile_mod.profile_from_dict(doc, "fuzz.toml")
        kinematics.check_reach(p)
    except ProfileError as err:
        msg = str(err)
        assert msg.startswith("fuzz.toml: ")
        assert "(expected " in msg
        return
    assert p.kinematics.tool_length == p.kinematics.tool_length  # finite, read


@settings(max_examples=300, deadline=None)
@given(st.integers(0, len(TEXT) - 1), st.text(max_size=4))
def test_mutated_text_gives_a_profile_or_a_located_error(pos: int, junk: str) -> None:
    text = TEXT[:pos] + junk + TEXT[pos + 1 :]
    try:
        profile_mod.loads(text, "fuzz.toml")
    except ProfileError as err:
        assert str(err).startswith("fuzz.toml")
