"""Cutter radius compensation (G40, G41, G42, G41.1, G42.1) as LinuxCNC does it
(``interp_convert.cc``: convert_straight_comp1/2, convert_arc_comp1/2;
``interp_queue.cc``).

The tool runs beside the programmed path, a radius away on the left (G41) or the
right (G42), in the XY plane (G17) or XZ (G18, ``(z, x)`` playing ``(x, y)``):

- the first move after G41/G42 (the entry) ends a radius beside its programmed
  end, square to the move (a straight) or on the arc's radius (an arc);
- then each move starts where the last one was left and ends a radius beside its
  programmed end. At a convex corner (the path turns away from the tool) an arc
  of the tool's radius about the programmed corner joins the two (for G0, a
  straight move); at a concave corner the previous move is cut short where the
  tool touches both (its end moved back: moves are held in a queue until the
  next one shows the corner, as in LinuxCNC). A corner within 0.05 rad of
  straight needs nothing. A corner the tool cannot enter without cutting into
  the part is an error;
- G40 ends it: the held move ends where it is; the next move must be a straight
  line, from the tool's position to the programmed point.

The radius is half the diameter of tool D (G41/G42; no D: the tool in the
spindle) from the tool table, or half of D itself (G41.1/G42.1); a negative one
swaps the side. With compensation on LinuxCNC refuses what would need the
programmed point it does not have: canned cycles, G28/G30, G92/G52, a change of
coordinate system, plane, tool, tool length, path control or retract mode, and
reading #5420-#5428.

Positions here are in the workpiece frame (mm); LinuxCNC works in program
coordinates, which differ by a translation (no rotated coordinate systems on
this machine), so the geometry is the same; its tolerances are converted to mm.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

from .moves import arc_center, arc_length, feed_rate, sweep_of, target
from .read import Word

if TYPE_CHECKING:
    from .execute import Interpreter

LEFT, RIGHT = 1, 2
#: LinuxCNC's TOLERANCE_CONCAVE_CORNER (interp_internal.hh, 2.9) [rad]
TOLERANCE_CONCAVE_CORNER = 0.05
#: the plane's (first, second, third) axes: XZ compensates in (z, x)
_AXES = {17: (0, 1, 2), 18: (2, 0, 1)}
_HALF_PI = math.pi / 2


def _inside(side: int, turn: int) -> bool:
    """TOOL_INSIDE_ARC: the tool is on the arc's centre side."""
    return (side == LEFT and turn > 0) or (side == RIGHT and turn < 0)


