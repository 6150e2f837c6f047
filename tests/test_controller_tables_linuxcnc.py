"""LinuxCNC comp files: loaded and applied as LinuxCNC does, they make the axis exact.

The loader below is LinuxCNC's, transcribed from its source (LinuxCNC/linuxcnc,
master):

- ``usrmotLoadComp`` (src/emc/motion/usrmotintf.cc): ``fgets`` each line,
  ``sscanf(buffer, "%lf %lf %lf", ...)``; the first line that does not give three
  numbers ends the loading. Type 0 rows are ``nominal forward reverse`` and become
  trims ``nominal − forward``, ``nominal − reverse``; type 1 rows are the trims.
- ``EMCMOT_SET_JOINT_COMP`` (src/emc/motion/command.c): a row is refused when the
  table already has ``EMCMOT_COMP_SIZE`` (256, motion.h) entries or when its
  nominal does not exceed the last one. Trims are C ``float``. The slope to the
  previous row is stored in the previous entry. The entry before the first row
  (nominal −DBL_MAX, motion.c) takes the first row's trims with slope 0, and the
  last row keeps slope 0.
- ``compute_screw_comp`` (src/emc/motion/control.c): find the entry with
  ``nominal <= pos_cmd < next nominal`` and use
  ``trim + slope * (pos_cmd − nominal)``, the forward trim when ``vel_cmd > 0``,
  the reverse one when ``vel_cmd < 0``, the last value when ``vel_cmd == 0``.
  ``motor_pos_cmd = pos_cmd + backlash_filt``, where ``backlash_filt`` follows
  ``backlash_corr`` with a ramp and equals it at rest. The tests look at rest.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from prsxy_post import axiscomp
from prsxy_post import profile as profile_mod
from prsxy_post.cli import main
from prsxy_post.controller_tables import linuxcnc
from prsxy_post.errors import MeasurementError, ProfileError
from prsxy_post.profile import MOTORS

from . import axis_runs

_NUM = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_THREE = re.compile(rf"\s*({_NUM})\s*({_NUM})\s*({_NUM})")
DBL_MAX = np.finfo(float).max
EMCMOT_COMP_SIZE = 256


class LinuxcncJoint:
    """One joint's screw compensation as LinuxCNC loads and applies it."""

    def __init__(self, text: str, comp_file_type: int) -> None:
        nominal: list[float] = []
        fwd: list[np.float32] = []
        rev: list[np.float32] = []
        for line in text.splitlines(keepends=True):  # fgets
            m = _THREE.match(line)  # sscanf "%lf %lf %lf" == 3
            if not m:
                break
            nom, a, b = (float(x) for x in m.groups())
            f_trim, r_trim = (nom - a, nom - b) if comp_file_type == 0 else (a, b)
            if len(nominal) >= EMCMOT_COMP_SIZE:  # "too many compensation entries"
                continue
            if nominal and nom <= nominal[-1]:  # "compensation values must increase"
                continue
            nominal.append(nom)
            fwd.append(np.float32(f_trim))
            rev.append(np.float32(r_trim))
        self.entries = len(nominal)
        self.nominal = np.array(nominal)
        self.fwd = np.array(fwd, dtype=np.float32)
        self.rev = np.array(rev, dtype=np.float32)
        # slopes stored in the entry before, last real entry keeps 0 (command.c)
        d = np.diff(self.nominal)
        self.fwd_slope = np.append((np.diff(self.fwd) / d).astype(np.float32), np.float32(0))
        self.rev_slope = np.append((np.diff(self.rev) / d).astype(np.float32), np.float32(0))

    def _trim(self, pos: float, forward: bool) -> float:
        if self.entries == 0:  # no comp data: +/- BACKLASH/2, BACKLASH = 0 here
            return 0.0
        i = int(np.searchsorted(self.nominal, pos, side="right")) - 1  # the two while loops
        trims, slopes = (self.fwd, self.fwd_slope) if forward else (self.rev, self.rev_slope)
        if i < 0:  # the −DBL_MAX entry: first trims, slope 0
            return float(trims[0])
        return float(trims[i]) + float(slopes[i]) * (pos - self.nominal[i])

    def motor_positions(self, pos_cmd: np.ndarray) -> np.ndarray:
        """motor_pos_cmd at rest-settled backlash_filt for each servo sample."""
        corr = 0.0  # backlash_corr starts at 0 (motion.c)
        out = np.empty_like(pos_cmd)
        prev = pos_cmd[0]
        for k, pos in enumerate(pos_cmd):
            vel = pos - prev
            if vel > 0:
                corr = self._trim(pos, True)
            elif vel < 0:
                corr = self._trim(pos, False)
            out[k] = pos + corr
            prev = pos
        return out


