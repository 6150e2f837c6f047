"""Where a motor with play reverses, and the window in which it crosses the play.

The real-axis compensation (contract, "Real-axis error") commands lo⁻¹(T) while
a motor moves up and hi⁻¹(T) while it moves down, so at a reversal the command
jumps across the play. A controller moves from one point to the next along a
smooth curve; if the jump were left between two ordinary points, the motor
would cross the play over a whole step, the driven part standing still for all
of it while the path goes on. So the jump gets a window of its own:

- a reversal in motion (the motor's planned velocity changes sign between two
  points): the root t_r of the velocity of the segment's cubic, and two new
  points at t_r ± δ/2. Inside the window the part stands at the extremum while
  the motor crosses; it misses the true path by at most |A| (δ/2)² / 2 for the
  motor's acceleration A at the reversal, so δ = sqrt(8 tol / |A|), at most the
  profile's ``reversal_ms``; on each side of the root no longer than keeps the
  tip's speed within CROSSING_SPEED_SHARE of F (the motor's lever on the tip,
  ``allowed`` of :func:`place_insertions`), so shorter on the side where the
  standing part pushes the tip on;
- a reversal at rest (the path stood still at the previous point, the motor
  leaves the other way): one more point at the same pose, δ later, at which the
  motor has crossed; the path waits for it;
- a dip (the motor moves the same way at both ends of a step, but the step's
  cubic turns back and on again inside it: a tight curve's extreme between two
  points): two windows, one at each turning point, when the dip is deeper than
  the tolerance; and the same where a motor sets off from rest or standing the
  other way first (:func:`_motor_dips`).

A chunk's reversals are planned in stages with no callback into the chain:
:func:`find_reversals` (the reversals, their kinds, the roots on the steps'
cubics, the dips), :func:`roots_search` (the roots moved onto the path: the
chain answers each look, :func:`root_queries`, with the path's velocity,
:func:`root_answer`), :func:`edge_queries` (where the chain gives the fastest a
motor may move while its part stands) and :func:`place_insertions` (the windows
and the points they put in).

After a crossing the part is brought back onto its wanted position along the path
(:func:`catch_up`), and what is left of its offset when the motor's next crossing
begins goes into that crossing (:func:`.kernel.play.follow_stretches` follows the part
there).
At a corner taken at speed where the motor stands on one side
(:func:`corners`), a PVT program blends the corner as a parabola over a millisecond
or so each side, every motor's velocity linear across it (:func:`blend_shift`). A
program of straight lines needs nothing there: a motor standing at both ends of a
chord stands all along it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from . import kernel
from .kernel import windows as kernel_windows
from .kernel.play import PlayTable

#: ``edge_speed(k, s, cols, accel)``: the fastest [mm/s] motors ``cols`` (q,) may
#: move while their parts stand before and after (two arrays) their reversals in
#: steps ``k`` at the fractions ``s`` of them, at accelerations ``accel`` there:
#: what the chain answers to :func:`edge_queries` (:func:`place_insertions`'
#: ``allowed``)
EdgeSpeed = Callable[
    [np.ndarray, np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]
]

#: ``velocity(k, frac, cols)``: the path's own velocity [mm/s] of motors ``cols``
#: (m,) at fractions ``frac`` (m,) of steps ``k`` (m,) of the chunk: what the
#: points sample, not the step's cubic between them; NaN where it is not known
#: (:func:`path_roots`; the chain answers :func:`root_queries` with it).
Velocity = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]

#: False-position steps that move a reversal's root from the step's cubic onto the
#: path, and the half width [fraction of the step] of the central difference that
#: gives the path's acceleration there (:func:`path_roots`).
ROOT_STEPS = 4
ROOT_SLOPE_STEP = 1e-3
#: A root is taken as found where the path's velocity there is what its
#: acceleration makes in this long [s]: a 250th of the shortest window
#: (MIN_WINDOW_S). On fast turns the cubic's root already is, and one look at the
#: path keeps it.
ROOT_TIME_S = 1e-6
#: How far the slope that test takes may overrate the path's at the root: the
#: secant to a bracket's end overrates it by 1 + c L² / A for a velocity A u + c
#: u³ seen a length L away (up to 5 x where the cubic term is 4 x the linear one a
#: step away; 1.02 µs off at 1.5 x, test_reversals' hypothesis).
ROOT_SLOPE_MARGIN = 5.0

#: A planned motor velocity below this [mm/s] gives no direction: a motor creeping
#: (a table following the head's parasitic motion by nanometres) does not make the
#: part cross its play at every wobble; its drift is watched instead (DRIFT_SHARE).
#: Its part stands meanwhile, and the tip loses the creep's share of its speed: at
#: 1e-3, a head motor creeping at 0.9 µm/s through a B tilt at F60 ran the tip
#: 1.0008 x F, and its drift's crossing window 1.0012 x (test_controller_truth's
#: found programs); at 5e-4, 1.00045 x.
V_EPS = 5e-4
#: The shortest window [s]: a PVT segment of the controller's own servo cycle.
MIN_WINDOW_S = 0.25e-3
#: A creeping motor (slower than V_EPS) may drift back from where it last moved
#: by this share of the reversal allowance before it crosses its play.
DRIFT_SHARE = 1.0
#: Window edges of different motors this close [s] are made one point.
SNAP_S = 0.1e-3
#: After a crossing the part meets its motor where it stood, off its wanted position
#: by up to the reversal allowance; it is brought back no faster than this share of
#: the path speed. Brought back within the next step, it would be the allowance per
#: step: 0.05 µm in 10 ms, 0.1 % of F300 and 0.5 % of F60 (test_controller_truth's
#: found programs). A part brought back runs that share faster than its motor's
#: path; the points of the written program keep within 1e-4 of F (the rounding of
#: their numbers: test_tracking), so the share is half of that: 0.05 µm takes 1 mm
#: of path. (2e-4 was seen to take a point 2e-4 over F in a corrected G-code.)
CATCH_UP_SHARE = 5e-5
#: Where an offset would be gone by the motor's next crossing at no more than this
#: many times CATCH_UP_SHARE, it is (still within the 1e-4 of F its points keep);
#: only a larger one goes into that crossing (:func:`catch_up`). A crossing taking in
#: an offset is reckoned again from where the part is, a round per crossing of a
#: chain (chain.Pipeline._settle): at 200 k lines of bench.py's program 28 000
#: offsets went in at the share alone, 23 600 with this, and the main process's
#: _settle took 1.10 s instead of 1.37 (ad-hoc spies).
CATCH_UP_HURRY = 2.0
#: At a corner taken at speed a point carries the mean of its sides' velocities; a
#: motor with play that stands on one side and moves on the other then turns back
#: inside the standing side's step, by up to (4/27) h |V| / 2, and leaves its part
#: (:func:`corners`). Below this [mm] that turn is left alone: the part stands
#: while its motor turns back by a nanometre.
CORNER_TURN_MM = 1e-6
#: Inside a crossing window the part stands while its motor would have moved on
#: at up to |A| δ / 2, and the tip lacks that motor's share of its velocity: its
#: speed may go past F by this share at most (as a creep's, V_EPS at F60). From the
#: path tolerance alone, a 1 ms window about a head motor's reversal on a tilting
#: line at F400 ran 1.0010 x F (test_controller_truth's found programs).
CROSSING_SPEED_SHARE = 5e-4


def signs(V: np.ndarray) -> np.ndarray:
    """Direction of each planned velocity: +1, −1, or 0 (standing)."""
    return np.where(V > V_EPS, 1, np.where(V < -V_EPS, -1, 0))


class Insertions:
    """What a chunk of points needs for its reversals (:func:`plan_insertions`).

    stand_k, stand_t : (s,) the rows k that get a standing point put before them
        (sorted, distinct) and its duration [s]
    s_k, s_col, s_new : (c,) the motors that cross at the standing point before
        row s_k, and the side each crosses to, motor after motor
    w_k, w_col, w_ta, w_tb, w_new : (w,) crossing windows inside steps: in the step
        ending at row w_k, motor w_col is on its old side −w_new up to w_ta and on
        the new side from w_tb (a dip gives one motor two windows in one step)
    w_t0 : (w,) the start of each window's step [s]
    w_kb, w_t0b : (w,) the step where each window ends and its start: w_k, or with
        straight lines between the points, the next step, where the window
        reaches past its step's end (:func:`chord_windows`; one that reaches
        before its step's start has w_k the step before)
    mid_k, mid_t : (m,) the points put inside steps: the row whose step they are in,
        and their time since the chunk's previous point; sorted by step, then time
    blended : rows of the corners blended (:func:`corners`) whose point before the
        corner was put in: the corner's point moves onto the blend
        (:func:`blend_shift`)
    near_next : the chunk's last row is a blended corner: the next chunk's first
        step gets a point this long [s] after its start (0: none)
    """

    def __init__(self) -> None:
        self.stand_k = np.zeros(0, dtype=int)
        self.stand_t = np.zeros(0)
        self.s_k = np.zeros(0, dtype=int)
        self.s_col = np.zeros(0, dtype=int)
        self.s_new = np.zeros(0, dtype=int)
        self.w_k = np.zeros(0, dtype=int)
        self.w_col = np.zeros(0, dtype=int)
        self.w_ta = np.zeros(0)
        self.w_tb = np.zeros(0)
        self.w_new = np.zeros(0, dtype=int)
        self.w_t0 = np.zeros(0)
        self.w_kb = np.zeros(0, dtype=int)
        self.w_t0b = np.zeros(0)
        self.mid_k = np.zeros(0, dtype=int)
        self.mid_t = np.zeros(0)
        self.near_next = 0.0
        self.blended = np.zeros(0, dtype=int)

    def __bool__(self) -> bool:
        return len(self.stand_k) > 0 or len(self.mid_k) > 0


def velocity_roots(
    P0: np.ndarray,
    V0: np.ndarray,
    P1: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    new: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Where the cubic through (P0, V0) and (P1, V1) over time h has zero velocity,
    for arrays of steps.

    The Hermite cubic's velocity is a quadratic (``kernel.play.velocity_quadratic``).
    With ``new`` (n,) the direction the motor turns to, the first root where the
    velocity turns that way: a motor standing at the step's start (V0 = 0) that
    sets off the old way first turns at the later root, not at s = 0.

    Returns
    -------
    s : (n,) the first root in [0, 1] (where the velocity changes sign from V0's,
        or turns to ``new``)
    accel : (n,) the cubic's acceleration there [mm/s²]
    """
    if new is None:
        return kernel.velocity_roots(P0, V0, P1, V1, h, np.zeros(0), False)
    return kernel.velocity_roots(P0, V0, P1, V1, h, new, True)


