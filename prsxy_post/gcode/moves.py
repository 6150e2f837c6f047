"""Straight moves, arcs and G28/G30: blocks into motions."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .codes import AXES
from .motion import MM_PER_INCH
from .offsets import from_work, to_work
from .read import Word

if TYPE_CHECKING:
    from .execute import Interpreter


#: LinuxCNC's arc tolerances (interp_internal.hh), per unit system.
RADIUS_TOLERANCE = {"mm": 0.00005 * MM_PER_INCH, "inch": 0.00005}
SPIRAL_ABS_TOLERANCE = {"mm": 2 * 0.01 * math.sqrt(2), "inch": 2 * 0.001 * math.sqrt(2)}
SPIRAL_REL_TOLERANCE = 0.001


def target(
    it: Interpreter,
    axis_words: dict[str, Word],
    machine: bool = False,
    seen: dict[str, Word] | None = None,
    base: list[float] | None = None,
) -> list[float]:
    """End point of a move (LinuxCNC's find_ends), workpiece frame.

    ``machine`` (G53): LinuxCNC machine coordinates are of the gauge point, so
    the tip lies the tool length below them in Z. ``base``: where axes not
    given stay, and incremental moves start (the programmed point, not the
    tool's, with cutter compensation on). ``seen`` may hold polar words
    (``@`` radius, ``^`` angle in degrees, about the program origin, G17)."""
    st = it.st
    here = st.pos if base is None else base
    sc = it.scale()
    if machine:
        # G53 is in the workpiece frame, unrotated: an axis not given stays
        # where the tool is on the machine (find_ends, interp_find.cc:170-197)
        if seen is not None and ("@" in seen or "^" in seen):
            w = seen.get("@") or seen["^"]
            raise it.err("polar coordinates with G53", it.line, w, "X Y Z machine coordinates")
        tip = to_work(st, here)
        for i, a in enumerate(AXES):
            if a in axis_words:
                v = axis_words[a].value * (sc if i < 3 else 1.0)
                tip[i] = v - st.tool_length if i == 2 else v
        return from_work(st, tip)
    off = it.offset()
    out = list(here)
    for i, a in enumerate(AXES):
        if a in axis_words:
            v = axis_words[a].value * (sc if i < 3 else 1.0)
            out[i] = (v + off[i]) if st.absolute else here[i] + v
    if seen is not None and ("@" in seen or "^" in seen):
        _polar(it, seen, out, here, off, sc)
    return out


def _polar(
    it: Interpreter,
    seen: dict[str, Word],
    out: list[float],
    here: list[float],
    off: tuple[float, ...],
    sc: float,
) -> None:
    """Polar X Y from ``@`` and ``^`` (find_ends), in program units about the
    program origin; G91 adds to the current radius and angle."""
    w = seen.get("@") or seen["^"]
    line = it.line
    for a in ("X", "Y"):
        if a in seen:
            raise it.err("X or Y words with polar coordinates", line, seen[a], "@ and ^ alone")
    px = (here[0] - off[0]) / sc
    py = (here[1] - off[1]) / sc
    d2r = math.pi / 180.0
    if it.st.absolute:
        if "@" in seen and "^" in seen:
            radius, theta = seen["@"].value, seen["^"].value * d2r
        elif "@" in seen:
            if px == 0 and py == 0:
                raise it.err("a polar radius at the origin", line, w, "an angle (^) too")
            radius, theta = seen["@"].value, math.atan2(py, px)
        else:
            radius, theta = math.hypot(py, px), seen["^"].value * d2r
    else:
        if px == 0 and py == 0:
            raise it.err("incremental polar motion at the origin", line, w, "G90 or a start off it")
        theta = math.atan2(py, px)
        radius = math.hypot(py, px)
        if "@" in seen:
            radius += seen["@"].value
        if "^" in seen:
            theta += seen["^"].value * d2r
    out[0] = radius * math.cos(theta) * sc + off[0]
    out[1] = radius * math.sin(theta) * sc + off[1]


def feed_rate(
    it: Interpreter,
    start: list[float],
    end: list[float],
    length: float | None,
    line: int,
    word: Word | None,
) -> float:
    """Feed in mm/min (deg/min for rotary-only moves), as LinuxCNC derives it."""
    st = it.st
    lin = math.dist(start[:3], end[:3]) if length is None else length
    if st.inverse_time:
        if "F" not in it._seen:
            raise it.err(
                "feed move without F in inverse time mode (G93)",
                line,
                word,
                "an F word on every G1/G2/G3 block in G93",
            )
        f = it._seen["F"].value
        if f <= 0:
            raise it.err("zero feed rate", line, it._seen["F"], "F > 0")
        # inverse_time_rate_*: max(0.1, length * F) in program units per minute,
        # which becomes the feed rate (#<_feed>, what M70 saves)
        if lin > 1e-12:
            rate = max(0.1 * it.scale(), f * lin)
            st.feed = rate / it.scale()
        else:
            rate = max(0.1, f * math.dist(start[3:], end[3:]))
            st.feed = rate
        it.inverse_rate = rate
        return rate
    if st.feed <= 0:
        raise it.err(
            "feed move with no feed rate",
            line,
            word,
            "an F word before (or on) the first G1/G2/G3",
        )
    if lin > 1e-12 or math.dist(start[3:], end[3:]) == 0:
        return st.feed * (MM_PER_INCH if st.units == "inch" else 1.0)
    return st.feed  # rotary-only: degrees per minute in either unit system


def linear(
    it: Interpreter,
    motion: int,
    axis_words: dict[str, Word],
    seen: dict[str, Word],
    line: int,
    machine: bool = False,
) -> None:
    st = it.st
    it._seen = seen
    start = list(st.pos)
    end = target(it, axis_words, machine, seen)
    if motion == 0:
        it.emit(line=line, kind="rapid", start=tuple(start), end=tuple(end))
    else:
        w = next(iter(axis_words.values()), None)
        f = feed_rate(it, start, end, None, line, w)
        it.emit(line=line, kind="feed", start=tuple(start), end=tuple(end), feed=f)
    st.pos = end


def arc(
    it: Interpreter, motion: int, axis_words: dict[str, Word], seen: dict[str, Word], line: int
) -> None:
    st = it.st
    gw = next(iter(axis_words.values()), None)
    iu, iv, iw = PLANE_AXES[st.plane]
    start = list(st.pos)
    end = target(it, axis_words, seen=seen)
    sc = it.scale()
    turns = _turns(seen)
    cu, cv = arc_center(
        it, motion, start[iu] / sc, start[iv] / sc, end[iu] / sc, end[iv] / sc, seen, line, gw
    )
    u0, v0, u1, v1 = start[iu] / sc, start[iv] / sc, end[iu] / sc, end[iv] / sc
    center = [0.0, 0.0, 0.0]
    center[iu], center[iv] = cu * sc, cv * sc
    center[iw] = end[iw]
    rotation = turns if motion == 3 else -turns
    rad = math.hypot(u0 - cu, v0 - cv) * sc
    length = arc_length(rad, sweep_of(u0, v0, cu, cv, rotation, u1, v1), end[iw] - start[iw])
    f = feed_rate(it, start, end, length, line, gw)
    it.emit(
        line=line,
        kind="arc",
        start=tuple(start),
        end=tuple(end),
        feed=f,
        plane=st.plane,
        center=tuple(center),
        rotation=rotation,
    )
    st.pos = end


#: the plane's first, second axes and its normal (indices into x y z a b)
PLANE_AXES = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}
#: the centre offsets of each plane
PLANE_OFFSETS = {17: ("I", "J"), 18: ("K", "I"), 19: ("J", "K")}


def _turns(seen: dict[str, Word]) -> int:
    return math.floor(seen["P"].value + 0.5) if "P" in seen else 1


def sweep_of(
    u0: float, v0: float, cu: float, cv: float, rotation: int, u1: float, v1: float
) -> float:
    """The signed angle an arc turns (LinuxCNC's find_turn) [rad]."""
    a = math.atan2(v0 - cv, u0 - cu)
    b = math.atan2(v1 - cv, u1 - cu)
    if rotation > 0:
        if b <= a:
            b += 2 * math.pi
        return (b - a) + (rotation - 1) * 2 * math.pi
    if a <= b:
        a += 2 * math.pi
    return (b - a) + (rotation + 1) * 2 * math.pi


def arc_length(radius: float, sweep: float, axial: float) -> float:
    """The length of a helix: ``hypot(r θ, h)`` (LinuxCNC's find_arc_length)."""
    return math.hypot(radius * sweep, axial)


def arc_center(
    it: Interpreter,
    motion: int,
    u0: float,
    v0: float,
    u1: float,
    v1: float,
    seen: dict[str, Word],
    line: int,
    gw: Word | None,
) -> tuple[float, float]:
    """The centre of an arc from (u0, v0) to (u1, v1) in the plane's axes, program
    units, from R or the centre words, with LinuxCNC's checks and tolerances
    (arc_data_r, arc_data_ijk)."""
    if "R" in seen:
        return _center_of_r(it, motion, (u0, v0), (u1, v1), seen, line)
    return _center_of_ijk(it, motion, (u0, v0), (u1, v1), seen, line, gw)


def _center_of_r(
    it: Interpreter,
    motion: int,
    start: tuple[float, float],
    end: tuple[float, float],
    seen: dict[str, Word],
    line: int,
) -> tuple[float, float]:
    """The centre from R (arc_data_r): on the chord's bisector, on the side G2/G3
    and R's sign choose; a radius short of half the chord by the tolerance is
    taken as that half."""
    u0, v0 = start
    u1, v1 = end
    for letter in ("I", "J", "K"):
        if letter in seen:
            raise it.err(
                "R and I/J/K in one arc",
                line,
                seen[letter],
                "either R or the centre offsets",
            )
    r = seen["R"].value
    if u0 == u1 and v0 == v1:
        raise it.err(
            "R arc whose end point is its start point",
            line,
            seen["R"],
            "a different end point (a full circle needs I/J/K)",
        )
    mu, mv = (u0 + u1) / 2.0, (v0 + v1) / 2.0
    half = math.hypot(mu - u1, mv - v1)
    ar = abs(r)
    if half - ar > RADIUS_TOLERANCE[it.st.units]:
        raise it.err(
            "arc radius too small to reach the end point",
            line,
            seen["R"],
            f"|R| >= {half:.4f} (half the chord)",
        )
    if ar == 0 or half / ar > 1 - 1e-12:
        half = ar
    if (motion == 2 and r > 0) or (motion == 3 and r < 0):
        theta = math.atan2(v1 - v0, u1 - u0) - math.pi / 2
    else:
        theta = math.atan2(v1 - v0, u1 - u0) + math.pi / 2
    turn2 = math.asin(half / ar) if ar > 0 else 0.0
    d = ar * math.cos(turn2)
    return mu + d * math.cos(theta), mv + d * math.sin(theta)


def _center_of_ijk(
    it: Interpreter,
    motion: int,
    start: tuple[float, float],
    end: tuple[float, float],
    seen: dict[str, Word],
    line: int,
    gw: Word | None,
) -> tuple[float, float]:
    """The centre from the plane's two centre words (arc_data_ijk): offsets from the
    start (G91.1) or a point (G90.1); the start and end must lie on one circle
    about it within LinuxCNC's spiral tolerances."""
    u0, v0 = start
    u1, v1 = end
    st = it.st
    iu, iv, _ = PLANE_AXES[st.plane]
    la, lb = PLANE_OFFSETS[st.plane]
    unit = st.units
    if la not in seen and lb not in seen:
        raise it.err(
            "arc with neither R nor centre offsets",
            line,
            gw,
            f"{la} and/or {lb} (or R) with G{motion} in G{st.plane}",
        )
    for letter in {"I", "J", "K"} - {la, lb}:
        if letter in seen:
            raise it.err(
                f"{letter} word in a G{st.plane} arc",
                line,
                seen[letter],
                f"{la} and {lb} in G{st.plane}",
            )
    if st.arc_absolute:
        for letter in (la, lb):
            if letter not in seen:
                raise it.err(
                    f"{letter} word missing in an absolute-centre arc (G90.1)",
                    line,
                    gw,
                    f"both {la} and {lb} in G90.1",
                )
    a = seen[la].value if la in seen else 0.0
    b = seen[lb].value if lb in seen else 0.0
    if st.arc_absolute:
        off = it.offset()
        sc = it.scale()
        cu = a + off[iu] / sc
        cv = b + off[iv] / sc
    else:
        cu, cv = u0 + a, v0 + b
    r1 = math.hypot(cu - u0, cv - v0)
    r2 = math.hypot(cu - u1, cv - v1)
    rt = RADIUS_TOLERANCE[unit]
    if r1 < rt or r2 < rt:
        raise it.err(
            "zero-radius arc",
            line,
            seen.get(la) or seen.get(lb),
            "a centre away from the start and end points",
        )
    ae = abs(r1 - r2)
    re_ = ae / max(r1, r2)
    sa = SPIRAL_ABS_TOLERANCE[unit]
    if ae > sa * 100.0 or (re_ > SPIRAL_REL_TOLERANCE and ae > sa):
        raise it.err(
            f"the end point is not on the arc's circle (radius {r1:.4f} at the start, "
            f"{r2:.4f} at the end)",
            line,
            seen.get(la) or seen.get(lb),
            f"radii equal within {sa:.4f} {'mm' if unit == 'mm' else 'in'}",
        )
    return cu, cv


def home(it: Interpreter, code: float, axis_words: dict[str, Word], line: int) -> None:
    st = it.st
    inter = target(it, axis_words)
    it.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(inter))
    st.pos = inter
    base = 5161 if code == 28 else 5181
    home = it.params.values[base : base + 5]
    home[2] -= st.tool_length  # a stored machine position is of the gauge point
    # in the unrotated frame: an axis not given keeps its program coordinate
    # (convert_home's find_relative, interp_find.cc:427-431)
    home = from_work(st, home)
    end = list(st.pos)
    for i, a in enumerate(AXES):
        if not axis_words or a in axis_words:
            end[i] = home[i]
    it.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(end))
    st.pos = end
