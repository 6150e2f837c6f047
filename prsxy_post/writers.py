"""Output writers: Turbo PMAC motion programs and corrected Cartesian G-code.

Both take the chain's arrays and return text; they never touch files.

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

from . import __version__
from .chain import MOTOR_ORDER, ChainResult
from .profile import Profile

#: PVT segment times are limited to 4095.9998 ms with I42 = 0; longer stays are DWELLs.
PVT_MAX_MS = 4095.0


@dataclass(frozen=True)
class Provenance:
    """What a program was made from, for its header."""

    source: str
    source_sha256: str
    profile_name: str
    profile_source: str
    profile_sha256: str
    options: str


def _fmt(x: np.ndarray, decimals: int) -> np.ndarray:
    """Round and clear negative zeros so equal values print equal bytes."""
    return np.round(x, decimals) + 0.0


def motor_velocities(P: np.ndarray, dt: np.ndarray, speed: np.ndarray) -> np.ndarray:
    """End velocities for PVT [mm/s]: central differences over the two segments.

    v_k = (P_{k+1} − P_{k−1}) / (dt_k + dt_{k+1}); zero where the path stands
    (planned speed 0: start, stops, dwells, the end).
    """
    n = len(P)
    v = np.zeros_like(P)
    if n >= 3:
        span = dt[1:-1] + dt[2:]
        v[1:-1] = (P[2:] - P[:-2]) / span[:, None]
    v[speed <= 0] = 0.0
    v[-1] = 0.0
    return v


def _header_lines(prov: Provenance, profile: Profile, result: ChainResult,
                  extra: Sequence[str]) -> list[str]:
    s = result.samples
    total = float(np.sum(s.dt))
    lines = [
        f"prsxy-post {__version__}",
        f"source: {prov.source}",
        f"source sha256: {prov.source_sha256}",
        f"profile: {prov.profile_name} ({prov.profile_source})",
        f"profile sha256: {prov.profile_sha256}",
        f"options: {prov.options}",
        f"points: {len(s)}; period: {profile.period_ms:g} ms; duration: {total:.3f} s",
        *extra,
    ]
    return lines


def write_pmac(result: ChainResult, profile: Profile, prov: Provenance,
               parts: int | None = None) -> list[str]:
    """A Turbo PMAC motion program (one text per part).

    Parameters
    ----------
    result : ChainResult
    profile : Profile (motor names, counts per mm, coordinate system, program number)
    prov : Provenance
    parts : split into programs of at most ``output.max_points_per_program``
        points when that is > 0; ``output.rotary_buffer_points`` > 0 writes for a
        rotary buffer instead (one text).

    Returns
    -------
    list of str, one per program.
    """
    out = profile.output
    dec = int(out["decimals"])
    cs = int(out["coordinate_system"])
    prog = int(out["program"])
    s = result.samples
    P = _fmt(result.P_cmd, dec)
    V = _fmt(motor_velocities(result.P_cmd, s.dt, s.speed), 4)
    names = [profile.motor(m).axis for m in MOTOR_ORDER]
    motors_txt = " ".join(str(m) for m in MOTOR_ORDER)
    setup = [
        "Controller settings that must be OFF on motors " + motors_txt + ", or the errors",
        "are compensated twice: leadscrew compensation tables (DEFINE COMP; Ixx51 = 0),",
        "backlash (Ixx86 = 0, Ixx85 = 0), and any kinematic subroutines in this",
        "coordinate system (Isx50 = 0): motors are commanded directly.",
        "PVT velocities are in mm/s: Isx90 = 1000. Motor positions in mm (#n->counts/mm).",
        "Spindle, coolant and tool changes are not in this program.",
    ]
    head = ["; " + x for x in _header_lines(prov, profile, result, setup)]
    defs = [f"#{m}->{profile.motor(m).counts_per_mm:g}{profile.motor(m).axis}"
            for m in MOTOR_ORDER]
    rot = int(out["rotary_buffer_points"])
    max_pts = int(out["max_points_per_program"])
    n = len(s)
    if rot > 0:
        bounds = [(0, n)]
    elif max_pts > 0:
        bounds = [(i, min(i + max_pts, n)) for i in range(0, n, max_pts)]
    else:
        bounds = [(0, n)]
    texts = []
    for part, (i0, i1) in enumerate(bounds):
        body: list[str] = []
        body += head
        if len(bounds) > 1:
            body.append(f"; part {part + 1} of {len(bounds)}: points {i0} to {i1 - 1}; run the "
                        "parts in order (each starts where the previous ended)")
        body.append("CLOSE")
        body.append(f"&{cs}")
        body += defs
        if rot > 0:
            body.append(f"DEFINE ROT {rot}")
            body.append("; stream the lines below into the rotary buffer (B0 R), "
                        f"keeping at most {rot} points ahead")
            body.append("OPEN ROT")
        else:
            body.append(f"OPEN PROG {prog + part} CLEAR")
        body.append("ABS")
        start = P[i0]
        body.append("RAPID " + " ".join(f"{a}{x:.{dec}f}" for a, x in zip(names, start,
                                                                            strict=True)))
        body.append("DWELL0")
        tm_cur = None
        last_line = None
        for k in range(max(i0, 1), i1):
            if s.first[k] or s.line[k] != last_line:
                body.append(f"; line {int(s.line[k])}")
                last_line = s.line[k]
            ms = float(s.dt[k] * 1000.0)
            pos = P[k]
            if np.array_equal(pos, P[k - 1]) and s.speed[k] == 0 and ms > 0:
                # the path stands (dwell): a DWELL keeps it there for any length
                body.append(f"DWELL{ms:.4f}")
                continue
            if ms > PVT_MAX_MS:
                raise AssertionError("segment longer than PVT allows")  # period <= 1000 ms
            ms_txt = f"{ms:.4f}"
            if ms_txt != tm_cur:
                body.append(f"PVT{ms_txt}")
                tm_cur = ms_txt
            vel = V[k] if k < i1 - 1 else np.zeros(5)
            body.append(" ".join(f"{a}{x:.{dec}f}:{v:.4f}" for a, x, v in zip(
                names, pos, vel, strict=True)))
        body.append("CLOSE")
        texts.append("\n".join(body) + "\n")
    return texts


def write_gcode(result: ChainResult, q_written: np.ndarray, profile: Profile,
                prov: Provenance, tolerance_mm: float = 0.0) -> str:
    """Corrected Cartesian G-code for a controller running [controller_kinematics].

    Each point is FK_controller(final motor commands), so the controller's own
    inverse kinematics reproduces the compensated motor commands. Timing is kept
    with G93 inverse time: F = 1 / (segment minutes).

    Parameters
    ----------
    q_written : (N, 5) the points to write [mm, deg], controller workpiece frame
    tolerance_mm : drop points while the chord through the kept ones stays within
        this distance (in XYZ, and in A/B read as mm at 1 mm = 1°); 0 keeps every point.
    """
    dec = int(profile.output["decimals"])
    s = result.samples
    keep = _reduce(q_written, s, tolerance_mm)
    ck = "profile [controller_kinematics]" if profile.controller_kinematics else \
        "the nominal design"
    extra = [
        f"For a controller whose inverse kinematics is {ck}, with an ideal table.",
        "Run with no tool length offset (G49) and no work offset: tool lengths and",
        "offsets are in the points. Timing is G93 inverse time per segment.",
    ]
    lines = ["%"]
    # G-code comments cannot nest parentheses
    lines += ["(" + x.replace("(", "[").replace(")", "]") + ")"
              for x in _header_lines(prov, profile, result, extra)]
    lines.append("G21 G90 G17 G40 G49 G94")
    q = _fmt(q_written, dec)
    ax = "XYZAB"
    lines.append("G0 " + " ".join(f"{a}{x:.{dec}f}" for a, x in zip(ax, q[0], strict=True)))
    lines.append("G93")
    last_line = None
    t_acc = 0.0
    for k in range(1, len(s)):
        t_acc += float(s.dt[k])
        if s.first[k] and s.line[k] != last_line:
            lines.append(f"(line {int(s.line[k])})")
            last_line = s.line[k]
        if not keep[k]:
            continue
        if np.array_equal(q[k], q[k - 1]) and s.speed[k] == 0:
            lines.append(f"G4 P{t_acc:.4f}")
        else:
            f = 1.0 / (t_acc / 60.0)
            lines.append("G1 " + " ".join(f"{a}{x:.{dec}f}" for a, x in zip(ax, q[k],
                                                                           strict=True))
                         + f" F{f:.3f}")
        t_acc = 0.0
    lines.append("G94")
    lines.append("M2")
    lines.append("%")
    return "\n".join(lines) + "\n"


def _reduce(q: np.ndarray, s, tol: float) -> np.ndarray:
    """Points to keep: all when tol = 0; else a greedy chord test within each block."""
    n = len(q)
    keep = np.ones(n, dtype=bool)
    if tol <= 0 or n < 3:
        return keep
    anchor = 0
    for k in range(1, n - 1):
        # never drop a block's end point (next point starts a new block) or a stop
        if s.first[k + 1] or s.speed[k] == 0:
            anchor = k
            continue
        seg = q[anchor:k + 2]
        a, b = seg[0], seg[-1]
        d = b - a
        dd = float(d @ d)
        if dd == 0:
            anchor = k
            continue
        t = np.clip((seg - a) @ d / dd, 0, 1)
        dev = np.linalg.norm(seg - (a + t[:, None] * d), axis=1).max()
        if dev <= tol:
            keep[k] = False
        else:
            anchor = k
    return keep
