"""Turbo PMAC tables: downloaded and applied as a Turbo PMAC does, they make the axis exact.

The controller below is written from the Turbo PMAC manuals (docs/turbo-pmac.md
has the pages). SRM = Turbo PMAC/PMAC2 Software Reference, TUM = Turbo PMAC User
Manual, PSR/PUM = the (non-Turbo) PMAC Software Reference / User Manual.

Download (on-line commands):
- ``#n`` addresses motor n, ``&n`` coordinate system n. ``;`` starts a comment.
- ``DEFINE COMP {entries},[#{source}[D],[#{target},]]{count length}`` creates the
  table that belongs to the addressed motor. Source and target default to that
  motor, and ``D`` makes the source the desired position (SRM pp. 302–303). It is
  refused with ERR003 if a COMP table exists for a lower-numbered motor, or if any
  BLCOMP, TBUF, ROTARY, LOOKAHEAD or GATHER buffer exists.
- ``DEFINE BLCOMP {entries},{count length}`` creates the addressed motor's backlash
  table (SRM p. 301; TUM p. 191). It is refused (ERR003) if a BLCOMP exists for a
  lower-numbered motor, or if a TBUF, ROTARY or GATHER buffer exists.
- Constants sent while a defined table is not yet full are its entries (PUM
  "Special-Use P-Variable": they would otherwise be P0 assignments).
- ``DELETE COMP``/``DELETE BLCOMP`` delete from the lowest motor up (SRM p. 303;
  deleting a table above a lower one is refused here as ERR003). ``DELETE GATHER``,
  ``DELETE ROTARY`` and ``DELETE LOOKAHEAD`` remove those buffers (SRM p. 315).

Servo loop (each servo cycle, desired position p in counts):
- With I51 = 1, each COMP table whose target is the motor adds its correction. The
  source position is rolled over into 0 … count length. The table is 0 at 0, then
  entry k at k·length/entries, linear in between. Entries are 1/16 count. (TUM
  p. 189; SRM p. 303.)
- Backlash (SRM p. 148 Ixx85/Ixx86; SRM p. 301; TUM p. 191): while the last
  commanded direction is negative, Ixx86 + BLCOMP(p) (BLCOMP with I51 = 1) is
  subtracted, and nothing while it is positive. The direction changes when the
  desired position reverses by more than the hysteresis Ixx87, taken here as
  64/16 counts: the PSR's default for its I99, since the Turbo default was not in
  the pages we had. The offset moves towards its value by Ixx85/16 counts per
  background cycle (one servo sample here). Ixx85 = 0 disables it.
- Motor zero is where homing puts it, Ixx26/16 counts from the trigger (PSR Ix26).
  The integrator applies the file's "add v to In26" notes and homes again, so
  motor zero moves by v/16 counts.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from dls_pmacanalyse.pmaclexer import PmacLexer
from dls_pmacanalyse.pmacparser import PmacParser
from dls_pmacanalyse.pmacstate import PmacState

from prsxy_post import axiscomp
from prsxy_post import profile as profile_mod
from prsxy_post.cli import main
from prsxy_post.controller_tables import pmac
from prsxy_post.errors import MeasurementError, ProfileError
from prsxy_post.profile import MOTORS

from . import axis_runs

HYSTERESIS = 64  # 1/16 count


class Err003(Exception):
    """What Turbo PMAC reports when a buffer cannot be defined or deleted now."""


@dataclass
class Table:
    entries: int
    length: int
    source: int
    target: int
    desired: bool
    values: list[int] = field(default_factory=list)

    def at(self, counts: np.ndarray) -> np.ndarray:
        """The table's value [1/16 count] at source positions [counts]."""
        s = np.mod(counts, self.length)
        grid = np.arange(self.entries + 1) * self.length / self.entries
        return np.interp(s, grid, np.concatenate([[0], self.values]))


