"""Parameters as LinuxCNC keeps them: numbered ``#1``–``#5601``, named local
``#<x>`` (one scope per subroutine call) and named global ``#<_x>``.

Numbered parameters hold the machine's settings where LinuxCNC keeps them, in
machine units (mm here, degrees for A and B):

=========== ==========================================================
#1-#30      subroutine arguments (saved and restored around a call)
#5161-5169  G28 position (x y z a b c u v w)
#5181-5189  G30 position
#5210       1 while G92 offsets apply
#5211-5219  G92 offsets
#5220       active coordinate system, 1 (G54) to 9 (G59.3)
#5221-5230  G54 offsets (x y z a b c u v w) and XY rotation; G55 at #5241, …,
            G59.3 at #5381 (every 20)
#5399       the result of M66
#5400-5413  the tool in the spindle: number, offsets x…w, diameter, front
            and back angle, orientation (read-only)
#5420-5428  the current position, program coordinates, program units
            (read-only; unreadable with cutter compensation on)
#5599       1: (DEBUG,…) messages are shown
=========== ==========================================================

Named global parameters that start with ``_`` and are LinuxCNC's own
(``#<_x>``, ``#<_metric>``, ``#<_coord_system>``, … listed in
:data:`SYSTEM_NAMES`) are read-only and computed from the interpreter's state.
"""

from __future__ import annotations

from collections.abc import Callable

from .expr import ExprError

NUM_PARAMETERS = 5602
#: numbered parameters a program may not set (LinuxCNC 2.9's _readonly_parameters)
READ_ONLY = frozenset([*range(5400, 5414), *range(5420, 5429)])
#: LinuxCNC's INTERP_SUB_ROUTINE_LEVELS: call levels 0 (the program) to 9
MAX_CALL_LEVELS = 10
#: arguments #1..#30 of a call
SUB_ARGS = 30

#: LinuxCNC's own named parameters (init_named_parameters), computed on reading
SYSTEM_NAMES = frozenset(
    [
        "_vmajor",
        "_vminor",
        "_metric_machine",
        "_line",
        "_motion_mode",
        "_plane",
        "_ccomp",
        "_metric",
        "_imperial",
        "_absolute",
        "_incremental",
        "_inverse_time",
        "_units_per_minute",
        "_units_per_rev",
        "_coord_system",
        "_tool_offset",
        "_retract_r_plane",
        "_retract_old_z",
        "_spindle_rpm_mode",
        "_spindle_css_mode",
        "_ijk_absolute_mode",
        "_lathe_diameter_mode",
        "_lathe_radius_mode",
        "_spindle_on",
        "_spindle_cw",
        "_mist",
        "_flood",
        "_speed_override",
        "_feed_override",
        "_adaptive_feed",
        "_feed_hold",
        "_feed",
        "_rpm",
        "_current_tool",
        "_current_pocket",
        "_selected_pocket",
        "_selected_tool",
        "_x",
        "_y",
        "_z",
        "_a",
        "_b",
        "_c",
        "_u",
        "_v",
        "_w",
        "_abs_x",
        "_abs_y",
        "_abs_z",
        "_abs_a",
        "_abs_b",
        "_abs_c",
        "_value",
        "_value_returned",
        "_task",
        "_call_level",
        "_remap_level",
    ]
)


class Parameters:
    """The parameter store of one program run.

    system : name → value of a LinuxCNC named parameter (:data:`SYSTEM_NAMES`)
    position : 5420..5428 → the current position in program coordinates
    comp_on : whether cutter radius compensation is on (then #5420.. cannot be read)
    """

    def __init__(
        self,
        system: Callable[[str], float],
        position: Callable[[int], float],
        comp_on: Callable[[], bool],
    ) -> None:
        self.values = [0.0] * NUM_PARAMETERS
        self.values[5599] = 1.0  # (DEBUG,...) on, as LinuxCNC starts
        self.values[5220] = 1.0
        #: named parameters per call level; level 0 holds the globals too
        self.frames: list[dict[str, float]] = [{}]
        #: parameters whose value is not known before the program runs (#5399
        #: after M66): reading one is an error
        self.unknown: set[int] = set()
        #: reading an undefined named parameter gives 0 instead of an error (the
        #: value of an endsub/return read while a subroutine is being defined)
        self.lenient_named = False
        self._system = system
        self._position = position
        self._comp_on = comp_on

    @property
    def call_level(self) -> int:
        return len(self.frames) - 1

    # -- reading (the expr.Params protocol)
    def get(self, index: int, column: int) -> float:
        if 5420 <= index <= 5428:
            if self._comp_on():
                raise ExprError(
                    "the current position cannot be read with cutter compensation on",
                    column,
                    "G40 before reading #5420-#5428",
                )
            return self._position(index)
        if not 1 <= index < NUM_PARAMETERS:
            raise ExprError(f"parameter number {index} out of range", column, "#1 to #5601")
        if index in self.unknown:
            raise ExprError(
                f"#{index} (the input M66 waited for) is not known before the program runs",
                column,
                "a program that does not branch on the machine's inputs",
            )
        return self.values[index]

    def _frame(self, name: str) -> dict[str, float]:
        return self.frames[0] if name.startswith("_") else self.frames[-1]

    def get_named(self, name: str, column: int) -> float:
        v = self._frame(name).get(name)
        if v is not None:
            return v
        if name in SYSTEM_NAMES:
            return self._system(name)
        if self.lenient_named:
            return 0.0
        raise ExprError(
            f"named parameter #<{name}> is not defined",
            column,
            f"#<{name}> set before it is read",
        )

    def exists_named(self, name: str) -> bool:
        return name in self._frame(name) or name in SYSTEM_NAMES

    # -- writing
    def add_named(self, name: str) -> None:
        """A ``#<name>=`` being read: the parameter exists from now on (value 0
        until the line's assignments take effect), as in LinuxCNC."""
        if name in SYSTEM_NAMES:
            return
        self._frame(name).setdefault(name, 0.0)

    def check_writable(self, target: int | str) -> str | None:
        """Why a program may not set this parameter (None: it may)."""
        if isinstance(target, str):
            if target in SYSTEM_NAMES:
                return f"#<{target}> is read-only"
            return None
        if target in READ_ONLY:
            return f"#{target} is read-only"
        return None

    def assign(self, sets: tuple[tuple[int | str, float], ...]) -> None:
        """A line's assignments, all together after it is read (in line order:
        the last of two to the same parameter wins)."""
        for target, value in sets:
            if isinstance(target, str):
                self._frame(target)[target] = value
            else:
                self.values[target] = value
                self.unknown.discard(target)

    # -- calls
    def enter(self, args: list[float] | None) -> list[float]:
        """A new call level with its own named locals; ``args`` (an O-word call)
        become #1..#30 (missing ones 0), and the caller's are returned to be
        restored; M98 (``args`` None) passes #1..#30 through."""
        self.frames.append({})
        if args is None:
            return []
        saved = self.values[1 : SUB_ARGS + 1]
        full = list(args) + [0.0] * (SUB_ARGS - len(args))
        self.values[1 : SUB_ARGS + 1] = full
        return saved

    def leave(self, saved: list[float]) -> None:
        """Back to the caller: its locals are visible again, its #1..#30 restored."""
        self.frames.pop()
        if saved:
            self.values[1 : SUB_ARGS + 1] = saved
