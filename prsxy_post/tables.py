"""Real-axis tables from laser runs, and the ISO 230-2 figures of a positioning axis.

Laser runs (contract ``# kind: axis``) give, per motor, the position reached at each
target, approached from both directions over several runs, with no compensation
active. The contract's ``[[axis_comp]]`` table is then the mean deviation
(measured − target) per target and direction: ``forward`` from the + approaches,
``reverse`` from the − approaches.

ISO 230-2:2014 figures (all in mm), with x_ij↑/↓ the deviations at target i in run j:

    x̄_i↑, x̄_i↓          mean unidirectional deviations
    s_i↑, s_i↓          their standard deviations (n − 1)
    B_i = x̄_i↑ − x̄_i↓    reversal value;  B = max |B_i|,  B̄ = mean B_i
    E = max(x̄↑, x̄↓) − min(x̄↑, x̄↓)                      systematic deviation (bidirectional)
    M = max x̄_i − min x̄_i,  x̄_i = (x̄_i↑ + x̄_i↓) / 2     range of the mean deviation
    R_i = max(2 s_i↑ + 2 s_i↓ + |B_i|, 4 s_i↑, 4 s_i↓),  R = max R_i   repeatability
    A = max(x̄↑ + 2 s↑, x̄↓ + 2 s↓) − min(x̄↑ − 2 s↑, x̄↓ − 2 s↓)      accuracy
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .errors import MeasurementError


@dataclass(frozen=True)
class AxisTable:
    motor: int
    positions: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray


@dataclass(frozen=True)
class Iso2302Figures:
    motor: int
    n_runs: int
    targets: np.ndarray
    mean_forward: np.ndarray
    mean_reverse: np.ndarray
    reversal_B: float
    mean_reversal: float
    systematic_E: float
    range_M: float
    repeatability_R: float
    accuracy_A: float


def _per_target(
    motor: np.ndarray,
    target: np.ndarray,
    measured: np.ndarray,
    direction: np.ndarray,
    run: np.ndarray,
    m: int,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, int]:
    sel = motor == m
    t = target[sel]
    dev = measured[sel] - t
    d = direction[sel]
    targets = np.unique(t)
    runs = len(np.unique(run[sel]))
    mf, mr, sf, sr = [], [], [], []
    for x in targets:
        up = dev[(t == x) & (d > 0)]
        dn = dev[(t == x) & (d < 0)]
        if len(up) < 2 or len(dn) < 2:
            raise MeasurementError(
                f"motor {m} at {x:g} mm has {len(up)} + and {len(dn)} − approaches",
                key=f"motor {m}",
                expected="at least 2 runs in each direction (ISO 230-2 asks for 5)",
            )
        mf.append(up.mean())
        mr.append(dn.mean())
        sf.append(up.std(ddof=1))
        sr.append(dn.std(ddof=1))
    return targets, np.array(mf), np.array(mr), np.array(sf), np.array(sr), runs


def tables_from_axis(
    motor: np.ndarray,
    target: np.ndarray,
    measured: np.ndarray,
    direction: np.ndarray,
    run: np.ndarray,
) -> list[AxisTable]:
    """The contract's [[axis_comp]] table of every motor in the runs."""
    out = []
    for m in sorted({int(x) for x in np.unique(motor)}):
        targets, mf, mr, _, _, _ = _per_target(motor, target, measured, direction, run, m)
        out.append(AxisTable(m, targets, mf, mr))
    return out


def iso230_2(
    motor: np.ndarray,
    target: np.ndarray,
    measured: np.ndarray,
    direction: np.ndarray,
    run: np.ndarray,
) -> dict[int, Iso2302Figures]:
    """ISO 230-2 bidirectional figures per motor (module docstring)."""
    out = {}
    for m in sorted({int(x) for x in np.unique(motor)}):
        targets, mf, mr, sf, sr, runs = _per_target(motor, target, measured, direction, run, m)
        b = mf - mr
        mean_bi = (mf + mr) / 2
        r_i = np.maximum(2 * sf + 2 * sr + np.abs(b), np.maximum(4 * sf, 4 * sr))
        out[m] = Iso2302Figures(
            motor=m,
            n_runs=runs,
            targets=targets,
            mean_forward=mf,
            mean_reverse=mr,
            reversal_B=float(np.max(np.abs(b))),
            mean_reversal=float(np.mean(b)),
            systematic_E=float(max(mf.max(), mr.max()) - min(mf.min(), mr.min())),
            range_M=float(mean_bi.max() - mean_bi.min()),
            repeatability_R=float(r_i.max()),
            accuracy_A=float(
                max((mf + 2 * sf).max(), (mr + 2 * sr).max())
                - min((mf - 2 * sf).min(), (mr - 2 * sr).min())
            ),
        )
    return out


