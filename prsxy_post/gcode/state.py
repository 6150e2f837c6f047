"""The interpreter's modal state."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class State:
    pos: list[float]  # workpiece frame, mm / deg
    units: str = "mm"
    plane: int = 17
    absolute: bool = True
    arc_absolute: bool = False
    inverse_time: bool = False
    motion: float | None = None  # LinuxCNC starts in G80
    feed: float = 0.0  # F as written (current units or deg per min)
    feed_units: str = "mm"
    spindle: float = 0.0
    spindle_dir: int = 0
    tool: int = 0
    next_tool: int = 0
    tool_length: float = 0.0
    coord: int = 54
    retract_r: bool = True  # G99 (LinuxCNC default) vs G98
    cycle_r: float = 0.0
    cycle_z: float = 0.0  # in the cycle's own axis, workpiece frame
    cycle_q: float = 0.0
    cycle_p: float = 0.0
    cycle_il: float | None = None
    path_tol: float | None = None
    ended: bool = False