class Queue:
    """Moves held until the next one shows the corner after them (LinuxCNC's
    interp queue); machine functions and dwells met meanwhile wait behind them,
    so the order of events stays."""

    def __init__(self, it: Interpreter) -> None:
        self.it = it
        self.items: list[dict[str, Any]] = []
        self.endpoint = (0.0, 0.0)  # where the held move starts (plane axes)
        self.endpoint_valid = False
        #: where the next move to go out starts (the end of the last one out)
        self.cursor: tuple[float, ...] = ()

    def __bool__(self) -> bool:
        return bool(self.items)

    def hold(self, **kw: Any) -> None:
        self.items.append(kw)

    def set_endpoint(self, x: float, y: float) -> None:
        self.endpoint = (x, y)
        self.endpoint_valid = True

    def flush(self) -> None:
        """dequeue_canons: the held events go out as they are, each move from
        where the one before it ended."""
        self.endpoint_valid = False
        items, self.items = self.items, []
        for kw in items:
            if kw["kind"] in ("rapid", "feed", "arc"):
                kw["start"] = self.cursor
                self.cursor = kw["end"]
            else:
                kw["start"] = kw["end"] = self.cursor
            self.it.emit_now(**kw)

    def move_endpoint_and_flush(self, x: float, y: float, line: int) -> None:
        """The held moves end at (x, y) instead (a concave corner), then go out;
        a move that would have to run backwards to get there is an error."""
        if not self.items:
            return
        it = self.it
        iu, iv, _ = _AXES[it.st.plane]
        for kw in self.items:
            kind = kw["kind"]
            if kind == "arc":
                cu, cv = kw["_center2"]
                r1 = math.hypot(kw["end"][iu] - cu, kw["end"][iv] - cv)
                r2 = math.hypot(x - cu, y - cv)
                l1 = kw["_sweep"]
                l2 = sweep_of(self.endpoint[0], self.endpoint[1], cu, cv, kw["rotation"], x, y)
                if abs(r1 - r2) > 0.01 * it.scale():
                    raise it.err(
                        "cutter compensation made an arc with mismatched radii", line, None
                    )
                slack = 0.0254 if it.st.units == "mm" else 0.001  # as LinuxCNC has it
                if l1 != 0.0 and self.endpoint_valid and abs(l2) > abs(l1) + slack:
                    raise it.err(
                        "an arc move in a concave corner the tool cannot reach without gouging",
                        line,
                        None,
                        "a tool smaller than the corner",
                    )
            elif kind in ("feed", "rapid"):
                dx, dy = kw["_dir"]
                nx, ny = x - self.endpoint[0], y - self.endpoint[1]
                if self.endpoint_valid and dx * nx + dy * ny < 0:
                    what = "straight feed" if kind == "feed" else "straight traverse"
                    raise it.err(
                        f"a {what} in a concave corner the tool cannot reach without gouging",
                        line,
                        None,
                        "a tool smaller than the corner",
                    )
            else:
                continue
            end = list(kw["end"])
            end[iu], end[iv] = x, y
            kw["end"] = tuple(end)
        self.flush()
        self.set_endpoint(x, y)


def turn_on(it: Interpreter, code: float, seen: dict[str, Word], w: Word, line: int) -> None:
    """G41/G42 (radius from the tool table), G41.1/G42.1 (diameter D)."""
    st = it.st
    if st.plane not in (17, 18):
        raise it.err("cutter compensation outside the XY and XZ planes", line, w, "G17 or G18")
    if st.comp_side:
        raise it.err("cutter compensation turned on while it is on", line, w, "G40 first")
    side = LEFT if code in (41, 41.1) else RIGHT
    sc = it.scale()
    if code in (41.1, 42.1):
        if "D" not in seen:
            raise it.err(f"G{code:g} without a D word", line, w, f"G{code:g} D<diameter>")
        if "L" in seen:
            raise it.err(
                "lathe tool orientation (L) is out of scope for this machine",
                line,
                seen["L"],
                f"G{code:g} D<diameter>",
            )
        radius = seen["D"].value * sc / 2.0
    else:
        if "D" in seen:
            d = seen["D"].value
            n = int(d + 0.5)
            if abs(n - d) >= 0.0001:
                raise it.err(
                    f"G{code:g} with a D word that is not a tool number", line, seen["D"], "D<n>"
                )
            if n < 0:
                raise it.err("negative D word", line, seen["D"], "a tool number")
            tool = n
        else:
            tool = 0
        if tool == 0:
            tool = st.tool
        radius = it.tool(tool, line, seen.get("D", w)).diameter / 2.0 if tool else 0.0
    if radius < 0.0:
        radius = -radius
        side = RIGHT if side == LEFT else LEFT
    st.comp_side = side
    st.comp_radius = radius
    st.comp_first = True


def turn_off(it: Interpreter, line: int) -> None:
    """G40: the held move goes out as it is; the next starts from the tool."""
    st = it.st
    if st.comp_side and st.comp_radius > 0.0 and not st.comp_first:
        iu, iv, _ = _AXES[st.plane]
        it.queue.move_endpoint_and_flush(st.pos[iu], st.pos[iv], line)
        it.queue.flush()
        it.detached = tuple(st.pos)
        st.pos = list(st.program)
        st.arc_not_allowed = True
    st.comp_side = 0
    st.comp_first = True


def active(it: Interpreter) -> bool:
    st = it.st
    return bool(st.comp_side) and st.comp_radius > 0.0


