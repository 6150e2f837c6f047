"""What the interpreter takes from the machine profile."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

from .motion import Pose


@dataclass(frozen=True)
class ToolEntry:
    """A tool of the profile's tool table."""

    length: float  # mm, the G43 H<n> length offset
    diameter: float = 0.0


@dataclass(frozen=True)
class InterpreterConfig:
    """What the interpreter needs from the machine profile.

    work_offsets : G54..G59 → (x, y, z, a, b) [mm, deg]; missing ones are zero
    g28_position, g30_position : stored positions, workpiece frame
    tool_table : tool number → ToolEntry
    start : initial position, workpiece frame
    """

    work_offsets: Mapping[int, Pose] = field(default_factory=dict)
    g28_position: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    g30_position: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    tool_table: Mapping[int, ToolEntry] = field(default_factory=dict)
    start: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    active_work_offset: int = 54