class TurboPmac:
    """Downloads a file and applies its tables to desired positions (module docstring)."""

    def __init__(self) -> None:
        self.motor = 1
        self.cs = 1
        self.i: dict[int, int] = {51: 0}
        self.comp: dict[int, Table] = {}
        self.blcomp: dict[int, Table] = {}
        # a controller that has run before: a gather buffer, a rotary and a lookahead
        # buffer in C.S. 1, and old tables (the file must get rid of them in order)
        self.buffers = {"GATHER", "ROTARY1", "LOOKAHEAD1"}
        for m in (1, 5):
            self.comp[m] = Table(4, 4000, m, m, True, [1, 2, 3, 0])
        self.blcomp[5] = Table(4, 4000, 5, 5, True, [1, 2, 3, 0])
        self.filling: Table | None = None
        self.home_shift: dict[int, int] = {}

    # ------------------------------------------------------------ download
    def download(self, text: str) -> None:
        for raw in text.splitlines():
            note = re.search(
                r";\s*home offset:\s*motor\s+(\d+)\s+add\s+([+-]\d+)\s+to\s+I(\d+)26", raw
            )
            if note:  # the integrator's step: change Ixx26 and home again
                assert note.group(1) == note.group(3)
                self.home_shift[int(note.group(1))] = int(note.group(2))
            line = raw.split(";", 1)[0].strip().upper()
            while line:
                line = self._command(line).strip()
        assert self.filling is None or len(self.filling.values) == self.filling.entries

    def _command(self, line: str) -> str:
        if self.filling is not None and len(self.filling.values) < self.filling.entries:
            m = re.match(r"-?\d+", line)
            assert m, f"a table wants {self.filling.entries} entries, got {line!r}"
            self.filling.values.append(int(m.group()))
            return line[m.end() :]
        if m := re.match(r"#(\d+)", line):
            self.motor = int(m.group(1))
        elif m := re.match(r"&(\d+)", line):
            self.cs = int(m.group(1))
        elif m := re.match(r"CLOSE", line):
            pass
        elif m := re.match(r"I(\d+)=(-?\d+)", line):
            self.i[int(m.group(1))] = int(m.group(2))
        elif m := re.match(r"DELETE\s*(GATHER|ROTARY|LOOKAHEAD|BLCOMP|COMP)", line):
            self._delete(m.group(1))
        elif m := re.match(r"DEFINE\s*COMP\s*(\d+),(?:#(\d+)(D?),(?:#(\d+),)?)?(\d+)", line):
            if any(k < self.motor for k in self.comp) or self.blcomp or self.buffers:
                raise Err003(
                    f"DEFINE COMP for motor {self.motor}: {sorted(self.comp)} {self.buffers}"
                )
            src = int(m.group(2)) if m.group(2) else self.motor
            tgt = int(m.group(4)) if m.group(4) else self.motor
            t = Table(int(m.group(1)), int(m.group(5)), src, tgt, m.group(3) == "D")
            self.comp[self.motor] = self.filling = t
        elif m := re.match(r"DEFINE\s*BLCOMP\s*(\d+),(\d+)", line):
            if any(k < self.motor for k in self.blcomp) or self.buffers - {"LOOKAHEAD1"}:
                raise Err003(f"DEFINE BLCOMP for motor {self.motor}")
            t = Table(int(m.group(1)), int(m.group(2)), self.motor, self.motor, True)
            self.blcomp[self.motor] = self.filling = t
        else:
            raise AssertionError(f"not a command this controller knows: {line!r}")
        return line[m.end() :]

    def _delete(self, what: str) -> None:
        if what == "GATHER":
            self.buffers.discard("GATHER")
        elif what in ("ROTARY", "LOOKAHEAD"):
            self.buffers.discard(f"{what}{self.cs}")
        else:
            tables = self.comp if what == "COMP" else self.blcomp
            if self.motor in tables:
                if any(k < self.motor for k in tables):
                    raise Err003(f"DELETE {what} for motor {self.motor} above a lower one")
                del tables[self.motor]

    # ------------------------------------------------------------ servo loop
    def motor_positions(self, motor: int, cpm: float, desired_mm: np.ndarray) -> np.ndarray:
        """Contract-frame motor positions [mm] for desired positions [mm] at servo
        samples, with rest samples appended until the backlash is taken up."""
        p = np.concatenate([desired_mm, np.full(400, desired_mm[-1])]) * cpm
        comp = np.zeros_like(p)
        if self.i.get(51) == 1:
            for t in self.comp.values():
                if t.target == motor:
                    # a table without D reads the actual position: the same here,
                    # where the servo follows exactly
                    assert t.source == motor, "the tests give tables of the motor's own position"
                    comp += t.at(p)
        ixx85, ixx86 = self.i.get(motor * 100 + 85, 0), self.i.get(motor * 100 + 86, 0)
        bl_tab = self.blcomp.get(motor) if self.i.get(51) == 1 else None
        negative, turn, offset = False, p[0], 0.0
        out = np.empty_like(p)
        for k, x in enumerate(p):
            if negative and x > turn + HYSTERESIS / 16:
                negative = False
            elif not negative and x < turn - HYSTERESIS / 16:
                negative = True
            turn = min(turn, x) if negative else max(turn, x)
            want = (ixx86 + (bl_tab.at(np.array([x]))[0] if bl_tab else 0.0)) if negative else 0.0
            if ixx85 > 0:
                offset += float(np.clip(want - offset, -ixx85, ixx85))
            out[k] = x + (comp[k] - offset) / 16
        return out / cpm + self.home_shift.get(motor, 0) / 16 / cpm


