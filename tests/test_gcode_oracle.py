"""Our interpreter against LinuxCNC's own (``rs274 -g``), program by program.

For every program: when both accept it, the same motions (kind, end point, feed,
arc plane, centre and rotation, dwell); when rs274 rejects it, we reject it too;
when we reject it as outside the supported subset, the motions before agree. rs274
prints four decimals of its current unit, which sets the tolerance.
"""

from __future__ import annotations

import hashlib
import os
import re
from dataclasses import dataclass
from pathlib import Path

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from prsxy_post import gcode
from prsxy_post.errors import GCodeError
from prsxy_post.gcode import split_lines

from . import oracle
from .conftest import DATA, ROOT, SHARED

OFFSETS = {55: (100.0, 0.0, -5.0, 0.0, 0.0), 56: (-40.0, 25.0, 0.0, 0.0, 0.0)}
G28 = (1.0, 2.0, 3.0, 0.0, 0.0)
G30 = (-5.0, 0.0, 10.0, 0.0, 0.0)
#: tool n: (length, diameter) [mm]
TOOLS = {n: (10.0 + n, 0.5 * n) for n in range(1, 100)}

OUT_OF_SUBSET = ("not supported", "out of scope")


EXTENSIONS = (".ngc", ".nc", ".gcode", ".tap", ".cnc", ".gc")


def _programs() -> list[Path]:
    """Our feature programs, the real programs copied into tests/data/gcode/corpus
    (sources and licences in its SOURCES.md), the samples, and every program of
    ../shared/corpus when it is present that is not among the copies (the
    GPL-2.0-only ones, which stay there, and those too large to copy)."""
    files = sorted((DATA / "gcode" / "features").glob("*.ngc"))
    files += sorted(
        p for p in (DATA / "gcode" / "corpus").rglob("*") if p.suffix.lower() in EXTENSIONS
    )
    files += sorted((ROOT / "samples").glob("*.ngc"))
    if SHARED is not None:
        copied = {hashlib.sha1(p.read_bytes()).digest() for p in files}
        files += sorted(
            p
            for p in (SHARED / "corpus").rglob("*")
            if p.suffix.lower() in EXTENSIONS
            and hashlib.sha1(p.read_bytes()).digest() not in copied
        )
    return files


def _require_rs274() -> None:
    if oracle.RS274 is None:
        if os.environ.get("PRSXY_REQUIRE_RS274"):
            pytest.fail("rs274 is required here (PRSXY_REQUIRE_RS274) but not installed")
        pytest.skip("rs274 not installed: apt-get install linuxcnc-uspace to run the oracle")


def _ours_all(text: str) -> tuple[list[gcode.Motion], list[str], GCodeError | None]:
    """Our motions, our machine functions as oracle.function_tokens writes them,
    and the error."""
    cfg = gcode.InterpreterConfig(
        work_offsets=OFFSETS,
        g28_position=G28,
        g30_position=G30,
        tool_table={n: gcode.ToolEntry(*v) for n, v in TOOLS.items()},
    )
    out: list[gcode.Motion] = []
    tokens: list[str] = []
    try:
        for m in gcode.iter_motions(gcode.split_lines(text), cfg, "p.ngc"):
            if m.kind == "function":
                tokens += _tokens(m.words)
            else:
                out.append(m)
    except GCodeError as err:
        return out, tokens, err
    return out, tokens, None


def _tokens(words: tuple[tuple[str, float], ...]) -> list[str]:
    """Our machine functions as oracle.function_tokens writes rs274's, but for
    those its stand-in canon does not show (spindle modes G96/G97 with D, M66,
    the override switches M50-M53, user M codes)."""
    out: list[str] = []
    skip = False
    for letter, v in words:
        if letter in ("S", "T"):
            out.append(f"{letter}{v:g}")
        elif letter == "M":
            code = int(v)
            skip = code in (66, 50, 51, 52, 53) or code >= 100
            if not skip:
                out.append(f"M{code}")
        elif letter == "G":
            skip = True
        elif letter in ("P", "E", "Q") and not skip:
            if out and out[-1].split()[0] in ("M61", "M62", "M63", "M64", "M65", "M67", "M68"):
                out[-1] += (
                    f" {letter}{int(v) if letter != 'Q' or out[-1].startswith('M61') else v:g}"
                )
    return out


