"""Turbo PMAC leadscrew and backlash tables: one file to download.

The controller's rules (docs/turbo-pmac.md cites each; SRM = Turbo PMAC/PMAC2
Software Reference, TUM = Turbo PMAC User Manual):

- ``#n DEFINE COMP {entries},#nD,#n,{count length}`` gives the table of the
  **addressed** motor n (SRM "DEFINE COMP", pp. 302–303). Its source is motor n's
  desired position (``D``), its target motor n. Entries are integers in 1/16 count,
  evenly spaced over ``count length`` counts; the first sits one spacing above
  motor zero. The correction at zero is zero by definition, and positions outside
  0 … count length roll over. Between entries PMAC interpolates linearly and
  **adds** the result to the target's command every servo cycle (TUM "Active
  Calculation of Corrections", p. 189). Tables are defined from the highest motor
  down and deleted from the lowest up (ERR003 otherwise). Definition is refused
  while a GATHER, ROTARY, LOOKAHEAD or any BLCOMP buffer exists.
- ``#n DEFINE BLCOMP {entries},{count length}`` (SRM p. 301; TUM "Backlash
  Compensation Tables", p. 191) and ``Ixx86`` (SRM p. 148, 0 … 8,388,607, 1/16 count)
  give the backlash: ``Ixx86`` is the backlash at motor zero, and the table its
  difference along the travel. PMAC **subtracts** Ixx86 + table from the command
  while the last commanded direction is negative, and nothing while it is positive.
  It takes the backlash up at ``Ixx85`` (1/16 count per background cycle,
  0 … 8,388,607; 0 disables the backlash) once a reversal exceeds the hysteresis
  Ixx87.
- ``I51=1`` enables the tables (SRM p. 301).

So for the desired position p (counts) of motor n PMAC commands

    q = p + COMP(p) − [last move negative] · (Ixx86 + BLCOMP(p))

and the tables hold (module :mod:`._common`) COMP(p) = c_f(p), the correction of a
+ approach (the forward error), and Ixx86 + BLCOMP(p) = c_f(p) − c_r(p) ≥ 0, the
backlash of the play model.

**Motor zero.** A PMAC table holds no correction at motor zero, but the contract's
table generally has one: c_f(0). It cannot be in a table. It belongs to the home
offset (PSR "Ix26 Home Offset": the motor stops Ixx26/16 counts from the home
trigger and calls that zero). Adding round(16 · c_f(0) · counts/mm) to Ixx26 and
homing again shifts motor zero by c_f(0). The tables then hold c_f(p) − c_f(0). The
file says so in a comment line for each motor (``; home offset: motor n add … to
Innn26``). It does not write Ixx26 itself, because it does not know the machine's
present value.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field

import numpy as np

from .. import __version__
from ..errors import MeasurementError, ProfileError
from ..profile import MOTORS, AxisComp, Profile
from ._common import comp_from_corrections, corrections, max_deviation

#: largest value of Ixx85, Ixx86 (SRM p. 148) and of a table entry: a 24-bit word
I_MAX = 8_388_607
#: default bound on the interpolation error of a table between its entries [mm]
MAX_INTERP_ERROR_MM = 2e-5
#: most entries a table may get while refining its spacing
MAX_ENTRIES = 8192
FILE_NAME = "axis-tables.pmc"

_HOME = re.compile(r";\s*home offset:\s*motor\s+(\d+)\s+add\s+([+-]?\d+)\s+to\s+I(\d+)26", re.I)


@dataclass(frozen=True)
class PmacMotorTable:
    """What the file holds for one motor.

    entries : number of entries of each table; count_length : span [counts]
    comp, blcomp : (entries,) table entries [1/16 count] (blcomp None: constant backlash)
    ixx85, ixx86 : backlash take-up rate and backlash at zero [1/16 count (per cycle)]
    home_offset : add this to Ixx26 [1/16 count] (the correction at motor zero)
    interp_error_mm : largest difference over the travel between what PMAC
        interpolates from the entries (rounded to 1/16 count) and the exact
        corrections, both directions [mm]
    """

    motor: int
    entries: int
    count_length: int
    comp: np.ndarray
    blcomp: np.ndarray | None
    ixx85: int
    ixx86: int
    home_offset: int
    interp_error_mm: float


@dataclass(frozen=True)
class PmacTables:
    name: str
    text: str
    motors: tuple[PmacMotorTable, ...]


@dataclass(frozen=True)
class _Layout:
    """Entries k = 1 … n at k·h counts; the first ``n_pos`` stand for +k·h, the
    rest (after one unused cell) for k·h − L: motor positions below zero roll over."""

    h_counts: int
    n: int
    n_pos: int

    @property
    def length(self) -> int:
        return self.h_counts * self.n

    def positions(self, cpm: float) -> np.ndarray:
        """Motor position of each entry [mm]."""
        k = np.arange(1, self.n + 1)
        s = k * self.h_counts
        return np.where(k <= self.n_pos, s, s - self.length) / cpm


def _layout(h_counts: int, travel: tuple[float, float], cpm: float) -> _Layout:
    h = h_counts / cpm
    n_pos = math.ceil(max(travel[1], 0.0) / h - 1e-9)
    n_neg = math.ceil(max(-travel[0], 0.0) / h - 1e-9)
    return _Layout(h_counts, n_pos + n_neg + 1, n_pos)


def _applied(
    lay: _Layout, cpm: float, comp: np.ndarray, total_bl: np.ndarray, home: float
) -> object:
    """The corrections PMAC applies, (c_f, c_r) [mm] as functions of p [mm].

    comp : (n,) COMP entries; total_bl : (n + 1,) Ixx86 + BLCOMP at zero and at the
    entries; home : the home-offset change [1/16 count]. Linear between entries,
    zero COMP at zero, positions rolled over into 0 … L (SRM pp. 301–303).
    """
    s_entries = np.arange(0, lay.n + 1) * lay.h_counts
    f = np.concatenate([[0.0], np.asarray(comp, dtype=float)])
    b = np.asarray(total_bl, dtype=float)

    def fn(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        s = np.mod(np.asarray(p, dtype=float) * cpm, lay.length)
        cf = (np.interp(s, s_entries, f) + home) / 16 / cpm
        return cf, cf - np.interp(s, s_entries, b) / 16 / cpm

    return fn


def _values(
    comp: AxisComp, lay: _Layout, cpm: float, exact: bool
) -> tuple[np.ndarray, np.ndarray, float, float]:
    """COMP entries, Ixx86 + BLCOMP (at zero, then the entries), home offset, Ixx86.

    In 1/16 count; rounded to integers unless ``exact``. Each is rounded from the
    exact value at its position, so the sums PMAC forms are within half a
    1/16 count of the exact corrections.
    """
    p = np.concatenate([[0.0], lay.positions(cpm)])
    cf, cr = corrections(comp, p)
    f = cf * cpm * 16
    b = (cf - cr) * cpm * 16
    if not exact:
        f, b = np.round(f), np.round(b)
    home, ixx86 = float(f[0]), float(b[0])
    return f[1:] - home, b, home, ixx86


def _check(value: int, what: str, lo: int, hi: int, key: str, where: str) -> None:
    if not lo <= value <= hi:
        raise ProfileError(
            f"{what} comes out as {value:,}", key=key, expected=f"{lo:,} … {hi:,} ({where})"
        )


def _motor_table(comp: AxisComp, profile: Profile, max_err: float) -> PmacMotorTable:
    """Entries of one motor's tables, the spacing refined until PMAC's linear
    interpolation is within ``max_err`` of the exact corrections."""
    mc = profile.motor(comp.motor)
    cpm = mc.counts_per_mm
    key = f"axis_comp[motor={comp.motor}]"
    travel = (mc.min, mc.max)
    pos = np.asarray(comp.positions, dtype=float)
    d = np.diff(pos)
    if len(d) and np.ptp(d) < 1e-9 and abs(pos[0] / d[0] - round(pos[0] / d[0])) < 1e-9:
        h0 = float(d[0])  # an even table on a grid through zero: PMAC's grid can match it
    elif len(d):
        h0 = float(np.min(d))
    else:
        h0 = (travel[1] - travel[0]) / 16
    h_counts = max(1, round(h0 * cpm))
    while True:
        lay = _layout(h_counts, travel, cpm)
        breaks = np.concatenate([lay.positions(cpm), [0.0]])
        f, b, home, _ = _values(comp, lay, cpm, exact=True)
        interp = max_deviation(comp, travel, _applied(lay, cpm, f, b, home), breaks)
        if interp <= max_err or h_counts == 1:
            break
        if lay.n * 2 > MAX_ENTRIES:
            raise ProfileError(
                f"a PMAC table within {max_err * 1e3:g} µm of the exact correction needs more "
                f"than {MAX_ENTRIES} entries",
                key=key,
                expected="a smoother table",
            )
        h_counts = max(1, h_counts // 2)
    f, b, home, ixx86 = _values(comp, lay, cpm, exact=False)
    err = max_deviation(comp, travel, _applied(lay, cpm, f, b, home), breaks)
    table = f.astype(np.int64)
    bl = (b[1:] - ixx86).astype(np.int64)
    ixx85 = round(profile.output["pmac"]["backlash_takeup_mm"] * cpm * 16)
    m = comp.motor
    _check(int(ixx86), f"I{m}86 (backlash at motor zero, 1/16 count)", 0, I_MAX, key, "SRM p. 148")
    _check(
        ixx85,
        f"I{m}85 (backlash take-up, 1/16 count per background cycle)",
        1,
        I_MAX,
        "output.pmac.backlash_takeup_mm",
        "SRM p. 148; 0 disables the backlash",
    )
    _check(
        int(home),
        f"the change of I{m}26 (home offset, 1/16 count)",
        -I_MAX - 1,
        I_MAX,
        key,
        "PSR Ix26",
    )
    for what, arr in (("DEFINE COMP", table), ("DEFINE BLCOMP", bl)):
        worst = int(arr[np.argmax(np.abs(arr))])
        _check(worst, f"a {what} entry (1/16 count)", -I_MAX - 1, I_MAX, key, "a 24-bit word")
    return PmacMotorTable(
        m, lay.n, lay.length, table, bl if np.any(bl) else None, ixx85, int(ixx86), int(home), err
    )


def export(profile: Profile, *, max_interp_error_mm: float = MAX_INTERP_ERROR_MM) -> PmacTables:
    """The download file with the tables of every motor that has an ``[[axis_comp]]``.

    Motors without a table get ``Ixx86=0`` (the profile says they have no play).

    Returns
    -------
    :class:`PmacTables`: the file name, its text, and what it holds per motor.
    """
    tables = [_motor_table(c, profile, max_interp_error_mm) for c in profile.axis_comp]
    cs = int(profile.output["pmac"]["coordinate_system"])
    lines = [
        f"; Turbo PMAC real-axis tables of profile '{profile.name}' (prsxy-post {__version__}).",
        "; Download this file as a whole. SRM = Turbo PMAC/PMAC2 Software Reference, TUM =",
        "; Turbo PMAC User Manual, PSR = PMAC Software Reference; docs/turbo-pmac.md cites",
        "; each rule.",
        ";",
        "; For motor n at desired position p PMAC commands (TUM p. 189, p. 191; SRM p. 301)",
        ";   p + COMP(p) - [last move negative] * (In86 + BLCOMP(p))",
        "; COMP makes a + approach end at p; In86 + BLCOMP is the backlash, so a - approach",
        "; ends at p too (the play model of the profile).",
        ";",
        "; Order: tables are refused (ERR003) while a gather, rotary or lookahead buffer or a",
        "; table of a lower motor exists, and COMP tables while any BLCOMP exists (SRM",
        f"; p. 301, p. 303). The file deletes the gather buffer, C.S. {cs}'s rotary and lookahead",
        "; buffers, and the tables of motors 1 to 6 from the lowest up, then defines COMP",
        "; tables from the highest motor down, then BLCOMP tables from the highest down.",
        "; Buffers of other coordinate systems must be deleted before downloading.",
        ";",
        "; A table holds no correction at motor zero (SRM p. 303). The profile's correction",
        "; there is a shift of motor zero: add the value below to the motor's home offset",
        "; Ixx26 (1/16 count; PSR Ix26) and home again. Without it the motor ends off by that.",
    ]
    for t in tables:
        mm = t.home_offset / 16 / profile.motor(t.motor).counts_per_mm
        note = f"add {t.home_offset:+d} to I{t.motor}26 ({mm * 1e3:+.4f} um)"
        lines.append(f"; home offset: motor {t.motor} {note}")
    for t in tables:
        lines.append(
            f"; motor {t.motor}: {t.entries} entries over {t.count_length} counts; PMAC's "
            f"interpolation is within {t.interp_error_mm * 1e3:.4f} um of the exact correction"
        )
    cyc = sorted({c.motor for c in profile.effects.cyclic})
    if cyc:
        lines.append(
            "; Not in these tables: the cyclic errors ([[effects.cyclic]]) of motors "
            + ", ".join(str(m) for m in cyc)
        )
    lines += [
        "",
        "CLOSE",
        "I51=0",
        "DELETE GATHER",
        f"&{cs} DELETE ROTARY",
        f"&{cs} DELETE LOOKAHEAD",
    ]
    lines += [f"#{m} DELETE BLCOMP" for m in range(1, 7)]
    lines += [f"#{m} DELETE COMP" for m in range(1, 7)]
    for t in sorted(tables, key=lambda t: -t.motor):
        lines.append(f"#{t.motor} DEFINE COMP {t.entries},#{t.motor}D,#{t.motor},{t.count_length}")
        lines += _entry_lines(t.comp)
    for t in sorted(tables, key=lambda t: -t.motor):
        if t.blcomp is not None:
            lines.append(f"#{t.motor} DEFINE BLCOMP {t.entries},{t.count_length}")
            lines += _entry_lines(t.blcomp)
    by_motor = {t.motor: t for t in tables}
    for m in MOTORS:
        if m in by_motor:
            lines.append(f"I{m}85={by_motor[m].ixx85} I{m}86={by_motor[m].ixx86}")
        else:
            lines.append(f"I{m}86=0 ; motor {m} has no [[axis_comp]] table")
    lines += ["I51=1", ""]
    return PmacTables(FILE_NAME, "\n".join(lines), tuple(tables))


def _entry_lines(values: np.ndarray, per_line: int = 10) -> list[str]:
    return [
        " ".join(str(int(v)) for v in values[i : i + per_line])
        for i in range(0, len(values), per_line)
    ]


_DEFINE = re.compile(r"^\s*(?:#(\d+)\s*)?DEFINE\s+(BLCOMP|COMP)\s+(\d+)\s*,\s*(.*)$", re.I)


def read(text: str, source: str, profile: Profile) -> list[AxisComp]:
    """Tables of a PMAC file (as :func:`export` writes them) as ``[[axis_comp]]``.

    The file is read as PMAC reads it: ``#n`` addresses motor n, a table belongs to
    the motor addressed when it is defined, entries follow it up to its count, and
    ``Inn85``/``Inn86`` assignments are taken; ``;`` starts a comment. The
    ``; home offset:`` notes give the correction at motor zero. Counts per mm and the
    travel (which entries stand for negative positions) come from ``profile``.
    Only tables whose source and target are their own motor describe that motor's
    real axis; any other table is an error at its line.
    """
    tables = _scan(text, source)
    out = [_motor_comp(m, tables, profile, source) for m in sorted(tables.comp)]
    for (m, v), val in tables.ivars.items():
        if v == 86 and val and m not in tables.comp:
            raise MeasurementError(
                f"I{m}86={val} without a DEFINE COMP table of motor {m}",
                source=source,
                expected="a table for every motor with backlash",
            )
    if not out:
        raise MeasurementError(
            "no DEFINE COMP table and no backlash",
            source=source,
            expected="#n DEFINE COMP entries,#nD,#n,count length and its entries",
        )
    return out


#: a motor's table as read: (entries, counts it spans, the entries [1/16 count])
_Table = tuple[int, int, list[int]]


@dataclass
class _Scanned:
    """What a PMAC file sets: COMP and BLCOMP tables by motor, Ixx85/Ixx86 by
    (motor, number), home offsets by motor [1/16 count]."""

    comp: dict[int, _Table] = field(default_factory=dict)
    blcomp: dict[int, _Table] = field(default_factory=dict)
    ivars: dict[tuple[int, int], int] = field(default_factory=dict)
    home: dict[int, int] = field(default_factory=dict)


def _scan(text: str, source: str) -> _Scanned:
    """The file's tables, I-variables and home notes, line by line as PMAC reads
    them (the motor addressed last owns a table defined; entries follow it)."""
    got = _Scanned()
    motor = 1
    pending: list[int] | None = None
    need = 0
    for n, raw in enumerate(text.splitlines(), 1):
        hm = _HOME.search(raw)
        if hm:
            if hm.group(1) != hm.group(3):
                raise MeasurementError(
                    "home offset note names two motors",
                    source=source,
                    line=n,
                    expected="; home offset: motor n add v to In26",
                )
            got.home[int(hm.group(1))] = int(hm.group(2))
        body = raw.split(";", 1)[0].strip()
        if not body:
            continue
        if pending is not None and len(pending) < need:
            _entries(pending, need, body, source, n)
            continue
        d = _DEFINE.match(body)
        if d:
            if d.group(1):
                motor = int(d.group(1))
            pending, need = [], int(d.group(3))
            is_comp, length = _define(d, motor, source, n)
            (got.comp if is_comp else got.blcomp)[motor] = (need, length, pending)
            continue
        for tok in re.findall(r"#\d+|I\d+\s*=\s*-?\d+", body, re.I):
            if tok.startswith("#"):
                motor = int(tok[1:])
            else:
                num, val = (x.strip() for x in tok[1:].split("="))
                if len(num) >= 3 and num[-2:] in ("85", "86"):
                    got.ivars[(int(num[:-2]), int(num[-2:]))] = int(val)
    for m, (entries, _, vals) in {**got.comp, **got.blcomp}.items():
        if len(vals) != entries:
            raise MeasurementError(
                f"motor {m}'s table has {len(vals)} entries",
                source=source,
                expected=f"{entries} entries",
            )
    return got


def _entries(pending: list[int], need: int, body: str, source: str, n: int) -> None:
    """A line of a table's entries, added to ``pending`` (``need`` in all)."""
    try:
        pending += [int(v) for v in body.split()]
    except ValueError:
        raise MeasurementError(
            f"{body!r} among the entries of a table",
            source=source,
            line=n,
            expected=f"{need} whole numbers (1/16 count)",
        ) from None
    if len(pending) > need:
        raise MeasurementError(
            f"{len(pending)} entries", source=source, line=n, expected=f"{need} entries"
        )


