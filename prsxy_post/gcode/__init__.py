"""G-code in: RS274/NGC as LinuxCNC 2.9 reads it, the milling dialect.

The package follows the split of LinuxCNC's own interpreter (rs274ngc):

- :mod:`.lines`: program text into lines, lines into batches;
- :mod:`.read`: one line into a :class:`Block` of words, each with its column
  (``parse_line``), expressions and parameters evaluated (:mod:`.expr`,
  :mod:`.params`); it knows nothing of modes;
- :mod:`.check`: a block's words checked and sorted into modal groups;
- :mod:`.execute`: the modal :class:`Interpreter`, a block executed in LinuxCNC's
  order (machine functions, modes, motion, stops);
- :mod:`.moves`, :mod:`.cycles`, :mod:`.splines`, :mod:`.comp`: straight moves,
  arcs, G28/G30, canned cycles, G5/G5.1/G5.2 curves and cutter radius
  compensation into :class:`Motion` s;
- :mod:`.offsets`: work offsets and their rotation (G10 L2/L20, G54..G59.3), the
  tool table (G10 L1/L10/L11), G92/G52, stored positions (G28.1/G30.1);
- :mod:`.control`: O-word subroutines, loops and conditions; :mod:`.functions`
  and :mod:`.messages`: machine functions and speaking comments;
- :mod:`.fast`: the common CAM block, matched over a batch of lines at once;
- :mod:`.stream`: :func:`iter_motions`, running it all over a program's lines as
  they come; :mod:`.rows`: motions as rows of a float table (the compiled fast
  path writes its moves there directly, :func:`iter_motion_items`).

Motions are what the machine does, in the workpiece frame (LinuxCNC's machine
coordinates: program coordinates plus the G92 offset, turned by the system's
rotation, plus the work offset), always mm and degrees.

Supported as LinuxCNC does them (``rs274 -g`` is the test oracle): numbered, named
and system parameters and ``[ ]`` expressions; O-word subroutines (``call``, files
on the subroutine path, M98/M99), ``while``/``do``/``repeat``/``if``; G0-G3 with
helices, R and centre arcs, G90.1/G91.1, polar coordinates (``@`` ``^``); canned
cycles G73, G74, G81-G86, G89 expanded into their moves (the tapping cycles in G17
only); G28/G30 through the intermediate point; G53; work offsets G54-G59.3 with G10
L2/L20 (their rotation R too), G92/G92.1/G92.2/G92.3 and G52; tool table changes G10
L1/L10/L11, tool lengths G43/G43.1/G49; cutter radius compensation
G41/G42/G41.1/G42.1/G40; splines G5, G5.1, G5.2/G5.3; G61/G61.1/G64, G93/G94,
G20/G21, G17/G18/G19; M functions, M70-M73, user M codes, comments (MSG, DEBUG,
PRINT, ABORT).

What LinuxCNC rejects is rejected here too, with ``file:line:column`` and the
offending word. What this machine does not do is rejected the same way, the message
saying "not supported" or "out of scope": a C, U, V or W axis; tool offsets other
than the length; arcs in G18/G19 while the coordinate system is rotated; G74/G84
outside G17; G43.2; G87/G88; lathe modes and cycles (G7, G8, G70-G72, G76),
threading and rigid tapping (G33, G33.1), probing (G38.x), feed per revolution
(G95), spindle orientation (M19) and selection (``$``).

Choices where LinuxCNC depends on settings: block delete ``/`` is off (the line
runs, as in LinuxCNC's default); the first ``%`` line starts the program and a
second one ends it; M2/M30 end the program (nothing after them is read).
"""

from . import rows
from .config import InterpreterConfig, ToolEntry
from .execute import Interpreter
from .lines import FileLines, ProgramLines, batches_of, iter_line_batches, split_lines
from .motion import EXACT_STOP, MM_PER_INCH, Motion, Pose, motion_to_json
from .read import Block, Word, evaluate, parse
from .stream import interpret, iter_motion_items, iter_motions, iter_motions_batched

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
    "iter_motion_items",
    "iter_motions",
    "iter_motions_batched",
    "motion_to_json",
    "parse",
    "rows",
    "split_lines",
]