def _agree(om: oracle.OracleMotion, m: gcode.Motion) -> str | None:
    # rs274 prints four decimals of a position and, apart, of the offsets added to
    # it: two roundings of half a unit of the last decimal each. Turned by a
    # rotation (G10 L2 R), the position's and the G92 offset's roundings in x and
    # y (up to 1e-4 each) mix: up to sqrt(2) * 1e-4 in one axis, then the work
    # offset's 0.5e-4. An offset printed in inches (set in G20) and added to a
    # point printed in mm carries its inch decimal
    tol = (1.2e-4 if not om.xy_rotation else 1.95e-4) * max(om.scale, om.offset_scale) + 1e-9
    if om.kind != m.kind:
        return f"kind {om.kind} vs {m.kind}"
    if abs(om.tool_length - m.tool_length) > 1.2e-4 * om.tool_scale + 1e-9:
        return f"tool length offset {m.tool_length}, rs274 {om.tool_length}"
    if om.kind == "dwell":
        return None if abs(om.duration - m.duration) < 1e-4 else "dwell time"
    if om.kind == "curve":
        # rs274 shows no geometry of a curve (test_gcode_splines checks it against
        # LinuxCNC's NURBS_FEED); the number of control points and the feed agree
        assert m.curve is not None
        if len(m.curve.control) != om.control_points:
            return f"{len(m.curve.control)} control points, rs274 {om.control_points}"
        return None if abs((om.feed or 0.0) - m.feed) <= 6e-5 * om.scale + 1e-6 * m.feed else "feed"
    d = max(abs(a - b) for a, b in zip(om.end, m.end, strict=True))
    if d > tol:
        return f"end differs by {d:.6f}"
    feed_tol = 6e-5 * om.scale + 1e-6 * m.feed
    if om.kind in ("feed", "arc") and abs((om.feed or 0.0) - m.feed) > feed_tol:
        return f"feed {om.feed} vs {m.feed}"
    if om.kind == "arc":
        assert om.center is not None and m.center is not None
        if om.rotation != m.rotation or om.plane != m.plane:
            return "arc rotation or plane"
        if max(abs(a - b) for a, b in zip(om.center, m.center, strict=True)) > tol:
            return "arc centre"
    return None


# ---------------------------------------------------------------- known differences
#
# Standalone rs274 is LinuxCNC's interpreter over a stand-in canonical machine
# (src/emc/sai/saicanon.cc), not a running LinuxCNC. Where the two differ, we do
# what the running machine does, and the comparison says so here.
#
# 1. A tool change re-reads the position (rs274ngc_pre.cc, Interp::synch, run
#    after a block with M6 or M61 returns INTERP_EXECUTE_FINISH:
#    ``_setup.current_z = GET_EXTERNAL_POSITION_Z()``). The stand-in canon's
#    GET_EXTERNAL_POSITION_Z returns ``_sai._program_position`` (saicanon.cc),
#    which its USE_TOOL_LENGTH_OFFSET never changes, so in ``T1 M6 G43`` the G43's
#    change of the current position is undone; a running LinuxCNC's canon
#    (emccanon.cc) keeps the tool offset in its position and loses nothing. So
#    for rs274 a block with M6 and a G43/G49 is split in two, ``T1 M6`` and the
#    rest: the same program for a running machine (the G codes run after the M
#    codes of a block anyway), and rs274 then sees it as the machine does.
#    Lines at LinuxCNC 2.9.0~pre1 (f1270d6ed7): rs274ngc_pre.cc:1599 and
#    :1447-1452 (the next read re-reads the position: read_inputs →
#    refresh_actual_position), sai/saicanon.cc:539 (USE_TOOL_LENGTH_OFFSET sets
#    only _sai._tool_offset) and :829 (GET_EXTERNAL_POSITION_Z),
#    task/emccanon.cc:2658-2690 (GET_EXTERNAL_POSITION: unoffset_and_unrotate_pos
#    takes the tool offset off the machine's position).
#    test_known_difference_tool_change_with_g43 keeps this note true.
# 3. The same loss without the split: when the tool length offset (or the
#    rotation of the system, or the offset of a rotated system) changed after
#    the last move and a tool change follows (``G43 H1`` / ``T2 M6`` /
#    ``G0 X-2.5``), the stand-in canon hands back the last point it was given,
#    which no longer is where the tool is (oracle._stale has the lines). No
#    rewrite of the program gives rs274 the machine's answer there, so from that
#    tool change on rs274 is no reference: the motions before it must agree
#    (verdict "rs274 loses the position"); test_known_difference_tool_change_after_g43
#    shows ours is right by a program that differs only in a move that stays
#    put, which rs274 then runs as a machine does.
# 2. M99 in the main program: with loop_on_main_m99 set, LinuxCNC would run the
#    program again for ever (interp_convert.cc:4577, convert_stop); nothing in
#    2.9 sets it (rs274ngc_pre.cc:1299 is its only setter, never called), so
#    rs274 and a running 2.9 both end the program there, as M2 does. We do too.