def _define(d: re.Match[str], motor: int, source: str, n: int) -> tuple[bool, int]:
    """A DEFINE COMP or DEFINE BLCOMP line: (whether COMP, the counts it spans)."""
    kind, entries, rest = d.group(2).upper(), int(d.group(3)), d.group(4).replace(" ", "")
    if kind != "COMP":
        if not re.fullmatch(r"\d+", rest):
            raise MeasurementError(
                f"DEFINE BLCOMP {entries},{rest}",
                source=source,
                line=n,
                expected="DEFINE BLCOMP entries,count length",
            )
        return False, int(rest)
    mm = re.fullmatch(r"(?:#(\d+)D?,(?:#(\d+),)?)?(\d+)", rest, re.I)
    if not mm:
        raise MeasurementError(
            f"DEFINE COMP {entries},{rest}",
            source=source,
            line=n,
            expected="DEFINE COMP entries,#nD,#n,count length",
        )
    src, tgt = mm.group(1), mm.group(2)
    if (src and int(src) != motor) or (tgt and int(tgt) != motor):
        raise MeasurementError(
            f"motor {motor}'s table acts on motor {tgt or motor} from motor {src}",
            source=source,
            line=n,
            expected="a table of the motor's own position and command",
        )
    return True, int(mm.group(3))


