"""The embedded route's kinematic programs, run in a third-party Turbo PMAC
kinematics emulator against the project's own kinematics.

pmacparser 0.4 (Diamond Light Source) runs a kinematic program's statements: Q, P,
I and M assignments, IF/ELSE/ENDIF, WHILE/ENDWHILE, and the functions ABS, EXP,
INT, LN, SIN, COS, TAN, ASIN, ACOS, ATAN, ATAN2, SQRT, in degrees while I15 = 0
and with ATAN2's cosine argument taken from Q0, as the Turbo PMAC Software
Reference has them. It does not read the download lines around a program (CLOSE,
&1, #n->I, OPEN FORWARD, M-variable definitions) nor numbers with an exponent,
and a variable with a computed number (``Q(expr)``) reads a different key than the
plain one; the programs keep to the subset both share (plain decimals, no indirect
variables), and the tests hand the emulator each buffer's body, from the line
after CLEAR to the buffer's CLOSE, with the variables the controller would have
set before running it: I15 as the file sets it, the axis positions Q1, Q2, Q7-Q9
(inverse; Software Reference, Isx50 and #{constant}->I) or the motor positions
in counts P1-P3, P5, P6 (forward; Software Reference, OPEN FORWARD), Q100 (the
tool length offset) and the run-time error bit M5182 clear. The emulator works in
doubles; Turbo PMAC's 36-bit mantissa would add about 1e-11 relative.
"""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import numpy as np
import pytest
from pmacparser.pmac_parser import PMACParser

from prsxy_post import chain, errormap, kinematics, simulate
from prsxy_post import profile as profile_mod
from prsxy_post.profile import MOTORS
from prsxy_post.writers import pmac_kinematics as pk

ROOT = Path(__file__).resolve().parent.parent
NOMINAL = profile_mod.loads((ROOT / "profiles" / "prsxy-shop.toml").read_text(), "shop")
COUNT_TOL = 0.01
UM_TOL = 0.01
ARCSEC_TOL = 0.01
# map coordinates in the order x, y, z, A, B, as the Q-variables carry them
Q_OF = ("Q7", "Q8", "Q9", "Q1", "Q2")


def random_map(rng: np.random.Generator) -> dict:
    """An [error_map] of the size calibration fits: micrometres and arcseconds,
    both structures, degrees 2 to 4, over part of the travel (the poses below go
    outside it, where the map holds its edge)."""
    lo = np.array([-80.0, -80.0, -30.0, -20.0, -20.0])
    hi = np.array([80.0, 80.0, 10.0, 20.0, 20.0])
    comps = {}
    for c, st, deg in (("x", "eq5-coupled", 3), ("y", "eq5", 4), ("z", "eq5-coupled", 2),
                       ("a", "eq5", 3), ("b", "eq5", 2)):  # fmt: skip
        X, _ = errormap.design(np.zeros((1, 5)), c, deg, lo, hi, st)
        size = 0.004 if c in "xyz" else 8.0 / 3600.0
        comps[c] = {
            "structure": st,
            "degree": deg,
            "coef": (rng.normal(0.0, size, X.shape[1])).tolist(),
        }
    return {"model": "legendre-eq5", "lo": lo.tolist(), "hi": hi.tolist(), "components": comps}


def fitted_map(rng: np.random.Generator) -> dict:
    """An [error_map] as calibration writes it: fitted (errormap.fit, its
    cross-validated structure, degree and ridge) to smooth errors of a few µm and
    arcsec measured with noise at 300 poses."""
    q = poses(rng, 300)
    u = q / np.array([120.0, 120.0, 35.0, 25.0, 25.0])
    err = np.column_stack(
        [
            0.003 * u[:, 0] * u[:, 1] + 0.002 * u[:, 3] ** 2,
            -0.002 * u[:, 0] ** 2 + 0.003 * u[:, 2] * u[:, 4],
            0.004 * u[:, 2] ** 3,
            (5.0 * u[:, 3] * u[:, 2]) / 3600.0,
            (4.0 * u[:, 4] ** 2) / 3600.0,
        ]
    ) + rng.normal(0.0, 2e-4, (300, 5)) * np.array([1, 1, 1, 1 / 3600, 1 / 3600])
    return errormap.fit(q, err, rng=rng).to_dict()