def straight(
    it: Interpreter,
    motion: int,
    axis_words: dict[str, Word],
    seen: dict[str, Word],
    line: int,
) -> None:
    """A G0/G1 with compensation on: the entry move (convert_straight_comp1) or a
    move after it (convert_straight_comp2)."""
    st = it.st
    it._seen = seen
    base = None if st.comp_first else _programmed_base(it)
    p = target(it, axis_words, seen=seen, base=base)
    w = next(iter(axis_words.values()), None)
    # the inverse-time rate of a move after the first is that of the programmed
    # path (inverse_time_rate_straight starts it at program_x, not current_x)
    feed = _straight_feed(it, motion, st.pos if st.comp_first else st.program, p, line, w)
    if st.comp_first:
        end = _straight_entry(it, motion, p, feed, line, w)
        st.comp_first = False
    else:
        end = _straight_next(it, motion, p, feed, line, w)
    st.pos = end
    st.program = p


def _straight_entry(
    it: Interpreter, motion: int, p: list[float], feed: float, line: int, w: Word | None
) -> list[float]:
    """The entry move (convert_straight_comp1): it ends a radius beside its
    programmed end, square to the move; its end."""
    st = it.st
    iu, iv, _ = _AXES[st.plane]
    px, py = p[iu], p[iv]
    cx, cy = st.pos[iu], st.pos[iv]
    radius = st.comp_radius
    q = it.queue
    q.cursor = it.take_position()
    if math.hypot(px - cx, py - cy) <= radius:
        raise it.err(
            "a cutter compensation entry move no longer than the tool radius",
            line,
            w,
            "an entry move longer than the radius",
        )
    alpha = math.atan2(py - cy, px - cx) + (_HALF_PI if st.comp_side == LEFT else -_HALF_PI)
    end = list(p)
    end[iu] = px + radius * math.cos(alpha)
    end[iv] = py + radius * math.sin(alpha)
    q.set_endpoint(cx, cy)
    _hold_straight(it, motion, line, end, feed, (math.cos(alpha), math.sin(alpha)))
    return end


def _straight_next(
    it: Interpreter, motion: int, p: list[float], feed: float, line: int, w: Word | None
) -> list[float]:
    """A move after the entry (convert_straight_comp2): the corner from the move
    before, convex (an arc round it) or concave (the move before cut back); its end."""
    st = it.st
    iu, iv, _ = _AXES[st.plane]
    px, py = p[iu], p[iv]
    cx, cy = st.pos[iu], st.pos[iv]
    radius, side, q = st.comp_radius, st.comp_side, it.queue
    op = st.program
    opx, opy = op[iu], op[iv]
    if px == opx and py == opy:  # no motion in the plane
        end = list(p)
        end[iu], end[iv] = cx, cy
        _hold_straight(it, motion, line, end, feed, (0.0, 0.0))
        return end
    theta = math.atan2(cy - opy, cx - opx)
    alpha = math.atan2(py - opy, px - opx)
    if side == LEFT:
        if theta < alpha:
            theta += 2 * math.pi
        beta = (theta - alpha) - _HALF_PI
        gamma = _HALF_PI
    else:
        if alpha < theta:
            alpha += 2 * math.pi
        beta = (alpha - theta) - _HALF_PI
        gamma = -_HALF_PI
    end = list(p)
    end[iu] = px + radius * math.cos(alpha + gamma)
    end[iv] = py + radius * math.sin(alpha + gamma)
    small = TOLERANCE_CONCAVE_CORNER
    front = q.items[0] if q.items else None
    if beta < -small or beta > math.pi + small:
        concave = True
    else:
        concave = (
            beta > math.pi - small
            and front is not None
            and front["kind"] == "arc"
            and (
                (side == RIGHT and front["rotation"] > 0)
                or (side == LEFT and front["rotation"] < 0)
            )
        )
    if not concave and beta > small:  # convex: an arc round the corner
        # the move before goes out as it is, then the arc (a rapid in G0)
        q.move_endpoint_and_flush(cx, cy, line)
        mid = (opx + radius * math.cos(alpha + gamma), opy + radius * math.sin(alpha + gamma))
        _corner_arc(it, line, p, mid, rapid=motion != 1)
    elif concave:
        if front is None or front["kind"] != "arc":
            halfcorner = (beta + math.pi) / 2.0
            if halfcorner == 0.0:
                raise it.err("a zero-degree inside corner with cutter compensation", line, w)
            retreat = radius / math.tan(halfcorner)
            mx = cx + retreat * math.cos(theta + gamma)
            my = cy + retreat * math.sin(theta + gamma)
        else:
            mx, my = _arc_cut_back(it, front, p, line, w)
        q.move_endpoint_and_flush(mx, my, line)
    else:
        q.flush()
        q.set_endpoint(cx, cy)
    _hold_straight(it, motion, line, end, feed, (px - opx, py - opy))
    return end


