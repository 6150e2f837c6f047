"""Profile reading, defaults and validation errors that name the key."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from prsxy_post import files, kinematics
from prsxy_post import profile as profile_mod
from prsxy_post.errors import ProfileError

from .conftest import ROOT, VECTORS

NOMINAL_TEXT = (ROOT / "profiles" / "prsxy-nominal.toml").read_text()


def test_nominal_profile_is_the_contract_design() -> None:
    p = profile_mod.loads(NOMINAL_TEXT, "nominal")
    h = math.sqrt(400.0**2 - 150.0**2)
    assert p.kinematics.tool_length == 150.0
    np.testing.assert_array_equal(p.origin, [0.0, 0.0, -150.0])
    for leg, ang in zip(p.kinematics.legs, (90.0, 210.0, 330.0), strict=True):
        assert (leg.guide_radius, leg.guide_angle, leg.strut_length) == (250.0, ang, 400.0)
        assert (leg.platform_radius, leg.platform_angle) == (100.0, ang)
        assert leg.guide_height == h
        assert (leg.guide_tilt_x, leg.guide_tilt_y, leg.hinge_twist, leg.platform_z) == (0,) * 4
    assert p.kinematics == profile_mod.nominal_kinematics()
    assert p.table == profile_mod.TableParams()


def test_contract_only_profile_gets_documented_defaults() -> None:
    p = profile_mod.loads((VECTORS / "nominal.toml").read_text(), "nominal.toml")
    assert p.period_ms == 10.0
    assert p.limits == profile_mod.MachineLimits(**_documented_defaults("limits"))
    assert p.limits.max_points == 50_000_000 and isinstance(p.limits.max_points, int)
    assert [m.axis for m in p.motors] == ["U", "V", "W", "X", "Y"]
    np.testing.assert_array_equal(p.start, np.zeros(5))
    assert p.work_offsets == {}
    assert p.controller_kinematics is None
    assert p.gcode["subroutine_path"] == [] and p.gcode["user_m_codes"] == []
    assert p.gcode["max_loop_passes"] == 10_000_000


def _documented_defaults(section: str) -> dict[str, float]:
    """The defaults of a section as profiles/README.md's table states them."""
    out = {}
    readme = (ROOT / "profiles" / "README.md").read_text()
    for m in re.finditer(rf"^\| `\[{section}\] (\w+)` \| ([\d ]+) \|", readme, re.M):
        out[m.group(1)] = float(m.group(2).replace(" ", ""))
    return out


def test_documented_limits_are_every_limit() -> None:
    assert set(_documented_defaults("limits")) == set(profile_mod.DEFAULTS["limits"])


def test_documented_output_settings_are_every_setting_with_its_default() -> None:
    """profiles/README.md's table holds every dialect's `[output.<name>]` key with
    the default its Setting has (the corrected G-code's decimals once stayed 6 in
    the table after the default became 7)."""
    from prsxy_post import writers

    readme = (ROOT / "profiles" / "README.md").read_text()
    for name, d in writers.DIALECTS.items():
        rows = dict(re.findall(rf"^\| `\[output\.{name}\] (\w+)` \| ([\d.]+) \|", readme, re.M))
        keys = {k for k in rows if k in d.settings}
        assert keys == set(d.settings), name
        for key, setting in d.settings.items():
            assert float(rows[key]) == setting.default, f"[output.{name}] {key}"


def test_limits_and_interpolation_read_typed() -> None:
    """Set keys are read as numbers into the typed sections; unset ones keep the
    documented defaults."""
    p = profile_mod.loads(
        NOMINAL_TEXT
        + "\n[limits]\nmax_tilt_deg = 12.5\n[interpolation]\npath_tolerance_mm = 0.002\n",
        "t",
    )
    assert p.limits.max_tilt_deg == 12.5
    assert p.interpolation.path_tolerance_mm == 0.002
    assert p.interpolation.reversal_ms == profile_mod.DEFAULTS["interpolation"]["reversal_ms"]
    assert isinstance(p.interpolation, profile_mod.Interpolation)


