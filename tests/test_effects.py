"""The effects registry: one place per effect, and every user of it agreeing."""

from __future__ import annotations

import importlib
import re

import numpy as np
import pytest

from prsxy_post import chain, diagnose, effects, simulate
from prsxy_post import profile as profile_mod
from prsxy_post.errors import ProfileError

from .conftest import ROOT


def _resolve(dotted: str) -> object:
    """``module.attr.attr`` inside the package, or an AssertionError naming it."""
    parts = dotted.split(".")
    obj: object = importlib.import_module(f"prsxy_post.{parts[0]}")
    for p in parts[1:]:
        obj = getattr(obj, p)
    return obj


@pytest.mark.parametrize("fam", effects.FAMILIES, ids=lambda f: f.key)
def test_every_family_names_real_functions_and_says_everything(fam: effects.Family) -> None:
    assert callable(_resolve(fam.simulated_by)), fam.simulated_by
    assert callable(_resolve(fam.compensated_by)), fam.compensated_by
    assert fam.unit and fam.prior > 0 and fam.home and fam.pattern
    assert fam.members(), fam.key
    for name in fam.members():
        assert effects.family(name) is fam
        s = fam.sentence(name, fam.prior, 10.0)
        assert s.endswith(".") and len(s) > 20


def test_member_names_are_unique_and_the_contract_is_the_calibration_order() -> None:
    names = effects.members()
    assert len(names) == len(set(names))
    assert len(effects.CONTRACT) == 36
    assert effects.GEOMETRY[:36] == effects.CONTRACT
    with pytest.raises(KeyError, match="unknown effect 'backlash\\[4\\]'"):
        effects.family("backlash[4]")


@pytest.mark.parametrize("name", effects.members(), ids=str)
def test_writing_a_member_moves_exactly_that_member(
    nominal: profile_mod.Profile, name: str
) -> None:
    """Each family writes its size at its profile home and reads it back: a
    geometry member's value moves by the change and nothing else does; a motor
    member adds its term (backlash to the tables, a cyclic entry, a lag)."""
    fam = effects.family(name)
    ch = fam.random_change(name, np.random.default_rng(1))
    assert 0.5 * fam.prior <= abs(ch.delta) <= 2.0 * fam.prior
    prof = simulate.plant(nominal, [ch])
    if fam.stage == "geometry":
        before = effects.theta_of(nominal, effects.GEOMETRY)
        after = effects.theta_of(prof, effects.GEOMETRY)
        expect = before.copy()
        expect[effects.GEOMETRY.index(name)] += ch.delta
        np.testing.assert_allclose(after, expect, rtol=0, atol=1e-12)
    elif fam.key == "backlash":
        m = int(name[9:-1])
        t = next(c for c in prof.axis_comp if c.motor == m)
        np.testing.assert_allclose(t.reverse - t.forward, ch.delta)
    elif fam.key == "cyclic":
        (c,) = prof.effects.cyclic
        assert (c.motor, c.amplitude, c.period) == (int(name[7:-1]), ch.delta, ch.period)
    else:
        lag = prof.effects.servo_lag_ms
        assert lag[effects.MOTOR_INDEX[int(name[10:-1])]] == ch.delta
        assert sum(abs(v) for v in lag) == abs(ch.delta)


def test_the_effects_section_is_read_by_the_families(tmp_path) -> None:
    text = (ROOT / "profiles/prsxy-nominal.toml").read_text()
    good = text + (
        "\n[effects]\nguide_bow = [0.01, 0.0, -0.02]\nservo_lag_ms = [0, 0, 0, 1.5, 0]\n"
        "[[effects.cyclic]]\nmotor = 5\namplitude = 0.003\nperiod = 10.0\n"
    )
    p = profile_mod.loads(good, "g.toml")
    assert p.effects.guide_bow == (0.01, 0.0, -0.02)
    assert p.effects.servo_lag_ms[3] == 1.5
    assert p.effects.cyclic[0].period == 10.0
    for bad, key in (
        ("[effects]\nguide_bow = [2.0, 0, 0]\n", "effects.guide_bow"),
        ("[effects]\nservo_lag_ms = [0, 0, 0]\n", "effects.servo_lag_ms"),
        ("[effects]\nwobble = 1\n", "effects.wobble"),
        ("[[effects.cyclic]]\nmotor = 4\namplitude = 0.001\nperiod = 5\n", "motor"),
    ):
        with pytest.raises(ProfileError, match=re.escape(key)):
            profile_mod.loads(text + "\n" + bad, "b.toml")


def test_the_chains_servo_lead_makes_the_simulated_motor_reach_its_position(
    nominal: profile_mod.Profile,
) -> None:
    """The conversion's lead (:func:`chain.servo_lead`, c = M + τ M' with the planned
    velocity M') and the simulator's follow (m = c − τ v(m), v by central
    differences over the 10 ms points) are one model: commands led by τ M' reach
    the wanted positions within the central difference's error, τ M' ω² h² / 6
    (0.05 µm here), away from the ends (the follow starts and ends at rest, this
    motion does not)."""
    prof = simulate.plant(nominal, [effects.Change("servo_lag[5]", 2.0)])
    t = np.arange(0, 2.0, 0.01)
    zero = np.zeros((len(t), 3))
    M = np.column_stack([zero, 50 * np.sin(3 * t), 20 * np.cos(2 * t)])
    V = np.column_stack([zero, 150 * np.cos(3 * t), -40 * np.sin(2 * t)])
    c = chain.servo_lead(M, V, effects.SERVO_LAG.lags_s(prof))
    assert np.max(np.abs(c[:, 3] - M[:, 3])) > 0.1  # 2 ms at 150 mm/s
    np.testing.assert_array_equal(c[:, 4], M[:, 4])  # no lag on motor 6
    inside = slice(10, -10)
    np.testing.assert_allclose(
        effects.SERVO_LAG.follow(prof, c, t)[inside], M[inside], atol=5e-5, rtol=0
    )


