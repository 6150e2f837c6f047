"""The G-code reader: features, located errors, and robustness."""

from __future__ import annotations

import itertools
import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from prsxy_post import gcode
from prsxy_post.errors import GCodeError

from .conftest import DATA

CFG = gcode.InterpreterConfig(
    work_offsets={55: (100.0, 0.0, -5.0, 0.0, 0.0)},
    g28_position=(1.0, 2.0, 3.0, 0.0, 0.0),
    tool_table={1: gcode.ToolEntry(35.0), 2: gcode.ToolEntry(20.0)},
)


def run(text: str, cfg: gcode.InterpreterConfig = CFG) -> list[gcode.Motion]:
    """The motions of a program (machine functions apart: :func:`functions`)."""
    return [m for m in gcode.interpret(text, cfg, "t.ngc") if m.kind != "function"]


def functions(text: str) -> list[tuple[int, str]]:
    """(line, words) of every machine function of a program."""
    return [
        (m.line, " ".join(f"{k}{v:g}" for k, v in m.words))
        for m in gcode.interpret(text, CFG, "t.ngc")
        if m.kind == "function"
    ]


def err(text: str) -> str:
    with pytest.raises(GCodeError) as exc:
        run(text)
    return str(exc.value)


# ---------------------------------------------------------------- what is read


def test_line_ends_number_like_an_editor() -> None:
    for sep in ("\n", "\r\n", "\r"):
        text = sep.join(["G21 G90", "G0 X1", "(comment)", "G1 X2 F100", "M2"])
        ms = run(text)
        assert [m.line for m in ms] == [2, 4]
    assert gcode.split_lines("a\r\nb\rc\nd") == ["a", "b", "c", "d"]


def test_spaces_case_comments_and_numbers() -> None:
    ms = run("g21 g90\nN10 G0 X 1 0.5 (ten and a half) Y-.5 ; rest\nG0Z  0.1000\nm2\n")
    assert ms[0].end[:2] == (10.5, -0.5)
    assert ms[1].end[2] == pytest.approx(0.1)


def test_block_delete_runs_the_line_as_linuxcnc_does() -> None:
    assert len(run("G21\n/G0 X5\nM2\n")) == 1


def test_percent_delimits_the_program() -> None:
    ms = run("%\nG21 G0 X1\n%\nG0 X2 (never read)\n")
    assert len(ms) == 1


def test_program_end_stops_reading() -> None:
    assert len(run("G21 G0 X1\nM30\nG0 X2\n")) == 1


def test_units_and_offsets() -> None:
    ms = run("G20 G90 G0 X1 Y1\nG21 G55 G0 X0 Y0 Z0\nM2\n")
    assert ms[0].end[:2] == pytest.approx((25.4, 25.4))
    assert ms[1].end[:3] == pytest.approx((100.0, 0.0, -5.0))


def test_incremental_and_feed_units() -> None:
    ms = run("G21 G91 G1 X1 Y2 F300\nX1\nG20 G1 X1 F10\nG1 A5 F90\nM2\n")
    assert ms[1].end[:2] == (2.0, 2.0)
    assert ms[2].end[0] == pytest.approx(2.0 + 25.4)
    assert ms[2].feed == pytest.approx(254.0)
    assert ms[3].feed == 90.0  # rotary-only: degrees per minute in either unit


def test_inverse_time_feed_is_length_times_f() -> None:
    ms = run("G21 G93 G1 X30 Y40 F2\nM2\n")
    assert ms[0].feed == pytest.approx(100.0)
    assert ms[0].inverse_time


def test_arc_ijk_r_turns_and_planes() -> None:
    ms = run(
        "G21 G17 G0 X10 Y0\nG3 X-10 Y0 I-10 J0 F100\nG2 X10 Y0 R10\n"
        "G3 X10 Y0 I-10 J0 Z-3 P2\nG18 G2 X20 Z-3 I5 K0\nM2\n"
    )
    a = ms[1]
    assert (a.kind, a.plane, a.rotation) == ("arc", 17, 1)
    assert a.center == pytest.approx((0.0, 0.0, 0.0))
    assert ms[2].rotation == -1
    assert ms[2].center[:2] == pytest.approx((0.0, 0.0), abs=1e-12)
    assert ms[3].rotation == 2 and ms[3].end[2] == -3
    assert ms[4].plane == 18 and ms[4].center == pytest.approx((15.0, 0.0, -3.0))
    # helix feed is along the helix
    assert ms[3].feed == 100.0


