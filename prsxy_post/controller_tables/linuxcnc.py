"""LinuxCNC joint compensation files (``[JOINT_n] COMP_FILE`` / ``COMP_FILE_TYPE``).

What LinuxCNC does with them (source: LinuxCNC/linuxcnc, read at master):

- ``usrmotLoadComp`` (src/emc/motion/usrmotintf.cc) reads the file line by line
  with ``sscanf("%lf %lf %lf")`` and **stops at the first line that is not three
  numbers** (a comment, a blank line). So the data come first; this module writes
  its notes after the last row, where the loader never looks.
- COMP_FILE_TYPE 0: each row is ``nominal forward reverse``, the positions reached,
  and the loader stores the trims ``nominal − forward``, ``nominal − reverse``.
  COMP_FILE_TYPE 1: each row is ``nominal forward_trim reverse_trim`` stored as
  they are.
- ``EMCMOT_SET_JOINT_COMP`` (src/emc/motion/command.c) takes at most
  ``EMCMOT_COMP_SIZE`` = 256 rows (src/emc/motion/motion.h); nominal positions
  must increase. Trims are stored as C ``float``.
- ``compute_screw_comp`` (src/emc/motion/control.c) adds to the commanded joint
  position the trim of the direction of motion (``vel_cmd`` > 0: forward, < 0:
  reverse, 0: the last one), interpolated linearly between rows; below the first
  and above the last row the end trim holds. With a comp file the joint's
  ``BACKLASH`` is not used.

So a trim is the correction c_f / c_r of :mod:`._common`: the file holds the
corrections at the rows, and between rows LinuxCNC interpolates them.

Joints: a PRS-XY LinuxCNC configuration (custom kinematics with five joints, in
the contract's motor order) has joint 0 = motor 1, joint 1 = motor 2, joint 2 =
motor 3 (the guides) and joint 3 = motor 5, joint 4 = motor 6 (the table); there is
no motor 4. :data:`JOINT_OF_MOTOR` is that map; the INI snippet names it.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..errors import MeasurementError, ProfileError
from ..profile import MOTORS, AxisComp, Profile
from ._common import comp_from_corrections, corrections, max_deviation

#: LinuxCNC's row limit: EMCMOT_COMP_SIZE in src/emc/motion/motion.h.
MAX_ROWS = 256
#: joint of each motor in a PRS-XY LinuxCNC configuration (module docstring)
JOINT_OF_MOTOR = {1: 0, 2: 1, 3: 2, 5: 3, 6: 4}
MOTOR_OF_JOINT = {j: m for m, j in JOINT_OF_MOTOR.items()}
#: name of the INI snippet written beside the comp files
INI_NAME = "linuxcnc-comp.ini"
#: default bound on the interpolation error of a resampled table [mm]
MAX_INTERP_ERROR_MM = 1e-4

_TRAILER = re.compile(r"^#\s*prsxy-post:\s*motor\s+(\d+)\b", re.I)


@dataclass(frozen=True)
class CompFile:
    """One joint's compensation file.

    ``interp_error_mm``: largest difference, over the motor's travel, between the
    correction LinuxCNC interpolates from the rows and the exact one [mm].
    ``resampled_from``: rows of the profile's table when it had more than
    :data:`MAX_ROWS` and was resampled, else None.
    """

    motor: int
    joint: int
    name: str
    text: str
    rows: int
    interp_error_mm: float
    resampled_from: int | None


@dataclass(frozen=True)
class LinuxcncTables:
    """The comp files of a profile and the INI snippet that names them."""

    file_type: int
    files: tuple[CompFile, ...]
    ini_name: str
    ini: str


def _rows(
    comp: AxisComp, travel: tuple[float, float], max_err: float
) -> tuple[np.ndarray, int | None, float]:
    """Rows for LinuxCNC: the table's own positions, or 256 evenly spaced when it has more."""
    pos = np.asarray(comp.positions, dtype=float)
    if len(pos) <= MAX_ROWS:
        rows, resampled = pos, None
    else:
        rows, resampled = np.linspace(pos[0], pos[-1], MAX_ROWS), len(pos)
    cf, cr = corrections(comp, rows)
    err = max_deviation(
        comp, travel, lambda p: (np.interp(p, rows, cf), np.interp(p, rows, cr)), rows
    )
    if resampled is not None and err > max_err:
        raise ProfileError(
            f"has {len(pos)} rows; LinuxCNC holds {MAX_ROWS} (EMCMOT_COMP_SIZE), and "
            f"{MAX_ROWS} evenly spaced rows miss the table by {err * 1e3:.3f} µm",
            key=f"axis_comp[motor={comp.motor}]",
            expected=f"a table LinuxCNC can hold within {max_err * 1e3:g} µm "
            f"(at most {MAX_ROWS} rows, or smoother)",
        )
    return rows, resampled, err


