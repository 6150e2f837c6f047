"""Sorting a block's words and checking them as LinuxCNC does before it executes
anything (``read_g``/``read_m``, ``enhance_block``, ``interp_check.cc``).

:func:`classify` gives the words by letter and the G and M codes by modal
group, with ``motion``, the motion the block will make (LinuxCNC's
``motion_to_be``: the block's own motion code, or the one in effect when the
block has axis words and no other G code takes them). Every rule is
LinuxCNC's: which words a block may hold, which codes go together, which word
needs which code to use it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from ..errors import GCodeError
from .codes import (
    G_GROUPS,
    G_NOT_YET,
    G_OUT_OF_SCOPE,
    M_GROUPS,
    M_NOT_YET,
    M_OUT_OF_SCOPE,
    code_of,
    g_code10,
)
from .read import Word, fail

_AXIS_LETTERS = ("X", "Y", "Z", "A", "B")


class Words:
    """A block's words sorted (LinuxCNC's block struct)."""

    __slots__ = ("axis", "g", "m", "motion", "seen")

    def __init__(
        self,
        seen: dict[str, Word] | None = None,
        g: dict[int, tuple[float, Word]] | None = None,
        m: dict[int, tuple[int, Word]] | None = None,
        motion: float | None = None,
        axis: dict[str, Word] | None = None,
    ) -> None:
        self.seen = {} if seen is None else seen  # letters other than G M N
        self.g = {} if g is None else g  # group → (code, word)
        self.m = {} if m is None else m  # group → (code, word)
        self.motion = motion  # the motion the block makes (80: G80)
        self.axis = {} if axis is None else axis


def classify(
    words: tuple[Word, ...],
    motion_mode: float | None,
    incremental: bool,
    plane: int,
    user_m: frozenset[int],
    source: str,
    line: int,
) -> Words:
    """Sort and check one block's words; ``motion_mode`` is the motion in effect
    (None for G80), ``user_m`` the M100-M199 the machine has."""

    def err(msg: str, w: Word | None, expected: str | None = None) -> GCodeError:
        text = f"{msg} ('{w.text}')" if w is not None else msg
        return fail(text, source, line, w.column if w is not None else None, expected)

    out = Words()
    m_count = 0
    for w in words:
        if w.letter == "G":
            _g_word(out, w, err)
        elif w.letter == "M":
            _m_word(out, w, user_m, err)
            m_count += 1
        else:
            _other_word(out.seen, w, err)
    if m_count > 4:
        raise err("more than four M codes in one block", None, "at most four")
    _enhance(out, motion_mode, plane, err)
    _check_g(out, incremental, err)
    _check_other(out, err)
    return out


#: a located error from a message, the word and what was expected (``classify``'s)
_Err = Callable[[str, Word | None, str | None], GCodeError]


def _g_word(out: Words, w: Word, err: _Err) -> None:
    """A G word into its modal group (read_g, and check_g_codes' one-per-group)."""
    c10 = g_code10(w.value)
    if c10 is None or c10 > 999:
        raise err("G code out of range", w, "a G code like G1 or G43.1")
    if c10 < 0:
        raise err("negative G code", w, "a G code like G1 or G43.1")
    grp = G_GROUPS.get(c10)
    if grp is None:
        raise err("unknown G code", w, "a G code LinuxCNC knows")
    if c10 in G_OUT_OF_SCOPE:
        raise err(G_OUT_OF_SCOPE[c10], w, "the milling codes this machine runs")
    if c10 in G_NOT_YET:
        raise err(G_NOT_YET[c10], w, "the milling subset (see README)")
    code = code_of(c10)
    if grp in out.g:
        # LinuxCNC lets G80 stand beside another motion code; the other wins
        if c10 == 800:
            return
        if out.g[grp][0] != 80:
            raise err(
                "two G codes of the same modal group",
                w,
                f"one of them (already {out.g[grp][1].text})",
            )
    out.g[grp] = (code, w)


def _m_word(out: Words, w: Word, user_m: frozenset[int], err: _Err) -> None:
    """An M word into its modal group (read_m): a whole number the machine knows."""
    v = w.value
    n = math.floor(v)
    if v - n > 0.9999:
        n = math.ceil(v)
    elif v - n > 0.0001:
        raise err("M code not an integer", w, "M followed by a whole number")
    if n < 0:
        raise err("negative M code", w, "M0 to M199")
    if n > 199:
        raise err("M code above 199", w, "M0 to M199")
    grp = M_GROUPS.get(n)
    if grp is None or (grp == 10 and n not in user_m):
        expected = (
            "an M1nn the profile lists in [gcode] user_m_codes"
            if grp == 10
            else "an M code LinuxCNC knows"
        )
        raise err(f"unknown M code M{n}", w, expected)
    if n in M_OUT_OF_SCOPE:
        raise err(M_OUT_OF_SCOPE[n], w, "the M codes this machine runs")
    if n in M_NOT_YET:
        raise err(M_NOT_YET[n], w, "the supported M codes (see README)")
    if grp in out.m:
        raise err(
            "two M codes of the same modal group",
            w,
            f"one of them (already {out.m[grp][1].text})",
        )
    out.m[grp] = (n, w)


def _other_word(seen: dict[str, Word], w: Word, err: _Err) -> None:
    """Any other word, once a block; F and S not negative; T, L and H whole numbers."""
    letter = w.letter
    if letter in seen:
        raise err(f"{letter} word repeated", w, f"one {letter} word per block")
    if letter in ("F", "S") and w.value < 0.0:
        raise err(f"negative {letter} word", w, f"{letter} >= 0")
    if letter in ("T", "L", "H"):
        v = w.value
        n = math.floor(v)
        if v - n > 0.9999:
            n = math.ceil(v)
        elif v - n > 0.0001:
            raise err(f"{letter} word not an integer", w, f"{letter} followed by a whole number")
        if n < (-1 if letter == "H" else 0):
            raise err(f"negative {letter} word", w, f"{letter} >= 0")
        w = w._replace(value=float(n))
    seen[letter] = w


def _enhance(out: Words, motion_mode: float | None, plane: int, err: _Err) -> None:
    """LinuxCNC's enhance_block: the block's motion, and where axis words go."""
    seen = out.seen
    axis = {a: seen[a] for a in _AXIS_LETTERS if a in seen}
    out.axis = axis
    polar = "@" in seen or "^" in seen
    ijk = "I" in seen or "J" in seen or "K" in seen
    mode0 = out.g[0][0] if 0 in out.g else None
    mode1 = out.g[1][0] if 1 in out.g else None
    covets = mode0 in (10, 28, 30, 52, 92)
    first_axis = next(iter(axis.values()), None)
    if polar:
        pw = seen.get("@") or seen.get("^")
        if plane != 17:
            raise err("polar coordinates outside the G17 plane", pw, "G17 for @ and ^")
        for a in ("X", "Y"):
            if a in seen:
                raise err(f"polar coordinates and a {a} word", seen[a], "@ and ^ without X, Y")
    if mode1 is not None:
        w1 = out.g[1][1]
        if mode1 == 80:
            if (polar or axis) and not covets:
                raise err("axis words with G80", first_axis, "no X Y Z A B with G80 (motion off)")
            if polar and mode0 == 92:
                raise err("polar coordinates with G92", w1, "polar coordinates for motion only")
            if not axis and mode0 in (52, 92):
                raise err(f"G{mode0:g} without axis words", out.g[0][1], f"G{mode0:g} X.. Y.. Z..")
        else:
            if covets:
                raise err(
                    "two G codes that both use axis words",
                    out.g[0][1],
                    f"G{mode0:g} or a motion, not both",
                )
            if not axis and not polar and mode1 not in (0, 1, 2, 3, 5.2):
                raise err(f"G{mode1:g} without axis words", w1, f"G{mode1:g} with X, Y or Z")
        out.motion = mode1
    elif covets:
        if polar and mode0 == 92:
            raise err(
                "polar coordinates with G92", out.g[0][1], "polar coordinates for motion only"
            )
        if not axis and mode0 in (52, 92):
            raise err(f"G{mode0:g} without axis words", out.g[0][1], f"G{mode0:g} X.. Y.. Z..")
    elif axis or polar:
        tlo = out.g[8][0] if 8 in out.g else None
        if motion_mode is None and tlo not in (43.1, 43.2):
            w = first_axis or seen.get("@") or seen.get("^")
            raise err(
                "axis words with no motion mode",
                w,
                "a G0, G1, G2, G3 or canned cycle in effect (not G80)",
            )
        if tlo != 43.1:
            out.motion = motion_mode
    elif ijk and motion_mode in (2, 3):
        out.motion = motion_mode
    if polar and out.motion is None:
        raise err(
            "polar coordinates without a motion",
            seen.get("@") or seen.get("^"),
            "polar coordinates for motion only",
        )


def _check_g(out: Words, incremental: bool, err: _Err) -> None:
    """LinuxCNC's check_g_codes (modal group 0)."""
    if 0 not in out.g:
        return
    mode0, w0 = out.g[0]
    seen = out.seen
    mode1 = out.g[1][0] if 1 in out.g else None
    if mode0 == 4:
        if "P" not in seen:
            raise err("G4 without a dwell time", w0, "G4 P<seconds>")
        if mode1 in (2, 3):
            raise err("G4 with G2 or G3 (both use P)", w0, "G4 on a line of its own")
    elif mode0 == 10:
        lw = seen.get("L")
        pw = seen.get("P")
        lv = int(lw.value) if lw is not None else -1
        if lv not in (0, 1, 2, 10, 11, 20):
            raise err("G10 without L0, L1, L2, L10, L11 or L20", lw or w0, "G10 L2 P1 X..")
        p = pw.value if pw is not None else -1.0
        p_int = int(p + 0.5) if p >= 0 else int(p - 0.5)
        if (p + 0.0001) - p_int > 0.0002:
            raise err("P of G10 not an integer", pw or w0, "G10 L2 P1 (a whole number)")
        if lv in (2, 20) and not 0 <= p_int <= 9:
            raise err(f"P of G10 L{lv} out of range", pw or w0, "P0 (current) to P9 (G59.3)")
        if lv in (1, 10, 11) and p_int < 1:
            raise err(f"P of G10 L{lv} out of range", pw or w0, "a tool number from 1")
    elif mode0 == 5.3:
        if mode1 not in (None, 5.2):
            raise err("G5.3 with another motion than G5.2", w0, "G5.3 on its own")
    elif mode0 == 53:
        if out.motion not in (0, 1):
            raise err("G53 with a motion other than G0 or G1", w0, "G53 G0 or G53 G1")
        g3 = out.g[3][0] if 3 in out.g else None
        if g3 == 91 or (g3 != 90 and incremental):
            raise err("G53 in incremental mode", w0, "G90 with G53")


def _check_other(out: Words, err: _Err) -> None:
    """LinuxCNC's check_other_codes: each word needs a code that uses it."""
    seen = out.seen
    motion = out.motion
    g = out.g
    m = out.m
    mode0 = g[0][0] if 0 in g else None
    comp = g[7][0] if 7 in g else None
    m5 = m[5][0] if 5 in m else None
    user_m = 10 in m
    cycle = motion is not None and (81 <= motion <= 89 or motion == 73)
    if cycle or motion == 74:  # is_a_cycle
        for a in ("A", "B"):
            if a in seen:
                raise err(
                    f"{a} word in a canned cycle",
                    seen[a],
                    "X Y Z R only: rotary axes may not move in a cycle",
                )
    if "D" in seen and comp not in (41, 42, 41.1, 42.1) and (g[14][0] if 14 in g else None) != 96:
        raise err("D word with no G41, G42 or G96 to use it", seen["D"], "D with G41/G42")
    if "E" in seen and m5 not in (66, 67, 68):
        raise err("E word with no M66, M67 or M68 to use it", seen["E"], "E with M66, M67, M68")
    if "H" in seen and (g[8][0] if 8 in g else None) not in (43, 43.2):
        raise err("H word with no G43 to use it", seen["H"], "H with G43")
    if "I" in seen and motion not in (2, 3, 5, 5.1) and mode0 != 10:
        raise err("I word with no arc to use it", seen["I"], "I, J, K with G2/G3 or G5")
    if "J" in seen and motion not in (2, 3, 5, 5.1) and mode0 != 10:
        raise err("J word with no arc to use it", seen["J"], "I, J, K with G2/G3 or G5")
    if "K" in seen and motion not in (2, 3):
        raise err("K word with no arc to use it", seen["K"], "I, J, K with G2/G3")
    if "L" in seen and not (
        cycle or motion == 5.2 or mode0 == 10 or comp in (41, 42, 41.1, 42.1) or m5 == 66
    ):
        raise err(
            "L word with no G10, canned cycle, cutter compensation, M66 or G5.2 to use it",
            seen["L"],
            "L with a canned cycle or G10",
        )
    if "P" in seen:
        pw = seen["P"]
        if not (
            mode0 in (10, 4)
            or (g[13][0] if 13 in g else None) == 64
            or motion in (82, 86, 88, 89, 5, 5.2, 2, 3, 74, 84)
            or (m[9][0] if 9 in m else None) in (50, 51, 52, 53)
            or m5 in (62, 63, 64, 65, 66)
            or user_m
        ):
            raise err(
                "P word with no G2, G3, G4, G10, G64, G5, G5.2, G82, G84, G86, G89, "
                "M50-M53, M62-M66 or user M code to use it",
                pw,
                "P with one of those",
            )
        if motion in (2, 3):
            p = pw.value
            if abs(round(p) - p) > 0.001:
                raise err("P (turns) of G2/G3 not an integer", pw, "P1, P2, ...")
            if math.floor(p + 0.5) < 1:
                raise err("P (turns) of G2/G3 below 1", pw, "P1, P2, ...")
    if "Q" in seen and not (
        motion in (83, 73, 5)
        or user_m
        or m5 in (66, 67, 68)
        or mode0 == 10
        or (m[6][0] if 6 in m else None) == 61
        or (g[13][0] if 13 in g else None) == 64
    ):
        raise err(
            "Q word with no G5, G10, G64, G73, G83, M61, M66-M68 or user M code to use it",
            seen["Q"],
            "Q with one of those",
        )
    if "R" in seen and not (motion in (2, 3, 74) or cycle or comp in (41.1, 42.1) or mode0 == 10):
        raise err(
            "R word with no arc or canned cycle to use it",
            seen["R"],
            "R with G2/G3, a canned cycle, G10 or G41.1/G42.1",
        )
    if 14 in g and g[14][0] == 96 and "S" not in seen:
        raise err("G96 without an S word", g[14][1], "G96 S<surface speed>")