def test_r_arc_negative_takes_the_long_way() -> None:
    short = run("G21 G0 X0 Y0\nG2 X10 Y0 R8 F100\nM2\n")[1]
    long = run("G21 G0 X0 Y0\nG2 X10 Y0 R-8 F100\nM2\n")[1]
    assert short.center[1] < 0 < long.center[1]


def test_g28_goes_through_the_intermediate_point() -> None:
    ms = run("G21 G0 X5 Y5 Z5\nG28 Z10\nG28\nM2\n")
    assert ms[1].end == (5.0, 5.0, 10.0, 0.0, 0.0)
    assert ms[2].end == (5.0, 5.0, 3.0, 0.0, 0.0)  # only Z goes home
    assert ms[4].end == (1.0, 2.0, 3.0, 0.0, 0.0)


def test_tool_length_offsets() -> None:
    ms = run("G21 G0 Z50\nT1 M6 G43 H1\nG1 Z0 F100\nG49 G0 Z10\nM2\n")
    assert ms[1].tool_length == 35.0 and ms[1].tool == 1
    assert ms[2].tool_length == 0.0


def test_canned_cycle_expands_like_linuxcnc() -> None:
    ms = run("G21 G0 X0 Y0 Z10\nG99 G81 X5 Y5 Z-2 R1 F100\nM2\n")
    kinds = [(m.kind, m.end[:3]) for m in ms[1:]]
    assert kinds == [
        ("rapid", (5.0, 5.0, 10.0)),
        ("rapid", (5.0, 5.0, 1.0)),
        ("feed", (5.0, 5.0, -2.0)),
        ("rapid", (5.0, 5.0, 1.0)),
    ]


def test_dwell() -> None:
    ms = run("G21 G4 P1.5\nM2\n")
    assert ms[0].kind == "dwell" and ms[0].duration == 1.5


def test_inspect_json_shape() -> None:
    ms = run("G21 G0 X1\nG2 X3 Y0 I1 J0 F60\nG4 P1\nM2\n")
    j = [gcode.motion_to_json(m) for m in ms]
    assert j[0] == {"line": 1, "kind": "rapid", "end": [1.0, 0.0, 0.0, 0.0, 0.0], "feed": None}
    assert j[1]["plane"] == 17 and j[1]["rotation"] == -1 and j[1]["center"][0] == 2.0
    assert j[2]["kind"] == "dwell" and j[2]["duration"] == 1.0


# ---------------------------------------------------------------- what is rejected

