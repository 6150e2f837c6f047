"""The interpreter's modal state."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class State:
    pos: list[float]  # the tool tip, mm / deg: workpiece frame when rotation is 0
    origin: list[float] = field(default_factory=lambda: [0.0] * 5)  # active work offset
    g92: list[float] = field(default_factory=lambda: [0.0] * 5)  # G92 / G52 offset
    #: the active system's rotation about Z [deg] (G10 L2 R); when it is not 0,
    #: pos is in the unrotated frame (offsets.py)
    rotation: float = 0.0
    units: str = "mm"
    plane: int = 17
    absolute: bool = True
    arc_absolute: bool = False
    inverse_time: bool = False
    motion: float | None = None  # LinuxCNC starts in G80
    feed: float = 0.0  # F as written (current units or deg per min)
    spindle: float = 0.0
    spindle_dir: int = 0
    tool: int = 0
    next_tool: int = 0
    tool_length: float = 0.0
    coord: int = 1  # LinuxCNC's origin index: 1 (G54) .. 9 (G59.3)
    mist: bool = False
    flood: bool = False
    feed_override: bool = True  # M48 (LinuxCNC's start) / M49, M50
    speed_override: bool = True  # M48 / M49, M51
    adaptive_feed: bool = False  # M52
    feed_hold: bool = False  # M53
    css: bool = False  # G96 (constant surface speed) / G97
    retract_r: bool = True  # G99 (LinuxCNC default) vs G98
    cycle_r: float = 0.0
    cycle_z: float = 0.0  # in the cycle's own axis, workpiece frame
    cycle_q: float = 0.0
    cycle_p: float = 0.0
    cycle_il: float | None = None
    path_tol: float | None = None
    ended: bool = False
    # cutter radius compensation (comp.py)
    comp_side: int = 0  # 0 off, 1 left (G41), 2 right (G42)
    comp_radius: float = 0.0  # mm
    comp_first: bool = True  # the next move is the entry move
    program: list[float] = field(default_factory=lambda: [0.0] * 5)  # programmed point
    arc_not_allowed: bool = False  # the move after G40 must be straight
    # splines (splines.py)
    g5_i: float = 0.0  # G5's first control point when I J are left out
    g5_j: float = 0.0
    nurbs: list[tuple[float, float, float]] = field(default_factory=list)  # x, y, weight
    nurbs_order: int = 3
    nurbs_line: int = 0
