"""Straight moves, arcs and G28/G30: blocks into motions."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .codes import AXES
from .motion import MM_PER_INCH
from .read import Word

if TYPE_CHECKING:
    from .execute import Interpreter


#: LinuxCNC's arc tolerances (interp_internal.hh), per unit system.
RADIUS_TOLERANCE = {"mm": 0.00005 * MM_PER_INCH, "inch": 0.00005}
SPIRAL_ABS_TOLERANCE = {"mm": 2 * 0.01 * math.sqrt(2), "inch": 2 * 0.001 * math.sqrt(2)}
SPIRAL_REL_TOLERANCE = 0.001


def target(it: Interpreter, axis_words: dict[str, Word], machine: bool = False) -> list[float]:
    """End point of a move; ``machine`` (G53): LinuxCNC machine coordinates are of
    the gauge point, so the tip lies the tool length below them in Z."""
    st = it.st
    off = (0.0, 0.0, -st.tool_length, 0.0, 0.0) if machine else it.offset()
    out = list(st.pos)
    sc = it.scale()
    for i, a in enumerate(AXES):
        if a in axis_words:
            v = axis_words[a].value * (sc if i < 3 else 1.0)
            out[i] = (v + off[i]) if (st.absolute or machine) else st.pos[i] + v
    return out


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
        if st.feed <= 0:
            raise it.err("zero feed rate", line, it._seen["F"], "F > 0")
        if lin > 1e-12:
            return st.feed * lin
        return st.feed * math.dist(start[3:], end[3:])
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
    end = target(it, axis_words, machine)
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
    iu, iv, iw = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[st.plane]
    off_letters = {17: ("I", "J"), 18: ("K", "I"), 19: ("J", "K")}[st.plane]
    start = list(st.pos)
    end = target(it, axis_words)
    sc = it.scale()
    turns = 1
    if "P" in seen:
        p = seen["P"].value
        if p != int(p) or p < 1:
            raise it.err("P (turns) must be a positive integer", line, seen["P"], "P1, P2, ...")
        turns = int(p)
    unit = st.units
    u0, v0 = start[iu] / sc, start[iv] / sc
    u1, v1 = end[iu] / sc, end[iv] / sc
    if "R" in seen:
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
        if half - ar > RADIUS_TOLERANCE[unit]:
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
        cu, cv = mu + d * math.cos(theta), mv + d * math.sin(theta)
    else:
        la, lb = off_letters
        if la not in seen and lb not in seen:
            raise it.err(
                "arc with neither R nor centre offsets",
                line,
                gw,
                f"{la} and/or {lb} (or R) with G{motion} in G{st.plane}",
            )
        third = {"I", "J", "K"} - {la, lb}
        for letter in third:
            if letter in seen:
                raise it.err(
                    f"{letter} word in a G{st.plane} arc",
                    line,
                    seen[letter],
                    f"{la} and {lb} in G{st.plane}",
                )
        a = seen[la].value if la in seen else 0.0
        b = seen[lb].value if lb in seen else 0.0
        if st.arc_absolute:
            off = it.offset()
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
    center = [0.0, 0.0, 0.0]
    center[iu], center[iv] = cu * sc, cv * sc
    center[iw] = end[iw]
    rotation = turns if motion == 3 else -turns
    # helix length for feed: the arc's sweep in the plane and the axial travel
    th0 = math.atan2(v0 - cv, u0 - cu)
    th1 = math.atan2(v1 - cv, u1 - cu)
    if rotation > 0:
        sweep = (th1 - th0) % (2 * math.pi)
    else:
        sweep = (th0 - th1) % (2 * math.pi)
    if sweep <= 1e-12:
        sweep = 2 * math.pi
    sweep += 2 * math.pi * (turns - 1)
    rad = math.hypot(u0 - cu, v0 - cv) * sc
    length = math.hypot(rad * sweep, end[iw] - start[iw])
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


def home(it: Interpreter, code: float, axis_words: dict[str, Word], line: int) -> None:
    st = it.st
    inter = target(it, axis_words)
    it.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(inter))
    st.pos = inter
    base = 5161 if code == 28 else 5181
    home = it.params.values[base : base + 5]
    home[2] -= st.tool_length  # a stored machine position is of the gauge point
    end = list(st.pos)
    for i, a in enumerate(AXES):
        if not axis_words or a in axis_words:
            end[i] = home[i]
    it.emit(line=line, kind="rapid", start=tuple(st.pos), end=tuple(end))
    st.pos = end