def _worst(prof: profile_mod.Profile, texts: dict[int, str], file_type: int, seed: int) -> float:
    rng = np.random.default_rng(seed)
    worst = 0.0
    for m in MOTORS:
        joint = LinuxcncJoint(texts[m], file_type)
        r = axis_runs.residuals(
            prof, m, joint.motor_positions, axis_runs.targets(prof.motor(m), rng)
        )
        worst = max(worst, float(np.max(np.abs(r))))
    return worst


def measured_residuals(seeds: tuple[int, ...] = (0, 1, 2)) -> dict[str, float]:
    """Largest |end − target| over the machines, per COMP_FILE_TYPE [mm]."""
    out = {}
    for ft in (0, 1):
        worst = 0.0
        for s in seeds:
            prof = axis_runs.machine(s, varying_backlash=bool(s % 2))
            exp = linuxcnc.export(prof, ft)
            worst = max(worst, _worst(prof, {f.motor: f.text for f in exp.files}, ft, s))
        out[f"linuxcnc COMP_FILE_TYPE {ft}"] = worst
    return out


@pytest.mark.parametrize("file_type", [0, 1])
@pytest.mark.parametrize("seed", [0, 1])
def test_exported_files_make_every_joint_exact(file_type: int, seed: int) -> None:
    prof = axis_runs.machine(seed, varying_backlash=seed == 1)
    exp = linuxcnc.export(prof, file_type)
    texts = {f.motor: f.text for f in exp.files}
    for f, comp in zip(exp.files, prof.axis_comp, strict=True):
        assert LinuxcncJoint(f.text, file_type).entries == len(comp.positions) == f.rows
    assert _worst(prof, texts, file_type, seed) < 0.5e-3


def test_without_compensation_the_same_check_fails() -> None:
    """The check can fail: an empty table leaves the real error (µm)."""
    prof = axis_runs.machine(0)
    assert _worst(prof, dict.fromkeys(MOTORS, ""), 1, 0) > 2e-3


def _steep_start(seed: int) -> profile_mod.Profile:
    """A machine whose tables change by 10 µm over their first 10 mm."""
    prof = axis_runs.machine(seed)
    doc = dict(prof.raw)
    doc["axis_comp"] = [dict(t) for t in doc["axis_comp"]]
    for t in doc["axis_comp"]:
        t["forward"] = [t["forward"][0] + 0.01, *t["forward"][1:]]
        t["reverse"] = [t["reverse"][0] + 0.01, *t["reverse"][1:]]
    return profile_mod.profile_from_dict(doc, "steep start")


@pytest.mark.parametrize("file_type", [0, 1])
def test_a_file_that_loses_its_first_row_fails(file_type: int) -> None:
    prof = _steep_start(3)
    exp = linuxcnc.export(prof, file_type)
    texts = {f.motor: f.text for f in exp.files}
    assert _worst(prof, texts, file_type, 3) < 0.5e-3
    cut = {m: t.split("\n", 1)[1] for m, t in texts.items()}
    assert _worst(prof, cut, file_type, 3) > 0.5e-3