# ---------------------------------------------------------------- formats users have
#
# LinuxCNC (Integrator's manual, "Axis compensation"): one line per nominal
# position, three numbers. COMP_FILE_TYPE 0: nominal, the position actually
# reached moving forward, the position actually reached moving backward.
# COMP_FILE_TYPE 1: nominal, forward offset, reverse offset (actual − nominal).
# Both carry exactly the contract's table: forward/reverse = actual − commanded.
#
# Turbo PMAC (Software Reference, "DEFINE COMP"): ``DEFINE COMP n,#s,#t,L`` then n
# corrections in 1/16 count, equally spaced over L counts of the source motor, the
# first entry one spacing past the motor's zero and the last at L (which also
# stands for zero: the table rolls over). A PMAC table corrects one direction only;
# the bidirectional table is written as its mean error (negated: a correction is
# added to the command) and the half-difference as the backlash size Ixx86, also in
# 1/16 count. Reading it back gives forward/reverse = mean ∓ backlash/2.


def _comp_rows(text: str, source: str) -> list[tuple[int, list[float]]]:
    rows = []
    for n, raw in enumerate(text.splitlines(), 1):
        s = raw.split("#", 1)[0].strip()
        if not s:
            continue
        parts = s.split()
        if len(parts) != 3:
            raise MeasurementError(
                f"{len(parts)} numbers on the line",
                source=source,
                line=n,
                expected="three numbers: nominal, forward, reverse",
            )
        try:
            vals = [float(p) for p in parts]
        except ValueError:
            raise MeasurementError(
                f"not a number in {s!r}", source=source, line=n, expected="three numbers"
            ) from None
        if not all(np.isfinite(vals)):
            raise MeasurementError(
                "a value is not finite", source=source, line=n, expected="finite numbers"
            )
        rows.append((n, vals))
    if len(rows) < 2:
        raise MeasurementError(
            f"{len(rows)} table rows", source=source, expected="at least two rows"
        )
    for (_, a), (n1, b) in itertools.pairwise(rows):
        if b[0] <= a[0]:
            raise MeasurementError(
                "nominal positions do not ascend",
                source=source,
                line=n1,
                expected="ascending nominal positions",
            )
    return rows


def read_linuxcnc_comp(text: str, source: str, *, file_type: int, motor: int) -> AxisTable:
    """A LinuxCNC compensation file (COMP_FILE_TYPE 0 or 1) as the contract's table."""
    if file_type not in (0, 1):
        raise MeasurementError(f"COMP_FILE_TYPE {file_type}", source=source, expected="0 or 1")
    v = np.array([r for _, r in _comp_rows(text, source)])
    nominal = v[:, 0]
    if file_type == 0:
        return AxisTable(motor, nominal, v[:, 1] - nominal, v[:, 2] - nominal)
    return AxisTable(motor, nominal, v[:, 1], v[:, 2])


def format_linuxcnc_comp(table: AxisTable, *, file_type: int) -> str:
    """The contract's table as a LinuxCNC compensation file."""
    lines = [f"# motor {table.motor}: COMP_FILE_TYPE = {file_type} (written by prsxy-post)"]
    for p, f, r in zip(table.positions, table.forward, table.reverse, strict=True):
        if file_type == 0:
            lines.append(f"{p:.6f} {p + f:.9f} {p + r:.9f}")
        else:
            lines.append(f"{p:.6f} {f:.9f} {r:.9f}")
    return "\n".join(lines) + "\n"


