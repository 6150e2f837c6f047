"""Measurement files of the contract (``data-formats.md``): poses, ballbar runs, laser runs.

UTF-8 CSV with a header row; ``# key: value`` metadata lines before it; the kind in
``# kind:``. Readers take text and return arrays; every problem is a
:class:`~prsxy_post.errors.MeasurementError` naming the file, the line and the
column. Writers return the exact contract form (extra columns are allowed on
reading and ignored).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import MeasurementError

KINDS = ("poses", "ballbar", "axis")
COLUMNS = {
    "poses": ("x", "y", "z", "a", "b", "mx", "my", "mz", "ma", "mb"),
    "ballbar": ("t", "x", "y", "z", "a", "b", "dev_um"),
    "axis": ("motor", "target", "measured", "direction", "run"),
}
#: fewest samples a ballbar run must have to be analysed (a circle's harmonics)
MIN_BALLBAR_ROWS = 16


@dataclass(frozen=True)
class PoseData:
    """Measured tool tip and axis at commanded poses.

    commanded : (N, 5) [mm, mm, mm, deg, deg], workpiece frame
    tip : (N, 3) measured mx, my, mz [mm]
    axis : (N, 2) measured ma, mb [deg]; NaN where the file leaves them empty
    rows : (N,) line number of each row in the file
    """

    source: str
    commanded: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    rows: np.ndarray
    meta: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class BallbarRun:
    """One ballbar run: pivot, nominal length, and the reading along the commanded path."""

    source: str
    name: str
    pivot: np.ndarray
    length: float
    t: np.ndarray
    commanded: np.ndarray
    dev_um: np.ndarray
    rows: np.ndarray
    meta: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class AxisData:
    """Laser interferometer runs per motor (ISO 230-2 style)."""

    source: str
    motor: np.ndarray
    target: np.ndarray
    measured: np.ndarray
    direction: np.ndarray
    run: np.ndarray
    rows: np.ndarray
    meta: dict[str, str] = field(default_factory=dict)


Measurement = PoseData | BallbarRun | AxisData


def _fail(
    msg: str,
    source: str,
    line: int | None = None,
    column: int | None = None,
    key: str | None = None,
    expected: str | None = None,
) -> MeasurementError:
    return MeasurementError(
        msg, source=source, line=line, column=column, key=key, expected=expected
    )


@dataclass
class _Table:
    meta: dict[str, str]
    meta_lines: dict[str, int]
    header: list[str]
    header_line: int
    rows: list[tuple[int, list[str]]]


def _split(text: str, source: str) -> _Table:
    if "\0" in text:
        raise _fail(
            "binary data (a NUL byte) in a measurement file",
            source,
            text[: text.index("\0")].count("\n") + 1,
            expected="a UTF-8 CSV file",
        )
    text = text.removeprefix("\ufeff")
    meta: dict[str, str] = {}
    meta_lines: dict[str, int] = {}
    header: list[str] | None = None
    header_line = 0
    rows: list[tuple[int, list[str]]] = []
    for n, raw in enumerate(text.replace("\r\n", "\n").replace("\r", "\n").split("\n"), 1):
        line = raw.strip()
        if not line:
            continue
        if header is None and line.startswith("#"):
            body = line[1:].strip()
            if ":" in body:
                k, v = body.split(":", 1)
                meta[k.strip().lower()] = v.strip()
                meta_lines[k.strip().lower()] = n
            continue
        cells = [c.strip() for c in line.split(",")]
        if header is None:
            header, header_line = [c.lower() for c in cells], n
            continue
        rows.append((n, cells))
    if header is None:
        raise _fail("no header row", source, 1, expected="a CSV header row after the # lines")
    return _Table(meta, meta_lines, header, header_line, rows)


def _columns(tab: _Table, kind: str, source: str) -> dict[str, int]:
    idx: dict[str, int] = {}
    for i, name in enumerate(tab.header):
        if name in idx:
            raise _fail(
                f"column {name!r} appears twice",
                source,
                tab.header_line,
                i + 1,
                key=name,
                expected="each column once",
            )
        idx[name] = i
    for name in COLUMNS[kind]:
        if name not in idx:
            raise _fail(
                f"missing column {name!r}",
                source,
                tab.header_line,
                key=name,
                expected="columns " + ",".join(COLUMNS[kind]),
            )
    return idx


def _numbers(
    tab: _Table,
    idx: dict[str, int],
    names: tuple[str, ...],
    source: str,
    optional: tuple[str, ...] = (),
) -> np.ndarray:
    out = np.empty((len(tab.rows), len(names)))
    width = len(tab.header)
    for r, (n, cells) in enumerate(tab.rows):
        if len(cells) != width:
            raise _fail(
                f"row has {len(cells)} cells", source, n, expected=f"{width} cells as in the header"
            )
        for c, name in enumerate(names):
            cell = cells[idx[name]]
            if cell == "" and name in optional:
                out[r, c] = math.nan
                continue
            try:
                v = float(cell)
            except ValueError:
                raise _fail(
                    f"{name} is {cell!r}, not a number",
                    source,
                    n,
                    idx[name] + 1,
                    key=name,
                    expected="a number",
                ) from None
            if not math.isfinite(v):
                raise _fail(
                    f"{name} is {cell}",
                    source,
                    n,
                    idx[name] + 1,
                    key=name,
                    expected="a finite number",
                )
            out[r, c] = v
    return out


def _kind(tab: _Table, source: str) -> str:
    kind = tab.meta.get("kind")
    if kind is None:
        raise _fail("no '# kind:' line", source, 1, expected="# kind: poses, ballbar or axis")
    if kind not in KINDS:
        raise _fail(
            f"unknown kind {kind!r}",
            source,
            tab.meta_lines["kind"],
            expected="poses, ballbar or axis",
        )
    return kind


def read_measurement(text: str, source: str = "<string>") -> Measurement:
    """Read any contract measurement file, by its ``# kind:``."""
    tab = _split(text, source)
    kind = _kind(tab, source)
    if kind == "poses":
        return _poses(tab, source)
    if kind == "ballbar":
        return _ballbar(tab, source)
    return _axis(tab, source)