def _corner_arc(
    it: Interpreter, line: int, p: list[float], mid: tuple[float, float], rapid: bool
) -> None:
    """A convex corner: an arc (a rapid where ``rapid``) round the programmed
    corner to ``mid``, a radius from it square to the next move, the rotary axes
    moving to ``p``'s on it; the queue flushed after it, its end the next move's
    start."""
    st = it.st
    iu, iv, iw = _AXES[st.plane]
    q = it.queue
    corner = list(st.pos)
    corner[iu], corner[iv] = mid
    corner[3], corner[4] = p[3], p[4]  # the rotary axes move on the added arc
    if rapid:
        q.hold(line=line, kind="rapid", end=tuple(corner), **it.extras())
    else:
        op = st.program
        center = [0.0, 0.0, 0.0]
        center[iu], center[iv], center[iw] = op[iu], op[iv], st.pos[iw]
        q.hold(
            line=line,
            kind="arc",
            end=tuple(corner),
            feed=it.feed_now(),
            plane=st.plane,
            center=tuple(center),
            rotation=-1 if st.comp_side == LEFT else 1,
            **it.extras(),
        )
    q.flush()
    q.set_endpoint(*mid)


def _arc_cut_back(
    it: Interpreter, front: dict[str, Any], p: list[float], line: int, w: Word | None
) -> tuple[float, float]:
    """A concave corner from an arc into a straight move: where on the arc before
    the compensated tool meets the new move's offset line."""
    st = it.st
    iu, iv, _ = _AXES[st.plane]
    radius, side = st.comp_radius, st.comp_side
    opx, opy = st.program[iu], st.program[iv]
    px, py = p[iu], p[iv]
    cu, cv = front["_center2"]
    pe = front["end"]
    oldrad = math.hypot(cv - pe[iv], cu - pe[iu])
    base_dir = math.atan2(py - opy, px - opx)
    turn = front["rotation"]
    th = base_dir + _HALF_PI if turn > 0 else base_dir - _HALF_PI
    phi = math.atan2(cv - opy, cu - opx)
    inside = _inside(side, turn)
    oldrad_uncomp = oldrad + radius if inside else oldrad - radius
    d = oldrad_uncomp * math.cos(th - phi)
    d2 = d - radius if inside else d + radius
    ratio = d2 / oldrad
    if ratio > 1.0 or ratio < -1.0:
        raise it.err(
            "an arc to straight corner the compensated tool cannot enter without gouging",
            line,
            w,
            "a tool smaller than the corner",
        )
    if inside:
        ang = (-math.acos(ratio) if turn > 0 else math.acos(ratio)) + th + math.pi
    else:
        ang = (math.acos(ratio) if turn > 0 else -math.acos(ratio)) + th + math.pi
    return cu + oldrad * math.cos(ang), cv + oldrad * math.sin(ang)


