"""The Core promise, end to end: a converted program, run by the machine it was made
for, traces the programmed path.

The written PMAC program (and the written G-code, through a controller running
[controller_kinematics]) is read back from its text, executed by the machine as the
contract defines it (play model, then forward kinematics of the true geometry), and
every executed point is held against the G-code's own geometry, computed here from
the interpreted motions (lines, arcs, helices), not from the interpolator:

- every point lies within 0.5 µm and 0.5 arcsec of its block's path;
- every block's end point is reached within 0.5 µm and 0.5 arcsec;
- the speed between points never exceeds F.

Machines: the nominal design and several with random errors in every contract term
and real-axis tables with backlash.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from prsxy_post import chain, gcode, kinematics, program, simulate, writers
from prsxy_post import profile as profile_mod

from .conftest import ROOT

TOL_MM = 0.5e-3
TOL_DEG = 0.5 / 3600

PROGRAMS = sorted((ROOT / "samples").glob("*.ngc"))


def read_pmac(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Motor positions (N, 5), segment times [s] and source line of every point."""
    names = "UVWXY"
    P, dt, line = [], [], []
    tm = 0.0
    cur_line = 0
    for raw in text.splitlines():
        s = raw.strip()
        if s.startswith("; line "):
            cur_line = int(s[7:])
            continue
        if not s or s.startswith(";"):
            continue
        if s.startswith("PVT"):
            tm = float(s[3:]) / 1000.0
            continue
        if s.startswith("DWELL"):
            if P and float(s[5:]) > 0:
                P.append(P[-1])
                dt.append(float(s[5:]) / 1000.0)
                line.append(cur_line)
            continue
        words = dict(re.findall(r"([UVWXY])(-?\d+\.\d+)", s))
        if set(words) == set(names):
            P.append([float(words[a]) for a in names])
            dt.append(0.0 if s.startswith("RAPID") else tm)
            line.append(cur_line)
    return np.array(P), np.array(dt), np.array(line)


