"""Machine functions without motion against rs274's canonical calls: spindle,
coolant, tools (M6, M61), outputs (M62-M65, M67, M68), overrides, the functions
inside tapping and boring cycles, modal state saved and restored (M70-M73), and
the spindle modes G96/G97 (which the stand-in canon shows as SET_SPINDLE_MODE).

The functions are compared as oracle.function_tokens writes rs274's calls;
motions as everywhere else.
"""

from __future__ import annotations

import pytest

from prsxy_post import gcode
from prsxy_post.errors import GCodeError

from . import oracle
from .test_gcode_macros import TOOLS, agree, ours
from .test_gcode_oracle import _require_rs274, _tokens

pytestmark = pytest.mark.linuxcnc


def functions_agree(text: str) -> list[str]:
    _require_rs274()
    _, err = agree(text)
    assert err is None, err
    ref = oracle.run(text, tools=TOOLS)
    cfg = gcode.InterpreterConfig(tool_table={n: gcode.ToolEntry(*v) for n, v in TOOLS.items()})
    mine: list[str] = []
    for m in gcode.interpret(text, cfg, "p.ngc"):
        if m.kind == "function":
            mine += _tokens(m.words)
    assert mine == oracle.function_tokens(ref.calls)
    return mine


PROGRAMS = {
    "spindle and coolant": "G21\nS1000 M3\nM8\nM7\nG0 X1\nM9\nS2000 M4\nM5\nM2\n",
    "tools": "G21\nT1\nM6\nT2 M6\nT2\nM61 Q1\nM61 Q0\nM30\n",
    "outputs": "G21\nM62 P1\nM63 P1\nM64 P3\nM65 P3\nM67 E1 Q2.5\nM68 E0 Q-1\nG0 X1\nM2\n",
    "overrides": "G21\nM49\nM48\nM2\n",
    "stops": "G21\nG0 X1\nM0\nG0 X2\nM1\nM60\nM2\n",
    "tapping": "G21 G0 Z10\nS500 M3\nG84 X1 Y1 Z-5 R2 F100 P0.2\nX3\nG80\nM2\n",
    "left-hand tapping": "G21 G0 Z10\nS500 M4\nG74 X1 Y1 Z-5 R2 F100\nG80\nM2\n",
    "boring with a stopped retract": "G21 G0 Z10\nS500 M3\nG86 X1 Y1 Z-5 R2 F100 P0.5\nG80\nM2\n",
    "tapping without overrides": "G21 G0 Z10\nM49\nS500 M3\nG84 X1 Y1 Z-5 R2 F100\nG80\nM2\n",
    "modal state saved and restored": (
        "G21 G90 G17 F100 S1000 M3 M8\nM70\nG20 G91 G18 F7 S300 M4 M9\nG1 X1\nM72\nG1 X10 Y2\nM2\n"
    ),
    "restored on return (M73)": (
        "G21 F100\no<s> sub\nM73\nG20 G91 F5\nG1 X1\no<s> endsub\no<s> call\nG1 X2\nM2\n"
    ),
    "spindle modes": "G21\nG96 S100 D3000 M3\nG0 X10\nG97 S800\nM2\n",
    # M99 in the main program ends it as M2 (convert_stop, loop_on_main_m99 unset)
    "M99 ends the main program": "G21\nS100 M3\nG0 X1\nM99\n",
}


@pytest.mark.parametrize("program", list(PROGRAMS.values()), ids=list(PROGRAMS))
def test_functions_agree_with_rs274(program: str) -> None:
    functions_agree(program)


def test_function_words_in_linuxcncs_order() -> None:
    """One block's functions come out as one event in execute_block's order:
    spindle mode, S, T, outputs, tool change, spindle, coolant, overrides."""
    text = "G21\nT1 M6\nM8 M3 S500 G96 D2000 M62 P1 M49 T2\nM2\n"
    cfg = gcode.InterpreterConfig(tool_table={n: gcode.ToolEntry(*v) for n, v in TOOLS.items()})
    events = [m.words for m in gcode.interpret(text, cfg) if m.kind == "function"]
    assert events[1] == (
        ("G", 96.0),
        ("D", 2000.0),
        ("S", 500.0),
        ("T", 2.0),
        ("M", 62.0),
        ("P", 1.0),
        ("M", 3.0),
        ("M", 8.0),
        ("M", 49.0),
    )


def test_m66_waits_and_its_result_cannot_be_read() -> None:
    """M66 is an event; what it reads (#5399) exists only on the running machine,
    so a program that branches on it is refused rather than guessed."""
    text = "G21\nM66 P2 L3 Q5\nG0 X1\nM2\n"
    events = [m.words for m in gcode.interpret(text) if m.kind == "function"]
    assert events[0] == (("M", 66.0), ("P", 2.0), ("L", 3.0), ("Q", 5.0))
    _, _, err = ours("G21\nM66 E1 L0\no1 if [#5399 gt 2]\no1 endif\nM2\n")
    assert err is not None and "#5399" in str(err) and "not known" in str(err)
    # set again by the program, it is known
    _, _, err = ours("G21\nM66 P1 L0\n#5399 = 1\n#1 = #5399\nM2\n")
    assert err is None


ERRORS = {
    "m62 without p": "G21\nM62\nM2\n",
    "m67 without e": "G21\nM67 Q1\nM2\n",
    "m66 with p and e": "G21\nM66 P1 E1\nM2\n",
    "m66 waiting without timeout": "G21\nM66 P1 L1\nM2\n",
    "m61 without q": "G21\nM61\nM2\n",
    "m72 with nothing saved": "G21\nM72\nM2\n",
    "g96 without s": "G21\nG96 D100\nM2\n",
    "g84 spindle stopped": "G21 G0 Z10\nG84 X1 Z-5 R2 F100\nM2\n",
    "g74 spindle clockwise": "G21 G0 Z10\nM3 S100\nG74 X1 Z-5 R2 F100\nM2\n",
    "two spindle codes": "G21\nM3 M70\nM2\n",
    "e word alone": "G21\nG0 X1 E1\nM2\n",
}


@pytest.mark.parametrize("program", list(ERRORS.values()), ids=list(ERRORS))
def test_function_errors_refused_by_both(program: str) -> None:
    _require_rs274()
    ref = oracle.run(program, tools=TOOLS)
    _, _, err = ours(program)
    assert ref.error is not None, "rs274 accepts it"
    assert err is not None, f"we accept what rs274 refuses: {ref.error}"


def test_tapping_outside_g17_is_refused_because_linuxcnc_taps_sideways() -> None:
    """LinuxCNC 2.9 feeds G84 in G18 along X instead of Y (convert_cycle_g74_g84
    permutes the coordinates that cycle_feed permutes again, interp_cycles.cc);
    its own tests/interp/g84/g18 record it. We refuse rather than tap sideways."""
    _require_rs274()
    text = "G21 G18 G0 X0 Y10 Z0\nS500 M3\nG84 X1 Z1 Y-5 R2 F100\nG80\nM2\n"
    feeds = [m for m in oracle.run(text, tools=TOOLS).motions if m.kind == "feed"]
    # the tap's depth (Y-5) went to X, the hole's X (1) to Y, the cycle's axis
    assert feeds[0].end[:3] == pytest.approx((-5.0, 1.0, 1.0))
    cfg = gcode.InterpreterConfig()
    with pytest.raises(GCodeError, match="G84 in G18 is not supported"):
        gcode.interpret(text, cfg, "p.ngc")