def _worst(
    prof: profile_mod.Profile, text: str, seed: int, motors: tuple[int, ...] = MOTORS
) -> float:
    ctl = TurboPmac()
    ctl.download(text)
    rng = np.random.default_rng(seed)
    worst = 0.0
    for m in motors:
        cpm = prof.motor(m).counts_per_mm
        r = axis_runs.residuals(
            prof,
            m,
            lambda d, m=m, cpm=cpm: ctl.motor_positions(m, cpm, d),
            axis_runs.targets(prof.motor(m), rng),
        )
        worst = max(worst, float(np.max(np.abs(r))))
    return worst


def measured_residuals(seeds: tuple[int, ...] = (0, 1, 2)) -> dict[str, float]:
    """Largest |end − target| over the machines [mm]."""
    worst = 0.0
    for s in seeds:
        prof = axis_runs.machine(s, varying_backlash=bool(s % 2))
        worst = max(worst, _worst(prof, pmac.export(prof).text, s))
    return {"turbo pmac": worst}


@pytest.mark.parametrize("seed,varying", [(0, False), (1, True), (2, True)])
def test_downloaded_tables_make_every_motor_exact(seed: int, varying: bool) -> None:
    prof = axis_runs.machine(seed, varying_backlash=varying)
    exp = pmac.export(prof)
    ctl = TurboPmac()
    ctl.download(exp.text)
    assert ctl.i[51] == 1 and sorted(ctl.comp) == sorted(MOTORS)
    assert (sorted(ctl.blcomp) == sorted(MOTORS)) == varying
    assert _worst(prof, exp.text, seed) < 0.5e-3


def test_without_the_home_offset_the_check_fails() -> None:
    """PMAC's table is zero at motor zero; without the home-offset step the
    correction at zero is missing there and the check sees it."""
    prof = axis_runs.machine(0)
    exp = pmac.export(prof)
    assert max(abs(t.home_offset) for t in exp.motors) / 16 / 10000 > 0.5e-3
    stripped = "\n".join(line for line in exp.text.splitlines() if "home offset:" not in line)
    assert _worst(prof, stripped, 0) > 0.5e-3


def _swap_tables(text: str, a: int, b: int) -> str:
    """The DEFINE COMP blocks of motors a and b exchanged: each motor gets the other's."""
    blocks = re.split(r"(?m)^(?=#\d+ DEFINE )", text)
    ia = next(i for i, s in enumerate(blocks) if s.startswith(f"#{a} DEFINE COMP"))
    ib = next(i for i, s in enumerate(blocks) if s.startswith(f"#{b} DEFINE COMP"))

    def body(s: str) -> str:
        return s.split("\n", 1)[1]

    ha, hb = blocks[ia].split("\n", 1)[0], blocks[ib].split("\n", 1)[0]
    blocks[ia], blocks[ib] = ha + "\n" + body(blocks[ib]), hb + "\n" + body(blocks[ia])
    return "".join(blocks)


def test_a_table_of_the_wrong_motor_fails() -> None:
    prof = axis_runs.machine(0)
    exp = pmac.export(prof)
    assert _worst(prof, exp.text, 0, (5, 6)) < 0.5e-3
    assert _worst(prof, _swap_tables(exp.text, 5, 6), 0, (5, 6)) > 0.5e-3


def test_tables_addressed_to_no_motor_fail() -> None:
    """Without ``#n`` a table belongs to the motor addressed last (here #6, from the
    deletes): every motor but one is left without its table."""
    prof = axis_runs.machine(0)
    text = re.sub(
        r"(?m)^#(\d+) DEFINE COMP (\d+),#\d+D,#\d+,", r"DEFINE COMP \2,", pmac.export(prof).text
    )
    assert "#5 DEFINE" not in text
    assert _worst(prof, text, 0) > 0.5e-3


