"""Offsets a program sets: work offsets (G10 L2/L20), tool table entries (G10
L1/L10/L11), the G92/G52 offset (G92, G92.1, G92.2, G92.3, G52), stored
positions (G28.1/G30.1), as LinuxCNC's ``convert_setup``,
``convert_setup_tool``, ``convert_axis_offsets`` and ``convert_savehome`` keep
them: in the numbered parameters (#5161.., #5181.., #5211.., #5221.., machine
units: mm and degrees here).

The frames (all mm and degrees, x y z a b): the tool tip in the workpiece frame
``tip``; the work offset ``origin`` of the active system and its rotation ``r``
about Z (G10 L2 R, parameter #5210 + 20 n); the G92 offset ``g92``; program
coordinates ``p``. As LinuxCNC's canon places a point (emccanon.cc
rotate_and_offset_pos: G92 offset, then the rotation, then the work offset)::

    tip_xy = R(r) (p_xy + g92_xy) + origin_xy,    tip_zab = p_zab + g92_zab + origin_zab

The interpreter's position ``st.pos`` is the point ``q = p + g92 + origin`` of the
*unrotated* frame (``q = R(-r) (tip - origin) + origin`` in XY): there the program
is a translation, so moves, arcs, cycles and compensation are computed as
without rotation, and :func:`to_work` turns each motion's points into the
workpiece frame when it goes out (``Interpreter.emit_now``). With ``r = 0`` the
two frames are one. The spindle's gauge point is the tip plus the tool length in
z. Changing an offset never moves the machine: the program coordinates of the
same tip change (:func:`change_frame`), except where LinuxCNC itself computes
them otherwise (G10 L2/L20 of the active system with G92 on and a rotation,
:func:`_carry_setup`).

Not on this machine: tool offsets other than the length (X, Y, A, B in G10
L1/L10/L11), and arcs in G18/G19 while the system is rotated (they would lie in
a plane that is not XZ or YZ of the workpiece).
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from .config import ToolEntry
from .read import Word

if TYPE_CHECKING:
    from ..curves import Nurbs
    from .execute import Interpreter
    from .state import State

_AXES = ("X", "Y", "Z", "A", "B")


def system_base(index: int) -> int:
    """The first parameter of coordinate system ``index`` (1: G54 .. 9: G59.3)."""
    return 5201 + 20 * index


def g10(it: Interpreter, seen: dict[str, Word], w: Word, line: int) -> None:
    """G10 L0/L1/L2/L10/L11/L20 (the L and P words are checked already)."""
    lv = int(seen["L"].value)
    if lv in (1, 10, 11):
        _setup_tool(it, lv, seen, w, line)
    elif lv == 0:
        if it.st.tool > 0:
            raise it.err(
                f"G10 L0 (reload the tool table) with tool {it.st.tool} loaded",
                line,
                w,
                "T0 M6 first",
            )
    else:
        _setup_system(it, lv, seen, w, line)


def rotate(x: float, y: float, degrees: float) -> tuple[float, float]:
    """(x, y) turned by ``degrees`` about the origin, counter-clockwise seen from
    +Z (LinuxCNC's Interp::rotate, interp_convert.cc:1743-1750)."""
    t = degrees * math.pi / 180.0
    c, s = math.cos(t), math.sin(t)
    return x * c - y * s, x * s + y * c


def to_work(st: State, q: list[float] | tuple[float, ...]) -> list[float]:
    """A point of the interpreter's unrotated frame in the workpiece frame:
    ``R(r) (q - origin) + origin`` in XY (see the module's docstring)."""
    out = list(q)
    if st.rotation:
        ox, oy = st.origin[0], st.origin[1]
        x, y = rotate(q[0] - ox, q[1] - oy, st.rotation)
        out[0], out[1] = x + ox, y + oy
    return out


def from_work(st: State, tip: list[float] | tuple[float, ...]) -> list[float]:
    """The inverse of :func:`to_work`."""
    out = list(tip)
    if st.rotation:
        ox, oy = st.origin[0], st.origin[1]
        x, y = rotate(tip[0] - ox, tip[1] - oy, -st.rotation)
        out[0], out[1] = x + ox, y + oy
    return out


def curve_to_work(st: State, curve: Nurbs) -> Nurbs:
    """A curve's control points into the workpiece frame (a rotation about Z
    maps a rational curve onto the one of its rotated control points)."""
    ctrl = np.array([to_work(st, tuple(c)) for c in curve.control])
    return replace(curve, control=ctrl)


def change_frame(it: Interpreter, origin: list[float], rotation: float) -> None:
    """The active system's offsets and rotation become these; the tool stays
    where it is, its program coordinates change (convert_coordinate_system
    through find_current_in_system, interp_convert.cc:1801-1820). G10 L2/L20 of
    the active system carry the point otherwise (:func:`_carry_setup`)."""
    st = it.st
    tip = to_work(st, st.pos)
    held = to_work(st, it.detached) if it.detached is not None else None
    st.origin = list(origin)
    st.rotation = rotation
    st.pos = from_work(st, tip)
    if held is not None:
        it.detached = tuple(from_work(st, held))


def _setup_system(it: Interpreter, lv: int, seen: dict[str, Word], w: Word, line: int) -> None:
    """G10 L2 P… sets a system's offsets and rotation; L20 so that the current
    position becomes the given one in that system (LinuxCNC's convert_setup,
    interp_convert.cc:4180-4374 at 2.9.0~pre1)."""
    st = it.st
    for bad in ("I", "J"):
        if bad in seen:
            raise it.err("I and J words with G10 L2", line, seen[bad], "X Y Z A B (and R)")
    p = int(seen["P"].value + 0.0001)
    index = p or st.coord
    if index == st.coord:
        it.no_comp("a change of the active coordinate system", line, w)
    base = system_base(index)
    pars = it.params.values
    if "R" in seen:
        if lv == 20:
            raise it.err("R word with G10 L20", line, seen["R"], "R with G10 L2 only")
        pars[base + 9] = seen["R"].value
    r = pars[base + 9]
    sc = it.scale()
    given = [
        seen[a].value * (sc if i < 3 else 1.0) if a in seen else None for i, a in enumerate(_AXES)
    ]
    if lv == 20:
        cur = _current_in_system(it, index)
        # the desired point, the current one on axes not given, in system
        # ``index``; the offset moves by their difference, turned by its rotation
        want = [cur[i] if v is None else v for i, v in enumerate(given)]
        dx, dy = rotate(cur[0] - want[0], cur[1] - want[1], r)
        pars[base] += dx
        pars[base + 1] += dy
        for i in range(2, 5):
            if given[i] is not None:
                pars[base + i] += cur[i] - want[i]
    else:
        for i, v in enumerate(given):
            if v is not None:
                pars[base + i] = v
    if index == st.coord:
        _carry_setup(it, it.stored_origin(index), r)


def _carry_setup(it: Interpreter, origin: list[float], rotation: float) -> None:
    """The active system's offsets and rotation become these, the program point
    carried as LinuxCNC's convert_setup carries it (interp_convert.cc:4328-4366):
    turned out by the old rotation, moved by the change of offset, turned back
    by the new one, the G92 offset left out of the turns. With G92 on and a
    rotation, the interpreter's point then is not where the tool is (the tip
    stays; the next move starts from it and goes where LinuxCNC sends it)."""
    st = it.st
    held = to_work(st, it.detached) if it.detached is not None else None
    old, g = st.origin, st.g92
    p = [st.pos[i] - old[i] - g[i] for i in range(5)]
    p[0], p[1] = rotate(p[0], p[1], st.rotation)
    p = [p[i] + old[i] - origin[i] for i in range(5)]
    p[0], p[1] = rotate(p[0], p[1], -rotation)
    st.origin = list(origin)
    st.rotation = rotation
    st.pos = [p[i] + g[i] + origin[i] for i in range(5)]
    if held is not None:
        it.detached = tuple(from_work(st, held))


def _current_in_system(it: Interpreter, index: int) -> list[float]:
    """The tool's program coordinates in system ``index`` (mm, deg), the G92
    offset applied when it is (LinuxCNC's find_current_in_system,
    interp_find.cc:467-526)."""
    st = it.st
    pars = it.params.values
    base = system_base(index)
    tip = to_work(st, st.pos)
    cur = [tip[i] - pars[base + i] for i in range(5)]
    cur[0], cur[1] = rotate(cur[0], cur[1], -pars[base + 9])
    if pars[5210]:
        cur = [c - pars[5211 + i] for i, c in enumerate(cur)]
    return cur


def _setup_tool(it: Interpreter, lv: int, seen: dict[str, Word], w: Word, line: int) -> None:
    """G10 L1 P<tool> Z<length> R<radius>: the tool table entry; L10: the
    length that makes the current position Z in the active system; L11: the same
    in G59.3, the G92 offset aside."""
    st = it.st
    tool = round(seen["P"].value)
    entry = it.tool(tool, line, seen["P"])
    if not any(a in seen for a in ("X", "Y", "Z", "A", "B", "R", "Q", "I", "J")):
        raise it.err("G10 L1 without offsets has no effect", line, w, "Z<length> or R<radius>")
    for a in ("X", "Y", "A", "B"):
        if a in seen and (lv != 1 or seen[a].value != 0.0):
            raise it.err(
                f"tool offsets in {a} are not supported",
                line,
                seen[a],
                "the tool length (Z) and radius (R) only on this machine",
            )
    if "Q" in seen:
        q = seen["Q"].value
        if abs(q - round(q)) > 0.0001:
            raise it.err("Q of G10 not an integer", line, seen["Q"], "a tool orientation 0..9")
        if round(q) > 9:
            raise it.err("tool orientation above 9", line, seen["Q"], "a tool orientation 0..9")
    sc = it.scale()
    length, diameter = entry.length, entry.diameter
    if "Z" in seen:
        z = seen["Z"].value * sc
        if lv == 1:
            length = z
        else:
            # the gauge point's z in the destination system (LinuxCNC's
            # find_current_in_system_without_tlo: the active one less the G92
            # offset for L10, G59.3 for L11)
            gauge = st.pos[2] + st.tool_length
            pars = it.params.values
            if lv == 10:
                here = gauge - st.origin[2] - (pars[5213] if pars[5210] else 0.0)
            else:
                here = gauge - pars[system_base(9) + 2]
            length = here - z
    if "R" in seen:
        diameter = 2.0 * seen["R"].value * sc
    it.tools[tool] = ToolEntry(length, diameter)
    if tool == st.tool:
        it.tool_parameters()


def axis_offsets(it: Interpreter, code: float, seen: dict[str, Word]) -> None:
    """G92 (the current position becomes the given one), G52 (a local offset),
    G92.1 (cancel, parameters zeroed), G92.2 (cancel, parameters kept), G92.3
    (apply the parameters again)."""
    st = it.st
    pars = it.params.values
    sc = it.scale()
    if code in (92, 52):
        pars[5210] = 1.0
        for i, a in enumerate(_AXES):
            if a in seen:
                v = seen[a].value * (sc if i < 3 else 1.0)
                st.g92[i] = v if code == 52 else st.pos[i] - st.origin[i] - v
        pars[5211:5216] = st.g92
    elif code in (92.1, 92.2):
        pars[5210] = 0.0
        st.g92 = [0.0] * 5
        if code == 92.1:
            pars[5211:5220] = [0.0] * 9
    else:  # 92.3
        pars[5210] = 1.0
        st.g92 = pars[5211:5216]


def save_home(it: Interpreter, code: float) -> None:
    """G28.1 / G30.1: the gauge point's position, stored for G28 / G30."""
    st = it.st
    base = 5161 if code == 28.1 else 5181
    gauge = to_work(st, st.pos)
    gauge[2] += st.tool_length
    it.params.values[base : base + 5] = gauge