def calibrated(seed: int, fitted: bool = False) -> profile_mod.Profile:
    """A machine with every contract term off, bowed guides, curved table axes and a
    virtual-axis map (of random coefficients, or ``fitted`` as calibration fits it)."""
    rng = np.random.default_rng(seed)
    prof = simulate.random_machine(NOMINAL, rng, effects=True, name=f"calibrated {seed}")
    emap = fitted_map(rng) if fitted else random_map(rng)
    return profile_mod.profile_from_dict(dict(prof.raw, error_map=emap))


def buffer(text: str, name: str) -> list[str]:
    """The statements of ``OPEN <name>`` (after its CLEAR, up to its CLOSE)."""
    m = re.search(rf"^OPEN {name}\nCLEAR\n(.*?)\nCLOSE$", text, re.S | re.M)
    assert m, name
    return m.group(1).splitlines()


def i15(text: str) -> float:
    return float(re.search(r"^I15=(\d+)$", text, re.M).group(1))  # type: ignore[union-attr]


def poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """Random tool poses over the travel (and beyond the map's domain)."""
    return np.column_stack(
        [
            rng.uniform(-120, 120, n),
            rng.uniform(-120, 120, n),
            rng.uniform(-45, 25, n),
            rng.uniform(-25, 25, n),
            rng.uniform(-25, 25, n),
        ]
    )


def project_motors(prof: profile_mod.Profile, q: np.ndarray, tlo: float = 0.0) -> np.ndarray:
    """The project's own chain for a pose: Q' = Q − e(Q) (chain.correct_virtual),
    then the calibrated IK; motor positions in counts (n, 5)."""
    geo = chain.ik_geometry(prof, chain.Stages())
    emap = errormap.from_profile(prof)
    qp = chain.correct_virtual(q, emap) if emap is not None else q
    ik = kinematics.inverse(geo, qp, tlo)
    assert np.all(ik.reachable)
    cpm = np.array([prof.motor(m).counts_per_mm for m in MOTORS])
    return ik.P * cpm


class Emulated:
    """A profile's download file with both buffers in the emulator."""

    def __init__(self, prof: profile_mod.Profile) -> None:
        self.text = pk.export(prof).text
        self.i15 = i15(self.text)
        self.inv = PMACParser(buffer(self.text, "INVERSE"))
        self.fwd = PMACParser(buffer(self.text, "FORWARD"))

    def inverse(self, q: np.ndarray, tlo: float = 0.0) -> tuple[np.ndarray, float]:
        given = {"I15": self.i15, "Q100": tlo, "M5182": 0.0}
        given.update({name: float(v) for name, v in zip(Q_OF, q, strict=True)})
        out = self.inv.parse(given)
        return np.array([float(out.get(f"P{m}", np.nan)) for m in MOTORS]), float(out["M5182"])

    def forward(self, counts: np.ndarray, tlo: float = 0.0) -> tuple[np.ndarray, float]:
        given = {"I15": self.i15, "Q100": tlo, "M5182": 0.0}
        given.update({f"P{m}": float(v) for m, v in zip(MOTORS, counts, strict=True)})
        out = self.fwd.parse(given)
        return np.array([float(out.get(n, np.nan)) for n in Q_OF]), float(out["M5182"])


@pytest.fixture(scope="module", params=[(21, False), (22, False), (23, True)])
def machine(request: pytest.FixtureRequest) -> tuple[profile_mod.Profile, Emulated]:
    prof = calibrated(*request.param)
    return prof, Emulated(prof)


def test_the_inverse_gives_the_project_s_motor_counts(machine) -> None:
    """OPEN INVERSE, run as PMAC runs it at a segment boundary, puts in P1-P3, P5,
    P6 the counts the project's chain (map, calibrated IK with bows and curved
    table axes) computes for the same pose: within 0.01 count."""
    prof, emu = machine
    q = poses(np.random.default_rng(3), 25)
    want = project_motors(prof, q)
    for qi, wi in zip(q, want, strict=True):
        got, flag = emu.inverse(qi)
        assert flag == 0.0
        assert np.max(np.abs(got - wi)) < COUNT_TOL, (qi, got - wi)