def test_tables_defined_from_the_lowest_motor_up_are_refused() -> None:
    prof = axis_runs.machine(0)
    text = pmac.export(prof).text
    blocks = re.split(r"(?m)^(?=#\d+ DEFINE COMP)", text)
    tail = blocks[-1].split("I185=", 1)
    ascending = blocks[0] + "".join(reversed([*blocks[1:-1], tail[0]])) + "I185=" + tail[1]
    with pytest.raises(Err003, match=r"DEFINE COMP for motor 2: \[1\]"):
        TurboPmac().download(ascending)


def test_backlash_needs_a_take_up_rate() -> None:
    """Ixx85 = 0 disables the backlash (SRM p. 148): approaches from above miss."""
    prof = axis_runs.machine(0)
    text = re.sub(r"I(\d)85=\d+", r"I\g<1>85=0", pmac.export(prof).text)
    assert _worst(prof, text, 0) > 0.5e-3


def test_the_file_parses_with_dls_pmacanalyse() -> None:
    """dls-pmacanalyse (Diamond Light Source) tokenises the whole file with its
    Turbo PMAC lexer, and its on-line command parser reads everything but the table
    blocks. Its parser has no DEFINE command (3.0.0 raises "Unexpected token:
    DEFINE"); the blocks are this file's controller's part. The I-variables it reads
    are the ones our controller applies."""
    prof = axis_runs.machine(1, varying_backlash=True)
    text = pmac.export(prof).text
    lexer = PmacLexer(text.splitlines())
    assert {"DEFINE", "COMP", "BLCOMP", "DELETE", "GATHER", "I"} <= {str(t) for t in lexer.tokens}
    online, in_table, need = [], 0, 0
    for line in text.splitlines():
        m = re.match(r"#\d+ DEFINE (?:BL)?COMP (\d+),", line)
        if m:
            need, in_table = int(m.group(1)), 0
            continue
        if in_table < need:
            in_table += len(line.split(";")[0].split())
            continue
        online.append(line)
    state = PmacState("prsxy")
    PmacParser(online, state).onLine()
    ctl = TurboPmac()
    ctl.download(text)
    for n in [51] + [m * 100 + k for m in MOTORS for k in (85, 86)]:
        assert float(state.getIVariable(n).valStr()) == ctl.i[n], n


def test_import_reads_back_what_export_writes() -> None:
    prof = axis_runs.machine(1, varying_backlash=True)
    exp = pmac.export(prof)
    back = {c.motor: c for c in pmac.read(exp.text, exp.name, prof)}
    for orig in prof.axis_comp:
        mc = prof.motor(orig.motor)
        a, b = axiscomp.MotorTable.from_comp(orig), axiscomp.MotorTable.from_comp(back[orig.motor])
        x = np.linspace(mc.min, mc.max, 3001)
        step = 1 / 16 / mc.counts_per_mm  # entries are whole 1/16 counts
        assert np.max(np.abs(b.lo(x) - a.lo(x))) < step + 2e-5
        assert np.max(np.abs(b.hi(x) - a.hi(x))) < 2 * step + 2e-5


def test_values_out_of_range_are_located() -> None:
    prof = axis_runs.machine(0)
    doc = dict(prof.raw)
    doc["output"] = {"pmac": {"backlash_takeup_mm": 1e-6}}  # 0.16 → 0: would disable it
    with pytest.raises(
        ProfileError, match=r"output.pmac.backlash_takeup_mm: I185 .* comes out as 0"
    ):
        pmac.export(profile_mod.profile_from_dict(doc, "slow"))
    doc = dict(prof.raw)
    doc["motors"] = [{"motor": 5, "counts_per_mm": 5e8}]  # 4 µm backlash = 32e6 / 16 count
    with pytest.raises(ProfileError, match=r"axis_comp\[motor=5\]: .* comes out as"):
        pmac.export(profile_mod.profile_from_dict(doc, "fine encoder"))


def test_reading_a_table_of_another_motor_is_an_error() -> None:
    prof = axis_runs.machine(0)
    text = pmac.export(prof).text.replace("#5 DEFINE COMP 61,#5D,#5,", "#5 DEFINE COMP 61,#6D,#5,")
    with pytest.raises(
        MeasurementError, match=r"axis-tables.pmc:\d+: motor 5's table acts on motor 5 from motor 6"
    ):
        pmac.read(text, "axis-tables.pmc", prof)


