"""G-code in: RS274/NGC as LinuxCNC reads it, the milling subset.

The package follows the split of LinuxCNC's own interpreter (rs274ngc):

- :mod:`.lines`: program text into lines, lines into batches;
- :mod:`.read`: one line into a :class:`Block` of words, each with its column
  (``parse_line``); it knows nothing of modes;
- :mod:`.execute`: the modal :class:`Interpreter`, a block executed in LinuxCNC's
  order (machine functions, modes, motion, stops);
- :mod:`.moves`, :mod:`.cycles`: straight moves, arcs, G28/G30 and canned cycles
  into :class:`Motion` s;
- :mod:`.fast`: the common CAM block, matched over a batch of lines at once;
- :mod:`.stream`: :func:`iter_motions`, running it all over a program's lines as
  they come.

Motions are what the machine does, in the workpiece frame (LinuxCNC's machine
coordinates: program coordinates plus the work offset), always mm and degrees.

What LinuxCNC rejects is rejected here too, with ``file:line:column`` and the
offending word; what is outside this tool's subset (parameters, expressions,
O-words, cutter compensation, G92, G10, splines, polar coordinates, a C, U, V or W
axis) is rejected the same way. The behaviour follows LinuxCNC 2.9's interpreter
(``rs274 -g`` is the test oracle): canned cycles expand into its moves, G28/G30
go through the intermediate point, arcs obey its radius tolerances.

Choices where LinuxCNC depends on settings: block delete ``/`` is off (the line
runs, as in LinuxCNC's default); the first ``%`` line starts the program and a
second one ends it; M2/M30 end the program (nothing after them is read).
"""

from .config import InterpreterConfig, ToolEntry
from .execute import Interpreter
from .lines import FileLines, ProgramLines, batches_of, iter_line_batches, split_lines
from .motion import EXACT_STOP, MM_PER_INCH, Motion, Pose, motion_to_json
from .read import Block, Word, evaluate, parse
from .stream import interpret, iter_motions, iter_motions_batched

__all__ = [
    "EXACT_STOP",
    "MM_PER_INCH",
    "Block",
    "FileLines",
    "Interpreter",
    "InterpreterConfig",
    "Motion",
    "Pose",
    "ProgramLines",
    "ToolEntry",
    "Word",
    "batches_of",
    "evaluate",
    "interpret",
    "iter_line_batches",
    "iter_motions",
    "iter_motions_batched",
    "motion_to_json",
    "parse",
    "split_lines",
]
