"""Output writers: Turbo PMAC motion programs and corrected Cartesian G-code.

Both are streaming: ``begin()``, then ``feed(chunk)`` for every
:class:`~prsxy_post.chain.PointChunk` in order, then ``finish()``. Each returns
text pieces tagged with the output part they belong to; the caller (the CLI)
decides where they go. Nothing here touches files.

PMAC output uses PVT mode: each line gives every motor's end position and end
velocity, and Turbo PMAC computes the unique cubic between consecutive points
(Turbo PMAC Software Reference, "PVT{data}"). The trajectory therefore passes
exactly through every interpolation point, and the segment time may change on
the fly, which lets every block end on a point. SPLINE1 would move the points
by (Dist(n+1) − Dist(n)) / 6 and cannot change its segment time without a stop.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from . import __version__, kinematics
from .chain import MOTOR_ORDER, ChainResult, PointChunk
from .profile import Profile

#: PVT segment times are limited to 4095.9998 ms with I42 = 0; longer stays are DWELLs.
PVT_MAX_MS = 4095.0

Piece = tuple[int, str]  # (output part, text)


@dataclass(frozen=True)
class Provenance:
    """What a program was made from, for its header."""

    source: str
    source_sha256: str
    profile_name: str
    profile_source: str
    profile_sha256: str
    options: str


def _round(x: np.ndarray, decimals: int) -> np.ndarray:
    """Round and clear negative zeros so equal values print equal bytes."""
    return np.round(x, decimals) + 0.0


#: integer digits the vectorised formatter writes; larger values take Python's %
_INT_DIGITS = 9


def format_fixed_rows(columns: Sequence[tuple[str, np.ndarray, int]], end: str = "\n") -> list[str]:
    """Rows of text, ``prefix value prefix value ...``, each value in fixed point.

    The same text as ``"%s%.{d}f" % (prefix, value)`` per column, built for all
    rows at once: digits as bytes in an (N, width) array, unused places dropped.
    Python formats a value itself only where the scaled value lies within 1e-6
    of a rounding tie (there the binary value decides, as in Python), and every
    value when one is too large for :data:`_INT_DIGITS` (or for exact integers).

    Parameters
    ----------
    columns : (prefix, values (N,), decimals) per column
    end : text after each row (kept on the returned rows)
    """
    n = len(columns[0][1]) if columns else 0
    if n == 0:
        return []
    parts: list[np.ndarray] = []
    for prefix, values, d in columns:
        if prefix:
            parts.append(np.tile(np.frombuffer(prefix.encode("ascii"), np.uint8), (n, 1)))
        v = np.asarray(values, dtype=float)
        if not np.all(np.abs(v) < min(10.0**_INT_DIGITS, 2.0**52 / 10.0**d)):
            text = "".join(
                "".join(
                    f"{p}{x:.{dd}f}"
                    for p, x, dd in zip(
                        [c[0] for c in columns], row, [c[2] for c in columns], strict=True
                    )
                )
                + end
                for row in np.column_stack([c[1] for c in columns]).tolist()
            )
            return text.splitlines(keepends=True)
        t = np.abs(v) * 10.0**d
        k = np.rint(t).astype(np.int64)
        tie = np.flatnonzero(np.abs(t - np.floor(t) - 0.5) < 1e-6)
        if tie.size:
            k[tie] = [int(f"{abs(x):.{d}f}".replace(".", "")) for x in v[tie].tolist()]
        width = max(len(str(int(k.max()))), d + 1)  # at least the units digit
        digits = np.empty((width, n), np.uint8)
        # int32 division is several times faster than int64 where the values fit
        x = k.astype(np.int32) if width < 10 else k
        for j in range(width - 1, -1, -1):
            q = x // 10
            digits[j] = x - q * 10
            x = q
        int_w = width - d
        chars = (digits + np.uint8(48)).T
        # leading zeros of the integer part go, the units digit stays
        chars[:, : int_w - 1] *= np.maximum.accumulate(digits[: int_w - 1], axis=0).T != 0
        sign = np.where(np.signbit(v), ord("-"), 0).astype(np.uint8)
        block = np.zeros((n, width + 2), np.uint8)
        block[:, 0] = sign
        block[:, 1 : int_w + 1] = chars[:, :int_w]
        if d:
            block[:, int_w + 1] = ord(".")
            block[:, int_w + 2 :] = chars[:, int_w:]
        parts.append(block)
    parts.append(np.tile(np.frombuffer(end.encode("ascii"), np.uint8), (n, 1)))
    flat = np.hstack(parts).ravel()
    return np.compress(flat != 0, flat).tobytes().decode("ascii").splitlines(keepends=True)


def _header(prov: Provenance, profile: Profile, extra: Sequence[str]) -> list[str]:
    return [
        f"prsxy-post {__version__}",
        f"source: {prov.source}",
        f"source sha256: {prov.source_sha256}",
        f"profile: {prov.profile_name} ({prov.profile_source})",
        f"profile sha256: {prov.profile_sha256}",
        f"options: {prov.options}",
        f"interpolation period: {profile.period_ms:g} ms",
        *extra,
    ]


def _empty_chunk() -> PointChunk:
    return PointChunk(
        *(
            np.zeros((0, 5))
            if f in ("q", "q_target", "P_ideal", "P_cmd")
            else np.zeros(0, dtype=bool)
            if f == "first"
            else np.zeros(0)
            for f in PointChunk.__dataclass_fields__
        )
    )


class _Lookahead:
    """Holds one point back: a point's velocity needs the next point."""

    def __init__(self) -> None:
        self.buf: PointChunk | None = None
        self.prev: tuple[np.ndarray, float] | None = None  # (P, dt) of the last point out

    def push(
        self, chunk: PointChunk, final: bool
    ) -> tuple[PointChunk, np.ndarray, np.ndarray] | None:
        """Points now complete, their PVT velocities, and whether each ends its block."""
        buf = chunk if self.buf is None else PointChunk.concat([self.buf, chunk])
        n = len(buf)
        k = n if final else n - 1
        if k <= 0:
            self.buf = buf
            return None
        P = buf.P_cmd
        dt = buf.dt
        # neighbours: previous point (carried) and next point (buffered)
        P_prev = np.vstack([self.prev[0][None, :] if self.prev else P[:1], P[:-1]])
        P_next = np.vstack([P[1:], P[-1:]])
        dt_next = np.concatenate([dt[1:], [0.0]])
        span = dt[:k] + dt_next[:k]
        with np.errstate(invalid="ignore", divide="ignore"):
            v = np.where(span[:, None] > 0, (P_next[:k] - P_prev[:k]) / span[:, None], 0.0)
        v[buf.speed[:k] <= 0] = 0.0  # the path stands here: start, stops, dwells
        if self.prev is None:
            v[0] = 0.0
        if final:
            v[-1] = 0.0
        ends = np.concatenate([buf.first[1:], [True]])[:k]
        self.prev = (P[k - 1].copy(), float(dt[k - 1]))
        self.buf = None if k == n else buf.take(slice(k, n))
        return buf.take(slice(0, k)), v, ends