def export(
    profile: Profile, file_type: int, *, max_interp_error_mm: float = MAX_INTERP_ERROR_MM
) -> LinuxcncTables:
    """Compensation files of every motor with an ``[[axis_comp]]`` table.

    Parameters
    ----------
    profile : the machine; its ``[[motors]]`` travel bounds the stated error
    file_type : 0 (nominal, forward, reverse positions) or 1 (nominal and trims)
    max_interp_error_mm : a table resampled to 256 rows may miss the exact
        correction by at most this much, else it is refused.

    Returns
    -------
    :class:`LinuxcncTables`: ``motor<m>.comp`` per motor and :data:`INI_NAME`.
    """
    if file_type not in (0, 1):
        raise ValueError(f"COMP_FILE_TYPE {file_type}")
    files = []
    for comp in profile.axis_comp:
        mc = profile.motor(comp.motor)
        rows, resampled, err = _rows(comp, (mc.min, mc.max), max_interp_error_mm)
        cf, cr = corrections(comp, rows)
        lines = []
        for p, a, b in zip(rows, cf, cr, strict=True):
            # type 0 holds positions: the loader's trim nominal − forward must be c_f
            x, y = (p - a, p - b) if file_type == 0 else (a, b)
            lines.append(f"{p:.9f} {x:.9f} {y:.9f}")
        joint = JOINT_OF_MOTOR[comp.motor]
        what = (
            "nominal, forward, reverse positions\n"
            "# (LinuxCNC's trims: nominal - forward, nominal - reverse)"
            if file_type == 0
            else "nominal, forward trim, reverse trim"
        )
        rows_note = f"{len(rows)} rows" + (
            f", resampled evenly from {resampled}" if resampled else ""
        )
        lines += [
            f"# prsxy-post: motor {comp.motor} = joint {joint}, COMP_FILE_TYPE {file_type}:",
            f"# {what} [mm].",
            "# LinuxCNC stops reading at the first line that is not three numbers",
            "# (usrmotLoadComp), so it never reads these notes after the data.",
            "# A trim is what LinuxCNC adds to the commanded position moving + (forward)",
            "# or - (reverse), so that the axis ends there (contract play model of",
            f"# profile '{profile.name}'). {rows_note}; interpolated linearly they are",
            f"# within {err * 1e3:.4f} um of the exact correction over the travel",
            f"# {mc.min:g} .. {mc.max:g} mm.",
        ]
        files.append(
            CompFile(
                comp.motor,
                joint,
                f"motor{comp.motor}.comp",
                "\n".join(lines) + "\n",
                len(rows),
                err,
                resampled,
            )
        )
    return LinuxcncTables(file_type, tuple(files), INI_NAME, _ini(files, file_type, profile.name))


def _ini(files: list[CompFile], file_type: int, name: str) -> str:
    joints = ", ".join(f"joint {j} = motor {m}" for m, j in JOINT_OF_MOTOR.items())
    out = [
        f"# prsxy-post: real-axis compensation of profile '{name}' for LinuxCNC.",
        f"# Joints of a PRS-XY configuration: {joints} (there is no motor 4).",
        "# Merge these keys into the [JOINT_n] sections of the machine's INI; COMP_FILE is",
        "# opened as written (relative to the directory LinuxCNC runs in, the config's).",
        "# With a comp file LinuxCNC does not use the joint's BACKLASH (control.c).",
        "# Nominal positions are joint positions in the profile's motor coordinates [mm]:",
        "# the joint must be homed so that its position 0 is the motor's zero.",
    ]
    for f in sorted(files, key=lambda f: f.joint):
        out += ["", f"[JOINT_{f.joint}]", f"COMP_FILE = {f.name}", f"COMP_FILE_TYPE = {file_type}"]
    return "\n".join(out) + "\n"


def motor_named_in(text: str) -> int | None:
    """The motor a file written by :func:`export` names in its notes, if any."""
    for raw in text.splitlines():
        m = _TRAILER.match(raw.strip())
        if m:
            return int(m.group(1))
    return None