REJECT = [
    ("G21\nG1 X#<nope> F100\nM2\n", "t.ngc:2:5:", "#<nope> is not defined"),
    ("G21\nG1 X[1+] F100\nM2\n", "t.ngc:2:8:", "a number is missing"),
    ("G21\nG1 X[1/[2-2]] F100\nM2\n", "t.ngc:2:7:", "division by zero"),
    ("G21\no100 endwhile\nM2\n", "t.ngc:2:1:", "without its opening label"),
    # a letter O typed for a zero is said to be one (issue 12), not taken for an O-word
    ("G21\nG1 X10 Y1O F100\nM2\n", "t.ngc:2:10:", "letter O inside the number of 'Y' ('Y1O')"),
    ("G21\nGO X1\nM2\n", "t.ngc:2:2:", "the letter O as the number of 'G' ('GO')"),
    ("G21\nG41 G1 X1 F100\nG81 X1 Z-1 R1\nM2\n", "t.ngc:3:5:", "canned cycle with cutter comp"),
    ("G21\nG92\nM2\n", "t.ngc:2:1:", "G92 without axis words"),
    ("G21\nG10 L2 P1 R30\nG18 G2 X1 Z1 R5 F9\nM2\n", "t.ngc:3:8:", "arcs in G18 in a rotated"),
    ("G21\nG10 L20 P1 R30\nM2\n", "t.ngc:2:12:", "R word with G10 L20"),
    ("G21\nG10 L3 P1 X0\nM2\n", "t.ngc:2:5:", "G10 without L0, L1, L2, L10, L11 or L20"),
    ("G21\nG1 F1\nG5.2 X1\nM2\n", "t.ngc:3:6:", "NURBS control point without both X and Y"),
    ("G21\nG16\nM2\n", "t.ngc:2:1:", "unknown G code"),
    ("G21\nG0 C10\nM2\n", "t.ngc:2:4:", "C axis"),
    ("G21\nG0 G1 X1 F1\nM2\n", "t.ngc:2:4:", "same modal group ('G1')"),
    ("G21\nG0 X1 X2\nM2\n", "t.ngc:2:7:", "X word repeated ('X2')"),
    ("G21\nG0 X0 Y0\nG2 X10 Y0 I3 J0 F100\nM2\n", "t.ngc:3:11:", "not on the arc's circle"),
    ("G21\nG1 X5\nM2\n", "t.ngc:2:4:", "no feed rate"),
    ("G21\nG93 G1 X5\nM2\n", "t.ngc:2:8:", "without F in inverse time"),
    ("G21\nX5\nM2\n", "t.ngc:2:1:", "axis words with no motion mode"),
    ("G21\nG0 X0\nG2 X0 Y0 R5 F100\nM2\n", "t.ngc:3:10:", "end point is its start point"),
    ("G21\nG0 X0\nG2 X20 Y0 R5 F100\nM2\n", "t.ngc:3:11:", "radius too small"),
    ("G21\nG1 X1 E2 F1\nM2\n", "t.ngc:2:7:", "E word with no M66, M67 or M68"),
    ("G21\nG1 X F1\nM2\n", "t.ngc:2:4:", "word 'X' has no number"),
    ("G21\nG1 X1 (open\nM2\n", "t.ngc:2:7:", "comment not closed"),
    ("G21\nG999 X1\nM2\n", "t.ngc:2:1:", "G code out of range"),
    ("G21\nG12 X1\nM2\n", "t.ngc:2:1:", "unknown G code"),
    ("G21\nM123\nM2\n", "t.ngc:2:1:", "unknown M code M123"),
    ("G21\nG43 H7\nM2\n", "t.ngc:2:5:", "tool 7 is not in the profile's tool table"),
    ("G21\nG81 X1 Y1 R1 F100\nM2\n", "t.ngc:2:5:", "Z missing in the first block"),
    ("G21\nG0 Z0\nG81 X1 Z5 R1 F100\nM2\n", "t.ngc:3:", "R below the bottom"),
    ("G21\nG4\nM2\n", "t.ngc:2:1:", "G4 without a dwell time"),
    ("G21\nG0 X1\n", "t.ngc:2:", "ends without M2"),
    ("G21\nG1 X1 F100\n%\nM2\n", "t.ngc:3:1:", "'%' after the start"),
    ("G21\nG80 X1\nM2\n", "t.ngc:2:5:", "axis words with G80"),
    ("G21\nG0 X1 I2\nM2\n", "t.ngc:2:7:", "I word with no arc to use it"),
    # a letter whose upper case is two letters ("ß" → "SS") must not shift columns
    ("G21\nG0 X1 \u00df[\nM2\n", "t.ngc:2:7:", "bad character 'ß'"),
]


@pytest.mark.parametrize(("text", "where", "what"), REJECT, ids=[r[2][:30] for r in REJECT])
def test_rejections_name_file_line_column_and_word(text: str, where: str, what: str) -> None:
    msg = err(text)
    assert msg.startswith(where), msg
    assert what in msg, msg
    assert "(expected " in msg


# ---------------------------------------------------------------- robustness

WORDS = st.sampled_from(
    [
        "G0",
        "G1",
        "G2",
        "G3",
        "G17",
        "G18",
        "G19",
        "G90",
        "G91",
        "G20",
        "G21",
        "G81",
        "G80",
        "G4",
        "M3",
        "M5",
        "F",
        "X",
        "Y",
        "Z",
        "A",
        "B",
        "I",
        "J",
        "K",
        "R",
        "P",
        "Q",
        "#",
        "[",
        "(",
        ")",
        ";",
        "%",
        "/",
        " ",
        "\t",
        "1",
        "-",
        ".",
        "5",
        "e",
        "N",
        "H",
        "T",
    ]
)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.lists(WORDS, max_size=12).map("".join), max_size=12))
def test_any_text_gives_motions_or_a_located_error(lines: list[str]) -> None:
    text = "\n".join(["G21 G90", *lines, "M2"])
    try:
        ms = run(text)
    except GCodeError as exc:
        assert str(exc).startswith("t.ngc:")
        return
    prev = (0.0,) * 5
    for m in ms:
        assert m.start == pytest.approx(prev)  # motions chain
        assert all(math.isfinite(v) for v in m.end)
        prev = m.end


@settings(max_examples=200, deadline=None)
@given(st.binary(max_size=200))
def test_random_bytes_never_crash(data: bytes) -> None:
    text = data.decode("latin-1")
    try:
        run(text)
    except GCodeError as exc:
        assert str(exc).startswith("t.ngc")