def test_a_header_line_would_load_nothing() -> None:
    """The old export began with a comment: LinuxCNC's loader stops there."""
    prof = axis_runs.machine(0)
    f = linuxcnc.export(prof, 1).files[0]
    assert LinuxcncJoint("# motor 1\n" + f.text, 1).entries == 0
    assert LinuxcncJoint(f.text, 1).entries == len(prof.axis_comp[0].positions)


def test_type_1_holds_corrections_not_errors() -> None:
    """LinuxCNC adds the trim (forward_trim = nominal − forward): a trim is minus the
    error, so writing the error (the old export) doubles it."""
    prof = axis_runs.machine(0)
    f = linuxcnc.export(prof, 1).files[0]
    comp = prof.axis_comp[0]
    rows = np.array(
        [[float(x) for x in line.split()] for line in f.text.splitlines()[: len(comp.positions)]]
    )
    np.testing.assert_allclose(rows[:, 1], -comp.forward, atol=1e-6)
    doubled = "".join(
        f"{p} {e} {r}\n" for p, e, r in zip(comp.positions, comp.forward, comp.reverse, strict=True)
    )
    r = axis_runs.residuals(
        prof, comp.motor, LinuxcncJoint(doubled, 1).motor_positions, np.array([0.0, 50.0])
    )
    assert np.max(np.abs(r)) > 1e-3


def test_rows_beyond_256_are_resampled_with_the_error_stated() -> None:
    prof = axis_runs.machine(0)
    doc = dict(prof.raw)
    dense = np.linspace(-200, 200, 401)
    t0 = prof.axis_comp[0]
    doc["axis_comp"] = [
        {
            "motor": 1,
            "positions": dense.tolist(),
            "forward": np.interp(dense, t0.positions, t0.forward).tolist(),
            "reverse": np.interp(dense, t0.positions, t0.reverse).tolist(),
        }
    ]
    p2 = profile_mod.profile_from_dict(doc, "dense")
    f = linuxcnc.export(p2, 1).files[0]
    assert f.rows == 256 and f.resampled_from == 401
    joint = LinuxcncJoint(f.text, 1)
    assert joint.entries == 256
    r = axis_runs.residuals(
        p2, 1, joint.motor_positions, axis_runs.targets(p2.motor(1), np.random.default_rng(0))
    )
    assert np.max(np.abs(r)) <= f.interp_error_mm + 1e-6
    assert f"{f.interp_error_mm * 1e3:.4f} um" in f.text
    # a table too rough for 256 rows is refused, naming it
    doc["axis_comp"][0]["forward"] = (
        np.interp(dense, t0.positions, t0.forward) + 0.002 * (np.arange(401) % 2)
    ).tolist()
    with pytest.raises(
        ProfileError, match=r"axis_comp\[motor=1\]: has 401 rows; LinuxCNC holds 256"
    ):
        linuxcnc.export(profile_mod.profile_from_dict(doc, "rough"), 1)


@pytest.mark.parametrize("file_type", [0, 1])
def test_import_reads_back_what_export_writes(file_type: int) -> None:
    prof = axis_runs.machine(1, varying_backlash=True)
    for f in linuxcnc.export(prof, file_type).files:
        assert linuxcnc.motor_named_in(f.text) == f.motor
        back = linuxcnc.read_comp(f.text, f.name, file_type=file_type, motor=f.motor)
        orig = next(c for c in prof.axis_comp if c.motor == f.motor)
        a, b = axiscomp.MotorTable.from_comp(orig), axiscomp.MotorTable.from_comp(back)
        x = np.linspace(-300, 300, 2001)
        np.testing.assert_allclose(b.lo(x), a.lo(x), atol=2e-7)
        np.testing.assert_allclose(b.hi(x), a.hi(x), atol=2e-7)


def test_ini_snippet_names_each_joint() -> None:
    prof = axis_runs.machine(0)
    exp = linuxcnc.export(prof, 1)
    got = linuxcnc.read_ini(exp.ini, exp.ini_name)
    assert got == {f"motor{m}.comp": (m, 1) for m in MOTORS}
    assert "[JOINT_3]\nCOMP_FILE = motor5.comp\nCOMP_FILE_TYPE = 1" in exp.ini