def arc(
    it: Interpreter, motion: int, axis_words: dict[str, Word], seen: dict[str, Word], line: int
) -> None:
    """A G2/G3 with compensation on, XY or XZ: the entry arc (convert_arc_comp1)
    or an arc after it (convert_arc_comp2)."""
    st = it.st
    it._seen = seen
    gw = next(iter(axis_words.values()), None)
    first = st.comp_first
    base = None if first else _programmed_base(it)
    p = target(it, axis_words, seen=seen, base=base)
    turns = math.floor(seen["P"].value + 0.5) if "P" in seen else 1
    turn = turns if motion == 3 else -turns
    if first:
        end = _arc_entry(it, motion, p, turn, seen, line, gw)
    else:
        end = _arc_next(it, motion, p, turn, seen, line, gw)
    st.program = list(p)
    st.pos = end


def _arc_entry(
    it: Interpreter,
    motion: int,
    p: list[float],
    turn: int,
    seen: dict[str, Word],
    line: int,
    gw: Word | None,
) -> list[float]:
    """The entry arc (convert_arc_comp1): it ends a radius beside its programmed
    end, on a circle through its start; its end."""
    st = it.st
    iu, iv, iw = _AXES[st.plane]
    sc = it.scale()
    ex, ey = p[iu], p[iv]
    cx, cy = st.pos[iu], st.pos[iv]
    side, radius = st.comp_side, st.comp_radius
    it.queue.cursor = it.take_position()
    if math.hypot(ex - cx, ey - cy) <= radius:
        raise it.err(
            "a cutter compensation entry arc whose radius is not above the tool radius",
            line,
            gw,
            "a larger entry arc",
        )
    cu, cv = arc_center(it, motion, cx / sc, cy / sc, ex / sc, ey / sc, seen, line, gw)
    center_x, center_y = cu * sc, cv * sc
    _check_arc_radius(it, motion, side, radius, center_x, center_y, cx, cy, seen, line, gw)
    length = arc_length(
        math.hypot(cx - center_x, cy - center_y),
        sweep_of(cx, cy, center_x, center_y, turn, ex, ey),
        p[iw] - st.pos[iw],
    )
    feed = feed_rate(it, st.pos, p, length, line, gw)
    if _inside(side, turn):
        gamma = math.atan2(center_y - ey, center_x - ex)
    else:
        gamma = math.atan2(ey - center_y, ex - center_x)
    st.comp_first = False
    end_x = ex + radius * math.cos(gamma)
    end_y = ey + radius * math.sin(gamma)
    b_len = math.hypot(cy - end_y, cx - end_x) / 2.0
    ab_ang = math.atan2(center_y - end_y, center_x - end_x)
    a_ang = math.atan2(cy - end_y, cx - end_x) - ab_ang
    if abs(math.cos(a_ang)) < 0.0001:
        raise it.err(
            "a tool radius not below the arc's radius with cutter compensation",
            line,
            gw,
            "a larger arc",
        )
    c_len = b_len / math.cos(a_ang)
    center_x = end_x + c_len * math.cos(ab_ang)
    center_y = end_y + c_len * math.sin(ab_ang)
    end = list(p)
    end[iu], end[iv] = end_x, end_y
    sweep = sweep_of(cx, cy, center_x, center_y, turn, end_x, end_y)
    _hold_arc(it, line, end, (center_x, center_y), turn, feed, sweep)
    return end


