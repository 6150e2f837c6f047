"""Measurement files of the contract (``data-formats.md``): poses, ballbar runs, laser runs.

UTF-8 CSV with a header row; ``# key: value`` metadata lines before it; the kind in
``# kind:``. Readers take text and return arrays; every problem is a
:class:`~prsxy_post.errors.MeasurementError` naming the file, the line and the
column. Writers return the exact contract form (extra columns are allowed on
reading and ignored).

Provenance (an optional metadata key of this project; the contract's files stay
valid without it): ``# commanded_with: <profile file name> sha256:<64 hex digits>``
says which profile commanded the machine while it was measured, by the sha256 of
that profile file's bytes (what ``sha256sum shop.toml`` prints). ``simulate``
writes it into every file; for a real instrument's export add the line by hand
before the header. ``calibrate`` and ``diagnose`` read it and refuse data that
were commanded with another profile than the one they are told
(:func:`check_commanded_with`).
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Sequence
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
#: the optional provenance key (module docstring)
COMMANDED_WITH = "commanded_with"
_SHA256 = re.compile(r"sha256:([0-9a-fA-F]{64})")


@dataclass(frozen=True)
class CommandedWith:
    """Which profile commanded the machine while it was measured.

    name : the profile's file name (for people; the digest decides)
    sha256 : hex digest of the profile file's bytes
    line : the metadata line it was read from (for messages), None when made here
    """

    name: str
    sha256: str
    line: int | None = field(default=None, compare=False)

    def __str__(self) -> str:
        return f"{self.name} sha256:{self.sha256}"

    @classmethod
    def of(cls, name: str, content: str | bytes) -> CommandedWith:
        """The fingerprint of a profile file: its name and the sha256 of its bytes."""
        data = content.encode("utf-8") if isinstance(content, str) else content
        return cls(name, hashlib.sha256(data).hexdigest())


@dataclass(frozen=True)
class PoseData:
    """Measured tool tip and axis at commanded poses.

    commanded : (N, 5) [mm, mm, mm, deg, deg], workpiece frame
    tip : (N, 3) measured mx, my, mz [mm]
    axis : (N, 2) measured ma, mb [deg]; NaN where the file leaves them empty
    rows : (N,) line number of each row in the file
    commanded_with : the profile that commanded the machine, when the file says
    """

    source: str
    commanded: np.ndarray
    tip: np.ndarray
    axis: np.ndarray
    rows: np.ndarray
    meta: dict[str, str] = field(default_factory=dict)
    commanded_with: CommandedWith | None = None


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
    commanded_with: CommandedWith | None = None


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
    commanded_with: CommandedWith | None = None


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
    return PoseData(
        source,
        v[:, :5],
        v[:, 5:8],
        v[:, 8:10],
        _rows(tab),
        dict(tab.meta),
        _commanded_with(tab, source),
    )


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
        source,
        name,
        pivot,
        length,
        v[:, 0],
        v[:, 1:6],
        v[:, 6],
        _rows(tab),
        dict(tab.meta),
        _commanded_with(tab, source),
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
        _commanded_with(tab, source),
    )


def _commanded_with(tab: _Table, source: str) -> CommandedWith | None:
    """The optional ``# commanded_with:`` line, checked for its form."""
    value = tab.meta.get(COMMANDED_WITH)
    if value is None:
        return None
    line = tab.meta_lines[COMMANDED_WITH]
    m = _SHA256.search(value)
    name = value[: m.start()].strip() if m else ""
    if m is None or value[m.end() :].strip() or not name:
        raise _fail(
            f"commanded_with is {value!r}",
            source,
            line,
            key=COMMANDED_WITH,
            expected="<profile file name> sha256:<64 hex digits of the file's sha256>",
        )
    return CommandedWith(name, m.group(1).lower(), line)


def check_commanded_with(
    data: Sequence[Measurement], commanding: CommandedWith, option: str = "--profile"
) -> None:
    """Refuse measurements that say another profile commanded the machine.

    Files without ``# commanded_with:`` are taken at the caller's word (the
    contract's form has no such line).

    Raises
    ------
    MeasurementError
        At the first file whose digest differs from ``commanding``'s, naming both.
    """
    for d in data:
        cw = d.commanded_with
        if cw is None or cw.sha256 == commanding.sha256:
            continue
        raise MeasurementError(
            f"measured while the machine was commanded with {cw.name} "
            f"(sha256 {cw.sha256[:12]}…), not with {commanding.name} "
            f"(sha256 {commanding.sha256[:12]}…) as {option} says",
            source=d.source,
            line=cw.line,
            key=COMMANDED_WITH,
            expected=f"--commanded-with naming the profile {cw.name} that commanded it, "
            "or --ignore-provenance to use these data anyway",
        )


def _meta_lines(d: Measurement) -> list[str]:
    return [f"# {COMMANDED_WITH}: {d.commanded_with}"] if d.commanded_with is not None else []


def _fmt(x: float, decimals: int) -> str:
    return f"{round(float(x), decimals) + 0.0:.{decimals}f}"


def format_poses(d: PoseData) -> str:
    lines = ["# kind: poses", *_meta_lines(d), ",".join(COLUMNS["poses"])]
    for q, tip, ax in zip(d.commanded, d.tip, d.axis, strict=True):
        cells = [_fmt(v, 6) for v in (*q, *tip)]
        cells += ["" if math.isnan(v) else _fmt(v, 6) for v in ax]
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def format_ballbar(r: BallbarRun) -> str:
    lines = [
        "# kind: ballbar",
        *_meta_lines(r),
        f"# name: {r.name}",
        "# pivot: " + ", ".join(f"{v:g}" for v in r.pivot),
        f"# length: {r.length:g}",
        ",".join(COLUMNS["ballbar"]),
    ]
    for t, q, dev in zip(r.t, r.commanded, r.dev_um, strict=True):
        lines.append(",".join([_fmt(t, 6), *(_fmt(v, 6) for v in q), _fmt(dev, 4)]))
    return "\n".join(lines) + "\n"


def format_axis(d: AxisData) -> str:
    lines = ["# kind: axis", *_meta_lines(d), ",".join(COLUMNS["axis"])]
    for m, t, meas, di, run in zip(d.motor, d.target, d.measured, d.direction, d.run, strict=True):
        lines.append(f"{int(m)},{_fmt(t, 4)},{_fmt(meas, 6)},{int(di)},{int(run)}")
    return "\n".join(lines) + "\n"