def test_tools_are_typed() -> None:
    p = profile_mod.loads(
        NOMINAL_TEXT + "\n[[tools]]\nnumber = 3\nlength = 35.0\ndiameter = 6.0\n", "t"
    )
    assert p.tools[3].length == 35.0 and p.tools[3].diameter == 6.0


def test_perturbed_vectors_profile_reads(perturbed: profile_mod.Profile) -> None:
    assert [a.motor for a in perturbed.axis_comp] == [1, 2, 3, 5, 6]


def _err(text: str) -> str:
    """The error reading a profile file gives: its keys and values
    (``profile.loads``), then its struts' reach (``kinematics.check_reach``)."""
    with pytest.raises(ProfileError) as exc:
        kinematics.check_reach(profile_mod.loads(text, "bad.toml"))
    return str(exc.value)


def test_a_profile_file_whose_struts_cannot_reach_is_refused(tmp_path: Path) -> None:
    """Reading the file (what every command does) checks the reach too."""
    bad = tmp_path / "bad.toml"
    bad.write_text(NOMINAL_TEXT.replace("strut_length = 400.0", "strut_length = 100.0", 1))
    with pytest.raises(ProfileError, match=r"legs\[1\]\.strut_length: strut 1 cannot reach"):
        files.load_profile(str(bad))


@pytest.mark.parametrize(
    ("old", "new", "expect"),
    [
        (
            "tool_length = 150.0",
            "tool_lenght = 150.0",
            "bad.toml: kinematics.tool_lenght: unknown key",
        ),
        ("tool_length = 150.0", 'tool_length = "150"', "kinematics.tool_length: is a string"),
        (
            "strut_length = 400.0\nplatform_radius = 100.0\nplatform_angle = 210.0",
            "strut_length = 100.0\nplatform_radius = 100.0\nplatform_angle = 210.0",
            "kinematics.legs[2].strut_length: strut 2 cannot reach",
        ),
        ("squareness = 0.0", "squareness = nan", "table.squareness: is nan (expected a finite"),
        ("origin = [0.0, 0.0, -150.0]", "origin = [0.0, -150.0]", "work.origin: has 2 values"),
        ("[machine]", "[limits]\nmax_tilt_deg = -1.0\n[machine]", "limits.max_tilt_deg: is -1"),
        (
            "[machine]",
            "[interpolation]\nperiod_ms = 0.0\n[machine]",
            "interpolation.period_ms: is 0",
        ),
        (
            "guide_radius = 250.0\nguide_angle = 330.0",
            "guide_angle = 330.0",
            "kinematics.legs[3].guide_radius: missing key",
        ),
        (
            "[machine]",
            "[gcode]\nsubroutine_path = [3]\n[machine]",
            "gcode.subroutine_path[0]: is 3 (expected a folder name)",
        ),
        (
            "[machine]",
            "[gcode]\nuser_m_codes = [101, 99]\n[machine]",
            "gcode.user_m_codes[1]: is 99 (expected an M code from 100 to 199)",
        ),
        ("[machine]", "[gcode]\nmax_loop_passes = -1\n[machine]", "gcode.max_loop_passes: is -1"),
    ],
)
def test_bad_profiles_name_the_key(old: str, new: str, expect: str) -> None:
    assert old in NOMINAL_TEXT
    assert expect in _err(NOMINAL_TEXT.replace(old, new, 1))


def test_missing_leg_is_named() -> None:
    i = NOMINAL_TEXT.rindex("[[kinematics.legs]]")
    j = NOMINAL_TEXT.index("[table]")
    msg = _err(NOMINAL_TEXT[:i] + NOMINAL_TEXT[j:])
    assert "kinematics.legs: has 2 legs (expected exactly three" in msg


