"""LinuxCNC's ``rs274 -g`` as a test oracle: run it, read its canonical calls back as motions.

rs274 prints positions in program coordinates (the work offset, the G92
offset and the rotation about Z are printed apart, by SET_G5X_OFFSET,
SET_G92_OFFSET and SET_XY_ROTATION) and in the length units in effect
(USE_LENGTH_UNITS); this turns them into the workpiece frame in mm, the frame of
``inspect --json``, as LinuxCNC's canon does (emccanon.cc, rotate_and_offset_pos:
the G92 offset is added, the sum turned by the rotation, the work offset added).
Its standalone tool table and parameter file are in inches.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import tempfile
from dataclasses import dataclass, field

RS274 = shutil.which("rs274")
#: an rs274 killed by a signal is run again, then refused: its empty output would
#: read as a program without motions (several rs274 sharing one $HOME died of
#: SIGBUS on the tool table file they share; each run now has its own, below)
CRASH_RETRIES = 3
NUM = r"(-?\d+\.\d+)"


@dataclass
class OracleMotion:
    line_index: int
    kind: str
    end: tuple[float, ...]
    feed: float | None
    plane: int = 0
    center: tuple[float, float, float] | None = None
    rotation: int = 0
    duration: float = 0.0
    scale: float = 1.0  # 25.4 when the interpreter printed inches (4 decimals of them)
    control_points: int = 0  # curves (NURBS_FEED): how many
    tool_length: float = 0.0  # Z of the tool length offset in effect (USE_TOOL_LENGTH_OFFSET) [mm]
    tool_scale: float = 1.0  # 25.4 when that offset was printed in inches
    xy_rotation: float = 0.0  # SET_XY_ROTATION in effect [deg]
    #: 25.4 when an offset added to the point (G5x, or a G92 offset not 0) was
    #: printed in inches: its last decimal is then 2.54e-3 mm
    offset_scale: float = 1.0


@dataclass
class OracleResult:
    motions: list[OracleMotion]
    error: str | None
    #: every canonical call in order: (name, argument text)
    calls: list[tuple[str, str]] = field(default_factory=list)
    #: what (PRINT,...) wrote (rs274 prints it among the calls)
    prints: list[str] = field(default_factory=list)
    #: rs274 lost the tool's position at a tool change (see :func:`_stale`): how
    #: many motions it made before, and why; None when it did not
    lost_after: int | None = None
    lost_why: str = ""


def run(
    program_text: str,
    offsets: dict[int, tuple[float, ...]] | None = None,
    g28: tuple[float, ...] = (0, 0, 0, 0, 0),
    g30: tuple[float, ...] = (0, 0, 0, 0, 0),
    tools: dict[int, float] | dict[int, tuple[float, float]] | None = None,
    timeout: float = 60.0,
    subroutines: dict[str, str] | None = None,
) -> OracleResult:
    """Interpret a program with rs274; offsets/positions in mm (converted to its inches).

    ``subroutines``: files ``name.ngc`` → text, put in a folder rs274 searches
    (``[RS274NGC] SUBROUTINE_PATH`` of an INI file); see :func:`subroutine_dir`.
    """
    assert RS274 is not None
    with tempfile.TemporaryDirectory() as d:
        prog = os.path.join(d, "p.ngc")
        extra: list[str] = []
        if subroutines:
            subs = os.path.join(d, "subs")
            os.mkdir(subs)
            for name, body in subroutines.items():
                with open(os.path.join(subs, name), "w", encoding="utf-8", newline="") as fh:
                    fh.write(body)
            ini = os.path.join(d, "p.ini")
            with open(ini, "w") as fh:
                fh.write(f"[RS274NGC]\nSUBROUTINE_PATH = {subs}\n")
            extra = ["-i", ini]
        with open(prog, "w", encoding="utf-8", newline="") as fh:
            fh.write(program_text)
        var = os.path.join(d, "p.var")
        lines = []
        for base, pos in ((5161, g28), (5181, g30)):
            lines += [f"{base + i} {v / 25.4:.12f}" for i, v in enumerate(pos[:3])]
            lines += [f"{base + 3 + i} {v:.12f}" for i, v in enumerate(pos[3:5])]
        for n, off in (offsets or {}).items():
            base = 5221 + 20 * (n - 54)
            lines += [f"{base + i} {v / 25.4:.12f}" for i, v in enumerate(off[:3])]
            lines += [f"{base + 3 + i} {v:.12f}" for i, v in enumerate(off[3:5])]
        with open(var, "w") as fh:
            fh.write("\n".join(sorted(lines, key=lambda s: int(s.split()[0]))) + "\n")
        tbl = os.path.join(d, "p.tbl")
        with open(tbl, "w") as fh:
            for n, spec in (tools or {}).items():
                length, diameter = spec if isinstance(spec, tuple) else (spec, 0.0)
                # (nearly) every digit of the double, in inches as rs274 keeps them:
                # at 9 decimals a 6 mm tool came back 5.6e-9 mm small in radius, which
                # a nearly straight compensation entry arc (its centre 1400 mm away)
                # turned into 4e-4 mm on the centre (test_gcode_comp)
                fh.write(f"T{n} P{n} Z{length / 25.4:.17f} D{diameter / 25.4:.17f} ;\n")
        for _ in range(CRASH_RETRIES):
            try:
                proc = subprocess.run(
                    [RS274, *extra, "-t", tbl, "-v", var, "-g", prog],
                    cwd=d,
                    capture_output=True,
                    text=True,
                    timeout=timeout,
                    stdin=subprocess.DEVNULL,
                    # LinuxCNC 2.9 keeps the tool table in a file mapped into
                    # memory, $HOME/.tool.mmap (rs274 makes it there on each run:
                    # its tool_mmap_creator); each run gets its own, or runs at
                    # the same time share and truncate it
                    env={**os.environ, "HOME": d},
                )
            except subprocess.TimeoutExpired as exc:
                # LinuxCNC's own tests hold a program it loops on for ever
                # (tests/interp/g71-endless-loop): it does not run to the end.
                # What it wrote up to then is kept, to its last whole line
                # (TimeoutExpired holds bytes whatever ``text`` says)
                out = exc.stdout or b""
                text = out.decode(errors="replace") if isinstance(out, bytes) else out
                result = parse(text[: text.rfind("\n") + 1])
                result.error = f"rs274 did not end within {timeout:g} s"
                return result
            if proc.returncode >= 0:
                break
        else:
            raise RuntimeError(
                f"rs274 was killed by signal {-proc.returncode} {CRASH_RETRIES} times: "
                "no verdict (another rs274 running at the same time?)"
            )
    return parse(proc.stdout, proc.stderr)


def parse(out: str, err: str = "") -> OracleResult:
    """Canonical calls from rs274's standard output; the error (the first line
    of standard error after "executing") from its standard error."""
    scale = 1.0
    g5x = [0.0] * 6
    g92 = [0.0] * 6
    g5x_scale = g92_scale = 1.0  # the scale each was printed at
    xy_rot = 0.0  # SET_XY_ROTATION [deg]

    def place(p: list[float]) -> tuple[float, ...]:
        """A printed point (x y z in the units in effect, then a b) in the
        workpiece frame, mm."""
        x, y, z = ((p[k] * scale + g92[k]) for k in range(3))
        if xy_rot:
            t = xy_rot * math.pi / 180.0
            x, y = x * math.cos(t) - y * math.sin(t), x * math.sin(t) + y * math.cos(t)
        xyz = (x + g5x[0], y + g5x[1], z + g5x[2])
        return (*xyz, *(p[3 + k] + g92[3 + k] + g5x[3 + k] for k in range(len(p) - 3)))

    feed = 0.0
    plane = 17
    tool_length = 0.0
    tool_scale = 1.0
    motions: list[OracleMotion] = []
    last: tuple[float, ...] = (0.0,) * 5
    error = None
    for ln in err.splitlines():
        if ln.strip() and ln.strip() != "executing":
            error = ln.strip()  # the message; the offending line follows
            break
    calls: list[tuple[str, str]] = []
    prints: list[str] = []
    lines = out.splitlines()
    #: what placed the last point the stand-in canon was given (see _stale)
    at_motion = (0.0, 0.0, (0.0,) * 6, False)
    lost_after: int | None = None
    lost_why = ""
    for i, ln in enumerate(lines):
        m = re.match(r"\s*\d+ N[\d.]+\s+(\w+)\((.*)\)\s*$", ln)
        if not m:
            if not re.match(r"\s*\d+ N", ln):
                prints.append(ln)
            continue
        name, args = m.group(1), m.group(2)
        calls.append((name, args))
        vals = [float(v) for v in re.findall(r"-?\d+\.\d+|-?\d+", args)] if args else []
        if name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED", "ARC_FEED"):
            at_motion = (tool_length, xy_rot, tuple(g5x), False)
        elif name == "NURBS_FEED":
            at_motion = (tool_length, xy_rot, tuple(g5x), True)
        elif (
            name in ("CHANGE_TOOL", "CHANGE_TOOL_NUMBER", "RELOAD_TOOLDATA") and lost_after is None
        ):
            why = _stale(at_motion, (tool_length, xy_rot, tuple(g5x)))
            if why:
                lost_after, lost_why = len(motions), why
        if name == "USE_LENGTH_UNITS":
            scale = 25.4 if "INCHES" in args else 1.0
        elif name == "SET_G5X_OFFSET":
            # printed in the length units in effect when it is set
            g5x = [v * scale for v in vals[1:4]] + list(vals[4:7])
            g5x_scale = scale
        elif name == "SET_G92_OFFSET":
            g92 = [v * scale for v in vals[0:3]] + list(vals[3:6])
            g92_scale = scale
        elif name == "SET_XY_ROTATION":
            xy_rot = vals[0]
        elif name == "USE_TOOL_LENGTH_OFFSET":
            tool_length = vals[2] * scale  # printed in the length units in effect
            tool_scale = scale
        elif name == "SELECT_PLANE":
            plane = {"CANON_PLANE_XY": 17, "CANON_PLANE_XZ": 18, "CANON_PLANE_YZ": 19}[args]
        elif name == "SET_FEED_RATE":
            feed = vals[0]
        elif name in ("STRAIGHT_TRAVERSE", "STRAIGHT_FEED"):
            end = place(vals[:5])
            kind = "rapid" if name == "STRAIGHT_TRAVERSE" else "feed"
            # the feed is in length units per minute when X, Y or Z move, else deg/min
            moved = math.dist(end[:3], last[:3]) > 1e-9 or end[3:] == last[3:]
            f = feed * (scale if moved else 1.0)
            motions.append(
                OracleMotion(
                    i,
                    kind,
                    end,
                    None if kind == "rapid" else f,
                    scale=scale,
                    tool_length=tool_length,
                    tool_scale=tool_scale,
                    xy_rotation=xy_rot,
                    offset_scale=max(g5x_scale, g92_scale if any(g92) else 1.0),
                )
            )
            last = end
        elif name == "ARC_FEED":
            e1, e2, c1, c2, rot, ax, a, b = vals[:8]
            # first/second axis per plane: XY: (x, y), XZ: (z, x), YZ: (y, z)
            idx = {17: (0, 1, 2), 18: (2, 0, 1), 19: (1, 2, 0)}[plane]
            end = [0.0] * 3
            cen = [0.0] * 3
            end[idx[0]], end[idx[1]], end[idx[2]] = e1, e2, ax
            cen[idx[0]], cen[idx[1]], cen[idx[2]] = c1, c2, ax
            end5 = place([*end, a, b])
            center = place(cen)
            motions.append(
                OracleMotion(
                    i,
                    "arc",
                    end5,
                    feed * scale,
                    plane,
                    center,
                    int(rot),
                    scale=scale,
                    tool_length=tool_length,
                    tool_scale=tool_scale,
                    xy_rotation=xy_rot,
                    offset_scale=max(g5x_scale, g92_scale if any(g92) else 1.0),
                )
            )
            last = end5
        elif name == "NURBS_FEED":
            # the stand-in canon prints only how many control points there are
            # (and reads its new position from past the end of them)
            motions.append(
                OracleMotion(
                    i,
                    "curve",
                    last,
                    feed * scale,
                    control_points=int(vals[0]),
                    tool_length=tool_length,
                    tool_scale=tool_scale,
                    xy_rotation=xy_rot,
                    offset_scale=max(g5x_scale, g92_scale if any(g92) else 1.0),
                )
            )
        elif name == "DWELL":
            p = motions[-1].end if motions else None
            motions.append(
                OracleMotion(
                    i,
                    "dwell",
                    p or (math.nan,) * 5,
                    None,
                    duration=vals[0],
                    tool_length=tool_length,
                    tool_scale=tool_scale,
                    xy_rotation=xy_rot,
                    offset_scale=max(g5x_scale, g92_scale if any(g92) else 1.0),
                )
            )
    return OracleResult(motions, error, calls, prints, lost_after, lost_why)


#: the canonical calls of the blocks after which LinuxCNC reads the position back
_REREAD = ("CHANGE_TOOL", "CHANGE_TOOL_NUMBER", "RELOAD_TOOLDATA")


def _stale(
    at_motion: tuple[float, float, tuple[float, ...], bool],
    now: tuple[float, float, tuple[float, ...]],
) -> str:
    """Why standalone rs274 takes a wrong position after a tool change, or "".

    After a block with M6 or M61, LinuxCNC reads the position back from the
    canon before the next line (LinuxCNC 2.9.0~pre1, f1270d6ed7, the rs274
    installed here: Interp::_read calls read_inputs, rs274ngc_pre.cc:1599, which
    on toolchange_flag calls refresh_actual_position, :1447-1452; that sets
    current_x.. from GET_EXTERNAL_POSITION_X.., interp_internal.cc:410-422; the
    flag is set by M6 at interp_convert.cc:5613, M61 at :3397 and G10 L0 at
    :3703). A running LinuxCNC's canon answers with the machine's position
    taken back through the tool offset, the work offset, the rotation and the
    G92 offset in effect (task/emccanon.cc:2658-2690, GET_EXTERNAL_POSITION →
    unoffset_and_unrotate_pos): the interpreter's own point, nothing changes.
    The stand-in canon of standalone rs274 answers with the last point it was
    given (sai/saicanon.cc:829, GET_EXTERNAL_POSITION_Z returns
    _sai._program_position_z), moved along by later G5x and G92 offsets
    (:122-162) but not by a new tool length offset (USE_TOOL_LENGTH_OFFSET,
    :539-544, keeps it apart) nor a rotation (SET_XY_ROTATION, :118-120, only
    prints), and after NURBS_FEED it is read from past the end of the control
    points (:325). So when, since the last move, the tool length offset or the
    rotation changed, or the work offset changed while the system was rotated,
    or the last move was a NURBS, rs274 goes on from a point where the tool is
    not; a running LinuxCNC does not.
    """
    tool, rot, g5x, nurbs = at_motion
    if nurbs:
        return "the last move before the tool change was a NURBS"
    if now[0] != tool:
        return f"tool length offset {tool:g} at the last move, {now[0]:g} at the tool change"
    if now[1] != rot:
        return f"rotation {rot:g} deg at the last move, {now[1]:g} at the tool change"
    if rot and now[2] != g5x:
        return "the work offset of a rotated system changed since the last move"
    return ""


#: canonical calls of one machine function each: call → our words as text
_SIMPLE = {
    "START_SPINDLE_CLOCKWISE": "M3",
    "START_SPINDLE_COUNTERCLOCKWISE": "M4",
    "MIST_ON": "M7",
    "FLOOD_ON": "M8",
    "OPTIONAL_PROGRAM_STOP": "M1",
}


def function_tokens(calls: list[tuple[str, str]]) -> list[str]:
    """rs274's canonical calls as our machine functions (``M3``, ``S1000``,
    ``M62 P1``, …), in order, for the ones a stand-in canon shows: spindle,
    coolant, tools, outputs, overrides, stops and ends. An S or T that repeats
    the one before is none (as in our events); the resets of M2/M30 are part
    of the end."""
    out: list[str] = []
    speed = 0.0
    tool = 0
    in_change = False
    reset_from: int | None = None
    prev = ""
    for name, args in calls:
        nums = [float(v) for v in re.findall(r"-?\d+\.\d+|-?\d+", args)] if args else []
        if name == "SET_SPINDLE_SPEED":
            if nums[1] != speed:
                out.append(f"S{nums[1]:g}")
            speed = nums[1]
        elif name == "SELECT_TOOL":
            if int(nums[0]) != tool:
                out.append(f"T{int(nums[0])}")
            tool = int(nums[0])
        elif name == "START_CHANGE":
            in_change = True
        elif name == "CHANGE_TOOL":
            in_change = False
            out.append("M6")
        elif name == "CHANGE_TOOL_NUMBER":
            out.append(f"M61 Q{int(nums[0])}")
        elif name == "STOP_SPINDLE_TURNING":
            if not in_change:
                out.append("M5")
        elif name == "MIST_OFF":
            out.append("M9")
        elif name == "FLOOD_OFF":
            if prev != "MIST_OFF":
                out.append("M9")
        elif name in _SIMPLE:
            out.append(_SIMPLE[name])
        elif name == "ENABLE_FEED_OVERRIDE":
            out.append("M48")
        elif name == "DISABLE_FEED_OVERRIDE":
            out.append("M49")
        elif name in ("SET_MOTION_OUTPUT_BIT", "CLEAR_MOTION_OUTPUT_BIT"):
            out.append(f"M{62 if name.startswith('SET') else 63} P{int(nums[0])}")
        elif name in ("SET_AUX_OUTPUT_BIT", "CLEAR_AUX_OUTPUT_BIT"):
            out.append(f"M{64 if name.startswith('SET') else 65} P{int(nums[0])}")
        elif name in ("SET_MOTION_OUTPUT_VALUE", "SET_AUX_OUTPUT_VALUE"):
            code = 67 if "MOTION" in name else 68
            out.append(f"M{code} E{int(nums[0])} Q{nums[1]:g}")
        elif name == "PROGRAM_STOP":
            out.append("M60" if prev == "PALLET_SHUTTLE" else "M0")
        elif name == "SET_FEED_MODE":
            reset_from = len(out)  # M2/M30 reset from here on, if PROGRAM_END follows
        elif name == "PROGRAM_END":
            del out[reset_from if reset_from is not None else len(out) :]
            out.append("M30" if prev == "PALLET_SHUTTLE" else "M2")
        prev = name
    return out
