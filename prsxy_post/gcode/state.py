"""The interpreter's modal state."""

from __future__ import annotations


class State:
    """The interpreter's modal state, one per interpreter (a plain class: it is
    made once and never compared or printed, so it needs none of the methods a
    dataclass would generate at import, 1.3 ms of every command's start-up)."""

    def __init__(self, pos: list[float]) -> None:
        self.pos = pos  # the tool tip, mm / deg: workpiece frame when rotation is 0
        self.origin = [0.0] * 5  # active work offset
        self.g92 = [0.0] * 5  # G92 / G52 offset
        # the active system's rotation about Z [deg] (G10 L2 R); when it is not 0,
        # pos is in the unrotated frame (offsets.py)
        self.rotation = 0.0
        self.units = "mm"
        self.plane = 17
        self.absolute = True
        self.arc_absolute = False
        self.inverse_time = False
        self.motion: float | None = None  # LinuxCNC starts in G80
        self.feed = 0.0  # F as written (current units or deg per min)
        self.spindle = 0.0
        self.spindle_dir = 0
        self.tool = 0
        self.next_tool = 0
        self.tool_length = 0.0
        self.coord = 1  # LinuxCNC's origin index: 1 (G54) .. 9 (G59.3)
        self.mist = False
        self.flood = False
        self.feed_override = True  # M48 (LinuxCNC's start) / M49, M50
        self.speed_override = True  # M48 / M49, M51
        self.adaptive_feed = False  # M52
        self.feed_hold = False  # M53
        self.css = False  # G96 (constant surface speed) / G97
        self.retract_r = True  # G99 (LinuxCNC default) vs G98
        self.cycle_r = 0.0
        self.cycle_z = 0.0  # in the cycle's own axis, workpiece frame
        self.cycle_q = 0.0
        self.cycle_p = 0.0
        self.cycle_il: float | None = None
        self.path_tol: float | None = None
        self.ended = False
        # cutter radius compensation (comp.py)
        self.comp_side = 0  # 0 off, 1 left (G41), 2 right (G42)
        self.comp_radius = 0.0  # mm
        self.comp_first = True  # the next move is the entry move
        self.program = [0.0] * 5  # programmed point
        self.arc_not_allowed = False  # the move after G40 must be straight
        # splines (splines.py)
        self.g5_i = 0.0  # G5's first control point when I J are left out
        self.g5_j = 0.0
        self.nurbs: list[tuple[float, float, float]] = []  # x, y, weight
        self.nurbs_order = 3
        self.nurbs_line = 0