def format_pmac_comp(
    table: AxisTable, *, motor: int, counts_per_mm: float, entries: int | None = None
) -> str:
    """A Turbo PMAC leadscrew table (and backlash size) for one motor (see above).

    A PMAC table covers 0 .. L and rolls over, so a table over [p_min, p_max] with
    p_min < 0 is written with L = p_max − p_min: entries past p_max stand for the
    negative positions (s − L). ``entries`` equal spacings.
    """
    p_min, p_max = float(min(table.positions[0], 0.0)), float(table.positions[-1])
    span = p_max - p_min
    if span <= 0:
        raise MeasurementError(
            f"motor {motor}: table ends at {p_max:g} mm", expected="positions reaching above 0 mm"
        )
    n = entries or (len(table.positions) - 1)
    s = np.arange(1, n + 1) * span / n
    pos = np.where(s <= p_max + 1e-9, s, s - span)
    mean = np.interp(pos, table.positions, (table.forward + table.reverse) / 2)
    back = float(np.mean(table.reverse - table.forward))
    corr = np.round(-mean * counts_per_mm * 16).astype(int)
    length = round(span * counts_per_mm)
    lines = [
        f"; motor {motor}: leadscrew compensation, 1/16 count, written by prsxy-post",
        f"DEFINE COMP {n},#{motor},#{motor},{length}",
    ]
    lines += [" ".join(str(c) for c in corr[i : i + 8]) for i in range(0, n, 8)]
    lines.append(f"I{motor}86={round(back * counts_per_mm * 16)} ; backlash size, 1/16 count")
    return "\n".join(lines) + "\n"


def read_pmac_comp(
    text: str, source: str, *, counts_per_mm: float, max_position: float | None = None
) -> list[AxisTable]:
    """Tables written by :func:`format_pmac_comp` (or by hand in that form) read back.

    ``max_position``: the highest motor position the table serves [mm]; entries past
    it stand for negative positions (rollover). Default: half the table (a travel
    symmetric about zero).
    """
    import re

    out: list[AxisTable] = []
    lines = text.splitlines()
    backlash: dict[int, float] = {}
    for raw in lines:
        m = re.match(r"\s*I(\d+)86\s*=\s*(-?\d+)", raw, re.I)
        if m and len(m.group(1)) <= 2:
            backlash[int(m.group(1))] = int(m.group(2)) / 16 / counts_per_mm
    k = 0
    while k < len(lines):
        m = re.match(
            r"\s*DEFINE\s+COMP\s+(\d+)\s*,\s*#(\d+)\s*,\s*#(\d+)\s*,\s*(\d+)", lines[k], re.I
        )
        if not m:
            k += 1
            continue
        n_entries, motor, length = int(m.group(1)), int(m.group(2)), int(m.group(4))
        vals: list[int] = []
        k += 1
        while len(vals) < n_entries and k < len(lines):
            body = lines[k].split(";", 1)[0].split()
            try:
                vals += [int(v) for v in body]
            except ValueError:
                raise MeasurementError(
                    "not a whole number in a DEFINE COMP table",
                    source=source,
                    line=k + 1,
                    expected="entries in 1/16 count",
                ) from None
            k += 1
        if len(vals) != n_entries:
            raise MeasurementError(
                f"{len(vals)} entries",
                source=source,
                line=k,
                expected=f"{n_entries} entries after DEFINE COMP",
            )
        span = length / counts_per_mm
        s = np.arange(1, n_entries + 1) * span / n_entries
        corr = np.array(vals, dtype=float) / 16 / counts_per_mm
        # the last entry also stands for zero (the table rolls over); a table written
        # for a travel below zero holds the negative positions past its middle
        p_max = float(np.max(s[s <= span / 2 + 1e-9])) if max_position is None else max_position
        pos = np.where(s <= p_max + 1e-9, s, s - span)
        pos = np.concatenate([[0.0], pos])
        mean = -np.concatenate([[corr[-1]], corr])
        order = np.argsort(pos)
        pos, mean = pos[order], mean[order]
        keep = np.concatenate([[True], np.diff(pos) > 1e-12])
        pos, mean = pos[keep], mean[keep]
        b = backlash.get(motor, 0.0)
        out.append(AxisTable(motor, pos, mean - b / 2, mean + b / 2))
    if not out:
        raise MeasurementError(
            "no DEFINE COMP table", source=source, expected="DEFINE COMP n,#m,#m,L and its entries"
        )
    return out