def _arc_next(
    it: Interpreter,
    motion: int,
    p: list[float],
    turn: int,
    seen: dict[str, Word],
    line: int,
    gw: Word | None,
) -> list[float]:
    """An arc after the entry (convert_arc_comp2): the corner from the move before,
    concave (the move before cut back), convex (an arc round it) or smooth; its end."""
    st = it.st
    iu, iv, iw = _AXES[st.plane]
    sc = it.scale()
    ex, ey = p[iu], p[iv]
    cx, cy = st.pos[iu], st.pos[iv]
    side, radius, q = st.comp_side, st.comp_radius, it.queue
    op = st.program
    opx, opy = op[iu], op[iv]
    cu, cv = arc_center(it, motion, opx / sc, opy / sc, ex / sc, ey / sc, seen, line, gw)
    centerx, centery = cu * sc, cv * sc
    length = arc_length(
        math.hypot(opx - centerx, opy - centery),
        sweep_of(opx, opy, centerx, centery, turn, ex, ey),
        p[iw] - op[iw],
    )
    feed = feed_rate(it, op, p, length, line, gw)
    arc_radius = math.hypot(centerx - ex, centery - ey)
    theta = math.atan2(cy - opy, cx - opx)
    theta = theta - _HALF_PI if side == LEFT else theta + _HALF_PI
    delta = math.atan2(centery - opy, centerx - opx)
    alpha = delta - _HALF_PI if motion == 3 else delta + _HALF_PI
    beta = theta - alpha if side == LEFT else alpha - theta
    if beta > 1.5 * math.pi:
        beta -= 2 * math.pi
    elif beta < -_HALF_PI:
        beta += 2 * math.pi
    if (side == LEFT and motion == 3) or (side == RIGHT and motion == 2):
        gamma = math.atan2(centery - ey, centerx - ex)
        if arc_radius <= radius:
            raise it.err(
                "a tool radius not below the arc's radius with cutter compensation",
                line,
                gw,
                "a larger arc or a smaller tool",
            )
    else:
        gamma = math.atan2(ey - centery, ex - centerx)
        delta = delta + math.pi
    small = TOLERANCE_CONCAVE_CORNER
    end = list(p)
    end[iu], end[iv] = ex + radius * math.cos(gamma), ey + radius * math.sin(gamma)
    sweep = sweep_of(opx, opy, centerx, centery, turn, ex, ey)
    if (
        beta < -small
        or beta > math.pi + small
        or (abs(beta - math.pi) < small and not _inside(side, turn))
    ):
        front = q.items[0] if q.items else None
        if front is None or front["kind"] != "arc":
            mx, my = _line_cut_back(it, (centerx, centery), arc_radius, theta, beta, turn, line, gw)
        else:
            mx, my = _arcs_cut_back(it, front, (centerx, centery), arc_radius, turn, line, gw)
        q.move_endpoint_and_flush(mx, my, line)
    elif beta > small:  # convex: an arc round the corner, then the arc
        q.flush()
        mid = (opx + radius * math.cos(delta), opy + radius * math.sin(delta))
        _corner_arc(it, line, p, mid, rapid=False)
    else:  # convex, smooth: the arc alone
        q.flush()
        q.set_endpoint(cx, cy)
    _hold_arc(it, line, end, (centerx, centery), turn, feed, sweep)
    return end


def _line_cut_back(
    it: Interpreter,
    center: tuple[float, float],
    arc_radius: float,
    theta: float,
    beta: float,
    turn: int,
    line: int,
    gw: Word | None,
) -> tuple[float, float]:
    """A concave corner from a straight move into an arc: where on the move before
    the compensated tool meets the arc's offset circle."""
    st = it.st
    radius, side = st.comp_radius, st.comp_side
    cyy = arc_radius * math.sin(beta - _HALF_PI)
    if _inside(side, turn):
        dist = arc_radius - radius
        ratio = (cyy + radius) / dist
        _reach(it, ratio, line, gw)
        ang = theta + math.asin(ratio) if turn > 0 else theta - math.asin(ratio)
    else:
        dist = arc_radius + radius
        ratio = (cyy - radius) / dist
        _reach(it, ratio, line, gw)
        if turn > 0:
            ang = theta + math.pi - math.asin(ratio)
        else:
            ang = theta + math.pi + math.asin(ratio)
    return center[0] + dist * math.cos(ang), center[1] + dist * math.sin(ang)