class _Bracket(NamedTuple):
    """False position's bracket about each of m roots: the fractions of the step
    ``s_a`` where the path's velocity ``v_a`` [mm/s] is still the old way and
    ``s_b`` where ``v_b`` is the new way, and ``last`` the end moved last (−1 a,
    +1 b, 0 neither)."""

    s_a: np.ndarray
    v_a: np.ndarray
    s_b: np.ndarray
    v_b: np.ndarray
    last: np.ndarray


def path_roots(
    s: np.ndarray,
    accel: np.ndarray,
    V0: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    new: np.ndarray,
    k: np.ndarray,
    cols: np.ndarray,
    velocity: Velocity,
    steps: int = ROOT_STEPS,
) -> tuple[np.ndarray, np.ndarray]:
    """The roots ``s`` of steps' cubics (:func:`velocity_roots`) moved onto the
    path's own velocity, and its acceleration there: the search
    (:func:`root_search`) run to its end, each of its questions answered by
    ``velocity`` (:data:`Velocity`). The chain runs the same stages itself
    (``chain.Pipeline._reversals``), answering between them.

    Parameters
    ----------
    s, accel, V0, V1, h, new, k, cols, steps : as :func:`root_search`
    velocity : the path's velocity inside steps (:data:`Velocity`)

    Returns
    -------
    s, accel : (m,)
    """
    st = root_search(s, accel, V0, V1, h, new, k, cols, steps)
    while st.phase != DONE:
        st = root_answer(st, velocity(*root_queries(st)))
    return root_result(st)


#: The phases of a root search (:class:`RootSearch`): false position's steps,
#: the slopes' look about the roots moved, done.
SEEK, SLOPE, DONE = 0, 1, 2


class RootSearch(NamedTuple):
    """A search that moves reversals' roots from the steps' cubics onto the
    path's own velocity (:func:`root_search`), between two looks at the path.

    s, accel : (m,) the cubic's roots [fraction of the step] and accelerations
        there [mm/s²]
    h, new, k, cols : (m,) the steps' durations [s], the way each motor turns to,
        the steps (rows of the chunk) and the motors
    ok : (m,) bool, roots bracketed and the path known so far
    going : (m,) bool, roots still sought
    moved : (m,) bool, moved off the cubic's root
    x : (m,) the roots so far [fraction of the step]
    br : false position's bracket
    left : false-position steps left
    phase : SEEK, SLOPE or DONE
    slope : (m,) the path's acceleration at the moved roots (SLOPE's answer)
    """

    s: np.ndarray
    accel: np.ndarray
    h: np.ndarray
    new: np.ndarray
    k: np.ndarray
    cols: np.ndarray
    ok: np.ndarray
    going: np.ndarray
    moved: np.ndarray
    x: np.ndarray
    br: _Bracket
    left: int
    phase: int
    slope: np.ndarray


def root_search(
    s: np.ndarray,
    accel: np.ndarray,
    V0: np.ndarray,
    V1: np.ndarray,
    h: np.ndarray,
    new: np.ndarray,
    k: np.ndarray,
    cols: np.ndarray,
    steps: int = ROOT_STEPS,
) -> RootSearch:
    """Start moving the roots ``s`` of steps' cubics (:func:`velocity_roots`)
    onto the path's own velocity, and finding its acceleration there.

    The cubic through a step's ends puts the root where the Hermite's velocity
    turns, which for a motor turning slowly is not where the path's does: a
    table motor on a tilting arc (40 mm/s² by the cubic, 1.7 mm/s² on the path,
    test_controller_truth's led-floor-tiny-arc-as-lines) had it 1 ms late in a
    9 ms step; on fast turns the two agree within a microsecond. Where the
    path's velocity goes from the old way (V0 · new < 0) to the new (V1 · new >
    0) over the step, false position from ``s`` keeps the root bracketed by the
    fractions where it was seen on either side,

        s' = s_a − v_a (s_b − s_a) / (v_b − v_a),

    with the Illinois rule (an end kept twice running has its v halved),
    until the path's velocity there is what the acceleration makes in
    ROOT_TIME_S; the acceleration is then a central difference of the path's
    velocity about the new root (a root found at once keeps the cubic's).
    Elsewhere (a motor setting off from a stand, a velocity not known
    there) the cubic's root and acceleration are kept.

    The search asks for the path's velocity (:func:`root_queries`), and goes on
    with the answer (:func:`root_answer`) until its phase is DONE; then
    :func:`root_result`. No callback: the caller looks at the path in between.

    Parameters
    ----------
    s, accel : (m,) the cubic's roots [fraction of the step] and accelerations
        there [mm/s²]
    V0, V1 : (m,) the path's velocity at the steps' start and end [mm/s]
    h : (m,) the steps' durations [s]
    new : (m,) the way each motor turns to (+1, −1)
    k : (m,) the steps (rows of the chunk)
    cols : (m,) the motors
    steps : false-position steps
    """
    ok = (new * V0 < 0) & (new * V1 > 0)
    # the bracket starts at the step's ends; the end moved last: −1 a, +1 b
    br = _Bracket(
        np.zeros(len(s)), V0.astype(float), np.ones(len(s)), V1.astype(float),
        np.zeros(len(s), dtype=int),
    )  # fmt: skip
    phase = SEEK if np.any(ok) and steps > 0 else DONE
    no = np.zeros(len(s), dtype=bool)
    return RootSearch(
        s, accel, h, new, k, cols, ok, ok.copy(), no, s.copy(), br, steps, phase, np.zeros(0)
    )