_TOOL_CHANGE = re.compile(r"m\s*0*6(?![0-9.])", re.I)
_LENGTH_CODE = re.compile(r"g\s*(?:43|49)(?![0-9])", re.I)
_T_WORD = re.compile(r"t\s*[0-9]+", re.I)
_S_WORD = re.compile(r"s\s*[0-9.]+", re.I)


def _for_rs274(text: str) -> str:
    """The program as rs274 must read it to do what a running LinuxCNC does."""
    out = []
    for line in split_lines(text):
        code = line.split(";")[0]
        code = re.sub(r"\([^)]*\)", "", code)
        if _TOOL_CHANGE.search(code) and _LENGTH_CODE.search(code):
            # S and T run before M6: they stay with it
            s = _S_WORD.search(code)
            t = _T_WORD.search(code)
            first = " ".join(w.group(0) for w in (s, t) if w) + " M6"
            rest = _S_WORD.sub("", _T_WORD.sub("", _TOOL_CHANGE.sub("", code)))
            out += [first, rest]
        else:
            out.append(line)
    return "\n".join(out)


@dataclass
class Verdict:
    """How our interpreter and rs274 took one program (see :func:`verdict`)."""

    #: "same", "different", "out of scope", "not supported", "we refuse",
    #: "both refuse", "only rs274 refuses", "rs274 loses the position" (known
    #: difference 3: the motions up to there agree)
    status: str
    #: what differs, or the error
    detail: str = ""
    #: motions both made (the program's, when both run it to the end)
    motions: int = 0
    #: rs274 ran the program to its end
    rs274_ran: bool = True


#: the verdicts the oracle test accepts
ACCEPTED = ("same", "out of scope", "not supported", "both refuse", "rs274 loses the position")


def verdict(text: str) -> Verdict:
    """Run a program through rs274 and through our interpreter and compare.

    Both run it to the end: the same motions (kind, end, feed, arc plane, centre
    and turns, dwell, tool length offset, curve) and the same machine functions,
    or "different". We refuse it: "both refuse" when rs274 does too; else "out of
    scope" / "not supported" (our message says so; the motions before agree) or
    "we refuse". rs274 refuses what we run: "only rs274 refuses".
    """
    ref = oracle.run(_for_rs274(text), offsets=OFFSETS, g28=G28, g30=G30, tools=TOOLS)
    ours, tokens, err = _ours_all(text)
    theirs = oracle.function_tokens(ref.calls)
    ran = ref.error is None
    n = ref.lost_after
    if n is not None and (err is None or len(ours) >= n):
        # known difference 3: rs274 is a reference up to that tool change only
        if len(ours) < n:
            return Verdict("different", f"{len(ours)} motions, rs274 {n} before it lost", 0, ran)
        for k, m in enumerate(ours[:n]):
            why = _agree(ref.motions[k], m)
            if why is not None:
                return Verdict("different", f"motion {k} (line {m.line}): {why}", k, ran)
        if err is not None and not ran:
            return Verdict("both refuse", f"{err} | rs274: {ref.error}", 0, ran)
        if err is not None and not any(w in str(err) for w in OUT_OF_SUBSET):
            return Verdict("we refuse", f"{err} (after rs274 lost the position)", n, ran)
        # rs274's own refusal after that point may come from the lost position
        later = "" if ran else f"; then rs274: {ref.error}"
        return Verdict("rs274 loses the position", ref.lost_why + later, n, ran)
    if err is None and not ran:
        return Verdict("only rs274 refuses", str(ref.error), len(ours), ran)
    if err is not None and not ran:
        return Verdict("both refuse", f"{err} | rs274: {ref.error}", 0, ran)
    if err is None and len(ours) != len(ref.motions):
        return Verdict("different", f"{len(ours)} motions, rs274 {len(ref.motions)}", 0, ran)
    if len(ours) > len(ref.motions):
        return Verdict("different", f"{len(ours)} motions before {err}, rs274 {len(ref.motions)}")
    for k, m in enumerate(ours):
        why = _agree(ref.motions[k], m)
        if why is not None:
            return Verdict("different", f"motion {k} (line {m.line}): {why}", k, ran)
    if tokens != (theirs if err is None else theirs[: len(tokens)]):
        return Verdict("different", f"machine functions {tokens}, rs274 {theirs}", len(ours), ran)
    if err is None:
        return Verdict("same", "", len(ours), ran)
    for status, words in (("out of scope", "out of scope"), ("not supported", "not supported")):
        if words in str(err):
            return Verdict(status, str(err), len(ours), ran)
    return Verdict("we refuse", str(err), len(ours), ran)