def _arcs_cut_back(
    it: Interpreter,
    front: dict[str, Any],
    center: tuple[float, float],
    arc_radius: float,
    turn: int,
    line: int,
    gw: Word | None,
) -> tuple[float, float]:
    """A concave corner from an arc into an arc: where on the arc before the
    compensated tool meets the new arc's offset circle."""
    st = it.st
    iu, iv, _ = _AXES[st.plane]
    radius, side = st.comp_radius, st.comp_side
    centerx, centery = center
    pcu, pcv = front["_center2"]
    pe = front["end"]
    oldrad = math.hypot(pcv - pe[iv], pcu - pe[iu])
    newrad = arc_radius - radius if _inside(side, turn) else arc_radius + radius
    arc_cc = math.hypot(pcv - centery, pcu - centerx)
    if oldrad == 0 or arc_cc == 0:
        raise it.err("an arc to arc corner about the same centre", line, gw)
    a = (oldrad**2 + arc_cc**2 - newrad**2) / (2 * oldrad * arc_cc)
    if a > 1.0 or a < -1.0:
        raise it.err(
            "an arc to arc corner the compensated tool cannot enter without gouging",
            line,
            gw,
            "a tool smaller than the corner",
        )
    pullback = math.acos(a)
    cc_dir = math.atan2(centery - pcv, centerx - pcu)
    if _inside(side, front["rotation"]):
        d = cc_dir + pullback if turn > 0 else cc_dir - pullback
    else:
        d = cc_dir - pullback if turn > 0 else cc_dir + pullback
    return pcu + oldrad * math.cos(d), pcv + oldrad * math.sin(d)


# ---------------------------------------------------------------- pieces


def _programmed_base(it: Interpreter) -> list[float]:
    """find_ends with compensation on: the programmed point in the plane's two
    axes, the tool's elsewhere."""
    st = it.st
    iu, iv, _ = _AXES[st.plane]
    base = list(st.pos)
    base[iu], base[iv] = st.program[iu], st.program[iv]
    return base


def _straight_feed(
    it: Interpreter, motion: int, start: list[float], end: list[float], line: int, w: Word | None
) -> float:
    if motion == 0:
        return math.nan
    return feed_rate(it, start, end, None, line, w)


def _hold_straight(
    it: Interpreter,
    motion: int,
    line: int,
    end: list[float],
    feed: float,
    direction: tuple[float, float],
) -> None:
    kind = "rapid" if motion == 0 else "feed"
    it.queue.hold(line=line, kind=kind, end=tuple(end), feed=feed, _dir=direction, **it.extras())


def _hold_arc(
    it: Interpreter,
    line: int,
    end: list[float],
    center2: tuple[float, float],
    turn: int,
    feed: float,
    sweep: float,
) -> None:
    """An arc about ``center2`` (plane axes) to ``end``; ``sweep`` is the angle
    LinuxCNC records for it (find_turn), the gouge check when its end moves."""
    st = it.st
    iu, iv, iw = _AXES[st.plane]
    center = [0.0, 0.0, 0.0]
    center[iu], center[iv], center[iw] = center2[0], center2[1], end[iw]
    it.queue.hold(
        line=line,
        kind="arc",
        end=tuple(end),
        feed=feed,
        plane=st.plane,
        center=tuple(center),
        rotation=turn,
        _center2=center2,
        _sweep=sweep,
        **it.extras(),
    )


def _reach(it: Interpreter, ratio: float, line: int, w: Word | None) -> None:
    if ratio > 1.0 or ratio < -1.0:
        raise it.err(
            "an arc move in a concave corner the tool cannot reach without gouging",
            line,
            w,
            "a tool smaller than the corner",
        )


def _check_arc_radius(
    it: Interpreter,
    motion: int,
    side: int,
    radius: float,
    center_x: float,
    center_y: float,
    cx: float,
    cy: float,
    seen: dict[str, Word],
    line: int,
    w: Word | None,
) -> None:
    """arc_data_comp_*: an arc the tool must fit inside has a larger radius."""
    r = (
        abs(seen["R"].value) * it.scale()
        if "R" in seen
        else math.hypot(center_x - cx, center_y - cy)
    )
    if r <= radius and ((side == LEFT and motion == 3) or (side == RIGHT and motion == 2)):
        raise it.err(
            "a tool radius not below the arc's radius with cutter compensation",
            line,
            w,
            "a larger arc or a smaller tool",
        )