def _expect_kind(text: str, source: str, want: str) -> _Table:
    tab = _split(text, source)
    kind = _kind(tab, source)
    if kind != want:
        raise _fail(
            f"a {kind} file where a {want} file was expected",
            source,
            tab.meta_lines["kind"],
            expected=f"# kind: {want}",
        )
    return tab


def read_poses(text: str, source: str = "<string>") -> PoseData:
    return _poses(_expect_kind(text, source, "poses"), source)


def read_ballbar(text: str, source: str = "<string>") -> BallbarRun:
    return _ballbar(_expect_kind(text, source, "ballbar"), source)


def read_axis(text: str, source: str = "<string>") -> AxisData:
    return _axis(_expect_kind(text, source, "axis"), source)


def _rows(tab: _Table) -> np.ndarray:
    return np.array([n for n, _ in tab.rows], dtype=int)


def _need_rows(tab: _Table, source: str, n_min: int, what: str) -> None:
    if len(tab.rows) < n_min:
        raise _fail(
            f"{len(tab.rows)} data rows",
            source,
            tab.header_line,
            expected=f"at least {n_min} rows for {what}",
        )


def _poses(tab: _Table, source: str) -> PoseData:
    idx = _columns(tab, "poses", source)
    _need_rows(tab, source, 1, "a pose file")
    v = _numbers(tab, idx, COLUMNS["poses"], source, optional=("ma", "mb"))
    for r, (n, _) in enumerate(tab.rows):
        if np.isnan(v[r, 8]) != np.isnan(v[r, 9]):
            raise _fail(
                "ma and mb must both be given or both be empty",
                source,
                n,
                idx["ma"] + 1,
                key="ma",
                expected="both or neither",
            )
    return PoseData(source, v[:, :5], v[:, 5:8], v[:, 8:10], _rows(tab), dict(tab.meta))


def _meta_vector(tab: _Table, key: str, n: int, source: str) -> np.ndarray:
    if key not in tab.meta:
        raise _fail(
            f"no '# {key}:' line",
            source,
            1,
            key=key,
            expected=f"# {key}: " + ", ".join(["x", "y", "z"][:n])
            if n > 1
            else f"# {key}: <number>",
        )
    try:
        v = np.array([float(s) for s in tab.meta[key].split(",")])
    except ValueError:
        raise _fail(
            f"{key} is {tab.meta[key]!r}",
            source,
            tab.meta_lines[key],
            key=key,
            expected=f"{n} numbers separated by commas",
        ) from None
    if v.shape != (n,) or not np.all(np.isfinite(v)):
        raise _fail(
            f"{key} is {tab.meta[key]!r}",
            source,
            tab.meta_lines[key],
            key=key,
            expected=f"{n} finite numbers",
        )
    return v