@pytest.mark.linuxcnc
@pytest.mark.parametrize("path", _programs(), ids=lambda p: str(p.relative_to(p.parents[1])))
def test_agrees_with_linuxcnc(path: Path) -> None:
    _require_rs274()
    v = verdict(path.read_bytes().decode("utf-8", errors="surrogateescape"))
    assert v.status in ACCEPTED, f"{v.status}: {v.detail}"


@pytest.mark.linuxcnc
def test_known_difference_tool_change_with_g43() -> None:
    """rs274 loses the tool length offset of a G43 in the block of its M6 (known
    difference 1 above); split, it keeps it, as a running LinuxCNC does and we do."""
    _require_rs274()
    together = "G21 G90\nT1 M6 G43\nG0 X1\nM2\n"
    split = _for_rs274(together)
    assert split.splitlines()[1:3] == ["T1 M6", "  G43"]
    length = TOOLS[1][0]
    lost = oracle.run(together, tools=TOOLS).motions[0]
    kept = oracle.run(split, tools=TOOLS).motions[0]
    assert lost.end[2] == pytest.approx(0.0, abs=1e-4)  # as if G43 had not moved Z
    assert kept.end[2] == pytest.approx(-length, abs=1e-4)
    ours, _, err = _ours_all(together)
    assert err is None and ours[0].end[2] == pytest.approx(-length, abs=1e-9)


@pytest.mark.linuxcnc
def test_known_difference_tool_change_after_g43() -> None:
    """Found by the derandomized draw of hypothesis 6.170.17 (issue 32): after
    ``G43 H1`` the tool tip's program Z is -11 (the spindle did not move);
    ``T2 M6`` changes no offset, so a running LinuxCNC reads Z -11 back and
    ``G0 X-2.5`` stays at that height. rs274's stand-in canon hands back the Z of
    the last point it was given, 0, and goes 11 mm up (known difference 3)."""
    _require_rs274()
    head = "G21 G90 G17 G94 G40 G49 G54 G80 F500\nG43 H1\n"
    found = head + "T2 M6\nG0 X-2.5\nM2\n"
    ref = oracle.run(_for_rs274(found), offsets=OFFSETS, tools=TOOLS)
    assert ref.error is None and ref.lost_after == 0, ref.lost_why
    length = TOOLS[1][0]
    assert ref.motions[0].end[2] == pytest.approx(0.0, abs=1e-4)  # rs274: up by 11 mm
    assert ref.motions[0].tool_length == pytest.approx(length, abs=1e-4)
    v = verdict(found)
    assert v.status == "rs274 loses the position", v
    ours, _, err = _ours_all(found)
    assert err is None and len(ours) == 1
    assert ours[0].end == pytest.approx((-2.5, 0.0, -length, 0.0, 0.0), abs=1e-12)
    # the same program with a move that stays where the tool is before the tool
    # change: the stand-in canon is given the point, and rs274 does what a
    # machine does; ours is the same but for that move
    still = head + "G0 X0\nT2 M6\nG0 X-2.5\nM2\n"
    v = verdict(still)
    assert v.status == "same", v
    theirs = oracle.run(_for_rs274(still), offsets=OFFSETS, tools=TOOLS)
    assert theirs.lost_after is None
    assert theirs.motions[1].end == pytest.approx(ours[0].end, abs=1.2e-4)
    again, _, _ = _ours_all(still)
    assert again[1:] == [ours[0]._replace(line=5)]


