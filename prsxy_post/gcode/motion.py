"""What the interpreter yields: :class:`Motion`, one move, arc, dwell or machine
function of the machine, in the workpiece frame, mm and degrees."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, NamedTuple

if TYPE_CHECKING:
    from ..curves import Nurbs

MM_PER_INCH = 25.4

Pose = tuple[float, ...]  # (x, y, z, A, B)


class Motion(NamedTuple):
    """One move, arc or dwell the machine makes (a named tuple: cheap to make by
    the hundred thousand).

    start, end : (x, y, z, A, B) [mm, deg], workpiece frame
    feed : mm/min along the XYZ path; deg/min when only A/B move; for G93 the
        rate LinuxCNC derives (length × F); NaN for rapids
    plane, center, rotation : arcs only: 17/18/19, centre [mm], signed turns as in
        LinuxCNC's ARC_FEED (+ counter-clockwise seen from the plane normal's + end)
    duration : dwell seconds
    tool_length : active tool length offset [mm] (G43 / G43.1), 0 after G49
    path_tol : path control mode in effect (LinuxCNC group 13) [mm]: None when the
        program set none or gave G64 without P (the profile's default tolerance
        applies), the G64 P tolerance, 0.0 for G61 (exact path), −1.0 for G61.1
        (exact stop at every block end)
    words : kind ``"function"`` only: the machine functions of the block, in
        LinuxCNC's order of execution, as (letter, value) pairs: S, T, M6,
        M3/M4/M5, M7/M8/M9, M48/M49 before the block's motion; M0, M1, M60, M2,
        M30 after it
    curve : kind ``"curve"`` only (G5, G5.1, G5.2/G5.3): the exact curve from
        start to end (:class:`prsxy_post.curves.Nurbs`, workpiece frame, mm);
        A and B go linearly from start to end along its arc length; ``feed`` is
        along the curve
    """

    line: int
    kind: str
    start: Pose
    end: Pose
    feed: float = math.nan
    plane: int = 0
    center: tuple[float, float, float] | None = None
    rotation: int = 0
    duration: float = 0.0
    tool_length: float = 0.0
    tool: int = 0
    spindle: float = 0.0
    inverse_time: bool = False
    path_tol: float | None = None
    words: tuple[tuple[str, float], ...] = ()
    curve: Nurbs | None = None


#: path_tol of G61.1 (exact stop)
EXACT_STOP = -1.0


def motion_to_json(m: Motion) -> dict[str, object]:
    """The ``inspect --json`` object of a motion."""
    d: dict[str, object] = {
        "line": m.line,
        "kind": m.kind,
        "end": [round(v, 9) + 0.0 for v in m.end],
    }
    d["feed"] = None if m.kind in ("rapid", "dwell", "function") else round(m.feed, 9)
    if m.kind == "arc":
        assert m.center is not None
        d["plane"] = m.plane
        d["center"] = [round(v, 9) + 0.0 for v in m.center]
        d["rotation"] = m.rotation
    if m.kind == "dwell":
        d["duration"] = m.duration
    if m.kind == "function":
        d["words"] = [f"{letter}{value:g}" for letter, value in m.words]
    if m.kind == "curve":
        assert m.curve is not None
        d["curve"] = m.curve.to_json()
    return d