def test_unreadable_files_are_located() -> None:
    with pytest.raises(MeasurementError, match=r"x.comp:3: nominal position does not increase"):
        linuxcnc.read_comp("0 0 0\n1 1 1\n0.5 0 0\n", "x.comp", file_type=0, motor=5)
    with pytest.raises(MeasurementError, match=r"x.comp:1: LinuxCNC reads 0 rows"):
        linuxcnc.read_comp("# motor 5\n0 0 0\n1 0 0\n", "x.comp", file_type=1, motor=5)
    with pytest.raises(MeasurementError, match=r"j.ini:3: COMP_FILE_TYPE = 2"):
        linuxcnc.read_ini("[JOINT_3]\nCOMP_FILE = a.comp\nCOMP_FILE_TYPE = 2\n", "j.ini")


def _write_profile(tmp: Path, prof: profile_mod.Profile) -> Path:
    path = tmp / "machine.toml"
    path.write_text(profile_mod.dumps(prof.raw))
    return path


def test_cli_export_then_import_finds_the_motor(tmp_path: Path) -> None:
    prof = axis_runs.machine(2)
    src = _write_profile(tmp_path, prof)
    out = tmp_path / "lc"
    r = CliRunner().invoke(
        main,
        ["tables", "export", "--profile", str(src), "--format", "linuxcnc1", "--out-dir", str(out)],
    )
    assert r.exit_code == 0, r.output
    assert "motor 5 (joint 3): 51 rows" in r.output
    assert (out / "linuxcnc-comp.ini").exists()
    empty = tmp_path / "empty.toml"
    doc = dict(prof.raw)
    doc.pop("axis_comp")
    empty.write_text(profile_mod.dumps(doc))
    # the motor from the file's notes
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "import",
            str(out / "motor5.comp"),
            "--profile",
            str(empty),
            "--format",
            "linuxcnc1",
            "-o",
            str(tmp_path / "a.toml"),
        ],
    )
    assert r.exit_code == 0, r.output
    got = profile_mod.loads((tmp_path / "a.toml").read_text(), "a.toml")
    assert [c.motor for c in got.axis_comp] == [5]
    # the motor from the INI snippet, for a file without notes
    bare = tmp_path / "bare" / "motor5.comp"
    bare.parent.mkdir()
    bare.write_text(
        "".join(
            line + "\n"
            for line in (out / "motor5.comp").read_text().splitlines()
            if not line.startswith("#")
        )
    )
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "import",
            str(bare),
            "--profile",
            str(empty),
            "--format",
            "linuxcnc1",
            "--ini",
            str(out / "linuxcnc-comp.ini"),
            "-o",
            str(tmp_path / "b.toml"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert [
        c.motor for c in profile_mod.loads((tmp_path / "b.toml").read_text(), "b").axis_comp
    ] == [5]
    # neither: a usage error saying how to give it
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "import",
            str(bare),
            "--profile",
            str(empty),
            "--format",
            "linuxcnc1",
            "-o",
            str(tmp_path / "c.toml"),
        ],
    )
    assert r.exit_code == 2 and "--motor or --ini" in r.output
    # --motor disagreeing with the file is an error, not a silent choice
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "import",
            str(out / "motor5.comp"),
            "--profile",
            str(empty),
            "--format",
            "linuxcnc1",
            "--motor",
            "6",
            "-o",
            str(tmp_path / "d.toml"),
        ],
    )
    assert r.exit_code == 2 and "motor 5" in r.output
    # the INI's COMP_FILE_TYPE must match --format
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "import",
            str(bare),
            "--profile",
            str(empty),
            "--format",
            "linuxcnc0",
            "--ini",
            str(out / "linuxcnc-comp.ini"),
            "-o",
            str(tmp_path / "e.toml"),
        ],
    )
    assert r.exit_code == 2 and "COMP_FILE_TYPE = 1" in r.output