@pytest.mark.linuxcnc
def test_rs274_loses_the_position_only_where_its_canon_does() -> None:
    """Known difference 3 is taken only where the stand-in canon's point is stale:
    a tool change after a move, or after a change of G92 or a work offset it
    follows (saicanon.cc:122-162), is compared all the way."""
    _require_rs274()
    for program, lost in [
        ("G21\nG0 X1 Z5\nT1 M6\nG43\nG0 X2\nM2\n", False),
        ("G21\nG0 X1 Z5\nG92 Z0\nG55\nT1 M6\nG0 X2\nM2\n", False),
        ("G21\nG43 H2\nG0 X1\nG49\nT1 M6\nG0 X2\nM2\n", True),
        ("G21\nG0 X1 Y1\nG10 L2 P1 R30\nT1 M6\nG0 X2\nM2\n", True),
        ("G21\nG10 L2 P1 R30\nG0 X1 Y1\nG10 L2 P1 X5\nM61 Q2\nG0 X2\nM2\n", True),
        ("G21\nG10 L2 P1 R30\nG0 X1 Y1\nG92 X0\nT1 M6\nG0 X2\nM2\n", False),
    ]:
        ref = oracle.run(program, tools=TOOLS)
        assert ref.error is None
        assert (ref.lost_after is not None) == lost, program
        v = verdict(program)
        assert v.status == ("rs274 loses the position" if lost else "same"), (program, v)


@pytest.mark.linuxcnc
def test_oracle_sees_the_work_offsets() -> None:
    """The oracle is configured like us: a G55 move ends at the offset position."""
    _require_rs274()
    ref = oracle.run("G21 G90\nG55 G0 X1 Y1 Z1\nM2\n", offsets=OFFSETS)
    assert ref.motions[-1].end[:3] == pytest.approx((101.0, 1.0, -4.0), abs=1e-4)


# ---------------------------------------------------------------- random programs

_VALUE = st.sampled_from(["-2.5", "-1", "0", "0.5", "1", "3", "10.25", "-0.75", "2"])


def _axis_words(letters: str, most: int) -> st.SearchStrategy[str]:
    return st.lists(
        st.tuples(st.sampled_from(letters), _VALUE),
        min_size=1,
        max_size=most,
        unique_by=lambda t: t[0],
    ).map(lambda words: " ".join(a + v for a, v in words))


_FEED = st.sampled_from(["", "", "F300", "F1000", "F50"])
_CODES = [
    "G20", "G21", "G90", "G91", "G90.1", "G91.1", "G17", "G18", "G19", "G54", "G55",
    "G56", "G59.3", "G61", "G61.1", "G64", "G64 P0.01", "G94", "G93 G1 X1 F2",
    "G92.1", "G92.2", "G92.3", "G49", "G43 H1", "G43 H2", "G43.1 Z1.5", "T2 M6",
    "T1 M6 G43", "G40", "G41.1 D1", "G42.1 D0.5", "G41 D1", "G42", "G80", "G98", "G99",
    "G28", "G30", "G28.1", "G53 G0 X1 Y2", "G4 P0.5", "M3 S1000", "M5", "M8", "M9",
    "G28 X1", "G30 Z2", "G10 L1 P2 Z3", "G10 L10 P1 Z2", "G10 L11 P1 Z1",
    "G10 L2 P1 R30", "G10 L2 P0 R-45 X1", "G10 L2 P2 R15 Y2", "G10 L2 P0 R0",
    "G10 L20 P0 X1 Y-1", "G10 L20 P2 X0", "G92 X1 Y1", "G52 X2",
]  # fmt: skip
_LINE = st.one_of(
    st.builds(
        lambda g, a, f: f"{g} {a} {f}",
        st.sampled_from(["G0", "G1", "", "G1"]),
        _axis_words("XYZAB", 4),
        _FEED,
    ),
    st.builds(
        lambda g, a, r, f: f"{g} {a} R{r} {f}",
        st.sampled_from(["G2", "G3"]),
        _axis_words("XYZ", 3),
        st.sampled_from(["3", "-3", "5", "1.5", "10"]),
        _FEED,
    ),
    st.builds(
        lambda g, a, c, f: f"{g} {a} {c} {f}",
        st.sampled_from(["G2", "G3"]),
        _axis_words("XYZ", 3),
        _axis_words("IJK", 2),
        _FEED,
    ),
    st.sampled_from(_CODES),
    st.builds(
        lambda c, a, r, z: f"{c} {a} R{r} Z{z}",
        st.sampled_from(
            ["G81", "G82 P0.2", "G83 Q0.5", "G73 Q0.4", "G85", "G86 P0.1", "G89 P0.1", "G81 L2"]
        ),
        _axis_words("XY", 2),
        _VALUE,
        _VALUE,
    ),
)