def read_gcode_points(text: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Written G-code points (N, 5), segment times [s] from G93 F, source lines. A
    G2/G3 is its arc as LinuxCNC runs it (tests/controllers.GcodeArc), sampled
    in chords within 1 nm of it, its time shared evenly by the angle."""
    from . import controllers as ctl

    q, dt, line = [], [], []
    cur = 0
    plane = 17
    for s in text.splitlines():
        m = re.match(r"\(line (\d+)\)", s)
        if m:
            cur = int(m.group(1))
            continue
        w = dict(re.findall(r"([XYZABFPIJK])(-?\d+\.?\d*)", s))
        planes = re.findall(r"\bG(17|18|19)\b", s)
        if planes:
            plane = int(planes[-1])
        if s.startswith(("G2 ", "G3 ")):
            a = np.array(q[-1])
            b = np.array([float(w[c]) for c in "XYZAB"])
            iu, iv, _ = ctl.ARC_PLANES[plane]
            center = list(a[:3])
            for i in (iu, iv):
                center[i] += float(w.get("IJK"[i], 0.0))
            arc = ctl.GcodeArc((center[0], center[1], center[2]), plane, s[1] == "3")
            n = ctl.arc_substeps(arc, a, b, 1)
            for p in arc.at(a, b, np.linspace(0.0, 1.0, n + 1)[1:]):
                q.append(p.tolist())
                dt.append(60.0 / float(w["F"]) / n)
                line.append(cur)
        elif s.startswith("G0 ") or s.startswith("G1 "):
            q.append([float(w[a]) for a in "XYZAB"])
            dt.append(60.0 / float(w["F"]) if "F" in w else 0.0)
            line.append(cur)
        elif s.startswith("G4 "):
            q.append(q[-1])
            dt.append(float(w["P"]))
            line.append(cur)
    return np.array(q), np.array(dt), np.array(line)


def _curve_distance(m: gcode.Motion, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance from a spline or NURBS: the curve as a fine polyline (4000 chords by
    arc length, whose sagitta is far below a nanometre on the curves here), each point
    projected onto the chords beside its nearest vertex; A/B linear in arc length."""
    c = m.curve
    assert c is not None
    n = 4000
    sv = np.linspace(0.0, c.length, n + 1)
    pts = c.point(c.u_at(sv))
    st, en = np.array(m.start), np.array(m.end)
    dist = np.full(len(q), np.inf)
    frac = np.zeros(len(q))
    for lo in range(0, len(q), 256):
        qq = q[lo : lo + 256, :3]
        near = np.argmin(np.linalg.norm(qq[:, None, :] - pts[None, :, :], axis=2), axis=1)
        for j0 in (near - 1, near):
            j = np.clip(j0, 0, n - 1)
            a, b = pts[j], pts[j + 1]
            d = b - a
            t = np.clip(np.einsum("ij,ij->i", qq - a, d) / np.einsum("ij,ij->i", d, d), 0, 1)
            dd = np.linalg.norm(qq - (a + t[:, None] * d), axis=1)
            better = dd < dist[lo : lo + 256]
            dist[lo : lo + 256] = np.where(better, dd, dist[lo : lo + 256])
            f = (sv[j] + t * (sv[j + 1] - sv[j])) / c.length
            frac[lo : lo + 256] = np.where(better, f, frac[lo : lo + 256])
    ab_err = np.abs(q[:, 3:] - (st[3:] + frac[:, None] * (en[3:] - st[3:]))).max(axis=1)
    return dist, ab_err


#: path parameters tried between the nearest in XYZ and the nearest in A/B
_PARAMETER_STEPS = 65


def path_distance(m: gcode.Motion, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance [mm] of poses q (k, 5) from motion m's XYZ path, and their A/B error [deg],
    both at the path parameter where the pose is nearest the programmed pose.

    The pose is on the path within the tolerances when one parameter t has both
    |xyz − p(t)| ≤ TOL_MM and |ab − a(t)| ≤ TOL_DEG. A straight move that tilts much
    along a short way (G1 Z-0.5 A3: 6° per mm) must be judged at that common t:
    at the parameter nearest in XYZ alone, a lag of Z behind A by 0.03 µm reads as
    0.65 arcsec of A/B error (found by the random cycle and compensation programs of
    test_controller_truth). t is searched between the nearest in XYZ and the
    nearest in A/B for the least of max(distance, A/B error · TOL_MM / TOL_DEG), on
    straight moves and arcs (:func:`_nearest_pose`); curves take the parameter
    nearest in XYZ, which bounds the distance from above."""
    s, e = np.array(m.start), np.array(m.end)
    if m.kind == "curve":
        return _curve_distance(m, q)
    if m.kind in ("rapid", "feed", "dwell"):
        d = e[:3] - s[:3]
        dd = float(d @ d)
        ab = e[3:] - s[3:]
        ab2 = float(ab @ ab)
        t_ab = np.clip((q[:, 3:] - s[3:]) @ ab / ab2, 0, 1) if ab2 else None
        if dd == 0:
            # rotary-only or dwell: the tip stands, A/B move linearly
            t = t_ab if t_ab is not None else np.zeros(len(q))
            dist = np.linalg.norm(q[:, :3] - s[:3], axis=1)
            ab_err = np.abs(q[:, 3:] - (s[3:] + t[:, None] * ab)).max(axis=1)
            return dist, ab_err
        t_xyz = np.clip((q[:, :3] - s[:3]) @ d / dd, 0, 1)
        return _nearest_pose(q, t_xyz, t_ab, lambda t: s + t[:, :, None] * (e - s))
    # arc / helix about the plane's normal through the centre
    iu, iv, iw = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[m.plane]
    c = np.array(m.center)
    th0 = np.arctan2(s[iv] - c[iv], s[iu] - c[iu])
    r0 = np.hypot(s[iu] - c[iu], s[iv] - c[iv])
    r1 = np.hypot(e[iu] - c[iu], e[iv] - c[iv])
    th1 = np.arctan2(e[iv] - c[iv], e[iu] - c[iu])
    turns = abs(m.rotation)
    if m.rotation > 0:
        sweep = (th1 - th0) % (2 * np.pi) or 2 * np.pi
        sweep += 2 * np.pi * (turns - 1)
    else:
        sweep = -(((th0 - th1) % (2 * np.pi) or 2 * np.pi) + 2 * np.pi * (turns - 1))
    th = np.arctan2(q[:, iv] - c[iv], q[:, iu] - c[iu])
    # unwrap each point's angle to the nearest parameter consistent with its axial position
    dw = e[iw] - s[iw]
    base = (th - th0) / sweep
    cands = [(base + k * 2 * np.pi / sweep) for k in range(-turns - 1, turns + 2)]
    best = np.full(len(q), np.inf)
    best_t = np.zeros(len(q))
    for t in cands:
        t = np.clip(t, 0, 1)
        pu = c[iu] + (r0 + (r1 - r0) * t) * np.cos(th0 + sweep * t)
        pv = c[iv] + (r0 + (r1 - r0) * t) * np.sin(th0 + sweep * t)
        pw = s[iw] + dw * t
        dist = np.sqrt((q[:, iu] - pu) ** 2 + (q[:, iv] - pv) ** 2 + (q[:, iw] - pw) ** 2)
        better = dist < best
        best[better] = dist[better]
        best_t[better] = t[better]
    best_t = _nearest_on_helix(
        q[:, (iu, iv, iw)], best_t, c[iu], c[iv], s[iw], dw, r0, r1, th0, sweep
    )
    ab = e[3:] - s[3:]
    ab2 = float(ab @ ab)
    t_ab = np.clip((q[:, 3:] - s[3:]) @ ab / ab2, 0, 1) if ab2 else None

    def pose_at(t: np.ndarray) -> np.ndarray:
        p = np.empty((*t.shape, 5))
        p[..., iu] = c[iu] + (r0 + (r1 - r0) * t) * np.cos(th0 + sweep * t)
        p[..., iv] = c[iv] + (r0 + (r1 - r0) * t) * np.sin(th0 + sweep * t)
        p[..., iw] = s[iw] + dw * t
        p[..., 3:] = s[3:] + t[..., None] * ab
        return p

    return _nearest_pose(q, best_t, t_ab, pose_at)


def _nearest_on_helix(
    quvw: np.ndarray,
    t: np.ndarray,
    cu: float,
    cv: float,
    w0: float,
    dw: float,
    r0: float,
    r1: float,
    th0: float,
    sweep: float,
) -> np.ndarray:
    """The parameter nearest in XYZ to each point (k, 3) of the helix p(t) =
    c + r(t) (cos θ(t), sin θ(t)) + (w0 + dw t) n, r linear in t, from the one at the
    point's own angle: Newton's steps on (p − q)·p' = 0 within [0, 1], each kept only
    where it brings p nearer. On a steep helix (a plunge with a little turn, as a
    compensated path's helix can be: test_controller_truth's found programs) the
    point at the same angle can be far: a pose 0.2 µm beside the helix, a hair
    ahead in angle, read 0.9 µm off in Z there."""

    def at(t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        r, th = r0 + (r1 - r0) * t, th0 + sweep * t
        co, si = np.cos(th), np.sin(th)
        dr = r1 - r0
        p = np.column_stack([cu + r * co, cv + r * si, w0 + dw * t])
        d1 = np.column_stack(
            [dr * co - r * sweep * si, dr * si + r * sweep * co, np.full(len(t), dw)]
        )
        d2 = np.column_stack(
            [
                -2 * dr * sweep * si - r * sweep**2 * co,
                2 * dr * sweep * co - r * sweep**2 * si,
                np.zeros(len(t)),
            ]
        )
        return p, d1, d2

    def dist(t: np.ndarray) -> np.ndarray:
        return np.linalg.norm(quvw - at(t)[0], axis=1)

    best = dist(t)
    for _ in range(8):
        p, d1, d2 = at(t)
        g = np.einsum("ij,ij->i", p - quvw, d1)
        h = np.einsum("ij,ij->i", d1, d1) + np.einsum("ij,ij->i", p - quvw, d2)
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(h > 0, g / h, 0.0)
        t_new = np.clip(t - step, 0.0, 1.0)
        d_new = dist(t_new)
        better = d_new < best
        t = np.where(better, t_new, t)
        best = np.where(better, d_new, best)
    return t


def _nearest_pose(
    q: np.ndarray,
    t_xyz: np.ndarray,
    t_ab: np.ndarray | None,
    pose_at: Callable[[np.ndarray], np.ndarray],
) -> tuple[np.ndarray, np.ndarray]:
    """(distance [mm], A/B error [deg]) of poses q (k, 5) at the path parameter
    between ``t_xyz`` (nearest in XYZ) and ``t_ab`` (nearest in A/B; None: A/B do
    not move) where max(distance, A/B error · TOL_MM / TOL_DEG) is least;
    ``pose_at(t (k, n)) -> (k, n, 5)`` is the path."""
    if t_ab is None:
        tries = t_xyz[:, None]
    else:
        tries = t_xyz[:, None] + (t_ab - t_xyz)[:, None] * np.linspace(0.0, 1.0, _PARAMETER_STEPS)
    p = pose_at(tries)
    dist_n = np.linalg.norm(q[:, None, :3] - p[:, :, :3], axis=2)
    ab_n = np.abs(q[:, None, 3:] - p[:, :, 3:]).max(axis=2)
    best = np.argmin(np.maximum(dist_n, ab_n * (TOL_MM / TOL_DEG)), axis=1)
    rows = np.arange(len(q))
    return dist_n[rows, best], ab_n[rows, best]


def _moves(m: gcode.Motion) -> bool:
    return m.kind in ("dwell", "arc") or m.start != m.end


def check_trace(
    motions: list[gcode.Motion],
    q_exec: np.ndarray,
    dt: np.ndarray,
    lines: np.ndarray,
    tool: np.ndarray,
    rapid_mm_min: float = 10000.0,
) -> None:
    """Every point on its block's path, every block end reached, speed ≤ F.

    Points are matched to the motions of their line in time order: a point belongs
    to the current motion until that motion's end point has been reached (every
    block's end is an interpolation point, which this also checks).
    """
    by_line: dict[int, list[gcode.Motion]] = {}
    for m in motions:
        if _moves(m):
            by_line.setdefault(m.line, []).append(m)
    worst = 0.0
    worst_ab = 0.0
    limit = np.full(len(q_exec), np.inf)
    for ln in np.unique(lines[1:]):
        sel = np.nonzero(lines == ln)[0]
        sel = sel[sel > 0]
        ms = by_line[int(ln)]
        j = 0
        for k in sel:
            m = ms[j]
            d, a = path_distance(m, q_exec[k : k + 1])
            worst = max(worst, float(d[0]))
            worst_ab = max(worst_ab, float(a[0]))
            xyz = (
                np.linalg.norm(np.array(m.end[:3]) - np.array(m.start[:3])) > 1e-9
                or m.kind == "arc"
            )
            if xyz and m.kind != "dwell":
                limit[k] = rapid_mm_min if m.kind == "rapid" else m.feed
            at_end = (
                np.linalg.norm(q_exec[k, :3] - np.array(m.end[:3])) <= 2 * TOL_MM
                and np.abs(q_exec[k, 3:] - np.array(m.end[3:])).max() <= 2 * TOL_DEG
            )
            if m.kind == "dwell":
                at_end = (
                    k + 1 >= len(lines)
                    or lines[k + 1] != ln
                    or not np.array_equal(q_exec[k + 1], q_exec[k])
                )
            if at_end and j + 1 < len(ms):
                j += 1
        assert j == len(ms) - 1, f"line {ln}: not every block's end point was reached"
    assert worst <= TOL_MM, f"path error {worst * 1000:.4f} µm"
    assert worst_ab <= TOL_DEG, f"A/B error {worst_ab * 3600:.4f} arcsec"
    # speed: chord over segment time never above F (a little over for rounding of
    # the written positions and times); not across a tool length change, where the
    # tip jumps along the spindle while the machine stands
    seg = np.linalg.norm(np.diff(q_exec[:, :3], axis=0), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        v = np.where(dt[1:] > 0, seg / dt[1:] * 60.0, 0.0)
    same_tool = tool[1:] == tool[:-1]
    over = (v > limit[1:] * (1 + 1e-4) + 0.06) & same_tool
    assert not np.any(over), f"faster than F at lines {np.unique(lines[1:][over])[:5]}"


def machines() -> list[tuple[str, int | None]]:
    return [("nominal", None), ("random", 11), ("random", 12), ("random", 13)]


def truth_machine(kind: str, seed: int | None, *, play: bool = True) -> profile_mod.Profile:
    """The shop profile's nominal machine, or one with random errors in every contract
    term and (``play``) real-axis tables with backlash for every motor."""
    nominal = profile_mod.loads((ROOT / "profiles" / "prsxy-shop.toml").read_text(), "shop")
    if seed is None:
        return nominal
    return simulate.random_machine(
        nominal, np.random.default_rng(seed), axis_errors=play, name=f"random {seed}"
    )


def with_output_setting(
    profile: profile_mod.Profile, dialect: str, key: str, value: Any
) -> profile_mod.Profile:
    """The profile with ``[output.<dialect>] key = value``, validated as a profile file is."""
    output = dict(profile.raw.get("output", {}))
    output[dialect] = {**output.get(dialect, {}), key: value}
    return profile_mod.profile_from_dict(dict(profile.raw, output=output))


PROV = writers.Provenance("x.ngc", "0" * 64, "p", "p.toml", "0" * 64, "")


def convert(
    profile: profile_mod.Profile, text: str, fmt: str = "pmac", chunk: int = 0
) -> tuple[list[gcode.Motion], chain.ChainResult, list[str]]:
    """Interpret, run the chain for the dialect and write: (motions, result, part texts)."""
    cfg = program.interpreter_config(profile)
    motions = list(gcode.iter_motions(gcode.split_lines(text), cfg, "x.ngc"))
    d = writers.dialect(fmt)
    settings = writers.settings_of(profile, fmt)
    res = chain.run_chain(
        motions,
        profile,
        segment=d.segment,
        chunk=chunk,
        max_part_points=d.parts(settings),
        written=d.written(settings),
    )
    w = d.make(profile, settings, PROV)
    parts: dict[int, list[str]] = {}
    for part, piece in [*w.begin(), *w.feed(res.points), *w.finish()]:
        parts.setdefault(part, []).append(piece)
    return motions, res, ["".join(parts[k]) for k in sorted(parts)]


@pytest.mark.parametrize(("kind", "seed"), machines())
@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: p.name)
def test_pmac_program_traces_the_path_at_its_points(kind: str, seed: int | None, path) -> None:
    truth = truth_machine(kind, seed)
    motions, res, texts = convert(truth, path.read_text())
    P, dt, lines = read_pmac(texts[0])
    pts = res.points
    # every chain point is the RAPID start, a row, a DWELL, or a machine function
    # (standing, no time: not a point the machine goes to)
    rows = ~(pts.dwell & (pts.dt == 0))
    rows[0] = True
    assert len(P) == int(np.sum(rows))
    q_exec = simulate.execute(truth, P, pts.tool_length[rows])
    check_trace(motions, q_exec, dt, lines, pts.tool_length[rows])


@pytest.mark.parametrize(("kind", "seed"), machines()[:3])
@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: p.name)
def test_gcode_output_through_controller_traces_the_path_at_its_points(
    kind: str, seed: int | None, path
) -> None:
    """The controller runs its own IK (here the nominal design) on the written points;
    the true machine executes the resulting motor commands."""
    truth = truth_machine(kind, seed)
    motions, res, texts = convert(truth, path.read_text(), "gcode")
    cgeo = kinematics.controller_geometry(truth)
    q_read, dt, lines = read_gcode_points(texts[0])
    tool = _tool_of_lines(res, lines)
    P_ctrl = kinematics.inverse(cgeo, q_read).P  # the controller's own IK
    q_exec = simulate.execute(truth, P_ctrl, tool)
    check_trace(motions, q_exec, dt, lines, tool)


def _tool_of_lines(res: chain.ChainResult, lines: np.ndarray) -> np.ndarray:
    """The tool length in effect at each written point, from the chain's points of
    its G-code line (a length changes only with the machine at rest)."""
    by_line = dict(zip(res.points.line.tolist(), res.points.tool_length.tolist(), strict=True))
    return np.array([by_line.get(int(ln), 0.0) for ln in lines])


def _tool_of_segments(
    res: chain.ChainResult, point_line: np.ndarray, seg: np.ndarray
) -> np.ndarray:
    """The tool length along each sample of a motor-space run: that of the line of
    its segment's end point, whose motion the segment runs; or, where that line
    makes no move (a function's point, the program's end), the start point's. A
    G43 without a move takes effect at the next point made: a segment that ends at
    a function's point does not move, and its tip is still the old tool's (read
    with the new one, it stood a tool length off the move before it)."""
    pts = res.points
    standing = pts.dwell | np.array([f is not None for f in pts.fn], dtype=bool)
    moving = np.unique(pts.line[~standing])
    end = point_line[seg]
    start = point_line[np.maximum(seg - 1, 0)]
    return _tool_of_lines(res, np.where(np.isin(end, moving), end, start))


def test_a_pose_is_judged_where_position_and_tilt_are_both_nearest() -> None:
    """On G1 Z-0.5 A3 (6° per mm) a pose whose Z lags its A by 0.03 µm is within
    0.03 µm and 0.03 arcsec of a pose of the path; read at the parameter nearest in
    XYZ alone, it was 0.65 arcsec off the tool axis. A real tilt error, with the position held, is
    still seen in full where A does not move along the move; on an arc too."""
    line = gcode.Motion(1, "feed", (0.0, 0.0, 0.0, 0.0, 0.0), (0.0, 0.0, -0.5, 3.0, 0.0), 100.0)
    lag = np.array([[0.0, 0.0, -0.25 + 0.03e-3, 1.5, 0.0]])
    d, ab = path_distance(line, lag)
    # the least of max(distance, tilt error at 1 µm per arcsec): both within the lag
    assert d[0] <= 0.031e-3 and ab[0] * 3600 <= 0.031
    assert 0.03e-3 * 6.0 * 3600 == pytest.approx(0.648)  # what the XYZ-nearest read
    still = gcode.Motion(1, "feed", (0.0, 0.0, 0.0, 1.0, 0.0), (0.0, 0.0, -0.5, 1.0, 0.0), 100.0)
    d, ab = path_distance(still, np.array([[0.0, 0.0, -0.25, 1.0 + 1.0 / 3600, 0.0]]))
    assert d[0] == pytest.approx(0.0, abs=1e-12) and ab[0] * 3600 == pytest.approx(1.0)
    arc = gcode.Motion(
        1, "arc", (1.0, 0.0, 0.0, 0.0, 0.0), (0.0, 1.0, 0.0, 5.0, 0.0), 100.0, 17,
        (0.0, 0.0, 0.0), 1,
    )  # fmt: skip
    # a quarter circle of 1 mm turning A by 5°: halfway, with the XY lagging by 0.05 µm
    th = np.pi / 4 - 0.05e-3
    d, ab = path_distance(arc, np.array([[np.cos(th), np.sin(th), 0.0, 2.5, 0.0]]))
    assert d[0] <= 0.051e-3 and ab[0] * 3600 <= 0.051


def test_a_pose_beside_a_steep_helix_is_judged_at_its_nearest_point() -> None:
    """A plunge of 0.5 mm that turns 0.1° about a centre 10 mm away (G2 with a tiny
    chord, Z-0.5; compensated paths make such helices): a pose 0.2 µm beside it
    along the binormal, which is nearly along the turn, is 0.2 µm from the helix,
    though at the helix's point of the same angle it is 5.7 µm off in Z."""
    sweep = -np.radians(0.1)
    r, dz = 10.0, -0.5
    end = (r * np.cos(sweep), r * np.sin(sweep), dz, 0.0, 0.0)
    arc = gcode.Motion(
        1, "arc", (r, 0.0, 0.0, 0.0, 0.0), end, 100.0, 17, (0.0, 0.0, dz), -1
    )  # fmt: skip
    t = 0.5
    th = sweep * t
    p = np.array([r * np.cos(th), r * np.sin(th), dz * t])
    tangent = np.array([-r * sweep * np.sin(th), r * sweep * np.cos(th), dz])
    radial = np.array([np.cos(th), np.sin(th), 0.0])
    binormal = np.cross(tangent, radial)
    binormal /= np.linalg.norm(binormal)
    q = np.concatenate([p + 0.2e-3 * binormal, [0.0, 0.0]])[None, :]
    d, _ab = path_distance(arc, q)
    assert d[0] == pytest.approx(0.2e-3, rel=1e-3)
    # at the same angle: the binormal's turn over the sweep's share of the plunge
    turn = 0.2e-3 * binormal @ np.array([-np.sin(th), np.cos(th), 0.0]) / r
    assert abs(turn / sweep * dz) > 5e-3