def test_no_module_dispatches_on_effect_names() -> None:
    """Adding an effect is one registry entry: nothing else parses member names."""
    pat = re.compile(r"startswith\(\"(backlash|cyclic|servo_lag|effects\.|kinematics\.legs)")
    offenders = [
        str(p.relative_to(ROOT))
        for p in (ROOT / "prsxy_post").rglob("*.py")
        if p.name != "effects.py" and pat.search(p.read_text())
    ]
    assert offenders == []


def test_diagnose_units_and_priors_come_from_the_registry() -> None:
    e = diagnose.Effect("table.squareness", 1e-4, 1e-6, effects.unit("table.squareness"))
    assert e.unit == "rad"
    assert "out of square by +0.1000 mm/m" in e.sentence()
    from prsxy_post import calibrate

    assert calibrate.PRIOR[calibrate.PARAMS.index("table.squareness")] == effects.prior(
        "table.squareness"
    )


def test_play_below_zero_folds_back_so_backlash_is_bounded(
    nominal: profile_mod.Profile,
) -> None:
    """A change of −δ to a motor without play gives the same machine as +δ (a
    table's play is |reverse − forward|): the model folds at zero play, where the
    signature −direction/2 changes sign. The bound is minus the least play the
    motor's table holds, 0 without a table."""
    from prsxy_post import axiscomp

    assert effects.lower_bound("backlash[2]", nominal) == 0.0
    plus = simulate.plant(nominal, [effects.Change("backlash[2]", 0.004)])
    minus = simulate.plant(nominal, [effects.Change("backlash[2]", -0.004)])
    p = np.linspace(-50, 50, 11)
    for side in (1, -1):
        np.testing.assert_allclose(
            axiscomp.approach(axiscomp.profile_tables(minus)[2], p, side),
            axiscomp.approach(axiscomp.profile_tables(plus)[2], p, side),
            atol=1e-12,
        )
    assert effects.lower_bound("backlash[2]", plus) == pytest.approx(-0.004)
    assert effects.lower_bound("kinematics.tool_length", plus) == -np.inf


def test_a_table_measured_with_a_cyclic_error_holds_it_at_its_points(
    nominal: profile_mod.Profile,
) -> None:
    """Laser targets 20 mm apart on a motor with a 16 mm cyclic error: the table
    made from them holds the error at the targets and interpolates between them
    (an 80 mm alias). Adding the cyclic term to such a table takes out what the
    table held (as making the table again without it would), so at the targets
    nothing changes; between them the change is the error less its interpolation,
    and the term's signature is that, per unit of its sine and cosine parts."""
    from prsxy_post import axiscomp

    pts = np.arange(-200.0, 201.0, 20.0)
    doc = dict(nominal.raw)
    doc["axis_comp"] = [
        {"motor": 5, "positions": pts.tolist(), "forward": [0.0] * 21, "reverse": [0.0] * 21}
    ]
    prof = profile_mod.profile_from_dict(doc, "t.toml")
    ch = effects.Change("cyclic[5]", 0.003, 16.0, 30.0)
    new = profile_mod.profile_from_dict(effects.apply(prof.raw, prof, [ch], {5}), "n.toml")
    table = axiscomp.profile_tables(new)[5]
    p = np.linspace(-190.0, 190.0, 777)
    err = 0.003 * np.sin(2 * np.pi * p / 16.0 + np.radians(30.0))
    held = np.interp(p, pts, 0.003 * np.sin(2 * np.pi * pts / 16.0 + np.radians(30.0)))
    for side in (1, -1):
        np.testing.assert_allclose(axiscomp.approach(table, pts, side), pts, atol=1e-12)
        np.testing.assert_allclose(axiscomp.approach(table, p, side) - p, err - held, atol=1e-12)
    # the profile's own table (not measured so) keeps what it holds: the term adds all
    plain = profile_mod.profile_from_dict(effects.apply(prof.raw, prof, [ch]), "p.toml")
    np.testing.assert_allclose(
        axiscomp.approach(axiscomp.profile_tables(plain)[5], p, 1) - p, err, atol=1e-12
    )
    fam = effects.family("cyclic[5]")
    assert isinstance(fam, effects.MotorFamily)
    ctx = effects.MotorContext(p, table, 1, pts)
    sig = fam.motor_term(p, np.ones_like(p), np.zeros_like(p), 16.0, ctx)
    ph = np.radians(30.0)  # amplitude · sin(θ + φ) = a cos φ · sin θ + a sin φ · cos θ
    np.testing.assert_allclose(
        sig @ [0.003 * np.cos(ph), 0.003 * np.sin(ph)], err - held, atol=1e-12
    )
