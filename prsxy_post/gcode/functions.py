"""Machine functions: what a block asks of the machine besides moving, as
LinuxCNC's ``execute_block`` and ``convert_m`` run them, carried as events
(motions of kind ``"function"``) whose words are in LinuxCNC's order of
execution. Before the block's motion:

====================================  =========================================
words                                 meaning
====================================  =========================================
``("G", 96), ("D", rpm)``             constant surface speed (D: maximum rpm,
                                      when given); S is then the surface speed
``("G", 97)``                         spindle speed in rpm
``("S", s)``                          spindle speed (only when it changes)
``("T", n)``                          select tool n (only when it changes)
``("M", 62..65), ("P", n)``           digital output n on/off, with the next
                                      motion (62, 63) or at once (64, 65)
``("M", 66), ("P", n) | ("E", n),``   wait for digital input P or analog input
``("L", mode), ("Q", seconds)``       E (L, Q when given); its result #5399 is
                                      not known before the program runs: a
                                      program that reads it is refused
``("M", 67 | 68), ("E", n),``         analog output n to value, with the next
``("Q", value)``                      motion (67) or at once (68)
``("M", 6)``                          tool change (the spindle stops)
``("M", 61), ("Q", n)``               tool n is in the spindle (no change)
``("M", 3 | 4 | 5)``                  spindle clockwise, counterclockwise, stop
``("M", 7 | 8 | 9)``                  mist, flood, coolant off
``("M", 48 | 49)``                    feed and speed overrides on, off
``("M", 50..53), ("P", p)``           feed override, speed override, adaptive
                                      feed, feed hold switch (P0 off, P when
                                      given)
``("M", 100..199), ("P", p),``        a user M code (P, Q when given), one the
``("Q", q)``                          profile lists in ``[gcode] user_m_codes``
====================================  =========================================

After the motion: ``("M", 0 | 1 | 60 | 2 | 30)`` (stops and ends; an M99 in
the main program ends it as M2 and is written so).

M70 (save the modal state), M71 (forget it), M72 (restore it) and M73 (save,
restored when the subroutine returns) change only the interpreter's state: the
restore runs the G and M codes LinuxCNC's ``restore_settings`` generates, so
their functions come out as events like any others.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from .read import Word

if TYPE_CHECKING:
    from .execute import Interpreter

Words = list[tuple[str, float]]


def _round_to_int(v: float) -> int:
    return math.floor(v + 0.5)


def spindle_mode(it: Interpreter, code: float, seen: dict[str, Word], pre: Words) -> None:
    """G96 S<surface speed> [D<max rpm>], G97."""
    st = it.st
    st.css = code == 96
    if code == 96:
        pre.append(("G", 96.0))
        if "D" in seen:
            pre.append(("D", seen["D"].value))
    else:
        pre.append(("G", 97.0))


def io(it: Interpreter, code: int, w: Word, seen: dict[str, Word], pre: Words, line: int) -> None:
    """M62-M68 (LinuxCNC's convert_m, modal group 5)."""
    if code in (62, 63, 64, 65):
        it.no_comp(f"M{code}", line, w)
        if "P" not in seen:
            raise it.err(f"M{code} without a P word", line, w, f"M{code} P<output number>")
        pre += [("M", float(code)), ("P", float(_round_to_int(seen["P"].value)))]
    elif code == 66:
        p, e, lw, q = (seen.get(k) for k in ("P", "E", "L", "Q"))
        if p is not None and e is not None:
            raise it.err("M66 with both P and E", line, w, "a digital (P) or an analog (E) input")
        timeout = q.value if q is not None else -1.0
        if timeout <= 0 and lw is not None and _round_to_int(lw.value) > 0:
            raise it.err("M66 waiting with no timeout", line, lw, "Q<seconds> with L1..L4")
        if e is not None and lw is not None and _round_to_int(lw.value) != 0:
            raise it.err("M66 waiting on an analog input", line, lw, "L0 with E")
        if (
            (p is not None and _round_to_int(p.value) < 0)
            or (e is not None and _round_to_int(e.value) < 0)
            or (p is None and e is None)
        ):
            raise it.err("M66 without a valid P or E word", line, w, "M66 P<input> or E<input>")
        it.no_comp("M66", line, w)
        pre.append(("M", 66.0))
        if p is not None:
            pre.append(("P", float(_round_to_int(p.value))))
        else:
            assert e is not None
            pre.append(("E", float(_round_to_int(e.value))))
        if lw is not None:
            pre.append(("L", float(_round_to_int(lw.value))))
        if q is not None:
            pre.append(("Q", q.value))
        it.params.unknown.add(5399)
    else:  # 67, 68
        it.no_comp(f"M{code}", line, w)
        e = seen.get("E")
        if e is None or _round_to_int(e.value) < 0:
            raise it.err(f"M{code} without a valid E word", line, w, f"M{code} E<output> Q<value>")
        value = seen["Q"].value if "Q" in seen else -1.0  # LinuxCNC's q_number when absent
        pre += [("M", float(code)), ("E", float(_round_to_int(e.value))), ("Q", value)]


def tool_number(it: Interpreter, w: Word, seen: dict[str, Word], pre: Words, line: int) -> None:
    """M61 Q<n>: tool n is in the spindle now, without a tool change."""
    st = it.st
    q = seen.get("Q")
    n = _round_to_int(q.value) if q is not None else -1
    if n < 0:
        raise it.err("M61 without a tool number", line, w, "M61 Q<tool number> (Q >= 0)")
    if n:
        it.tool(n, line, q)
    st.tool = n
    it.tool_parameters()
    pre += [("M", 61.0), ("Q", float(n))]


def overrides(
    it: Interpreter, code: int, w: Word, seen: dict[str, Word], pre: Words, line: int
) -> None:
    """M48/M49 (all overrides), M50 (feed), M51 (speed), M52 (adaptive feed),
    M53 (feed hold): P0 turns the switch off, anything else (or no P) on."""
    st = it.st
    it.no_comp(f"M{code}", line, w)
    pre.append(("M", float(code)))
    if code in (48, 49):
        st.feed_override = st.speed_override = code == 48
        return
    on = True
    if "P" in seen:
        pre.append(("P", seen["P"].value))
        on = seen["P"].value != 0.0
    if code == 50:
        st.feed_override = on
    elif code == 51:
        st.speed_override = on
    elif code == 52:
        st.adaptive_feed = on
    else:
        st.feed_hold = on


# ---------------------------------------------------------------- M70-M73


def snapshot(it: Interpreter) -> dict[str, object]:
    """The modal state LinuxCNC saves (write_g_codes, write_m_codes,
    write_settings)."""
    st = it.st
    return {
        "plane": st.plane,
        "comp": {0: 40, 1: 41, 2: 42}[st.comp_side],
        "units": st.units,
        "absolute": st.absolute,
        "inverse_time": st.inverse_time,
        "coord": st.coord,
        "g43": st.tool_length != 0.0,
        "retract_r": st.retract_r,
        "path_tol": st.path_tol,
        "css": st.css,
        "arc_absolute": st.arc_absolute,
        "g92_applied": bool(it.params.values[5210]),
        "feed": st.feed,
        "speed": st.spindle,
        "spindle_dir": st.spindle_dir,
        "mist": st.mist,
        "flood": st.flood,
        "feed_override": st.feed_override,
        "speed_override": st.speed_override,
        "adaptive_feed": st.adaptive_feed,
        "feed_hold": st.feed_hold,
    }


def _gez(s: dict[str, object]) -> list[str]:
    """The restorable G codes in LinuxCNC's active_g_codes order (3 plane,
    4 compensation, 6 distance, 7 feed mode, 8 coordinate system, 9 length
    offset, 10 retract, 11 path control, 13 spindle mode, 14 arc centres,
    16 G92)."""
    coord = int(s["coord"])  # type: ignore[call-overload]
    tol = s["path_tol"]
    control = (
        "G64"
        if tol is None or (isinstance(tol, float) and tol > 0)
        else ("G61" if tol == 0.0 else "G61.1")
    )
    return [
        f"G{s['plane']}",
        f"G{s['comp']}",
        "G90" if s["absolute"] else "G91",
        "G93" if s["inverse_time"] else "G94",
        f"G{53 + coord}" if coord < 7 else f"G59.{coord - 6}",
        "G43" if s["g43"] else "G49",
        "G99" if s["retract_r"] else "G98",
        control,
        "G96" if s["css"] else "G97",
        "G90.1" if s["arc_absolute"] else "G91.1",
        "G92.3" if s["g92_applied"] else "G92.2",
    ]


def _emz(s: dict[str, object]) -> list[int]:
    """The restorable M codes in LinuxCNC's active_m_codes order (-1: none)."""
    fo, so = bool(s["feed_override"]), bool(s["speed_override"])
    return [
        {1: 3, -1: 4, 0: 5}[int(s["spindle_dir"])],  # type: ignore[call-overload]
        7 if s["mist"] else (-1 if s["flood"] else 9),
        8 if s["flood"] else -1,
        (48 if so else 50) if fo else (51 if so else 49),
        52 if s["adaptive_feed"] else -1,
        53 if s["feed_hold"] else -1,
    ]


def restore_blocks(now: dict[str, object], saved: dict[str, object]) -> list[str]:
    """The G-code LinuxCNC's restore_settings runs to go back to ``saved``
    (gen_settings, gen_m_codes): G20/G21 first, then one block of F, S and the
    G codes that differ (G64 and its P last), then one line per M code."""
    lines: list[str] = []
    if now["units"] != saved["units"]:
        lines.append("G20" if saved["units"] == "inch" else "G21")
    cmd = ""
    if now["feed"] != saved["feed"]:
        cmd += f" F{saved['feed']:.1f}"
    if now["speed"] != saved["speed"]:
        cmd += f" S{saved['speed']:.0f}"
    g64 = now["path_tol"] != saved["path_tol"]
    for a, b in zip(_gez(now), _gez(saved), strict=True):
        if a != b and b != "G64":
            cmd += " " + b
    if g64 and _gez(saved)[7] == "G64":
        tol = saved["path_tol"]
        unit = 25.4 if saved["units"] == "inch" else 1.0
        cmd += " G64" if tol is None else f" G64 P{float(tol) / unit:f}"  # type: ignore[arg-type]
    if cmd:
        lines.append(cmd.strip())
    for m_now, m_saved in zip(_emz(now), _emz(saved), strict=True):
        if m_now != m_saved and m_saved != -1:
            lines.append(f"M{m_saved}")
    return lines