class PmacWriter:
    """A Turbo PMAC PVT motion program, streamed.

    Long jobs: ``output.max_points_per_program`` > 0 splits the points into
    programs PROG n, n+1, ... (parts, each a file, run in order);
    ``output.rotary_buffer_points`` > 0 writes for a rotary buffer instead.
    """

    def __init__(self, profile: Profile, prov: Provenance) -> None:
        self.profile = profile
        self.prov = prov
        out = profile.output
        self.dec = int(out["decimals"])
        self.cs = int(out["coordinate_system"])
        self.prog = int(out["program"])
        self.rot = int(out["rotary_buffer_points"])
        self.max_pts = 0 if self.rot else int(out["max_points_per_program"])
        self.names = [profile.motor(m).axis for m in MOTOR_ORDER]
        self.look = _Lookahead()
        self.part = 0
        self.in_part = 0  # points written in the current part
        self.n = 0  # points written in all
        self.t_total = 0.0
        self.tm_cur: str | None = None
        self.last_line: int | None = None
        self.last_P: np.ndarray | None = None
        d = self.dec
        self.pos_fmt = " ".join(f"{a}%.{d}f" for a in self.names)

    def _open_part(self, P0: np.ndarray) -> list[str]:
        motors = " ".join(str(m) for m in MOTOR_ORDER)
        setup = [
            "Controller settings that must be OFF on motors " + motors + ", or the errors",
            "are compensated twice: leadscrew compensation tables (DEFINE COMP; Ixx51 = 0),",
            "backlash (Ixx86 = 0, Ixx85 = 0), and any kinematic subroutines in this",
            "coordinate system (Isx50 = 0): motors are commanded directly.",
            "PVT velocities are in mm/s: Isx90 = 1000. Motor positions in mm (#n->counts/mm).",
            "Spindle, coolant and tool changes are not in this program.",
        ]
        lines = ["; " + x for x in _header(self.prov, self.profile, setup)]
        if self.max_pts:
            lines.append(
                f"; part {self.part + 1}: run the parts in order; each starts where "
                "the previous one ended"
            )
        lines += ["CLOSE", f"&{self.cs}"]
        lines += [
            f"#{m}->{self.profile.motor(m).counts_per_mm:g}{self.profile.motor(m).axis}"
            for m in MOTOR_ORDER
        ]
        if self.rot:
            lines += [
                f"DEFINE ROT {self.rot}",
                f"; stream the lines below into the rotary buffer (B0 R), at most "
                f"{self.rot} points ahead",
                "OPEN ROT",
            ]
        else:
            lines.append(f"OPEN PROG {self.prog + self.part} CLEAR")
        lines += ["ABS", "RAPID " + self.pos_fmt % tuple(_round(P0, self.dec)), "DWELL0"]
        self.tm_cur = None
        self.last_line = None
        return lines

    def begin(self) -> list[Piece]:
        return []

    def feed(self, chunk: PointChunk, final: bool = False) -> list[Piece]:
        got = self.look.push(chunk, final)
        if got is None:
            return []
        pts, vel, _ = got
        n = len(pts)
        P = _round(pts.P_cmd, self.dec)
        V = _round(vel, 4)
        # all text that can be made for the whole chunk at once is made here; the
        # loop below runs once per part
        rows = format_fixed_rows(
            [
                col
                for i, a in enumerate(self.names)
                for col in ((f"{' ' if i else ''}{a}", P[:, i], self.dec), (":", V[:, i], 4))
            ]
        )
        prev = np.vstack([self.last_P[None, :] if self.last_P is not None else P[:1], P[:-1]])
        standing = np.all(P == prev, axis=1) & (pts.speed == 0) & (pts.dt > 0)
        pieces: list[Piece] = []
        out: list[str] = []
        k = 0
        while k < n:
            if self.n == 0 or (self.max_pts and self.in_part >= self.max_pts):
                if out:
                    pieces.append((self.part, "".join(out)))
                    out = []
                if self.n:
                    pieces.append((self.part, "CLOSE\n"))
                    self.part += 1
                    self.in_part = 0
                out += [x + "\n" for x in self._open_part(P[k])]
                if self.n == 0:
                    self.n = 1
                    self.in_part = 1
                    k += 1
                    continue
            stop = n if not self.max_pts else min(n, k + self.max_pts - self.in_part)
            out.append(self._segment(pts, rows, standing, k, stop))
            self.n += stop - k
            self.in_part += stop - k
            k = stop
        if n:
            self.last_P = P[-1]
        if out:
            pieces.append((self.part, "".join(out)))
        return pieces

    def _segment(
        self, pts: PointChunk, rows: list[str], standing: np.ndarray, k0: int, k1: int
    ) -> str:
        """Points k0..k1 of one part: each with its line comment when the G-code line
        changes, a PVT time when the segment time changes, and its row (or a DWELL
        where the path stands)."""
        m = k1 - k0
        line = pts.line[k0:k1]
        # one running sum in order (accumulate is sequential, unlike sum): the same
        # bits however the program was chunked
        self.t_total = float(np.add.accumulate(np.concatenate([[self.t_total], pts.dt[k0:k1]]))[-1])
        text = np.empty((m, 3), dtype=object)
        text[:] = ""
        prev_line = np.concatenate([[-1 if self.last_line is None else self.last_line], line[:-1]])
        changed = np.flatnonzero(line != prev_line)
        text[changed, 0] = [f"; line {ln}\n" for ln in line[changed].tolist()]
        self.last_line = int(line[-1])
        stand = standing[k0:k1]
        ms = format_fixed_rows([("", pts.dt[k0:k1] * 1000.0, 4)])  # "%.4f\n" each
        moving = np.flatnonzero(~stand)
        if moving.size:
            mv = [ms[i] for i in moving.tolist()]
            before = [self.tm_cur, *mv[:-1]]
            new = [i for i, a, b in zip(moving.tolist(), mv, before, strict=True) if a != b]
            text[new, 1] = ["PVT" + ms[i] for i in new]
            self.tm_cur = mv[-1]
        text[:, 2] = rows[k0:k1]
        for i in np.flatnonzero(stand).tolist():
            # the path stands (dwell): a DWELL holds it for any length
            text[i, 2] = "DWELL" + ms[i]
        return "".join(text.ravel().tolist())

    def finish(self, chunk: PointChunk | None = None) -> list[Piece]:
        pieces = self.feed(chunk if chunk is not None else _empty_chunk(), final=True)
        pieces.append((self.part, f"; end: {self.n} points, {self.t_total:.3f} s\nCLOSE\n"))
        return pieces