def test_the_inverse_takes_the_tool_length_offset_from_q100(machine) -> None:
    prof, emu = machine
    q = poses(np.random.default_rng(4), 4)
    want = project_motors(prof, q, 35.0)
    for qi, wi in zip(q, want, strict=True):
        got, flag = emu.inverse(qi, 35.0)
        assert flag == 0.0 and np.max(np.abs(got - wi)) < COUNT_TOL


def test_the_forward_takes_the_tool_length_offset_from_q100(machine) -> None:
    """PMATCH after a tool change: with Q100 = 35 the forward gives back the pose
    of the longer tool's tip."""
    prof, emu = machine
    q = poses(np.random.default_rng(7), 3)
    for qi, ci in zip(q, project_motors(prof, q, 35.0), strict=True):
        got, flag = emu.forward(ci, 35.0)
        assert flag == 0.0
        assert np.max(np.abs(got[:3] - qi[:3])) * 1000 < UM_TOL
        assert np.max(np.abs(got[3:] - qi[3:])) * 3600 < ARCSEC_TOL


def test_the_forward_gives_back_the_pose(machine) -> None:
    """OPEN FORWARD, run as PMAC runs it at R or PMATCH on the motors' counts,
    puts in Q7-Q9, Q1, Q2 the pose whose compensated motors those are: within
    0.01 µm and 0.01 arcsec, without setting the error bit."""
    prof, emu = machine
    q = poses(np.random.default_rng(5), 12)
    counts = project_motors(prof, q)
    for qi, ci in zip(q, counts, strict=True):
        got, flag = emu.forward(ci)
        assert flag == 0.0
        assert np.max(np.abs(got[:3] - qi[:3])) * 1000 < UM_TOL, (qi, got - qi)
        assert np.max(np.abs(got[3:] - qi[3:])) * 3600 < ARCSEC_TOL, (qi, got - qi)


def test_the_map_is_in_the_inverse() -> None:
    """Without its map the same machine's inverse differs by the map's correction:
    the map is not a no-op in the emulated program (the counts move by more than
    the tolerance)."""
    prof = calibrated(21)
    bare = profile_mod.profile_from_dict({k: v for k, v in prof.raw.items() if k != "error_map"})
    q = poses(np.random.default_rng(6), 3)
    a = np.array([Emulated(prof).inverse(x)[0] for x in q])
    b = np.array([Emulated(bare).inverse(x)[0] for x in q])
    assert np.max(np.abs(a - b)) > 100 * COUNT_TOL
    np.testing.assert_allclose(b, project_motors(bare, q), atol=COUNT_TOL, rtol=0)


def _forward_of(geo: kinematics.Geometry) -> PMACParser:
    return PMACParser(pk.forward_program(geo, None, [1000.0] * 5).lines)


def test_a_forward_that_cannot_converge_sets_the_run_time_error_bit() -> None:
    """A geometry whose struts are shorter than the gap between guide and platform
    radius (100 < 150 mm; the profile check refuses it at the start pose, so the
    geometry is built here directly): no platform pose meets any motors, the fixed
    Newton steps end with a residual, and the program sets M5182 (User Manual,
    Iterative Solutions: stop the program) and leaves the axis positions alone.
    On the profile as designed the bit stays clear and the home pose comes back."""
    kp = NOMINAL.kinematics
    short = dataclasses.replace(
        kp, legs=tuple(dataclasses.replace(leg, strut_length=100.0) for leg in kp.legs)
    )
    geo = kinematics.Geometry.from_params(short, NOMINAL.origin)
    given = {"I15": 0.0, "Q100": 0.0, "M5182": 0.0, "P1": 0.0, "P2": 0.0, "P3": 0.0}
    out = _forward_of(geo).parse(dict(given, P5=0.0, P6=0.0))
    assert float(out["M5182"]) == 1.0
    assert not any(n in out for n in Q_OF)
    out = _forward_of(kinematics.Geometry.from_params(kp, NOMINAL.origin)).parse(
        dict(given, P5=0.0, P6=0.0)
    )
    assert float(out["M5182"]) == 0.0
    np.testing.assert_allclose([float(out[n]) for n in Q_OF], 0.0, atol=1e-9)


