"""The fast path: the common CAM block, matched over a batch of lines at once.

Two implementations give the same motions, bit for bit: this module's
:func:`fast_run` (the reference: a regex over the batch, a Python loop) and its
compiled twin ``_fast.pyx`` (a scanner that accepts what the regex matches, the
same arithmetic in C, arcs as ``moves.arc`` computes them, and :func:`_fast_arc`
for any arc the interpreter may refuse). :data:`SELECTED`
is the one the stream runs, picked once at import as the kernel's are
(``PRSXY_KERNEL=pure`` selects the reference; without the built extension the
reference runs too).
"""

from __future__ import annotations

import functools
import itertools
import math
import re
from collections.abc import Callable
from typing import Any, NamedTuple

from .. import kernel
from ..errors import GCodeError
from .codes import AXES
from .execute import Interpreter
from .motion import MM_PER_INCH, Motion
from .moves import RADIUS_TOLERANCE, SPIRAL_ABS_TOLERANCE, SPIRAL_REL_TOLERANCE, arc
from .read import Word
from .rows import WIDTH, new_rows

#: The common CAM block: an optional N, an optional G0/G1/G2/G3, axis words in the
#: order X Y Z A B, arc words I J K R, an optional F (each at most once), nothing
#: else. Matched over a whole batch of lines at once (one match per line: the last
#: group takes any other line).
#: Possessive quantifiers (nothing is given back: the last group takes whatever is
#: left, so no match ever needs to backtrack) make it a third faster; only the
#: zeros of G00 must be able to give one back.
_NUM = r"[ \t]*+([-+]?+(?:[0-9]++\.?+[0-9]*+|\.[0-9]++))[ \t]*+"
_FAST_LINE = (
    r"^[ \t]*+(?:[Nn][ \t]*+[0-9]++[ \t]*+)?+(?:[Gg][ \t]*+0*([0-3])(?![0-9.])[ \t]*+)?+"
    + "".join(f"(?:[{c}{c.lower()}]{_NUM})?+" for c in "XYZABIJKRF")
    + r"(.*)$"
)


@functools.cache
def _fast_line() -> re.Pattern[str]:
    """:data:`_FAST_LINE` compiled, on first use (the compiled twin matches
    without it, and compiling it is 1 ms of every command's start-up)."""
    return re.compile(_FAST_LINE, re.M)


_ARC_LETTERS = ("X", "Y", "Z", "A", "B", "I", "J", "K", "R", "F")
#: lines matched at once: large enough that the regex runs in C for most of the
#: time, small enough that what a batch makes stays in the CPU's caches (measured:
#: 256 lines are 30 % faster than 4096)
BATCH = 256


def fast_run(it: Interpreter, matches: list[tuple[str, ...]], i: int, n0: int) -> int:
    """Interpret matched lines from ``i`` on while they are common moves, without
    building Blocks; return the index of the first line not taken.

    ``matches[k]``: the groups of :data:`_FAST_LINE` (G, X, Y, Z, A, B, I, J, K, R,
    F, rest) of line ``n0 + k + 1``. Only blocks the full path would accept the
    same way are taken: G0/G1 without arc words, or G2/G3 (given or in effect),
    in G94, with F positive for a feed move; anything else, and every error,
    goes the full way, which reports it with its column. The modal state lives
    in locals over the run and is written back at its end.
    """
    if not _takes(it, matches[i]):
        return i
    st = it.st
    x, y, z, a, b = st.pos
    motion = st.motion
    feed = st.feed
    sc = MM_PER_INCH if st.units == "inch" else 1.0
    absolute = st.absolute
    offset = it.offset()
    extra = (st.tool_length, st.tool, st.spindle * st.spindle_dir, False, st.path_tol, (), None)
    append = it.out.append
    new_motion = False
    k = i
    for words in itertools.islice(matches, i, None):
        g, xs, ys, zs, as_, bs, is_, js, ks, rs, fs, rest = words
        if rest or not (xs or ys or zs or as_ or bs):
            break
        m = int(g) if g else motion
        if m not in (0, 1, 2, 3):
            break
        if fs:
            f = float(fs)
            if f < 0 or (f == 0 and m):
                break
        elif m and feed <= 0:
            break
        else:
            f = feed
        if m >= 2:
            st.pos, st.motion, st.feed = [x, y, z, a, b], motion, feed
            if not _fast_arc(it, int(m), words, n0 + k + 1):
                break
            x, y, z, a, b = st.pos
            motion, feed = st.motion, st.feed
            k += 1
            continue
        if is_ or js or ks or rs:
            break
        ex, ey, ez, ea, eb = _line_end(words, (x, y, z, a, b), absolute, sc, offset)
        if fs:
            feed = f
        if g:
            motion = m
            new_motion = True
        if m == 0:
            kind, rate = "rapid", math.nan
        else:
            kind = "feed"
            try:
                moved = (ex - x) ** 2 + (ey - y) ** 2 + (ez - z) ** 2 > 1e-24
            except OverflowError:  # a square past the largest float: it moved
                moved = True
            rate = f * sc if (moved or (ea == a and eb == b)) else f
        append(
            _motion_of(
                (
                    n0 + k + 1,
                    kind,
                    (x, y, z, a, b),
                    (ex, ey, ez, ea, eb),
                    rate,
                    0,
                    None,
                    0,
                    0.0,
                    *extra,
                )
            )
        )
        x, y, z, a, b = ex, ey, ez, ea, eb
        k += 1
    if k > i:
        st.pos = [x, y, z, a, b]
        st.motion = motion
        st.feed = feed
        if new_motion:
            st.cycle_il = None
        it.started = True
    return k