def _broken(text: str, old: str, new: str) -> str:
    assert old in text
    return text.replace(old, new, 1)


@pytest.mark.parametrize(
    ("old", "new", "want"),
    [
        (
            "; home offset: motor 1 add +454 to I126",
            "; home offset: motor 1 add +454 to I226",
            r"m.pmc:\d+: home offset note names two motors \(expected ; home offset: motor n",
        ),
        (
            "#6 DEFINE COMP 61,#6D,#6,6100000",
            "#6 DEFINE COMP 61,#6D,#6,x6100000",
            r"m.pmc:\d+: DEFINE COMP 61,#6D,#6,x6100000 \(expected DEFINE COMP entries,#nD",
        ),
        (
            "#6 DEFINE BLCOMP 61,6100000",
            "#6 DEFINE BLCOMP 61,#6,6100000",
            r"m.pmc:\d+: DEFINE BLCOMP 61,#6,6100000 \(expected DEFINE BLCOMP entries,count",
        ),
        (
            "#6 DEFINE BLCOMP 61,6100000",
            "#6 DEFINE BLCOMP 61,6000000",
            r"m.pmc: motor 6: BLCOMP and COMP tables differ in spacing",
        ),
        (
            "#6 DEFINE COMP 61,#6D,#6,6100000",
            "#6 DEFINE COMP 61,#6D,#6,6100001",
            r"m.pmc: motor 6: 6100001 counts over 61 entries \(expected a whole number",
        ),
        ("I185=80 I186=952", "I185=80 I486=952", r"m.pmc: I486=952 without a DEFINE COMP table"),
    ],
)
def test_reading_a_broken_table_file_names_what_is_wrong(old: str, new: str, want: str) -> None:
    """Each way a hand-edited file can go wrong is an error at its line (where it
    has one) saying what was expected, and nothing is read."""
    prof = axis_runs.machine(1, varying_backlash=True)
    text = _broken(pmac.export(prof).text, old, new)
    with pytest.raises(MeasurementError, match=want):
        pmac.read(text, "m.pmc", prof)


def test_reading_a_table_cut_short_or_with_words_among_its_entries_is_an_error() -> None:
    prof = axis_runs.machine(1, varying_backlash=True)
    lines = pmac.export(prof).text.splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("#6 DEFINE COMP"))
    words = [*lines[: k + 1], "12 x 4", *lines[k + 1 :]]
    with pytest.raises(MeasurementError, match=rf"m.pmc:{k + 2}: '12 x 4' among the entries"):
        pmac.read("\n".join(words), "m.pmc", prof)
    short = "\n".join(ln for ln in lines if not ln.startswith("#6 DEFINE BLCOMP"))
    blank = "\n".join(lines[: k + 1])  # the file ends inside motor 6's table
    with pytest.raises(MeasurementError, match=r"m.pmc: motor 6's table has 0 entries"):
        pmac.read(blank, "m.pmc", prof)
    assert pmac.read(short, "m.pmc", prof)  # no BLCOMP for motor 6: read without it


def test_cli_export_and_import(tmp_path: Path) -> None:
    prof = axis_runs.machine(2, varying_backlash=True)
    src = tmp_path / "m.toml"
    src.write_text(profile_mod.dumps(prof.raw))
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "export",
            "--profile",
            str(src),
            "--format",
            "pmac",
            "--out-dir",
            str(tmp_path / "out"),
        ],
    )
    assert r.exit_code == 0, r.output
    t5 = next(t for t in pmac.export(prof).motors if t.motor == 5)
    assert f"add {t5.home_offset:+d} to I526" in r.output
    r = CliRunner().invoke(
        main,
        [
            "tables",
            "import",
            str(tmp_path / "out" / "axis-tables.pmc"),
            "--profile",
            str(src),
            "--format",
            "pmac",
            "-o",
            str(tmp_path / "back.toml"),
        ],
    )
    assert r.exit_code == 0, r.output
    assert "motors 1, 2, 3, 5, 6" in r.output
    back = profile_mod.loads((tmp_path / "back.toml").read_text(), "back.toml")
    assert [c.motor for c in back.axis_comp] == list(MOTORS)