def _ballbar(tab: _Table, source: str) -> BallbarRun:
    idx = _columns(tab, "ballbar", source)
    pivot = _meta_vector(tab, "pivot", 3, source)
    length = float(_meta_vector(tab, "length", 1, source)[0])
    if length <= 0:
        raise _fail(
            f"length is {length:g}",
            source,
            tab.meta_lines["length"],
            key="length",
            expected="a ball-to-ball length > 0 mm",
        )
    _need_rows(tab, source, MIN_BALLBAR_ROWS, "a ballbar run")
    v = _numbers(tab, idx, COLUMNS["ballbar"], source)
    dt = np.diff(v[:, 0])
    if np.any(dt <= 0):
        n = tab.rows[int(np.argmax(dt <= 0)) + 1][0]
        raise _fail(
            "t does not increase",
            source,
            n,
            idx["t"] + 1,
            key="t",
            expected="rows in time order, t strictly increasing",
        )
    name = tab.meta.get("name", source)
    return BallbarRun(
        source, name, pivot, length, v[:, 0], v[:, 1:6], v[:, 6], _rows(tab), dict(tab.meta)
    )


def _axis(tab: _Table, source: str) -> AxisData:
    idx = _columns(tab, "axis", source)
    _need_rows(tab, source, 2, "a laser run")
    v = _numbers(tab, idx, COLUMNS["axis"], source)
    for r, (n, _) in enumerate(tab.rows):
        m, d, run = v[r, 0], v[r, 3], v[r, 4]
        if m not in (1, 2, 3, 5, 6):
            raise _fail(
                f"motor is {m:g}",
                source,
                n,
                idx["motor"] + 1,
                key="motor",
                expected="1, 2, 3, 5 or 6",
            )
        if d not in (1, -1):
            raise _fail(
                f"direction is {d:g}",
                source,
                n,
                idx["direction"] + 1,
                key="direction",
                expected="+1 or -1",
            )
        if run != int(run) or run < 1:
            raise _fail(
                f"run is {run:g}",
                source,
                n,
                idx["run"] + 1,
                key="run",
                expected="a positive whole number",
            )
    return AxisData(
        source,
        v[:, 0].astype(int),
        v[:, 1],
        v[:, 2],
        v[:, 3].astype(int),
        v[:, 4].astype(int),
        _rows(tab),
        dict(tab.meta),
    )


def _fmt(x: float, decimals: int) -> str:
    return f"{round(float(x), decimals) + 0.0:.{decimals}f}"


def format_poses(d: PoseData) -> str:
    lines = ["# kind: poses", ",".join(COLUMNS["poses"])]
    for q, tip, ax in zip(d.commanded, d.tip, d.axis, strict=True):
        cells = [_fmt(v, 6) for v in (*q, *tip)]
        cells += ["" if math.isnan(v) else _fmt(v, 6) for v in ax]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def format_ballbar(r: BallbarRun) -> str:
    lines = [
        "# kind: ballbar",
        f"# name: {r.name}",
        "# pivot: " + ", ".join(f"{v:g}" for v in r.pivot),
        f"# length: {r.length:g}",
        ",".join(COLUMNS["ballbar"]),
    ]
    for t, q, dev in zip(r.t, r.commanded, r.dev_um, strict=True):
        lines.append(",".join([_fmt(t, 6), *(_fmt(v, 6) for v in q), _fmt(dev, 4)]))
    return "\n".join(lines) + "\n"


def format_axis(d: AxisData) -> str:
    lines = ["# kind: axis", ",".join(COLUMNS["axis"])]
    for m, t, meas, di, run in zip(d.motor, d.target, d.measured, d.direction, d.run, strict=True):
        lines.append(f"{int(m)},{_fmt(t, 4)},{_fmt(meas, 6)},{int(di)},{int(run)}")
    return "\n".join(lines) + "\n"