class GcodeWriter:
    """Corrected Cartesian G-code for a controller running [controller_kinematics].

    Each point is FK_controller(final motor commands), so the controller's own
    inverse kinematics reproduces the compensated motor commands. Timing is kept
    with G93 inverse time: F = 1 / (segment minutes). With a tolerance > 0,
    points are dropped while the chord from the last written point stays within
    it of every point in between (XYZ in mm, A/B read as mm at 1 mm per degree);
    a block's end point and every stop are always written.
    """

    def __init__(self, profile: Profile, prov: Provenance, tolerance_mm: float = 0.0) -> None:
        from .chain import controller_geometry

        self.profile = profile
        self.prov = prov
        self.tol = tolerance_mm
        self.dec = int(profile.output["decimals"])
        self.cgeo = controller_geometry(profile)
        self.n = 0
        self.t_total = 0.0
        self.last_line: int | None = None
        self.last_q: np.ndarray | None = None
        self.run: list[tuple[np.ndarray, float]] = []  # held back: (point, its dt)
        self.look = _Lookahead()
        self.fmt = " ".join(f"{a}%.{self.dec}f" for a in "XYZAB")

    def begin(self) -> list[Piece]:
        ck = (
            "profile [controller_kinematics]"
            if self.profile.controller_kinematics
            else "the nominal design"
        )
        extra = [
            f"For a controller whose inverse kinematics is {ck}, with an ideal table.",
            "Run with no tool length offset (G49) and no work offset: tool lengths and",
            "offsets are in the points. Timing is G93 inverse time per segment.",
        ]
        lines = ["%"] + [
            "(" + x.replace("(", "[").replace(")", "]") + ")"
            for x in _header(self.prov, self.profile, extra)
        ]
        lines.append("G21 G90 G17 G40 G49 G94")
        return [(0, "\n".join(lines) + "\n")]

    def written_points(self, chunk: PointChunk) -> np.ndarray:
        """FK of the controller's geometry at the motor commands, warm-started."""
        from .errors import ReachError

        guess = kinematics.platform_guess(
            kinematics.solve_platform(self.cgeo, chunk.q_target), chunk.q_target
        )
        q, ok = kinematics.forward(self.cgeo, chunk.P_cmd, guess=guess)
        if not np.all(ok):
            k = int(np.argmin(ok))
            raise ReachError(
                "the controller's kinematics cannot express this point",
                line=int(chunk.line[k]),
                expected="a pose within reach of [controller_kinematics]",
            )
        return q

    def feed(self, chunk: PointChunk, final: bool = False) -> list[Piece]:
        got = self.look.push(chunk, final)
        if got is None:
            return []
        chunk, _, ends = got
        q = _round(self.written_points(chunk), self.dec)
        lines: list[str] = []
        for k in range(len(chunk)):
            qk = q[k]
            if self.n == 0:
                lines.append("G0 " + self.fmt % tuple(qk))
                lines.append("G93")
                self.last_q = qk
                self.n = 1
                continue
            if chunk.line[k] != self.last_line:
                lines.append(f"(line {int(chunk.line[k])})")
                self.last_line = int(chunk.line[k])
            dtk = float(chunk.dt[k])
            self.t_total += dtk
            standing = (
                self.last_q is not None
                and np.array_equal(qk, self.last_q)
                and chunk.speed[k] == 0
                and not self.run
            )
            if standing:
                lines.append(f"G4 P{dtk:.4f}")
                continue
            if self.tol > 0 and not ends[k] and chunk.speed[k] > 0:
                # a point that may be dropped: keep it back while the chord from the
                # last written point to it passes all the held-back ones
                if not self._within(qk):
                    self._write_held(lines)
                self.run.append((qk, dtk))
                continue
            if self.run and not self._within(qk):
                self._write_held(lines)
            t = dtk + sum(d for _, d in self.run)
            lines.append("G1 " + self.fmt % tuple(qk) + f" F{60.0 / t:.3f}")
            self.last_q = qk
            self.run = []
            self.n += 1
        return [(0, "\n".join(lines) + "\n")] if lines else []

    def _write_held(self, lines: list[str]) -> None:
        """Write the last held-back point (it becomes the new chord start)."""
        qh = self.run[-1][0]
        t = sum(d for _, d in self.run)
        lines.append("G1 " + self.fmt % tuple(qh) + f" F{60.0 / t:.3f}")
        self.last_q = qh
        self.run = []
        self.n += 1

    def _within(self, qk: np.ndarray) -> bool:
        """Would the chord from the last written point to qk pass the held-back points?"""
        if not self.run or self.last_q is None:
            return True
        a = self.last_q
        d = qk - a
        dd = float(d @ d)
        if dd == 0:
            return False
        pts = np.array([p for p, _ in self.run])
        t = np.clip((pts - a) @ d / dd, 0, 1)
        return float(np.linalg.norm(pts - (a + t[:, None] * d), axis=1).max()) <= self.tol

    def finish(self, chunk: PointChunk | None = None) -> list[Piece]:
        pieces = self.feed(chunk if chunk is not None else _empty_chunk(), final=True)
        pieces.append((0, f"G94\nM2\n(end: {self.n} points, {self.t_total:.3f} s)\n%\n"))
        return pieces


def _collect(writer: PmacWriter | GcodeWriter, chunk: PointChunk) -> list[str]:
    parts: dict[int, list[str]] = {}
    for part, text in [*writer.begin(), *writer.finish(chunk)]:
        parts.setdefault(part, []).append(text)
    return ["".join(parts[k]) for k in sorted(parts)]


def _chunk_of(result: ChainResult) -> PointChunk:
    s = result.samples
    t = result.t if len(result.t) == len(s) else np.cumsum(s.dt)
    return PointChunk(
        s.q,
        s.dt,
        t,
        s.line,
        s.first,
        s.tool_length,
        s.speed,
        result.q_target,
        result.P_ideal,
        result.P_cmd,
    )


def write_pmac(result: ChainResult, profile: Profile, prov: Provenance) -> list[str]:
    """A whole PMAC program in memory (one text per part)."""
    return _collect(PmacWriter(profile, prov), _chunk_of(result))


def write_gcode(
    result: ChainResult, profile: Profile, prov: Provenance, tolerance_mm: float = 0.0
) -> str:
    """Whole corrected G-code in memory."""
    return _collect(GcodeWriter(profile, prov, tolerance_mm), _chunk_of(result))[0]