def test_motors_no_pose_meets_set_the_error_bit_in_the_forward() -> None:
    """On a valid profile, head motors 300 mm apart: no pose, the bit is set."""
    emu = Emulated(NOMINAL)
    counts = np.array([300.0, -300.0, 0.0, 0.0, 0.0]) * NOMINAL.motor(1).counts_per_mm
    got, flag = emu.forward(counts)
    assert flag == 1.0 and np.all(np.isnan(got))


def test_an_unreachable_pose_sets_the_error_bit_in_the_inverse() -> None:
    """The short-strut geometry: no strut reaches, the inverse sets M5182 and
    writes no motor position (where the project's IK says unreachable too)."""
    kp = NOMINAL.kinematics
    short = dataclasses.replace(
        kp, legs=tuple(dataclasses.replace(leg, strut_length=100.0) for leg in kp.legs)
    )
    geo = kinematics.Geometry.from_params(short, NOMINAL.origin)
    assert not kinematics.inverse(geo, np.zeros((1, 5))).reachable[0]
    inv = PMACParser(pk.inverse_program(geo, None, [1000.0] * 5).lines)
    given = {"I15": 0.0, "Q100": 0.0, "M5182": 0.0}
    out = inv.parse(dict(given, **{n: 0.0 for n in Q_OF}))
    assert float(out["M5182"]) == 1.0
    assert not any(f"P{m}" in out for m in MOTORS)


def test_the_download_file_sets_up_coordinate_system_1() -> None:
    """The lines around the buffers: motors as inverse-kinematic axes, Isx13 the
    coarse period, Isx50 set after both buffers, I15 degrees, the error bit."""
    prof = calibrated(21)
    text = pk.export(prof).text
    lines = [ln for ln in text.splitlines() if not ln.startswith(";")]
    assert lines[:3] == ["CLOSE", "I15=0", "&1"]
    assert "#1->I #2->I #3->I #5->I #6->I" in lines
    assert f"I5113={prof.period_ms:g}" in lines
    assert lines[-1] == "I5150=1"
    assert lines.index("OPEN FORWARD") < lines.index("OPEN INVERSE") < lines.index("I5150=1")
    assert pk.ERROR_FLAG_DEF in lines
    assert not re.search(r"\d[eE][-+]?\d", "\n".join(lines))  # no exponents
    body = buffer(text, "INVERSE") + buffer(text, "FORWARD")
    used = {int(n) for ln in body for n in re.findall(r"Q(\d+)", ln)}
    assert used <= {0, 1, 2, 7, 8, 9, 100} | set(range(20, 1024))


def test_dls_pmacanalyse_reads_the_download_file() -> None:
    """Diamond Light Source's Turbo PMAC parser (dls-pmacanalyse) reads the whole
    file as on-line commands: its I-variables are the file's, and the forward and
    inverse buffers it stores for C.S. 1 hold the statements the emulator ran (it
    ends each buffer with the RETURN a CLOSE adds)."""
    from dls_pmacanalyse.pmacparser import PmacParser
    from dls_pmacanalyse.pmacstate import PmacState

    prof = calibrated(22)
    text = pk.export(prof).text
    state = PmacState("prsxy-post")
    PmacParser(text.splitlines(), state).onLine()
    assert float(state.getIVariable(5150).valStr()) == 1.0
    assert float(state.getIVariable(5113).valStr()) == prof.period_ms
    assert float(state.getIVariable(15).valStr()) == 0.0
    for prog, name in (
        (state.getForwardKinematicProgram(1), "FORWARD"),
        (state.getInverseKinematicProgram(1), "INVERSE"),
    ):
        read = "".join(str(t) for t in prog.v if str(t) != "\n")
        ours = re.sub(r"\s", "", "\n".join(buffer(text, name))).upper()
        assert read == ours + "RETURN", name


def test_the_kinematics_command_writes_the_file(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from prsxy_post.cli import main

    prof_path = ROOT / "profiles" / "prsxy-shop.toml"
    out = tmp_path / "kin.pmc"
    res = CliRunner().invoke(main, ["kinematics", "--profile", str(prof_path), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert out.read_text() == pk.export(NOMINAL, str(prof_path)).text
    res = CliRunner().invoke(
        main, ["kinematics", "--profile", str(tmp_path / "none.toml"), "-o", str(out)]
    )
    assert res.exit_code != 0
    assert "none.toml: cannot read profile" in res.output
    assert "Traceback" not in res.output