def _motor_comp(m: int, tables: _Scanned, profile: Profile, source: str) -> AxisComp:
    """Motor m's ``[[axis_comp]]`` from its COMP table, its BLCOMP table and Ixx86
    (backlash), laid out over the profile's travel."""
    if m not in MOTORS:
        raise MeasurementError(
            f"a table of motor {m}", source=source, expected="motors 1, 2, 3, 5, 6"
        )
    mc = profile.motor(m)
    cpm = mc.counts_per_mm
    entries, length, vals = tables.comp[m]
    if length % entries:
        raise MeasurementError(
            f"motor {m}: {length} counts over {entries} entries",
            source=source,
            expected="a whole number of counts per entry",
        )
    lay = _layout(length // entries, (mc.min, mc.max), cpm)
    if lay.n != entries:
        raise MeasurementError(
            f"motor {m}: {entries} entries of {length // entries} counts do not cover the "
            f"travel {mc.min:g} … {mc.max:g} mm of the profile as prsxy-post lays them out",
            source=source,
            expected=f"{lay.n} entries",
        )
    ixx86 = tables.ivars.get((m, 86), 0)
    bl = tables.blcomp.get(m)
    if bl is not None and (bl[0], bl[1]) != (entries, length):
        raise MeasurementError(
            f"motor {m}: BLCOMP and COMP tables differ in spacing",
            source=source,
            expected="the same entries and count length",
        )
    total = ixx86 + (np.array(bl[2]) if bl is not None else np.zeros(entries))
    # entry 0 is zero at zero; the last entry stands for zero too (rollover) and goes
    p = np.concatenate([[0.0], lay.positions(cpm)[:-1]])
    c_f = (np.concatenate([[0], vals[:-1]]) + tables.home.get(m, 0)) / 16 / cpm
    c_r = c_f - np.concatenate([[ixx86], total[:-1]]) / 16 / cpm
    order = np.argsort(p)
    return comp_from_corrections(m, p[order], c_f[order], c_r[order])