def read_ini(text: str, source: str) -> dict[str, tuple[int, int]]:
    """``COMP_FILE`` → (motor, COMP_FILE_TYPE) from an INI (or the snippet).

    Only ``[JOINT_n]`` sections with a ``COMP_FILE`` count; the joint is turned into
    the motor by :data:`MOTOR_OF_JOINT`. COMP_FILE_TYPE defaults to 0 as in
    LinuxCNC (src/emc/ini/inijoint.cc).
    """
    out: dict[str, tuple[int, int]] = {}
    section: str | None = None
    found: dict[str, dict[str, tuple[str, int]]] = {}
    for n, raw in enumerate(text.splitlines(), 1):
        s = raw.strip()
        if not s or s[0] in "#;":
            continue
        if s.startswith("["):
            if not s.endswith("]"):
                raise MeasurementError(
                    f"section header {s!r}", source=source, line=n, expected="[NAME]"
                )
            section = s[1:-1].strip()
            continue
        if "=" not in s:
            raise MeasurementError(
                f"{s!r} is not a key", source=source, line=n, expected="KEY = value"
            )
        k, v = (x.strip() for x in s.split("=", 1))
        if section and re.fullmatch(r"JOINT_\d+", section) and k in ("COMP_FILE", "COMP_FILE_TYPE"):
            found.setdefault(section, {})[k] = (v, n)
    for sec, keys in found.items():
        if "COMP_FILE" not in keys:
            continue
        joint = int(sec.split("_")[1])
        name, line = keys["COMP_FILE"]
        if joint not in MOTOR_OF_JOINT:
            raise MeasurementError(
                f"[{sec}] names a comp file, but a PRS-XY configuration has joints 0 .. 4",
                source=source,
                line=line,
                expected="JOINT_0 .. JOINT_4",
            )
        ftype = 0
        if "COMP_FILE_TYPE" in keys:
            v, tl = keys["COMP_FILE_TYPE"]
            if v not in ("0", "1"):
                raise MeasurementError(
                    f"COMP_FILE_TYPE = {v}", source=source, line=tl, expected="0 or 1"
                )
            ftype = int(v)
        out[name] = (MOTOR_OF_JOINT[joint], ftype)
    return out


def read_comp(text: str, source: str, *, file_type: int, motor: int) -> AxisComp:
    """A compensation file read as LinuxCNC reads it, as the motor's ``[[axis_comp]]``.

    Rows are read as ``usrmotLoadComp`` reads them, up to the first line that is not
    three numbers; what follows is ignored as LinuxCNC ignores it. A file in which
    LinuxCNC would find fewer than two rows, more than 256, or nominal positions that
    do not increase is an error at its line (LinuxCNC would load a part of it, or
    nothing, and say so only in its log).
    """
    if file_type not in (0, 1):
        raise MeasurementError(f"COMP_FILE_TYPE {file_type}", source=source, expected="0 or 1")
    if motor not in MOTORS:
        raise MeasurementError(f"motor {motor}", source=source, expected="1, 2, 3, 5 or 6")
    rows: list[tuple[float, float, float]] = []
    last_line = 0
    for n, raw in enumerate(text.splitlines(), 1):
        parts = raw.split()
        try:
            vals = tuple(float(x) for x in parts[:3])
        except ValueError:
            vals = ()
        if len(vals) != 3:
            break  # where usrmotLoadComp stops
        if not all(np.isfinite(vals)):
            raise MeasurementError(
                "a value is not finite", source=source, line=n, expected="finite numbers"
            )
        if rows and vals[0] <= rows[-1][0]:
            raise MeasurementError(
                "nominal position does not increase (LinuxCNC refuses the row and loads the rest)",
                source=source,
                line=n,
                expected="increasing nominal positions",
            )
        rows.append((vals[0], vals[1], vals[2]))
        last_line = n
    if len(rows) < 2:
        raise MeasurementError(
            f"LinuxCNC reads {len(rows)} rows from it (it stops at the first line that is "
            "not three numbers)",
            source=source,
            line=last_line + 1,
            expected="at least two rows of three numbers first",
        )
    if len(rows) > MAX_ROWS:
        raise MeasurementError(
            f"{len(rows)} rows; LinuxCNC keeps the first {MAX_ROWS} (EMCMOT_COMP_SIZE)",
            source=source,
            line=MAX_ROWS + 1,
            expected=f"at most {MAX_ROWS} rows",
        )
    v = np.array(rows)
    nominal = v[:, 0]
    if file_type == 0:
        c_f, c_r = nominal - v[:, 1], nominal - v[:, 2]
    else:
        c_f, c_r = v[:, 1], v[:, 2]
    return comp_from_corrections(motor, nominal, c_f, c_r)