def test_toml_syntax_error_is_located() -> None:
    msg = _err(NOMINAL_TEXT.replace("tool_length = 150.0", "tool_length = = 150.0"))
    assert msg.startswith("bad.toml:")
    assert "not valid TOML" in msg
    line = NOMINAL_TEXT.splitlines().index("tool_length = 150.0") + 1
    assert msg.startswith(f"bad.toml:{line}:")


def test_axis_comp_must_ascend() -> None:
    text = (
        NOMINAL_TEXT + "\n[[axis_comp]]\nmotor = 5\npositions = [0.0, -1.0]\n"
        "forward = [0.0, 0.0]\nreverse = [0.0, 0.0]\n"
    )
    assert "axis_comp[1].positions: is not strictly ascending" in _err(text)


def test_round_trip_through_dumps(perturbed: profile_mod.Profile) -> None:
    again = profile_mod.loads(profile_mod.dumps(perturbed.raw), "again")
    assert again.kinematics == perturbed.kinematics
    assert again.table == perturbed.table


def test_output_pmac_section() -> None:
    """[output.pmac] backlash_takeup_mm: documented default, > 0, unknown keys named."""
    text = (ROOT / "profiles" / "prsxy-nominal.toml").read_text()
    assert profile_mod.loads(text).output["pmac"]["backlash_takeup_mm"] == 0.0005
    got = profile_mod.loads(text + "\n[output.pmac]\nbacklash_takeup_mm = 0.002\n")
    assert got.output["pmac"]["backlash_takeup_mm"] == 0.002
    with pytest.raises(
        ProfileError,
        match=r"output.pmac.backlash_takeup_mm: is 0 \(expected a number in \[1e-09, 1",
    ):
        profile_mod.loads(text + "\n[output.pmac]\nbacklash_takeup_mm = 0\n", "x.toml")
    with pytest.raises(ProfileError, match=r"output.pmac.takeup: unknown key"):
        profile_mod.loads(text + "\n[output.pmac]\ntakeup = 1\n", "x.toml")


PROFILE_FILES = sorted((ROOT / "profiles").glob("*.toml")) + sorted(VECTORS.glob("*.toml"))


def test_a_profile_text_is_parsed_once_and_each_load_gets_its_own_profile(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A batch loads the same profile for every program: its TOML is parsed once
    per text (a changed text again, the last PARSED_KEEP kept), and every load
    still validates into a profile of its own, equal to one made from a fresh
    parse, whose document is its own copy: the parse kept for the next load is
    the text's, whatever was done with the profiles made from it."""
    import tomllib

    monkeypatch.setattr(profile_mod, "_PARSED", {})
    parses: list[str] = []
    parse = tomllib.loads

    def counted(text: str) -> dict:  # type: ignore[type-arg]
        parses.append(text)
        return parse(text)

    monkeypatch.setattr(profile_mod.tomllib, "loads", counted)
    texts = [p.read_text() for p in PROFILE_FILES]
    first = [profile_mod.loads(t, str(p)) for t, p in zip(texts, PROFILE_FILES, strict=True)]
    first[0].raw["kinematics"]["tool_length"] = -1.0  # what a caller may do with its own
    again = [profile_mod.loads(t, str(p)) for t, p in zip(texts, PROFILE_FILES, strict=True)]
    assert parses == texts
    for a, b, text in zip(first, again, texts, strict=True):
        assert a is not b and a.raw is not b.raw
        assert b.raw == parse(text)
        assert b.kinematics == profile_mod.profile_from_dict(parse(text)).kinematics
        assert repr(b) == repr(a)
    edited = texts[0].replace("tool_length = 150.0", "tool_length = 151.0", 1)
    assert edited != texts[0]
    assert profile_mod.loads(edited).kinematics.tool_length == 151.0
    assert parses[-1] == edited
    assert len(profile_mod._PARSED) <= profile_mod.PARSED_KEEP
