"""What the interpreter takes from the machine profile."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import NamedTuple

from .motion import Pose


class ToolEntry(NamedTuple):
    """A tool of the profile's tool table."""

    length: float  # mm, the G43 H<n> length offset
    diameter: float = 0.0


@dataclass(frozen=True)
class InterpreterConfig:
    """What the interpreter needs from the machine profile.

    work_offsets : G54..G59.3 → (x, y, z, a, b) [mm, deg] (keys 54..59, 59.1..59.3);
        missing ones are zero. They are the parameters #5221.. a program reads and
        may change (G10 L2/L20, or by assigning them)
    g28_position, g30_position : stored positions, workpiece frame (#5161.., #5181..)
    tool_table : tool number → ToolEntry (G10 L1/L10/L11 change the program's copy)
    start : initial position, workpiece frame
    active_work_offset : the coordinate system in effect at the start (54..59.3)
    subroutine_path : directories searched, in order, for ``name.ngc`` when a
        program calls a subroutine it has not defined (LinuxCNC's
        ``[RS274NGC] SUBROUTINE_PATH``); the program's own directory is searched
        first (LinuxCNC's ``PROGRAM_PREFIX``)
    max_loop_passes : how often, in all, the program's loops may go round
        (while, do, repeat passes and M98 L repeats); one more is an error (a
        program that never ends would otherwise hang the conversion)
    user_m_codes : the M100..M199 the controller has (LinuxCNC runs a user M code
        only when its program file exists); a program's others are refused
    on_message : called as ``on_message(source, line, kind, text)`` for the
        program's ``(MSG,…)``, ``(DEBUG,…)`` and ``(PRINT,…)`` comments (kind
        "MSG", "DEBUG", "PRINT"; parameters in DEBUG and PRINT already
        substituted as LinuxCNC does); None: messages are dropped (the library
        never prints)
    """

    work_offsets: Mapping[int, Pose] = field(default_factory=dict)
    g28_position: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    g30_position: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    tool_table: Mapping[int, ToolEntry] = field(default_factory=dict)
    start: Pose = (0.0, 0.0, 0.0, 0.0, 0.0)
    active_work_offset: float = 54
    subroutine_path: tuple[str, ...] = ()
    max_loop_passes: int = 10_000_000
    user_m_codes: frozenset[int] = frozenset()
    on_message: Callable[[str, int, str, str], None] | None = None