def root_queries(st: RootSearch) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the search looks at the path next: steps ``k``, fractions of them and
    motors (q,) (:data:`Velocity`'s arguments); none when DONE."""
    if st.phase == SEEK:
        return st.k[st.going], st.x[st.going], st.cols[st.going]
    if st.phase == SLOPE:
        # the acceleration at a moved root: a central difference over
        # ±ROOT_SLOPE_STEP of the step (false position closes in from one side,
        # and the bracket's other end may stay at the step's end, too far for a
        # slope at the root)
        lo, hi = _slope_fractions(st)
        return (
            np.tile(st.k[st.moved], 2), np.concatenate([lo, hi]), np.tile(st.cols[st.moved], 2),
        )  # fmt: skip
    return np.zeros(0, dtype=int), np.zeros(0), np.zeros(0, dtype=int)


def _slope_fractions(st: RootSearch) -> tuple[np.ndarray, np.ndarray]:
    d = ROOT_SLOPE_STEP
    x = st.x[st.moved]
    return np.clip(x - d, 0.0, 1.0), np.clip(x + d, 0.0, 1.0)


def root_answer(st: RootSearch, v: np.ndarray) -> RootSearch:
    """The search gone on with the path's velocity ``v`` (q,) [mm/s] at its
    questions (:func:`root_queries`; NaN where not known)."""
    if st.phase == SLOPE:
        lo, hi = _slope_fractions(st)
        slope = np.full(len(st.x), np.nan)
        with np.errstate(divide="ignore", invalid="ignore"):
            slope[st.moved] = (v[len(lo) :] - v[: len(lo)]) / ((hi - lo) * st.h[st.moved])
        return st._replace(phase=DONE, slope=slope)
    if st.phase != SEEK:
        return st
    br = st.br
    x, going, ok, moved, s_a, v_a, s_b, v_b, last = kernel.seek_step(
        st.x, v, st.going, st.ok, st.moved, st.new, st.accel, st.h,
        br.s_a, br.v_a, br.s_b, br.v_b, br.last, ROOT_SLOPE_MARGIN, ROOT_TIME_S,
    )  # fmt: skip
    br = _Bracket(s_a, v_a, s_b, v_b, last)
    left = st.left - 1
    if np.any(going) and left > 0:
        return st._replace(ok=ok, going=going, moved=moved, x=x, br=br, left=left)
    moved &= ok
    phase = SLOPE if np.any(moved) else DONE
    return st._replace(ok=ok, going=going, moved=moved, x=x, br=br, left=left, phase=phase)


def root_result(st: RootSearch) -> tuple[np.ndarray, np.ndarray]:
    """The roots [fraction of the step] and the accelerations there [mm/s²] (m,)
    of a search that is DONE: moved onto the path where it was found there."""
    if not len(st.slope):
        return st.s, st.accel
    moved = st.moved & np.isfinite(st.slope)
    return np.where(moved, st.x, st.s), np.where(moved, st.slope, st.accel)


def _reach_or_none(
    reach: tuple[np.ndarray, np.ndarray] | None, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """The reach before and after n roots (:func:`reach`), or none (inf) where not
    given."""
    if reach is None:
        return np.full(n, np.inf), np.full(n, np.inf)
    return reach


def windows(
    t0: np.ndarray,
    t1: np.ndarray,
    t_root: np.ndarray,
    accel: np.ndarray,
    tol: float,
    longest: float,
    reach: tuple[np.ndarray, np.ndarray] | None = None,
    chords: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The crossing windows about reversals at ``t_root`` inside steps [t0, t1].

    The part stands at the extreme meanwhile and misses the path by |A| d² / 2
    after standing d on a side of the root: up to sqrt(2 tol / |A|) on each side
    (a width of sqrt(8 tol / |A|)), and no longer than ``reach`` (before, after)
    [s] allows for the speed (:func:`plan_insertions`); the width between
    MIN_WINDOW_S and ``longest``, a window too short for the first grown on the
    side with more reach to spare. A window that would reach past an end of its
    step is cut there, not shifted: shifted, the part would stand for a whole
    width on one side of the extreme and meet the motor 4 x as far behind the
    path, to be caught up by the next segment (a corner's point is often the root
    itself). No sliver of a step is left beside a window (a step much shorter than
    the window makes the rounding of the written positions a large velocity
    error): the window grows by at most half its width on that side, where its
    reach allows, or where the sliver would be shorter than MIN_WINDOW_S.

    With ``chords`` (straight lines between the points: corrected G-code) a window
    stands no longer before its root than after it: the part stands where its
    motor left it, A (db² − da²) / 2 ahead of the path at the window's end where
    db > da, and the straight line after the window, carrying no velocity, goes
    back to the path there while the part stands on (0.35 % over F,
    test_controller_truth's found programs). A PVT cubic leaves the window with the
    path's velocity, and the commands after it take the difference up along the
    path (:func:`catch_up`).
    """
    rb, ra = _reach_or_none(reach, len(t_root))
    return kernel.crossing_windows(
        t0, t1, t_root, accel, rb, ra, tol, longest, chords, MIN_WINDOW_S
    )


def chord_windows(
    t0: np.ndarray,
    t1: np.ndarray,
    t_root: np.ndarray,
    accel: np.ndarray,
    tol: float,
    longest: float,
    reach: tuple[np.ndarray, np.ndarray] | None,
    t_before: np.ndarray,
    t_after: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The crossing windows about reversals at ``t_root`` inside steps [t0, t1]
    for straight lines between the points (corrected G-code).

    The controller runs a window as one straight line at one speed while the part
    stands in it and lacks its wanted velocity A (t − t_root): the line's mean
    lacks A (da² − db²) / 2 over its length, none where the window stands as long
    after its root as before it, and across it the tip's speed strays by up to
    |A| d through the head's lever (1.0044 x F in a 1 ms window,
    test_controller_truth's found programs). So a window is symmetric about its
    root, d on each side: within the tolerance (|A| d² / 2), the ``reach`` on
    either side (:func:`reach`) and half the longest, but at least half a servo
    cycle. Where that passes its step's end (or start) it reaches over into the
    step beside as far as ``t_after`` (``t_before``) allows, no longer than its
    step (or a servo cycle); where it may not, it is cut there (and is longer
    on the other side, to a servo cycle). A sliver of its step left beside it,
    shorter than a servo cycle (its written digits' rounding a large velocity
    error), is taken in, on both sides alike where there is room (over a short
    step, up to twice its length), else on its side alone. The arithmetic is the
    kernel's (:func:`prsxy_post.kernel.chord_windows`, compiled when built).

    Returns the windows' starts and ends [s], as :func:`windows`.
    """
    rb, ra = _reach_or_none(reach, len(t_root))
    return kernel.chord_windows(
        t0, t1, t_root, accel, rb, ra, tol, longest, t_before, t_after, MIN_WINDOW_S, SNAP_S
    )


class _Dip(NamedTuple):
    """A motor's dips (or settings-off back) in a chunk (:func:`_motor_dips`): the
    steps ``k`` (m,), the way ``sg`` the motor moves at the step's end, the
    fractions ``s1``, ``s2`` of the step where it turns and its accelerations
    ``A1``, ``A2`` there [mm/s²], the steps' durations ``h``, their starts ``t0``,
    middles ``tm`` (between the turning points) and ends ``t1`` [s]."""

    k: np.ndarray
    sg: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    A1: np.ndarray
    A2: np.ndarray
    h: np.ndarray
    t0: np.ndarray
    tm: np.ndarray
    t1: np.ndarray


def _dip_windows(
    dips: list[_Dip],
    rules: _Rules,
    reaches: list[tuple[np.ndarray, np.ndarray]] | None,
) -> list[tuple[np.ndarray, ...]]:
    """The two crossings of every dip of ``dips`` (every motor's :func:`_motor_dips`,
    one after another), within the reach (:func:`reach`) about its first and
    second turning point: ``reaches`` two a part of ``dips`` (before, after)
    (None: the tolerance alone decides). Each of the two windows keeps to its own
    half of the step (cut between the two turning points), so that they never
    overlap.

    Returns, for each part of ``dips``, (step, new side of the first crossing,
    of the second, first window's start, second's, first window's end, second's):
    views of arrays made in one call for every motor (the windows are made row by
    row).
    """
    if not dips:
        return []
    k, sg, s1, s2, A1, A2, h, t0, tm, t1 = (
        np.concatenate([getattr(d, f) for d in dips]) for f in _Dip._fields
    )
    n = len(k)
    wide = None
    if reaches is not None:
        # every first turning point's, then every second's (as the rows below)
        halves = reaches[0::2] + reaches[1::2]
        wide = (np.concatenate([r[0] for r in halves]), np.concatenate([r[1] for r in halves]))
    ta, tb = windows(
        np.concatenate([t0, tm]),
        np.concatenate([tm, t1]),
        np.concatenate([t0 + s1 * h, t0 + s2 * h]),
        np.concatenate([A1, A2]),
        rules.tol,
        rules.longest,
        wide,
        rules.chords,
    )
    back = -sg
    out: list[tuple[np.ndarray, ...]] = []
    a = 0
    for d in dips:
        b = a + len(d.k)
        out.append(
            (k[a:b], back[a:b], sg[a:b], ta[a:b], ta[n + a : n + b], tb[a:b], tb[n + a : n + b])
        )
        a = b
    return out


def reach(
    allowed: tuple[np.ndarray, np.ndarray], accel: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How long [s] a part may stand on each side of its motor's reversal, the
    motor at acceleration ``accel`` moving at |A| d a time d from the root: below
    ``allowed`` (before, after) [mm/s] (:data:`EdgeSpeed`)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        a = np.abs(accel)
        return (
            np.where(a > 0, allowed[0] / a, np.inf),
            np.where(a > 0, allowed[1] / a, np.inf),
        )


def corners(
    V_in: np.ndarray, V_out: np.ndarray, cols: list[int], h: np.ndarray, accel: float
) -> tuple[np.ndarray, np.ndarray]:
    """Corners taken at speed where a motor with play stands on one side and moves
    on the other, or moves much slower on one side than on the other, which a PVT
    program blends (:func:`blend_shift`), and over how long.

    The corner's point carries the mean of its sides' velocities (the planner's
    blend, :mod:`.interpolate.lookahead`), so the cubic of the standing side's step
    turns back by (4/27) h |ΔV| / 2 (the basis s³ − s² peaks at 4/27): setting off,
    the motor leaves its part, which is pushed on only when the motor comes back,
    later than the other motors' parts; stopping, it pushes its part past the corner
    and leaves it there. Either way a head tilts and its tip runs fast. Worse, the
    mean's cubics swing every motor past its sides' velocities by (V_in − V_out)/6
    however short the step, and where a part cannot follow its motor's swing the
    others' swings reach the tip (test_controller_truth's found programs). A blend
    over ±τ makes every motor's velocity linear across the corner at |ΔV| / (2τ):
    τ = max(BLEND_MIN_S, max |ΔV| / (2 ``accel``)) over all the motors. None where
    the turn back is below CORNER_TURN_MM, or where τ reaches half the step.

    A motor moving the same way on both sides turns back too, where the slower
    side's speed v is below |ΔV| / 6: that step's velocity, v − (|ΔV| / 2)(2s −
    3s²), is negative between the roots s = (1 ± sqrt(1 − 6 v / |ΔV|)) / 3, and the
    motor goes back by (4/27) h (|ΔV| / 2) (1 − 6 v / |ΔV|)^(3/2) (a tilt speeding
    up eightfold at F60 along a straight line: 1.0045 x F, test_controller_truth's
    found programs). A motor reversing at the corner is not blended: it crosses
    its play in a window (:func:`plan_insertions`).

    Parameters
    ----------
    V_in, V_out : (k, 5) the motors' planned velocities just before and just past
        each corner [mm/s]
    cols : the motors (columns) with play
    h : (k,) the standing side's step [s]
    accel : the acceleration the blend may take [mm/s²]

    Returns
    -------
    blend : (k,) bool, the corner is blended
    tau : (k,) [s] its τ
    """
    return kernel.corner_blends(
        V_in, V_out, np.asarray(cols, dtype=int), h, accel, V_EPS, CORNER_TURN_MM, BLEND_MIN_S
    )


#: The shortest τ of a blend [s]. Its steps' chords are written to 1e-7 mm (the
#: PMAC default): over a servo cycle that is 4e-4 mm/s of velocity, and a blend at
#: F60 ran 1.0011 x F (test_controller_truth's found programs); over 1 ms, 1e-4.
#: The blend cuts the corner by τ |Δv| / 4, (27/8) (τ / period) of the mean's
#: cubics' (4/27) period |Δv| / 2: a third of it at 1 ms.
BLEND_MIN_S = 1e-3


def blend_shift(V_in: np.ndarray, V_out: np.ndarray, tau: np.ndarray) -> np.ndarray:
    """How far a corner's point moves onto its parabolic blend [mm], (k, m).

    Two points of the path, τ before and τ after the corner, carry their sides'
    velocities V_in and V_out; the corner's point between them carries the mean.
    The cubics through them are then one parabola whose velocity goes linearly
    from V_in to V_out (each step's chord is the mean of its ends' velocities): no
    motor swings back or bulges past its sides' velocities, and the tip's velocity
    is a mean of its sides', never faster than either. The parabola passes the
    corner at x(−τ) + τ V_in + τ (V_out − V_in) / 4, so the corner's point, on the
    path at x(−τ) + τ V_in, moves by τ (V_out − V_in) / 4: inside the corner by
    τ |ΔV| / 4: tens of nanometres at τ of a millisecond (BLEND_MIN_S).

    With the mean's cubics over whole steps instead, a motor standing on one side
    swings back by (V_in − V_out)/6 in velocity however short the step, and with
    play its part cannot: the other motors' blend then reaches the tip
    (test_controller_truth's found programs).
    """
    return tau[:, None] * (V_out - V_in) / 4.0


def _snap(k: np.ndarray, t: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Window edges of one step within SNAP_S of each other (or of the step's ends)
    made one point: motors reversing together (a path reversing) share their
    points."""
    t = np.where(t - t0 < SNAP_S, t0, np.where(t1 - t < SNAP_S, t1, t))
    order = np.lexsort((t, k))
    ks, ts = k[order], t[order]
    new_group = np.ones(len(ts), dtype=bool)
    new_group[1:] = (ks[1:] != ks[:-1]) | (ts[1:] - ts[:-1] >= SNAP_S)
    first = np.maximum.accumulate(np.where(new_group, np.arange(len(ts)), 0))
    out = np.empty_like(t)
    out[order] = ts[first]
    return out


class _Turns(NamedTuple):
    """One motor's reversals in a chunk (:func:`plan_insertions`): its directions
    ``sg`` per row and the one each row comes from, the reversals' steps ``k`` and
    new ways, its wanted positions ``p``, each reversal's kind, the roots ``sr``
    [fraction of the step] and accelerations ``acc`` of those in motion, and its
    wanted velocities ``v``."""

    col: int
    sg: np.ndarray
    came: np.ndarray
    k: np.ndarray
    new: np.ndarray
    p: np.ndarray
    at_rest: np.ndarray
    crept_f: np.ndarray
    stood: np.ndarray
    mid: np.ndarray
    sr: np.ndarray
    acc: np.ndarray
    v: np.ndarray


class _Chunk(NamedTuple):
    """A chunk's n points as :func:`plan_insertions` looks at them.

    t_end : (n,) time of each point since the point before the chunk [s]
    dt : (n,) time of the step that ends at each point [s]
    resting : (n,) bool, the path stands at the point
    P, V : (5, off + n) wanted motor positions and velocities [mm, mm/s], a motor
        a row (each motor's contiguous: the kernels take them so), the point
        before the chunk first where there is one
    rest : (off + n,) bool, ``resting`` likewise
    off : 1 where the point before the chunk leads P, V and rest, else 0
    """

    t_end: np.ndarray
    dt: np.ndarray
    resting: np.ndarray
    P: np.ndarray
    V: np.ndarray
    rest: np.ndarray
    off: int


class _Rules(NamedTuple):
    """What sizes a crossing window (:func:`place_insertions`' parameters): the
    path error allowed to a crossing ``tol`` [mm], the longest window ``longest``
    [s], and straight lines between the points (``chords``) or cubics."""

    tol: float
    longest: float
    chords: bool


class Found(NamedTuple):
    """A chunk's reversals before their windows (:func:`find_reversals`): the
    chunk ``ch``, every motor's reversals ``seen`` (in the order of ``cols``) and
    its dips and settings-off back ``dips`` (two :class:`_Dip` a motor)."""

    ch: _Chunk
    seen: list[_Turns]
    dips: list[list[_Dip]]


def plan_insertions(
    t_end: np.ndarray,
    dt: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    resting: np.ndarray,
    prev: tuple[np.ndarray, np.ndarray, bool] | None,
    cols: list[int],
    side: np.ndarray,
    ref: np.ndarray,
    tol: float,
    longest: float,
    blends: tuple[np.ndarray, np.ndarray] | None = None,
    near_first: float = 0.0,
    chords: bool = False,
    corners_at: np.ndarray | None = None,
) -> Insertions:
    """Find every reversal of the motors ``cols`` in a chunk of points and its
    window, the roots in motion on the steps' cubics and the windows sized by the
    tolerance alone: :func:`find_reversals` then :func:`place_insertions` (the
    chain moves the roots onto the path and sizes the windows by the tip's speed
    in between: ``chain.Pipeline._reversals``)."""
    found = find_reversals(t_end, dt, P, V, resting, prev, cols, side, ref, tol)
    return place_insertions(found, tol, longest, chords, None, blends, near_first, corners_at)


def find_reversals(
    t_end: np.ndarray,
    dt: np.ndarray,
    P: np.ndarray,
    V: np.ndarray,
    resting: np.ndarray,
    prev: tuple[np.ndarray, np.ndarray, bool] | None,
    cols: list[int],
    side: np.ndarray,
    ref: np.ndarray,
    tol: float,
) -> Found:
    """Every reversal of the motors ``cols`` in a chunk of points and its kind,
    the roots of those in motion on the steps' cubics, and the dips.

    Parameters
    ----------
    t_end : (n,) time of each point since the point before the chunk [s]
    dt : (n,) time of the step that ends at each point [s]
    P, V : (n, 5) wanted motor positions and velocities [mm, mm/s]
    resting : (n,) bool, the path stands at the point (speed 0)
    prev : (P, V, resting) of the point before the chunk, None at the start
    cols : motors (columns) with play
    side : (5,) the side each motor is on before the chunk (+1 up, −1 down)
    ref : (5,) the wanted position where each motor last moved with a direction;
        updated in place (a creeping motor's drift is measured from it)
    tol : path error allowed to a crossing [mm]
    """
    off = 0 if prev is None else 1
    # a motor a row, transposed once (not a column copied for each motor)
    P_all = np.empty((P.shape[1], off + len(P)))
    V_all = np.empty((V.shape[1], off + len(V)))
    P_all[:, off:] = P.T
    V_all[:, off:] = V.T
    if prev is None:
        ch = _Chunk(t_end, dt, resting, P_all, V_all, resting, 0)
    else:
        P_all[:, 0] = prev[0]
        V_all[:, 0] = prev[1]
        rest_all = np.concatenate([[prev[2]], resting])
        ch = _Chunk(t_end, dt, resting, P_all, V_all, rest_all, 1)
    # every motor's reversals, dips and settings-off back in one kernel call
    found = kernel.motor_reversals(
        V_all, P_all, ch.rest, np.array(cols, dtype=int), side, ref, DRIFT_SHARE * tol,
        ch.off, V_EPS, dt, tol,
    )  # fmt: skip
    seen = [_turns(ch, col, found, i) for i, col in enumerate(cols)]
    ref[cols] = found.reach  # where each got farthest its way, for the next chunk
    return Found(ch, seen, [_motor_dips(ch, found, i) for i in range(len(cols))])


def roots_search(found: Found, steps: int = ROOT_STEPS) -> RootSearch:
    """The search (:func:`root_search`) that moves every motor's roots in motion
    onto the path's own velocity, one for all the motors (each look at the path
    is an IK call); needs a motor in ``found``."""
    seen, ch = found.seen, found.ch
    off = ch.off
    km_all = np.concatenate([x.k[x.mid] for x in seen])
    col_all = np.concatenate([np.full(len(x.sr), x.col) for x in seen])
    return root_search(
        np.concatenate([x.sr for x in seen]),
        np.concatenate([x.acc for x in seen]),
        ch.V[col_all, km_all + off - 1],
        ch.V[col_all, km_all + off],
        ch.dt[km_all],
        np.concatenate([x.new[x.mid] for x in seen]),
        km_all,
        col_all,
        steps,
    )


def with_roots(found: Found, st: RootSearch) -> Found:
    """``found`` with its roots in motion and accelerations there those of the
    finished search ``st`` (:func:`roots_search`)."""
    sr_all, acc_all = root_result(st)
    cut = np.cumsum([len(x.sr) for x in found.seen])[:-1]
    seen = [
        x._replace(sr=a, acc=b)
        for x, a, b in zip(found.seen, np.split(sr_all, cut), np.split(acc_all, cut), strict=True)
    ]
    return found._replace(seen=seen)


def _edge_parts(t: _Turns, dips: list[_Dip]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """One motor's turning points whose reach is asked, in :func:`edge_queries`'
    order: (steps, fractions, accelerations) of its dips' first and second, its
    settings-off's first and second, its reversals in motion."""
    d, o = dips
    return [
        (d.k, d.s1, d.A1),
        (d.k, d.s2, d.A2),
        (o.k, o.s1, o.A1),
        (o.k, o.s2, o.A2),
        (t.k[t.mid], t.sr, t.acc),
    ]


def edge_queries(found: Found) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where a window's reach by the tip's speed is asked (:func:`place_insertions`'
    ``allowed``): the steps ``k``, fractions of them, motors and accelerations
    there [mm/s²] (q,) of every motor's turning points (:func:`_edge_parts`),
    motor after motor."""
    ks, fr, cs, acc = (
        [np.zeros(0, dtype=int)],
        [np.zeros(0)],
        [np.zeros(0, dtype=int)],
        [np.zeros(0)],
    )
    for t, dips in zip(found.seen, found.dips, strict=True):
        for k, f, a in _edge_parts(t, dips):
            ks.append(k)
            fr.append(f)
            cs.append(np.full(len(k), t.col))
            acc.append(a)
    return np.concatenate(ks), np.concatenate(fr), np.concatenate(cs), np.concatenate(acc)


def place_insertions(
    found: Found,
    tol: float,
    longest: float,
    chords: bool = False,
    allowed: tuple[np.ndarray, np.ndarray] | None = None,
    blends: tuple[np.ndarray, np.ndarray] | None = None,
    near_first: float = 0.0,
    corners_at: np.ndarray | None = None,
) -> Insertions:
    """The windows of every reversal ``found`` (:func:`find_reversals`) and the
    points they put in.

    Parameters
    ----------
    found : the chunk's reversals (roots in motion moved onto the path or not:
        :func:`roots_search`)
    tol : path error allowed to a crossing [mm]
    longest : the longest crossing window [s]
    chords : the controller runs straight lines between the points (corrected
        G-code), not cubics: windows in motion are :func:`chord_windows`, a dip's
        :func:`windows` with ``chords``
    allowed : (before, after) (q,) how fast [mm/s] a motor may move while its
        part stands before and after each turning point of :func:`edge_queries`
        (in its order): its window stands no longer than :func:`reach` of that on
        each side. None: the tolerance alone decides
    blends : (rows, tau) of the corners blended (:func:`corners`): row k's step
        gets a point tau before its end, and row k + 1's tau after its start (k =
        n − 1: the next chunk's first step, ``near_next``)
    near_first : the chunk before ended at a blended corner (its ``near_next``):
        this chunk's first step gets a point that long [s] after its start
    corners_at : rows whose point is a corner of the path (its direction turns
        there): with ``chords``, no window reaches over one into the step beside
    """
    ins = Insertions()
    ch = found.ch
    rules = _Rules(tol, longest, chords)
    # sorted once for every motor's look-ups (:func:`_chord_room`)
    bent = None if corners_at is None else np.sort(corners_at)
    w = _Windows([], [], [], [], [])
    at = 0
    s_k, s_col, s_new = [ins.s_k], [ins.s_col], [ins.s_new]
    parts = [_edge_parts(t, dips) for t, dips in zip(found.seen, found.dips, strict=True)]
    if allowed is not None:
        # every turning point's reach at once (edge_queries' order), sliced below
        acc_all = np.concatenate([np.zeros(0)] + [acc for p in parts for _, _, acc in p])
        q = len(acc_all)
        r_before, r_after = reach((allowed[0][:q], allowed[1][:q]), acc_all)
    # the reaches about every motor's turning points, in _edge_parts' order: its
    # dips' and settings-off's (two each), then its reversals in motion's
    dip_reach: list[tuple[np.ndarray, np.ndarray]] = []
    wide: list[tuple[np.ndarray, np.ndarray] | None] = []
    for edges in parts:
        if allowed is None:
            wide.append(None)
            continue
        for j, (k, _, _) in enumerate(edges):
            r = (r_before[at : at + len(k)], r_after[at : at + len(k)])
            at += len(k)
            if j < 4:
                dip_reach.append(r)
            else:
                wide.append(r)
    # every motor's dips' and settings-off's windows in one call
    dw = _dip_windows(
        [d for dips in found.dips for d in dips], rules, None if allowed is None else dip_reach
    )
    for i, t in enumerate(found.seen):
        s_k.append(t.k[t.at_rest])
        s_col.append(np.full(len(s_k[-1]), t.col))
        s_new.append(t.new[t.at_rest])
        ks, tas, tbs, news = _motor_windows(t, dw[2 * i : 2 * i + 2], ch, rules, bent, wide[i])
        w.k.extend(ks)
        w.ta.extend(tas)
        w.tb.extend(tbs)
        w.col.append(np.full(sum(len(x) for x in news), t.col))
        w.new.extend(news)
    ins.s_k, ins.s_col, ins.s_new = (np.concatenate(x) for x in (s_k, s_col, s_new))
    # distinct rows, sorted (np.unique's answer, a tenth of its time here)
    rows = np.sort(ins.s_k)
    ins.stand_k = rows[np.concatenate([[True], rows[1:] != rows[:-1]])] if len(rows) else rows
    ins.stand_t = np.full(len(ins.stand_k), longest)
    if w.col:
        _place_points(ins, ch, w, blends, near_first)
    return ins


class _Windows(NamedTuple):
    """The crossing windows inside steps gathered motor by motor, each a list of
    arrays to be joined in order: steps ``k``, motors ``col``, starts ``ta`` and
    ends ``tb`` [s], new sides ``new`` (:class:`Insertions`' w_*)."""

    k: list[np.ndarray]
    col: list[np.ndarray]
    ta: list[np.ndarray]
    tb: list[np.ndarray]
    new: list[np.ndarray]


def _place_points(
    ins: Insertions,
    ch: _Chunk,
    w: _Windows,
    blends: tuple[np.ndarray, np.ndarray] | None,
    near_first: float,
) -> None:
    """Set in ``ins`` every window (its edges snapped, :func:`_place_windows`) and
    the points inside steps: the windows' edges and the blends' points
    (:func:`_blend_points`), each distinct (step, time) once."""
    ek, et = _place_windows(
        ins, ch, np.concatenate(w.k), np.concatenate(w.ta), np.concatenate(w.tb)
    )
    ins.w_col = np.concatenate(w.col)
    ins.w_new = np.concatenate(w.new)
    late, t_late, early, t_early = _blend_points(ins, ch, blends, near_first, et)
    ins.blended = late
    ek = np.concatenate([ek, late, early])
    et = np.concatenate([et, t_late, t_early])
    ins.mid_k, ins.mid_t = _distinct_points(ek, et)


def _turns(ch: _Chunk, col: int, found: kernel_windows.Reversals, i: int) -> _Turns:
    """Motor ``col``'s reversals in the chunk and their kinds (:class:`_Turns`),
    the roots and accelerations of those in motion on the steps' cubics, from the
    kernel's answer ``found`` (its ``i``-th motor: :func:`.kernel.windows.motor_reversals`:
    creeps back made reversals, :func:`.kernel.play.creeps`)."""
    off, dt = ch.off, ch.dt
    p, v = ch.P[col], ch.V[col]
    sg, came = found.sg[i], found.came[i]
    at = slice(int(found.turns[i]), int(found.turns[i + 1]))
    r, kind = found.r[at], found.kind[at]
    k = r - off
    new = sg[r]
    # a step whose chord goes the old way sets off that way first and turns
    # inside it: a reversal in motion, at the cubic's root, also where the step
    # leaves from rest or from a motor standing (a head motor through the extreme
    # of a tilt: 0.22 % over F, and 0.5 µm off the path from rest,
    # test_controller_truth's found programs); drifted back within a step that
    # began moving the old way (it ends at rest, or creeping): the step's cubic
    # turns inside it, and the window goes there (kernel.windows.motor_turns)
    at_rest = kind == kernel_windows.AT_REST
    crept_f = kind == kernel_windows.CREPT
    stood = kind == kernel_windows.STOOD
    mid = kind == kernel_windows.MID
    km, rm = k[mid], r[mid]
    sr, acc = velocity_roots(p[rm - 1], v[rm - 1], p[rm], v[rm], dt[km], new[mid])
    return _Turns(col, sg, came, k, new, p, at_rest, crept_f, stood, mid, sr, acc, v)


def _motor_windows(
    t: _Turns,
    dw: list[tuple[np.ndarray, ...]],
    ch: _Chunk,
    rules: _Rules,
    corners_at: np.ndarray | None,
    wide: tuple[np.ndarray, np.ndarray] | None,
) -> tuple[list[np.ndarray], list[np.ndarray], list[np.ndarray], list[np.ndarray]]:
    """One motor's crossing windows inside steps: for its reversals creeping,
    standing, in motion, and its dips and settings-off back (two windows each,
    ``dw``: :func:`_dip_windows`' answer for the motor's two parts), in that
    order, the windows' steps, starts and ends [s] and new sides (four lists of
    seven arrays). ``wide``: the :func:`reach` about its reversals in motion
    (None: the tolerance alone decides)."""
    # a creeping motor has drifted back past the allowance: it crosses over the
    # end of this step (its speed makes the crossing's error tiny)
    kc = t.k[t.crept_f]
    t1 = ch.t_end[kc]
    ta_c, tb_c = np.maximum(t1 - ch.dt[kc], t1 - rules.longest), t1
    # the motor stood through the step before while the path moved on: it crosses
    # at that step's end, standing, and leaves from contact
    ks = t.k[t.stood] - 1
    t1 = ch.t_end[ks]
    t0 = t1 - ch.dt[ks]
    ta_s, tb_s = np.where(t1 - t0 <= 1.5 * rules.longest, t0, t1 - rules.longest), t1
    d, o = dw
    km, ta_m, tb_m = _motion_windows(t, ch, rules, [d[0], o[0]], corners_at, wide)
    return (
        [kc, ks, km, d[0], d[0], o[0], o[0]],
        [ta_c, ta_s, ta_m, d[3], d[4], o[3], o[4]],
        [tb_c, tb_s, tb_m, d[5], d[6], o[5], o[6]],
        [t.new[t.crept_f], t.new[t.stood], t.new[t.mid], d[1], d[2], o[1], o[2]],
    )


def _motor_dips(ch: _Chunk, found: kernel_windows.Reversals, i: int) -> list[_Dip]:
    """One motor's dips and settings-off back, in that order: the two turning
    points of every step whose cubic turns back and on again while the motor
    moves the same way at both of its ends (:func:`_dip_windows` gives their
    windows), from the kernel's answer ``found`` for the chunk's ``i``-th motor
    (:func:`.kernel.windows.motor_reversals`, :func:`.kernel.windows.motor_dips`).

    A dip shallower than ``tol`` is left alone: the part stands at the first
    turning point while the motor goes back and forth within its play, and misses
    the path by the dip's depth at most.

    Setting off back: the steps that a motor leaves from rest, or standing, the
    way against ``sg``, the way it ends the step moving and its part is on: it
    crosses to −sg as it sets off (at the step's start, s1 = 0) and back at the
    root where its cubic turns to ``sg``; left alone where it goes back no
    further than ``tol``.
    """
    # a dip: the motor moves the same way at both ends of a step, but the step's
    # cubic turns twice inside it (the extreme of a tight curve between two
    # points, or a corner whose point carries the mean of its sides' velocities);
    # setting off back: a motor at rest or standing leaves with its chord against
    # the way it ends the step and its part is on: it goes the other way first
    # and turns inside the step (from rest through the extreme of a tilt: 0.5
    # µm off the path, test_controller_truth's found programs)
    out = []
    sg = found.sg[i]
    for part in (2 * i, 2 * i + 1):  # its dips, then its settings-off back
        at = slice(int(found.dips[part]), int(found.dips[part + 1]))
        j, s1, s2, A1, A2 = (found.j[at], found.s1[at], found.s2[at], found.A1[at], found.A2[at])
        k = j - ch.off
        h = ch.dt[k]
        t1 = ch.t_end[k]
        t0 = t1 - h
        tm = t0 + 0.5 * (s1 + s2) * h
        out.append(_Dip(k, sg[j], s1, s2, A1, A2, h, t0, tm, t1))
    return out


def _motion_windows(
    t: _Turns,
    ch: _Chunk,
    rules: _Rules,
    dips: list[np.ndarray],
    corners_at: np.ndarray | None,
    wide: tuple[np.ndarray, np.ndarray] | None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One motor's windows about its reversals in motion, within the reach
    ``wide`` (:func:`reach`): their steps, starts and ends [s] (:func:`windows`,
    or :func:`chord_windows` with ``chords``, which may reach into a step beside
    that has no other window of the motor's: ``dips``, the steps of its dips'
    and settings-off's windows)."""
    # a reversal in motion: the window about the root of the step's cubic
    sr, acc = t.sr, t.acc
    km = t.k[t.mid]
    h = ch.dt[km]
    t1 = ch.t_end[km]
    t0 = t1 - h
    if rules.chords:
        busy = np.concatenate([t.k, t.k[t.stood] - 1, dips[0], dips[1]])
        t_before, t_after = _chord_room(km, t0, t1, ch, busy, corners_at)
        ta, tb = chord_windows(
            t0, t1, t0 + sr * h, acc, rules.tol, rules.longest, wide, t_before, t_after
        )
    else:
        ta, tb = windows(t0, t1, t0 + sr * h, acc, rules.tol, rules.longest, wide)
    return km, ta, tb


def _chord_room(
    km: np.ndarray,
    t0: np.ndarray,
    t1: np.ndarray,
    ch: _Chunk,
    busy: np.ndarray,
    corners_at: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """How far [s] a straight lines' window in step ``km`` (m,) [t0, t1] may reach
    before and after its step (:func:`chord_windows`' ``t_before``, ``t_after``):
    into the step beside where the path moves through both without a corner
    (``corners_at``, rows, sorted) between and the motor has no other
    window there (``busy``, steps), leaving it a servo cycle."""
    bent = np.zeros(0, dtype=int) if corners_at is None else corners_at
    return kernel.chord_room(km, t0, t1, ch.dt, ch.resting, np.sort(busy), bent, MIN_WINDOW_S)


def _place_windows(
    ins: Insertions, ch: _Chunk, wk: np.ndarray, ta: np.ndarray, tb: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Set the windows' steps and snapped edges in ``ins`` (w_k, w_ta, w_tb, w_t0,
    w_kb, w_t0b) from every window's step ``wk`` (w,) and edges ``ta``, ``tb`` (w,)
    [s]; returns the edges strictly inside their steps: (steps, times)."""
    n, t_end, dt = len(ch.dt), ch.t_end, ch.dt
    t1 = t_end[wk]
    t0 = t1 - dt[wk]
    # a window that reaches over an end of its step begins in the step before
    # or ends in the next
    wka = np.where(ta < t0, wk - 1, wk)
    wkb = np.where(tb > t1, wk + 1, wk)
    t1a, t1b = t_end[wka], t_end[np.minimum(wkb, n - 1)]
    t0a, t0b = t1a - dt[wka], t1b - dt[np.minimum(wkb, n - 1)]
    ek = np.concatenate([wka, wkb])
    e_t0, e_t1 = np.concatenate([t0a, t0b]), np.concatenate([t1a, t1b])
    both = _snap(ek, np.concatenate([ta, tb]), e_t0, e_t1)
    ta, tb = both[: len(wk)], both[len(wk) :]
    ins.w_k, ins.w_ta, ins.w_tb = wka, ta, tb
    ins.w_t0, ins.w_kb, ins.w_t0b = t0a, wkb, t0b
    # the points inside steps: each distinct window edge strictly inside its step
    et = both
    inside = (et > e_t0) & (et < e_t1)
    return ek[inside], et[inside]


def _blend_points(
    ins: Insertions,
    ch: _Chunk,
    blends: tuple[np.ndarray, np.ndarray] | None,
    near_first: float,
    et: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The points τ each side of the blended corners (:func:`corners`) that are
    put in: (rows, times) before the corners, then (rows, times) after them; none
    where a window's edge (``et`` [s], and ``ins``' windows) is that near
    already, inside a window (another motor's crossing), or after a standing point
    at the corner. Sets ``ins.near_next``."""
    n, t_end, dt = len(ch.dt), ch.t_end, ch.dt
    # the points τ each side of a blended corner (corners); none where a
    # window's edge is that near already, inside a window (another motor's
    # crossing), or after a standing point at the corner
    if blends is None:
        blends = (np.zeros(0, dtype=int), np.zeros(0))
    rows, tau = blends
    late, tau_l = rows, tau
    t_late = t_end[late] - tau_l
    early, tau_e = rows + 1, tau
    ins.near_next = float(tau_e[early == n][0]) if np.any(early == n) else 0.0
    if near_first:
        early, tau_e = np.concatenate([[0], early]), np.concatenate([[near_first], tau_e])
    keep = (early < n) & ~kernel_windows.in_sorted(early, ins.stand_k)
    early, tau_e = early[keep], tau_e[keep]
    t_early = t_end[early] - dt[early] + tau_e
    edges, starts, stops = np.sort(et), np.sort(ins.w_ta), np.sort(ins.w_tb)
    ok_l = (dt[late] >= 2 * tau_l) & _free(
        t_late, t_late - tau_l, t_end[late], edges, starts, stops
    )
    ok_e = (dt[early] >= 2 * tau_e) & _free(
        t_early, t_early - tau_e, t_early + tau_e, edges, starts, stops
    )
    return late[ok_l], t_late[ok_l], early[ok_e], t_early[ok_e]


def _free(
    t_new: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    edges: np.ndarray,
    starts: np.ndarray,
    stops: np.ndarray,
) -> np.ndarray:
    """(m,) bool, no window edge (sorted ``edges`` [s]) lies in [lo, hi] and the
    time ``t_new`` is inside no window (sorted ``starts`` and ``stops`` [s])."""
    no_edge = np.searchsorted(edges, lo, "left") == np.searchsorted(edges, hi, "right")
    within = np.searchsorted(starts, t_new, "left") - np.searchsorted(stops, t_new, "right")
    return no_edge & (within <= 0)


def _distinct_points(ek: np.ndarray, et: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each distinct (step, time) of the points ``ek``, ``et`` (m,) once, sorted by
    step, then time."""
    # each distinct (step, time) once, sorted by step, then time
    order = np.lexsort((et, ek))
    ek, et = ek[order], et[order]
    new = np.ones(len(ek), dtype=bool)
    new[1:] = (ek[1:] != ek[:-1]) | (et[1:] != et[:-1])
    return ek[new].astype(int), et[new]


class Rows:
    """Where each step's points are in a chunk with new points put in (ordered by
    step, standing points first, then by time; the times never decrease).

    step : (m,) the original row whose step each point belongs to
    when : (m,) time of each point since the point before the chunk [s]
    standing_before : (m,) the point is a standing point put before its row
    """

    def __init__(self, step: np.ndarray, when: np.ndarray, standing_before: np.ndarray) -> None:
        self.step = step
        self.when = when
        self.before = standing_before

    def first(self, k: np.ndarray) -> np.ndarray:
        """The first point of each step k (its standing point, if it has one)."""
        return np.searchsorted(self.step, k, "left")

    def last(self, k: np.ndarray) -> np.ndarray:
        """The last point of each step k (its end)."""
        out: np.ndarray = np.searchsorted(self.step, k, "right") - 1
        return out

    def first_plain(self, k: np.ndarray) -> np.ndarray:
        """The first point of each step k that is not a standing point."""
        f = self.first(k)
        return f + self.before[np.minimum(f, len(self.before) - 1)]

    def at(
        self, k: np.ndarray, t: np.ndarray, t0: np.ndarray, last: np.ndarray | None = None
    ) -> np.ndarray:
        """The point of each step k at time t: a point put inside the step or its
        end; for t at the step's start t0, the point before the step's first plain
        point (−1 before the chunk). ``last``: the steps' last points
        (:meth:`last`), where the caller has them.

        Window edges are either a step's ends or at least SNAP_S inside it
        (:func:`_snap`), so the step's start is told by time, not by an equality
        that the rounding of the times (relative to where a chunk begins) could
        break; the search is kept inside the step for the same reason.
        """
        fp = self.first_plain(k)
        if last is None:
            last = self.last(k)
        idx = np.clip(np.searchsorted(self.when, t - 0.5 * SNAP_S, "left"), fp, last)
        return np.where(t - t0 < 0.5 * SNAP_S, fp - 1, idx)


def sides(
    rows: Rows,
    V: np.ndarray,
    resting: np.ndarray,
    ins: Insertions,
    cols: list[int],
    side: np.ndarray,
) -> np.ndarray:
    """The side (+1, −1) every motor is on at every point of a chunk:
    :func:`sides_and_ends`' first answer."""
    return sides_and_ends(rows, V, resting, ins, cols, side)[0]


def sides_and_ends(
    rows: Rows,
    V: np.ndarray,
    resting: np.ndarray,
    ins: Insertions,
    cols: list[int],
    side: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`sides_by_motor` for velocities and sides a point a row: the sides
    (m, 5) ints, and the points where the windows end and the standing crossings'
    steps begin."""
    # a motor's velocities contiguous, transposed once (not a column copied a motor)
    by_motor, e_all, s_first = sides_by_motor(
        rows, np.ascontiguousarray(V.T), resting, ins, cols, side
    )
    return np.ascontiguousarray(by_motor.T, dtype=int), e_all, s_first


def sides_by_motor(
    rows: Rows,
    V_cols: np.ndarray,
    resting: np.ndarray,
    ins: Insertions,
    cols: list[int],
    side: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The side (+1, −1) every motor is on at every point of a chunk (new points
    included), and so which of lo⁻¹ and hi⁻¹ commands it: the direction of its
    planned velocity, held while it stands, switched inside a crossing window only
    at the window's end: the whole step up to the window's end is on the old side
    (the velocity may turn a little before the window begins), and at the window's
    end the motor has crossed, moving or not.

    rows : the chunk's points (:class:`Rows`)
    V_cols, resting : (5, m), (m,) planned motor velocities (a motor a row), path
        at rest
    side : (5,) the side before the chunk

    Returns the sides (5, m) [float, a motor a row: as the chain's tables take
    them, not transposed again], and the points where the windows end
    (``rows.at(ins.w_kb, ins.w_tb, ins.w_t0b)``) and where the standing
    crossings' steps begin (``rows.first(ins.s_k)``), which the sides are made
    from: the crossings' ends.
    """
    m = len(rows.step)
    out = np.empty((len(side), m))
    out[:] = np.asarray(side, dtype=int)[:, None]
    f_all = rows.first_plain(ins.w_k)
    last_row = rows.last(ins.w_kb)  # its end's step's end
    e_all = rows.at(ins.w_kb, ins.w_tb, ins.w_t0b, last_row)
    s_first, s_col, s_new = rows.first(ins.s_k), ins.s_col, ins.s_new
    # every motor's windows by their ends, in one sort (stable: as each motor's own;
    # lexsort((e_all, w_col))'s order as one int key, the ends points from −1)
    by_col = np.argsort(ins.w_col * (m + 1) + (e_all + 1), kind="stable")
    w_cols = ins.w_col[by_col]
    lo, hi = np.searchsorted(w_cols, cols, "left"), np.searchsorted(w_cols, cols, "right")
    # the points after a window's end inside its step (another motor's window, a
    # blend's point before a corner) are on the new side: where the path turns a
    # corner the cubic's root is before the corner, the plan's velocity turns at
    # it (kernel.play.motor_sides); every motor in one call
    kernel.motors_sides(
        V_cols,
        resting,
        np.array(cols, dtype=int),
        side,
        f_all[by_col],
        e_all[by_col],
        ins.w_new[by_col],
        last_row[by_col],
        lo,
        hi,
        s_first,
        s_new,
        s_col,
        V_EPS,
        out,
    )
    return out, e_all, s_first


def catch_up(
    off0: np.ndarray,
    way: np.ndarray,
    start: np.ndarray,
    stop: np.ndarray,
    s_path: np.ndarray,
    share: float = CATCH_UP_SHARE,
    motion: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """How far each part is from its wanted position after its crossings, while it
    is brought back along the path: the offset shrinks by a share of the path
    length run,

        off_j = sign(off0) · max(0, |off0| − share · (s_j − s_start)),

    so its rate is that share of the path speed, up to the point ``stop`` where
    the motor's next crossing begins (or up to CATCH_UP_HURRY times it, where that
    has it gone there). What is left there is not hurried away: it goes into that
    crossing (the command at its start still carries it, and the
    crossing is reckoned from where the part then is: chain.Pipeline._settle). Taken
    up in the few points a tight curve leaves between two crossings, it ran a part
    20 x the share, 1.0013 x F (test_controller_truth's found programs). A part
    standing with the path keeps its offset.

    Only a part behind its motor's way (``off0 · way < 0``) is brought back; one
    ahead of it (a blend carried it past the wanted extreme, or a window stood
    longer before its root than after it) cannot be pulled back, and without
    ``motion`` waits for the motor to come up to it: the commands are left
    wanted. With ``motion`` it is taken up at the same share, and over no step
    by more than half the motor's own move its way, so the command never turns
    back (a motor turned back leaves its part standing, out of the play model's
    reckoning): the part is pushed on a little slower than its motor's path
    until the path has come up to it. Left wanted, the step after the window
    took the whole offset: where it was short (a sliver of its step) its cubic
    turned back and the part stood while the path ran on (0.57 % over F,
    test_controller_truth's found programs).

    Parameters
    ----------
    off0 : (m,) the part's offset at each crossing's end [mm]
    way : (m,) the side each motor is on after its crossing (+1 up, −1 down)
    start : (m,) the point where each crossing ends (−1: the point before the chunk)
    stop : (m,) the point where the motor's next crossing begins (its command
        there is still on this side), or the chunk's length (it goes on in the
        next chunk)
    s_path : (n,) path length run by each point since the point before the chunk
    share : the offset's rate, a share of the path speed
    motion : (dP, V, speed), each (n,): the motor's wanted move into each point
        [mm], its wanted velocity there [mm/s], and the path's speed there
        [mm/s]; given, parts ahead of their motor's way are taken up too

    Returns
    -------
    idx : (k,) the points start < j ≤ stop (j < n) with an offset left, by crossing
    off : (k,) their offsets [mm]
    slope : (k,) d off / d s there: times the path speed, the offset's rate
    left : (m,) the offset left at ``stop``, carried into the next crossing, or
        where ``stop`` is the chunk's length at its last point, carried into the
        next chunk [mm]
    """
    return kernel.catch_up(off0, way, start, stop, s_path, share, CATCH_UP_HURRY, motion)


def follow(
    table: PlayTable,
    y0: float,
    P0: float,
    V0: float,
    P: np.ndarray,
    V: np.ndarray,
    dt: np.ndarray,
    cubic: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where a motor's driven part is along the cubics the controller runs through
    commands (P, V) from (P0, V0), starting at y0: the contract's play model on the
    continuous command. With ``cubic`` false the controller runs straight lines
    between the points (corrected G-code), and the points alone are the command's
    extremes.

    The play model is rate-independent: its result after a monotone stretch of
    commands depends only on where the stretch ends. So the command's cubic in each
    step is taken at its turning points (the roots of its velocity, a quadratic)
    and its end, and the result is exact, with one or three samples a step.

    Parameters
    ----------
    table : the motor's table as the kernel takes it (``MotorTable.flat``)

    Returns
    -------
    y_end : (n,) the part at each point
    y_min, y_max : (n,) the least and greatest position of the part within each
        step (its end included)
    """
    one = np.ones(1)
    return kernel.follow_stretches(
        table, y0 * one, P0 * one, V0 * one, P, V, dt, np.array([len(P)]), cubic
    )