def test_speed_of_the_interpreter() -> None:
    """A sanity bound, not a benchmark (bench/bench.py measures): 20 k lines well
    under a second on any machine that runs the suite."""
    import time

    lines = (
        ["G21 G90 G1 F2000"]
        + [f"G1 X{i * 0.1:.3f} Y{(i % 7) * 0.1:.3f}" for i in range(20000)]
        + ["M2"]
    )
    t0 = time.perf_counter()
    n = sum(1 for _ in gcode.iter_motions(lines, CFG))
    # "G1 F2000" alone is a zero-length move, as in LinuxCNC; M2 is a machine function
    assert n == 20002
    assert time.perf_counter() - t0 < 5.0


# ------------------------------------------------- the fast path and the line reader

STRAIGHT = st.sampled_from(
    [
        "G0", "G1", "g01", "G2", "G91", "G90", "G20", "G21", "G55", "G93", "G94", "N10", "n 7",
        "X1.5", "x-2", "Y.5", "Y3.", "Z-0.25", "Z 1", "A10", "a-5", "B2.5", "F100", "f0",
        "F-1", "F 250.", "X1X2", "R1", "I1", "M2", " ", "\t", "\u00a0", "X\u0661", "(c)", ";c",
    ]
)  # fmt: skip


def _outcome(lines: list[str], fast: bool) -> tuple[list[gcode.Motion], str | None]:
    got: list[gcode.Motion] = []
    try:
        for m in gcode.iter_motions(lines, CFG, "t.ngc", fast=fast):
            got.append(m)
    except GCodeError as exc:
        return got, str(exc)
    return got, None


NUMBER = st.sampled_from(["1.5", "-2", ".5", "3.", "-0.25", " 1", "0", "10", "-7.125"])
WELL_FORMED = st.builds(
    lambda n, g, axes, arc, f, sep: sep.join(
        [x for x in (n, g) if x] + [a + v for a, v in axes + arc] + ([f] if f else [])
    ),
    st.sampled_from(["", "N10", "n 7"]),
    st.sampled_from(
        [
            "",
            "",
            "G0",
            "G1",
            "g01",
            "G90",
            "G91",
            "G20",
            "G21",
            "G55",
            "G54",
            "G2",
            "G3",
            "g03",
            "G18",
            "G17",
            "G91.1",
            "G90.1",
        ]
    ),
    st.lists(st.tuples(st.sampled_from("XYZABxyzab"), NUMBER), max_size=4),
    st.lists(st.tuples(st.sampled_from("IJKRij"), NUMBER), max_size=2),
    st.sampled_from(["", "", "F100", "f0", "F-1", "F 250."]),
    st.sampled_from(["", " ", "\t"]),
)


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(
        st.one_of(
            WELL_FORMED, WELL_FORMED, WELL_FORMED, st.lists(STRAIGHT, max_size=7).map("".join)
        ),
        max_size=25,
    )
)
def test_fast_path_gives_what_the_full_interpreter_gives(body: list[str]) -> None:
    """Common moves (G0-G3) skip building a Block; the motions, and every error
    with the motions before it, must be the full interpreter's."""
    lines = ["G21 G90 G17 G1 F500", *body, "M2"]
    assert _outcome(lines, fast=True) == _outcome(lines, fast=False)


@pytest.mark.parametrize("units", ["G20", "G21"])
@pytest.mark.parametrize("mode", ["G90", "G91"])
@pytest.mark.parametrize("coord", ["G54", "G55"])
def test_fast_path_in_every_modal_state(units: str, mode: str, coord: str) -> None:
    body = ["G1 X1 F200", "Y2", "Z-1", "A5", "B-3 F50", "G0 X2 Y1 Z1 A1 B1", "X3", "G1 A2"]
    body += [
        "G2 X5 Y1 R10",
        "G3 X3 Y2 Z2 R10 F300",
        "X1 Y1 R5 F250",
        "G1 X2 F10 Y1",
        "G18 G2 X3 Z0 R10",
    ]
    body += ["G17 G2 X2 Y0 I1 J0"] if mode == "G91" else ["G17 G2 X5 Y1 I1 J0"]
    lines = [f"{units} {mode} {coord} G17", *body, "G1 Z.5", "M2"]
    fast, slow = _outcome(lines, True), _outcome(lines, False)
    assert slow[1] is None
    assert fast == slow


def test_fast_path_crosses_batches() -> None:
    lines = ["G21 G90 G1 F1000"] + [f"X{i}" for i in range(2500)] + ["G0 Z1", "M2"]
    fast, slow = _outcome(lines, True), _outcome(lines, False)
    assert fast == slow
    assert len(fast[0]) == 2503  # 2502 moves and the M2
    # an error many batches in: every motion before it, none after
    bad = [*lines[:2100], "G1 X1 X2", *lines[2100:]]
    got, msg = _outcome(bad, True)
    assert msg is not None and msg.startswith("t.ngc:2101:")
    assert got == _outcome(bad, False)[0]
    assert got[-1].line == 2100