def _takes(it: Interpreter, first: tuple[str, ...]) -> bool:
    """Whether the fast path may start at a line with the groups ``first``: a move
    with axis words and nothing else, in a state it keeps (no cutter compensation,
    rotation, inverse time, queued or detached work, pending arc check)."""
    if first[11] or not (first[1] or first[2] or first[3] or first[4] or first[5]):
        return False  # not a move the fast path takes: no state to set up
    st = it.st
    return not (
        st.ended
        or st.inverse_time
        or st.comp_side
        or st.rotation  # points go out through Interpreter.emit_now's rotation
        or st.arc_not_allowed  # the full path clears it at the next straight move
        or it.detached is not None
        or it.queue
    )


def _line_end(
    words: tuple[str, ...],
    here: tuple[float, float, float, float, float],
    absolute: bool,
    sc: float,
    offset: tuple[float, ...],
) -> tuple[float, float, float, float, float]:
    """A straight move's end [mm, mm, mm, deg, deg]: each axis word in the
    program's units (``sc`` mm per unit) and offsets (``offset``, in G90), or
    added to ``here`` (G91); an axis without a word stays."""
    _, xs, ys, zs, as_, bs = words[:6]
    x, y, z, a, b = here
    if absolute:
        ox, oy, oz, oa, ob = offset
        return (
            float(xs) * sc + ox if xs else x,
            float(ys) * sc + oy if ys else y,
            float(zs) * sc + oz if zs else z,
            float(as_) + oa if as_ else a,
            float(bs) + ob if bs else b,
        )
    return (
        x + float(xs) * sc if xs else x,
        y + float(ys) * sc if ys else y,
        z + float(zs) * sc if zs else z,
        a + float(as_) if as_ else a,
        b + float(bs) if bs else b,
    )


def _motion_of(fields: tuple[object, ...]) -> Motion:
    return tuple.__new__(Motion, fields)


def _fast_arc(it: Interpreter, motion: int, words: tuple[str, ...], n: int) -> bool:
    """G2/G3 from matched words through the interpreter's own arc code. Words carry
    no columns here, so an arc the interpreter refuses goes the full way (with
    the state as it was) to be reported with its column."""
    st = it.st
    seen = {
        letter: Word(letter, float(text), text, 0)
        for letter, text in zip(_ARC_LETTERS, words[1:11], strict=True)
        if text
    }
    axis_words = {a: seen[a] for a in AXES if a in seen}
    saved = (st.feed, st.motion, st.cycle_il)
    if "F" in seen:
        st.feed = seen["F"].value
    it._seen = seen
    try:
        arc(it, motion, axis_words, seen, n)
    except GCodeError:
        st.feed, st.motion, st.cycle_il = saved
        return False
    if words[0]:
        st.cycle_il = None
    st.motion = motion
    it.started = True
    return True


def pure_matches(batch: list[str]) -> list[tuple[str, ...]]:
    """The regex's groups of each line of a batch, for :func:`fast_run`; none (no
    fast path) when a line holds a character that ends lines."""
    matches = _fast_line().findall("\n".join(batch))
    return matches if len(matches) == len(batch) else []


class FastPath(NamedTuple):
    """One implementation of the fast path: ``run(it, matches(batch), i, n0)``;
    ``run_rows`` the same in rows mode (:mod:`.rows`: the moves it takes as runs
    of rows in ``it.out``; the reference makes Motions there too)."""

    name: str
    matches: Callable[[list[str]], list[Any]]
    run: Callable[[Interpreter, list[Any], int, int], int]
    run_rows: Callable[[Interpreter, list[Any], int, int], int]


#: the reference
PURE = FastPath("pure", pure_matches, fast_run, fast_run)


def _compiled() -> FastPath | None:
    """The compiled twin bound to this module's pieces, or None where it is not
    built."""
    try:
        from ._fast import bind, fast_rows, matches_of
        from ._fast import fast_run as compiled_run
    except ImportError:
        return None
    bind(
        Motion,
        _fast_arc,
        fast_run,
        pure_matches,
        MM_PER_INCH,
        math.nan,
        math.hypot,
        RADIUS_TOLERANCE,
        SPIRAL_ABS_TOLERANCE,
        SPIRAL_REL_TOLERANCE,
        WIDTH,
        new_rows,
    )
    return FastPath("compiled", matches_of, compiled_run, fast_rows)


#: the compiled twin (None when not built), and the one the stream runs
COMPILED = _compiled()
#: (the kernel's own choice: PRSXY_KERNEL=pure, which it names as why the
#: reference runs, selects every reference)
SELECTED = PURE if COMPILED is None or kernel.WHY_PURE.startswith(kernel.ENV) else COMPILED