@pytest.mark.linuxcnc
@settings(
    max_examples=200, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(st.lists(_LINE, min_size=1, max_size=20))
@example(["G94", "G1 X-2.5"])  # G94 sets the feed rate to 0: found in CI
# the draw of hypothesis 6.170.17 (issue 32): known difference 3
@example(["G43 H1", "T2 M6", "G0 X-2.5 "])
def test_random_programs_agree_with_linuxcnc(body: list[str]) -> None:
    """Random blocks of the dialect's motion, modal, offset, tool, compensation and
    cycle codes (tool table, work offsets, G28/G30 as the corpus test has them):
    the same motions and machine functions, or both refuse. Run with
    max_examples=3000 while writing it: 808 ran in both, the other 2 192 both
    refused (the first error of a random program comes early), none differed; CI's
    own draw then found the ``@example`` (a plain G94 sets the feed rate to 0)."""
    _require_rs274()
    v = verdict("G21 G90 G17 G94 G40 G49 G54 G80 F500\n" + "\n".join(body) + "\nM2\n")
    assert v.status in ACCEPTED, f"{v.status}: {v.detail}"


_ANGLE = st.sampled_from(["30", "-45", "90", "12.5", "-170", "0", "7.25"])


_ROTATED_CODES = [
    "G54", "G55", "G56", "G59.3", "G92.1", "G92.2", "G92.3", "G28", "G28 X1", "G30 Y2", "G28.1",
    "G80", "T1 M6", "G43", "G43 H2", "G49", "G20", "G21", "G90.1", "G91.1", "G91", "G90",
]  # fmt: skip


@st.composite
def _rotated(draw: st.DrawFn) -> str:
    """Programs in rotated coordinate systems (G10 L2 R): moves, G17 arcs (R
    large enough to reach, and centre words), G91, G92/G52, G10 L2/L20 of the
    active system and others, system switches, G53, G28/G30, G28.1, cycles,
    polar moves, tool lengths, both units."""
    units = draw(st.sampled_from(["G21", "G20"]))
    lines = [f"{units} G90 G17 G94 G40 G49 G54 G80 F500"]
    lines.append(f"G10 L2 P1 R{draw(_ANGLE)} X{draw(_VALUE)} Y{draw(_VALUE)}")
    lines.append(f"G10 L2 P2 R{draw(_ANGLE)} X{draw(_VALUE)} Z{draw(_VALUE)}")
    lines.append(draw(st.sampled_from(["G54", "G55", "G56"])) + " G0 X0 Y0 Z5")
    xy = _axis_words("XY", 2)
    line = st.one_of(
        st.builds(lambda g, a: f"{g} {a}", st.sampled_from(["G0", "G1"]), _axis_words("XYZ", 3)),
        # R arcs incremental: an end on the start is then one in both (rs274 and
        # we round an absolute point after a G10 L20 differently, by 1e-16)
        st.builds(lambda g, a: f"G91 {g} {a} R40\nG90", st.sampled_from(["G2", "G3"]), xy),
        st.builds(
            lambda g, a, c: f"{g} {a} {c} P1",
            st.sampled_from(["G2", "G3"]),
            st.just("Z1"),
            _axis_words("IJ", 2),
        ),
        st.builds(lambda a: f"G91 G1 {a}\nG90", xy),
        st.builds(lambda a: f"G92 {a}", xy),
        st.builds(lambda a: f"G52 {a}", xy),
        st.builds(lambda r, a: f"G10 L2 P0 R{r} {a}", _ANGLE, xy),
        st.builds(lambda n, r: f"G10 L2 P{n} R{r}", st.sampled_from("1239"), _ANGLE),
        st.builds(lambda n, a: f"G10 L20 P{n} {a}", st.sampled_from("0123"), xy),
        st.builds(lambda a: f"G53 G0 {a}", _axis_words("XYZ", 2)),
        st.builds(lambda a: f"G81 {a} Z-1 R2", xy),
        st.builds(lambda r, t: f"G1 @{r} ^{t}", st.sampled_from(["3", "10"]), _ANGLE),
        st.sampled_from(_ROTATED_CODES),
    )
    lines += draw(st.lists(line, min_size=1, max_size=12))
    return "\n".join([*lines, "G80", "M2"]) + "\n"


@pytest.mark.linuxcnc
@settings(
    max_examples=150, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(_rotated())
def test_random_rotated_programs_agree_with_linuxcnc(program: str) -> None:
    """G10 L2 R and all that goes through a rotated system, as rs274 does it, or
    both refuse."""
    _require_rs274()
    v = verdict(program)
    assert v.status in ACCEPTED, f"{v.status}: {v.detail}"


#: each plane's two cycle-position axes and its depth axis
_CYCLE_AXES = {"G17": ("X", "Y", "Z"), "G18": ("Z", "X", "Y"), "G19": ("Y", "Z", "X")}


@st.composite
def _cycles(draw: st.DrawFn) -> str:
    """Canned cycles in any plane, repeated (L) or modal (positions alone), in
    G90/G91, G98/G99 and both units; R and the depth usually given."""
    plane = draw(st.sampled_from(list(_CYCLE_AXES)))
    a, b, c = _CYCLE_AXES[plane]
    start = draw(st.sampled_from(["5", "10", "-1", "0"]))
    lines = [
        f"G21 G90 G94 G40 G49 G54 G80 F500 {plane} M3 S1000",
        draw(st.sampled_from(["G98", "G99"])),
    ]
    lines.append(f"G0 {c}{start}")
    for _ in range(draw(st.integers(1, 8))):
        kind = draw(st.sampled_from(["cycle", "cycle", "position", "position", "mode", "move"]))
        if kind == "cycle":
            words = [f"{ax}{draw(_VALUE)}" for ax in (a, b) if draw(st.booleans())] or [f"{a}1"]
            if draw(st.integers(0, 3)):
                words.append(f"{c}{draw(_VALUE)}")
            if draw(st.integers(0, 4)):
                words.append(f"R{draw(st.sampled_from(['-1', '0', '1', '2.5', '5', '12']))}")
            if not draw(st.integers(0, 3)):
                words.append(f"L{draw(st.integers(1, 3))}")
            if draw(st.booleans()):
                words.append(draw(st.sampled_from(["F100", "F250"])))
            code = [
                "G81",
                "G82 P0.5",
                "G83 Q1",
                "G83 Q0.7",
                "G73 Q1",
                "G85",
                "G89 P0.2",
                "G86 P0.1",
            ]
            lines.append(" ".join([draw(st.sampled_from(code)), *words]))
        elif kind == "position":
            lines.append(
                " ".join(
                    [f"{ax}{draw(_VALUE)}" for ax in (a, b) if draw(st.booleans())] or [f"{b}2"]
                )
            )
        elif kind == "mode":
            lines.append(
                draw(st.sampled_from(["G90", "G91", "G98", "G99", "G80", "G20", "G21", "G4 P0.1"]))
            )
        else:
            lines.append(f"G0 {c}{draw(_VALUE)}")
    return "\n".join([*lines, "G80", "M2"]) + "\n"


@pytest.mark.linuxcnc
@settings(
    max_examples=100, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.too_slow]
)
@given(_cycles())
# found in CI, 2026-11-24: the cycle repeated after G20 went across to its first
# hole at the level the cycles started at (5, read in inches: 127 mm); LinuxCNC
# goes across at the tool's height there (5 mm) and only retracts to that level
@example(
    "G21 G90 G94 G40 G49 G54 G80 F500 G17 M3 S1000\nG98\nG0 Z5\nG81 X1 Z-2.5 R-1\n"
    "G81 X1\nG20\nY2\nG80\nM2\n"
)
# found by the random rotated programs, 2026-11-27: a G53 move is a move that
# is no cycle, after which the next cycle starts from its own first level
# (convert_motion, interp_convert.cc:3778-3779)
@example(
    "G20 G90 G94 G40 G49 G54 G80 F500 G17 M3 S1000\nG99\nG0 Z1\nG81 X1 Z-1 R2\n"
    "G53 G0 Y2 Z2\nG81 X1 Z-1 R2\nG80\nM2\n"
)
def test_random_canned_cycles_agree_with_linuxcnc(program: str) -> None:
    """Every move of every cycle (rapid to the position, to R, the pecks, the feed
    in and out, dwells, the return to R or the old level) as rs274 makes it, or
    both refuse. Run with max_examples=1500 while writing it: 505 ran in both, the
    other 995 both refused (R below the level, a missing depth...), none differed."""
    _require_rs274()
    v = verdict(program)
    assert v.status in ACCEPTED, f"{v.status}: {v.detail}"
