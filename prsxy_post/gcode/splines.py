"""Splines and NURBS (G5, G5.1, G5.2/G5.3) as LinuxCNC reads them
(``interp_convert.cc``: convert_spline, convert_nurbs), each one motion of kind
"curve" carrying the exact curve (:class:`prsxy_post.curves.Nurbs`).

- ``G5 X Y I J P Q``: a cubic Bézier from the current point to (X, Y) with
  control points current + (I, J) and end + (P, Q). I and J may be left out
  after a G5: the first control point is then the mirror of the last one
  (current − (P, Q) of the previous G5).
- ``G5.1 X Y I J``: a quadratic Bézier with control point current + (I, J).
- ``G5.2 X Y P<weight> [L<order>]`` … ``G5.3``: a NURBS of order L (default 3,
  LinuxCNC takes only L above 3) through LinuxCNC's open uniform knot vector;
  its first control point is the current point (weight P when the first G5.2
  line has P and no X Y), then one per line; G5.3 ends it and leaves no motion
  mode in effect.

All in the XY plane (G17) at the current Z; G5 and G5.1 may not move Z, A or B
(LinuxCNC refuses), G5.2 ignores them (as LinuxCNC does). No cutter
compensation, no inverse time (LinuxCNC sets no feed rate for a spline in
G93). The feed is F along the curve.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .moves import target
from .read import Word

if TYPE_CHECKING:
    from ..curves import Nurbs
    from .execute import Interpreter


def _common(it: Interpreter, code: float, seen: dict[str, Word], w: Word | None, line: int) -> None:
    st = it.st
    it.no_comp("a spline", line, w)
    if st.plane != 17:
        raise it.err("a spline outside the XY plane", line, w, "G17 for G5, G5.1, G5.2")
    if st.inverse_time:
        # LinuxCNC sets no feed rate for a spline in G93: it runs at whatever
        # rate the controller last had
        raise it.err("splines in inverse time mode (G93) are not supported", line, w, "G94")
    if st.feed <= 0:
        raise it.err(f"G{code:g} with no feed rate", line, w, "an F word before it")


def bezier(
    it: Interpreter, code: float, axis_words: dict[str, Word], seen: dict[str, Word], line: int
) -> None:
    """G5 (cubic) and G5.1 (quadratic)."""
    st = it.st
    w = next(iter(axis_words.values()), None) or seen.get("I") or seen.get("P")
    _common(it, code, seen, w, line)
    for a in ("Z", "A", "B"):
        if a in axis_words:
            raise it.err("a spline moving Z, A or B", line, axis_words[a], "X and Y only")
    sc = it.scale()
    start = list(st.pos)
    end = target(it, axis_words, seen=seen)
    x0, y0 = start[0], start[1]
    if code == 5.1:
        if "I" not in seen or "J" not in seen:
            raise it.err("G5.1 without both I and J", line, w, "G5.1 X Y I J")
        ctrl = [(x0, y0), (x0 + seen["I"].value * sc, y0 + seen["J"].value * sc)]
    else:
        if ("I" in seen) != ("J" in seen):
            raise it.err(
                "G5 with one of I and J", line, seen.get("I") or seen.get("J"), "both or neither"
            )
        if "I" in seen:
            i, j = seen["I"].value, seen["J"].value
        else:
            i, j = st.g5_i, st.g5_j
        if "P" not in seen or "Q" not in seen:
            raise it.err("G5 without both P and Q", line, w, "G5 X Y I J P Q")
        p, q = seen["P"].value, seen["Q"].value
        ctrl = [
            (x0, y0),
            (x0 + i * sc, y0 + j * sc),
            (end[0] + p * sc, end[1] + q * sc),
        ]
        st.g5_i, st.g5_j = -p, -q
    ctrl.append((end[0], end[1]))
    pts = np.array([(x, y, start[2]) for x, y in ctrl])
    from ..curves import Nurbs  # here: a program without curves never loads them

    _emit(it, line, start, end, Nurbs.bezier(pts), w)


def nurbs_point(
    it: Interpreter, axis_words: dict[str, Word], seen: dict[str, Word], line: int
) -> None:
    """A G5.2 line: one more control point (or the first one's weight)."""
    st = it.st
    w = next(iter(axis_words.values()), None) or seen.get("P")
    has_x, has_y = "X" in axis_words, "Y" in axis_words
    if has_x != has_y:
        raise it.err("a NURBS control point without both X and Y", line, w, "X and Y")
    p = seen["P"].value if "P" in seen else -1.0
    if not has_x and p > 0 and st.nurbs:
        raise it.err("P without X and Y after the first NURBS control point", line, w, "X Y P")
    if p <= 0 and st.nurbs:
        raise it.err("a NURBS control point without a positive weight P", line, w, "P > 0")
    if st.inverse_time:
        raise it.err("splines in inverse time mode (G93) are not supported", line, w, "G94")
    if st.feed <= 0:
        raise it.err("G5.2 with no feed rate", line, w, "an F word before it")
    if st.motion != 5.2:
        st.nurbs = []
    if not st.nurbs:
        weight = p if (not has_x and p > 0) else 1.0
        st.nurbs = [(st.pos[0], st.pos[1], weight)]
        st.nurbs_order = 3
        st.nurbs_line = line
    if "L" in seen and seen["L"].value > 3:
        st.nurbs_order = int(seen["L"].value)
    if has_x:
        end = target(it, axis_words, seen=seen)
        st.nurbs.append((end[0], end[1], p))


def nurbs_end(it: Interpreter, w: Word, line: int) -> None:
    """G5.3: the NURBS of the control points so far, one curve."""
    st = it.st
    if st.motion != 5.2:
        raise it.err("G5.3 without G5.2 first", line, w, "G5.2 control points, then G5.3")
    if len(st.nurbs) < st.nurbs_order:
        raise it.err(
            f"fewer NURBS control points than the order L = {st.nurbs_order}",
            line,
            w,
            f"at least {st.nurbs_order} control points",
        )
    if st.comp_side:
        raise it.err("a NURBS with cutter compensation on is not supported", line, w, "G40 first")
    if st.plane != 17:
        raise it.err("a NURBS outside the XY plane is not supported", line, w, "G17")
    z = st.pos[2]
    pts = np.array([(x, y, z) for x, y, _ in st.nurbs])
    weights = np.array([wt for _, _, wt in st.nurbs])
    start = list(st.pos)
    end = list(st.pos)
    end[0], end[1] = float(pts[-1][0]), float(pts[-1][1])
    from ..curves import Nurbs  # here: a program without curves never loads them

    _emit(it, line, start, end, Nurbs.linuxcnc(pts, weights, st.nurbs_order), w)
    st.nurbs = []
    st.motion = None


def _emit(
    it: Interpreter, line: int, start: list[float], end: list[float], curve: Nurbs, w: Word | None
) -> None:
    st = it.st
    sc = it.scale()
    feed = st.feed * sc
    if math.isnan(feed) or feed <= 0:
        raise it.err("a spline with no feed rate", line, w, "F > 0")
    it.emit(
        line=line,
        kind="curve",
        start=tuple(start),
        end=tuple(end),
        feed=feed,
        plane=17,
        curve=curve,
    )
    st.pos = end