def test_machine_functions_in_linuxcncs_order_of_execution() -> None:
    """S, T, M6, M3/M4/M5, M7-M9 run before the block's motion, M0/M1/M2/M30 after
    it (LinuxCNC's G-code docs, "Order of Execution"); an S or T that changes
    nothing is no function."""
    text = "\n".join(
        [
            "G21 G90",
            "T2 M6",
            "M3 S12000 G0 X1",
            "S12000 G1 X2 F100",
            "M8 G1 X3 M0",
            "M9 M5 M1",
            "M30",
        ]
    )
    assert functions(text) == [
        (2, "T2 M6"),
        (3, "S12000 M3"),
        (5, "M8"),
        (5, "M0"),
        (6, "M5 M9"),
        (6, "M1"),
        (7, "M30"),
    ]
    ms = gcode.interpret(text, CFG, "t.ngc")
    kinds = [(m.line, m.kind) for m in ms]
    assert kinds.index((3, "function")) < kinds.index((3, "rapid"))
    assert kinds.index((5, "feed")) < kinds.index((5, "function"), kinds.index((5, "feed")))


@pytest.mark.parametrize(
    ("mode", "tol"),
    [("G61", 0.0), ("G61.1", gcode.EXACT_STOP), ("G64 P0.01", 0.01), ("G64", None), ("", None)],
)
def test_path_control_mode_rides_on_every_motion(mode: str, tol: float | None) -> None:
    ms = run(f"G21 G90 {mode}\nG1 X1 F100\nG0 X2\nM2")
    assert [m.path_tol for m in ms] == [tol, tol]
    assert run("G20 G64 P0.001\nG1 X1 F10\nM2")[0].path_tol == pytest.approx(0.0254)


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet="ab\r\n", max_size=40), st.lists(st.integers(0, 40), max_size=6))
def test_lines_read_in_pieces_are_the_lines_of_the_file(text: str, cuts: list[int]) -> None:
    import io

    bounds = sorted({0, len(text), *(c for c in cuts if c <= len(text))})
    pieces = [text[a:b] for a, b in itertools.pairwise(bounds)]
    want = [x.rstrip("\r\n") for x in io.StringIO(text, newline="")]
    assert [x for b in gcode.iter_line_batches(pieces) for x in b] == want


# ---------------------------------------------------------------- plain lines

_LETTERS = "abdefghijklmpqrstxyzABDEFGHIJKLMPQRSTXYZ"
_NUMBER = st.from_regex(r"\A[+-]?(?:[0-9]{1,6}\.?[0-9]{0,6}|\.[0-9]{1,6})\Z")
_PLAIN = st.lists(
    st.tuples(st.sampled_from(_LETTERS), _NUMBER, st.sampled_from(["", " ", "\t", "  "])),
    min_size=1,
    max_size=12,
).map(lambda ws: "".join(f"{letter}{num}{gap}" for letter, num, gap in ws))


def _same_reading(line: str) -> None:
    from prsxy_post.gcode import read

    fast, slow = read.parse(line), read._parse(line)
    assert (fast.kind, fast.m99, fast.oword, fast.problem, fast.always) == (
        slow.kind,
        slow.m99,
        slow.oword,
        slow.problem,
        slow.always,
    )
    a = read.evaluate(fast, 1, None, "p.ngc", lambda name: None)  # type: ignore[arg-type]
    b = read.evaluate(slow, 1, None, "p.ngc", lambda name: None)  # type: ignore[arg-type]
    assert (a.words, a.sets, a.comment) == (b.words, b.sets, b.comment)


@settings(max_examples=400, deadline=None)
@given(_PLAIN, st.sampled_from(["", " ", "\t"]))
def test_plain_lines_read_by_pattern_as_character_by_character(line: str, lead: str) -> None:
    """A line of plain words goes through a regular expression, not LinuxCNC's
    reading character by character: the same words, values, text and columns."""
    if len(lead + line) <= 252:
        _same_reading(lead + line)


def test_plain_lines_of_the_corpus_read_the_same() -> None:
    from prsxy_post.gcode import read

    n = 0
    for path in sorted((DATA / "gcode").rglob("*")):
        if path.suffix.lower() not in (".ngc", ".nc", ".gcode", ".tap"):
            continue
        for line in gcode.split_lines(path.read_bytes().decode("utf-8", "surrogateescape")):
            if read._PLAIN_LINE.fullmatch(line) and len(line) <= 252:
                _same_reading(line)
                n += 1
    assert n > 100_000  # most CAM lines are plain
