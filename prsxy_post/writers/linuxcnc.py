"""Corrected Cartesian G-code for LinuxCNC running the machine's kinematics.

Each point is written where the controller's own kinematics reproduce the
compensated motor commands (:mod:`.cartesian`). LinuxCNC moves along a straight
line between two points (in its Cartesian space) and blends corners within the
``G64 P`` tolerance the program sets before its first motion (LinuxCNC's default
G64 without P may cut corners by any amount); the planner makes points dense
enough on curves that the chords stay within the path tolerance. Timing is kept
with G93 inverse time: F = 1 / (segment minutes). Machine functions (S, T, M6,
M3-M5, M7-M9, M0, M1, ...) are written where the program has them, at rest; each
G4 is one G4.

Where the planned motion stands (a corner taken from rest, a motor crossing its
play at rest, the ends of rapids), the line that ends there runs in ``G61``
(exact path) and the next moving one in ``G64 P`` again. LinuxCNC's planner does
not stop where the G93 times slow down to nothing: under ``G64 P`` it blends
every junction, and a blend into a crossing window at a corner starts the motor
across its play while the line before is still being finished (0.77 µm off the
path on ``xy-corner-F60``, with the stop 0.085 µm:
``tests/test_linuxcnc_motion.py``, run on LinuxCNC itself). "G61: Moves will
slow or stop as needed to reach every programmed point" (LinuxCNC G-code
reference, G61); the planner takes a line's termination mode from the mode
active when the line is queued, and it governs the junction at that line's end.

The same goes for a block's end in motion where LinuxCNC would cut the corner by
more than the blend's share of the tolerance. LinuxCNC 2.9 blends lines that move
A or B parabolically (``tpCheckBlendArcType``: "If we have any rotary axis
motion, then don't create a blend arc"), and corrected G-code for a machine with
errors moves A and B a little on every line. In a parabolic blend both lines run
at once for t = min(t_in, t_out, v / a_t) (``tpComputeBlendVelocity``: the
shorter line's time, or the time to reach the speed v at the tangential
acceleration a_t, half the line's limit in a parabolic blend, so at most
2 v / a with a the profile's limit), the pose's direction per mm of X Y Z
travel turning from d_in to d_out over it at the speed v: the corner is cut by
|d_out − d_in| v t / 8, in X Y Z and in A and B alike (a line that turns A or B
alone: its rates, |r_out − r_in| t / 8). On LinuxCNC itself G64 P0.00025 did
not hold such blends: drill.ngc's corner from a Z rapid into a diagonal one at
2.1 mm/s was cut by 0.83 µm, and tball-with-a-tilt-F1016's tilt corner by
24 arcsec (7.3 µm at the tip); with G61 there 0.47 µm and 0.46 arcsec (0.04 µm
and 0.01 arcsec with the G4 P0 below). With the written speeds the reckoning
bounds the cut from above (drill.ngc's corner: 10.7 µm; LinuxCNC took it slower
than written), so some of these stops are more than LinuxCNC needs. Inside a block
the rate turns by a step's worth of curvature, and the blend cuts the polyline back
towards the curve.

A stop in G61 is not where the commands stand still: LinuxCNC ends a line within a
servo cycle and, in the same cycle, starts the next from rest (``tp.c``,
``tpHandleSplitCycle``), so no servo sample falls on the corner and the drive,
following its samples, cuts it. A motor that reverses there turns short of its
extreme, and with play its part is left elsewhere in the play, which carries on to
the next crossing: compass-sets-off-back-F400 ran 0.605 µm off its path. So every
line in G61 is followed by ``G4 P0``: a dwell waits for the motion to end
(``emctaskmain.cc``, ``emcTaskCheckPreconditions``: ``EMC_TRAJ_DELAY_TYPE`` waits
for motion and I/O), and the next line starts on a sample at the corner (0.064 µm).
That next line runs in G61 as well, and so does the program's first: LinuxCNC
refills its queue after the dwell (or at the start) while the line already runs,
and a blend added to a running line left steep-helix's path 0.49 µm to one side
for the lines after it (0.71 µm off; 0.12 µm with the line in G61).

What LinuxCNC 2.9 joins at speed (its source at Debian's 2.9.0~pre1 commit
f1270d6ed7) sets four rules for the lines written. (1) A line whose A and B move
by any amount gets neither a tangent join nor a blend arc: ``tpSetupTangent``
(tp.c:1846) and ``tpCheckBlendArcType`` (tp.c:1645) both return on
``tcRotaryMotionCheck`` (tp.c:131), which is false only where ``abc.tmag_zero``
is set, that is where the largest of |ΔA|, |ΔB| is below ``CART_FUZZ`` = 1e-8
(``pmCartLineInit``, _posemath.c:1695-1704, ``IS_FUZZ`` _posemath.c:92,
posemath.h:717); and the look-ahead stops at such a join (``tpRunOptimization``,
tp.c:1761). Corrected G-code for a machine with errors turned A and B by about
1e-7° a line, so every join was parabolic and LinuxCNC ran slow (2.45 x the plan on
a five-axis program). On a machine without play the writer writes A and B again as
last written while the compensated tilt stays within ``TILT_HOLD_SHARE`` of the
tool-axis tolerance (only the tool axis moves, by less than that: the tip is X Y Z
of the controller's kinematics). With play it does not: a held tilt moves motors
by a step and back, and a motor that turns back crosses its play. (2) LinuxCNC runs
a line in no less than 1.02 servo cycles (``tpComputeOptimalVelocity``,
tp.c:1707-1708, ``TP_MIN_SEGMENT_CYCLES`` in tp_types.h), and its task feeds the
queue at the host's pace: a line every 10 ms period and shorter on curves ran below
the plan's speed, and its queue ran dry on a loaded host. ``tolerance_mm`` (0.1 µm
in the shop profile) writes a chord where the points lie within it, A and B within
``TILT_CHORD_SHARE`` of the tolerance of the compensated chord; where they stray
further (the compensated tilt along a side of a five-axis program on a machine with
errors bends away from a straight line by up to 2.7 arcsec on 40 mm), within
``TILT_FIT_SHARE`` of a line whose end tilt is fitted: LinuxCNC moves A and B in
proportion to X Y Z along a line (``tcGetPosReal``, tc.c: ``pmCartLinePoint`` of each at
the progress times its length over the X Y Z length), so
from the tilt written last the end tilts that keep every point within the share
form an interval (a Chebyshev fit with its start fixed; the end is shared with the
next line), and the value nearest the compensated one in it is written. A convex
tilt's largest departure is about halved: on random 11's five-axis square at
F10000 a side became 2 lines instead of 3-5 (1.16 x the plan instead of 1.33),
X Y Z within ``tolerance_mm`` then setting the count. Not on machines with play
(the tilt as compensated, above). (3) LinuxCNC ramps a line's speed up and
down by its own acceleration limit (the profile's, as the plan's), so a chord is
timed at its fastest piece, not its mean speed (timed at the mean a stop-to-stop
line cruised below the plan), and its X Y Z no faster than the plan's fastest speed
on the piece that stretches the planned path least; a chord never spans a dip of
the plan's speed, nor a play crossing (what the real-axis tables add to a motor
moving by more than the chord tolerance), whose points carry its timing. Measured:
``bench/linuxcnc_speed.py``, docs/measurements.md.

(4) A parabolic blend runs over F where written naively, and the writer keeps it
within F (``blend_within_f``). Where LinuxCNC blends a line ``tc`` parabolically
into ``nexttc`` (a join where either moves A or B, both in G64 P), it starts the
blend once ``tc`` is on its final deceleration below its blend speed (``tcIsBlending``,
tc.c:529-540) and from then on updates both each cycle (``tpHandleRegularCycle``,
tp.c:3370-3384; ``tpDoParabolicBlending``, tp.c:3044-3048). ``tpUpdateBlend``
(tp.c:2642-2662) sets ``nexttc->target_vel`` from the speed ``tc`` has lost, scaled
by their blend speeds, but ``nexttc`` never reads it: ``tpCalculateTrapezoidalAccel``
takes the target from ``tpGetRealTargetVel`` (tp.c:2391), which is ``tc->reqvel``, the
programmed speed, for any motion not synchronized with the spindle (tp.c:254-265).
So ``nexttc`` speeds up towards its own F at its own tangential acceleration while
``tc`` slows down, and the sum is what the tool does. ``tc`` slows down at half its
limit (term condition parabolic: ``tcGetOverallMaxAccel``, tc.c:55-68); ``nexttc``
speeds up at half its limit only if its own end is a parabolic join too, or if
``blend_prev`` is set, which only ``tpChooseBestBlend`` does (tp.c:928), never
reached for lines that move A or B (``tpHandleBlendArc`` returns on
``tpSetupTangent``'s failure, tp.c:2008-2013, tp.c:1846-1849, and a new line starts
zeroed, tp.c:2057). A line in G61 (term condition exact, set from the mode by
``tcSetupState``, tc.c:674-676) or one whose end joins tangentially speeds up at its
whole limit: measured, 1.52 x F on two 10 mm lines at F600 turning A, the second in
G61 (1.50 x on the five-axis program). With both at half the limit the sum still
rises by one servo cycle's worth of acceleration, ``nexttc`` leading (1.09 x F at
F600, 1.02 x at F3000, 1.16 x at F300: about a / 2 x 1 ms = 1 mm/s). A line's limit
a is its own: LinuxCNC's canon gives it the path length over the longest time an
axis takes at its own limit (``getStraightAcceleration``, emccanon.cc:612-721, the
distance over the limit of each axis, A and B at theirs: 688-717), more than
the axes' limit on a diagonal (2175 mm/s² for 2000 on five-axis.ngc's diagonal on
random 11: 1.0031 x F with a bound that took 2000). The bound the writer keeps:
with ``tc`` slowing from v0 ≤ v_p at a_t (half its limit) and ``nexttc`` speeding
up towards v_n at a_n (half its limit or all of it), a servo cycle T (1 ms) ahead,
their sum peaks at v0 + v_n (1 − a_t / a_n) + a_t T where a_n ≥ a_t, at v0 + a_n T
where not. So the line into such a join runs at v_p ≤ max(v_p, v_n) − v_n (1 −
a_t / a_n) − a_t T (or − a_n T; its F lowered), T doubled where either line is
shorter than twice the blend (2 v / a_t: then blends overlap; 1.026 x F on a helix of
9 ms chords at F600 with one cycle), or, where that costs more time than a stop, it
stops there: G4 P0 after it (still in G64 P: its end has
no next line to blend with, as the task waits), the next line in G61. An exact
line into which the line before is blended parabolically is written in G64 P with
its G4 P0, so that it too speeds up at half its limit. With ``g61_every_line = 1``
every line runs in G61, which LinuxCNC never blends: F holds, and the program takes
longer (``bench/linuxcnc_truth.py --g61-everywhere``).

(5) Arcs are written as arcs. Chords within 0.1 µm of an R10 arc are 0.09 mm,
which LinuxCNC runs no faster than 88 mm/s (rule 2; F10000 is 167 mm/s) and joins
slowly: arcs and helices at F10000 ran 1.34-1.49 x the plan. Where the points of a
run still lie on a circle (a helix: a circle and its axis) within ``tolerance_mm``,
A and B within ``TILT_CHORD_SHARE`` of the tolerance of a line between the ends,
one G2/G3 replaces them (:mod:`.arcs`: the fit, verified against every point as
LinuxCNC runs the written words, emccanon.cc:1482-1830 ARC_FEED), in G17, G18 or
G19 (a plane word on a line of its own where it changes), I J K the center's
offsets from the start in the writer's decimals, timed in G93 as a chord is (rule
3) with the arc's X Y Z length. Where the fit fails the run is split, and the
chords go on. The rules it keeps: an arc never spans a dip of the plan's speed or
a play crossing (rule 3); it ends at a block's end in motion (an arc short of it
left a line of one piece between two arcs, and the near-tangent join of a line of
under two servo cycles with an arc cost a slow-down: 1.23 x the plan on arcs
F10000, measured), its corner judged from its last piece; after a stop the first
line is one piece in G61 and the arc starts at its end (the line after a dwell
runs in G61, above; an arc in G61 would stop at its end). LinuxCNC runs an arc at
no more than √(0.866 a R_eff) (``tcUpdateCircleAccRatio``, tc.c:748-760, at
``tcFinalizeLength``, tc.c:769-785, calling ``pmCircleActualMaxVel``,
blendmath.c:1640-1676: ``BLEND_ACC_RATIO_NORMAL`` = √(1 − 0.5²), blendmath.h:19-20,
R_eff = r + h²/r with h the arc's whole rise, ``pmCircleEffectiveMinRadius``,
blendmath.c:1843-1858) and along it at half of a (``tcGetTangentialMaxAccel``,
tc.c:73-85), as the plan does (``interpolate.geometry.ARC_TANGENTIAL_SHARE``); but
a is halved where the arc ends in a parabolic join (``tcGetOverallMaxAccel``,
tc.c:55-68), that is where it or the next line turns A or B (rule 1): an arc that
turns A or B, and the one before it, ran at 0.71 of the plan's speed on a small
radius, and rule 4 stopped the one before (a helix on a machine with errors, whose
compensated tilt changes along it: 1.07 x the plan at F3000). So where the tilt
is held an arc turns neither: an arc's A and B, constant, may stay ``arc_hold``
(``tilt_hold`` and ``tilt_chord``, 0.4 arcsec) from its points', as far as a
chord's may (held, and straying along the chord); before a run of arcs the tilt is
held at the value nearest the one held that covers the whole run within that and
its start within ``tilt_hold`` (``_center_tilt``; the line to the run's start turns
it, after a stop for the most part), and where the written A or B must change all
the same, the arc ends a point
before, a line of one piece turns them, and the arc goes on from its end: LinuxCNC
all but stops there (from 93 to 6 mm/s on the helix at F10000, measured), as at
every line that turns A or B. Where LinuxCNC blends an arc and a line parabolically
all the same (one of them turns A or B), the two run at once over the blend, and on
a tangent join the G64 P tolerance, which enters only through the angle between
their ends (``tpComputeBlendVelocity``, tp.c:2254-2282), does not shorten it: the
arc's rise over its tangent along the overlap cuts the path (9.8 µm on an R0.22 arc
into a line turning A, measured). So where that cut (``arc_blend_cut``, timed as
tp.c times the blend) passes ``blend``, the move before stops there (G4 P0, the
next in G61), as rule 4 stops a line.
LinuxCNC's motion controller does not command the planner's points: each joint's
command is a cubic B-spline through way points (x₋₁ + 4 x + x₊₁) / 6 of them
(``cubicAddPoint`` and ``cubicInterpolate``, control.c:1358-1377; ``wayPoint``,
cubic.c:97-101), which on a circle of radius R at the speed v, sampled every servo
cycle T, lie (v T)² / (6 R) inside it; a drive that moves straight between its 1 ms
commands cuts (v T)² / (8 R) more: (7/24) (v T)² / R, 0.505 µm on R10 at the plan's
131.6 mm/s (arcs and helix F10000 on the nominal machine, measured). An arc is
timed no faster than that keeps within the path tolerance less ``tolerance_mm``
(0.4 µm in the shop profile): v ≤ √(24 R e / 7) / T (117 mm/s on R10).

These rules decide, point by point, which points become lines, each line's time and
F, its mode and the G4 P0 after it: the kernel makes those decisions
(:mod:`prsxy_post.kernel.gwrite`, its functions named here: ``within``,
``chord_time``, ``dips``, ``tilt_held``, ``resolve_corner``, ``g1``,
``blend_within_f``, ``arc_blend_cut``; compiled in ``_gwrite.pyx``), and this
writer makes the text.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import kernel, kinematics
from ..interpolate.geometry import CORNER_SHARE
from ..kernel import gwrite
from ..profile.output import OUTPUT_SETTINGS
from .arcs import ArcTable, arc_lines
from .base import Dialect, Piece, Provenance, header, words_text
from .cartesian import WrittenPoints
from .numbers import format_fixed_rows, round_clean

if TYPE_CHECKING:
    from ..points import PointChunk
    from ..profile import Profile

SETTINGS = OUTPUT_SETTINGS["gcode"]
#: the share of the tool-axis tolerance a written tilt may stay from the compensated one
TILT_HOLD_SHARE = 0.6
#: the share of it a chord's A and B may stray from the points it replaces
TILT_CHORD_SHARE = 0.2
#: the share of it a chord's fitted A and B may stray from them (``tilt_fit``)
TILT_FIT_SHARE = 0.6
#: LinuxCNC's servo period [s] (its sample configurations' SERVO_PERIOD, as the
#: tests' harness runs it): a parabolic blend's next line leads by one
SERVO_PERIOD_S = gwrite.SERVO_PERIOD_S
#: how much a chord's pieces may slow down and speed up again (a share of their rate)
DIP_SHARE = gwrite.DIP_SHARE
#: how far LinuxCNC's parabolic blend may cut a corner (the kernel's reference)
corner_cut = gwrite.corner_cut


class GcodeWriter:
    """Corrected Cartesian G-code (module docstring).

    With a tolerance > 0, points are dropped while the chord from the last written
    point stays within it of every point in between (XYZ in mm, A/B read as mm at
    1 mm per degree); a block's end point and every stop are always written. The
    decisions are the kernel's (:func:`prsxy_post.kernel.gcode_ops`); this class
    makes the lines' text from them.
    """

    #: the point fields :meth:`feed` reads (and :class:`.cartesian.WrittenPoints`
    #: for it): a writer in a process of its own is sent only these
    #: (:class:`prsxy_post.sinks.WriterProcess`)
    reads = ("q_target", "P_cmd", "P_ideal", "dt", "dwell", "line", "speed", "block_end", "fn")

    def __init__(self, profile: Profile, settings: Mapping[str, Any], prov: Provenance) -> None:
        self.profile = profile
        self.prov = prov
        self.dec = int(settings["decimals"])
        #: every line in G61: LinuxCNC 2.9's parabolic blends run over F (module docstring)
        self.all_exact = bool(settings["g61_every_line"])
        self.cgeo = kinematics.controller_geometry(profile)
        self.written_points = WrittenPoints(self.cgeo)
        self.blend = CORNER_SHARE * profile.interpolation.path_tolerance_mm
        tol_deg = profile.interpolation.path_tolerance_arcsec / 3600.0
        #: how far a written A or B may stay from the compensated one [deg]: within
        #: it the last written tilt is written again (module docstring)
        tilt_hold = TILT_HOLD_SHARE * tol_deg
        if any(np.any(a.forward != a.reverse) for a in profile.axis_comp):
            # a held tilt moves the motors by a step and back, and a motor with play
            # that turns back crosses it (0.34 um off the path on the found programs
            # of test_controller_truth): the tilt is held only on machines without
            tilt_hold = 0.0
        #: the path acceleration LinuxCNC's axes are set to [mm/s²], A's and B's [deg/s²]
        self.accel = profile.limits.max_accel_mm_s2
        self.accel_deg = profile.limits.max_accel_deg_s2
        #: the kernel's state between chunks: the tolerance, how far LinuxCNC may cut
        #: a corner (``blend`` [mm], its tilt [deg]), the tilt hold, how far a chord's
        #: A and B may stray from the points it replaces [deg] (module docstring)
        #: the chord tolerance [mm] and how far a chord's A and B may stray [deg]
        self.tol = float(settings["tolerance_mm"])
        self.tilt_chord = TILT_CHORD_SHARE * tol_deg
        #: how far an arc's A and B, held, may stay from its points' [deg]: a held
        #: tilt's share and a chord's, as a chord's A and B may (an arc's are constant)
        self.arc_hold = tilt_hold + self.tilt_chord if tilt_hold > 0.0 else 0.0
        self.state = gwrite.new_state(
            tol=self.tol,
            blend=self.blend,
            tilt_cut=CORNER_SHARE * tol_deg,
            tilt_hold=tilt_hold,
            tilt_chord=TILT_CHORD_SHARE * tol_deg,
            accel=self.accel,
            accel_deg=self.accel_deg,
            all_exact=self.all_exact,
            # how far LinuxCNC's smoothing may take an arc inside [mm]: the path
            # tolerance less the chord tolerance (rule 5)
            smooth=max(profile.interpolation.path_tolerance_mm - self.tol, 0.0),
            arc_hold=self.arc_hold,
            decimals=self.dec,
            # where the tilt may be held (no play), a chord's end tilt may be fitted
            tilt_fit=TILT_FIT_SHARE * tol_deg if tilt_hold > 0.0 else 0.0,
        )
        #: the points kept from chunks before (as written): the tilt written last,
        #: the held corner, the last held-back point (rows -3, -2, -1, as the kernel
        #: names them)
        self.kept = np.zeros((3, 5))
        self.ended_by: str | None = None
        #: the lines written but not yet handed out: the last line that LinuxCNC may
        #: blend into the next waits for it, which may lower its F or stop it
        self.buf: list[str] = []
        #: where in ``buf`` the line that waits for the next chunk stands (None: none)
        self.keep: int | None = None
        #: the arc the corner held over a chunk's end closes (the kernel's CORNER_SRC):
        #: its rows (:class:`.arcs.ArcTable`'s ai, af)
        self.kept_arc: tuple[np.ndarray, np.ndarray] | None = None

    def begin(self) -> list[Piece]:
        ck = (
            "profile [controller_kinematics]"
            if self.profile.controller_kinematics
            else "the nominal design"
        )
        modes = (
            [
                "Every line runs in G61 (exact path, g61_every_line), followed by G4 P0:",
                "a stop at every point, no blend.",
            ]
            if self.all_exact
            else [
                f"Corners blend within G64 P{self.blend:g} (LinuxCNC's G64 without P would",
                "cut them by any amount); a line that ends where the motion stands, or at",
                "a corner LinuxCNC would blend too far, runs in G61 (exact path) and is",
                "followed by G4 P0, so that the next line (in G61 too) starts where it ends.",
            ]
        )
        extra = [
            f"For a controller whose inverse kinematics is {ck}, with an ideal table.",
            "Run with no tool length offset (G49) and no work offset: tool lengths and",
            "offsets are in the points. Timing is G93 inverse time per segment.",
            *modes,
        ]
        lines = ["%"] + [
            "(" + x.replace("(", "[").replace(")", "]") + ")"
            for x in header(self.prov, self.profile, extra)
        ]
        lines.append("G21 G90 G17 G40 G49 G94")
        lines.append("G61" if self.all_exact else f"G64 P{self.blend:g}")
        return [(0, "\n".join(lines) + "\n")]

    def feed(self, chunk: PointChunk) -> list[Piece]:
        if len(chunk) == 0:
            return []
        q_arr = round_clean(self.written_points(chunk), self.dec)
        # the points with machine functions: a function point stands (PointChunk),
        # so only the standing ones are looked at (a comparison of every row of an
        # object column with None is a Python call a row)
        fn = np.zeros(len(chunk), dtype=bool)
        standing = np.flatnonzero(chunk.dwell)
        fn[standing] = chunk.fn[standing] != None  # noqa: E711 (elementwise)
        fn_end = np.zeros(len(chunk), dtype=bool)
        for k in np.flatnonzero(fn).tolist():
            fn_end[k] = any(w in (("M", 2.0), ("M", 30.0)) for w in chunk.fn[k])
        # what the real-axis tables add to each motor [mm]: it ramps where a motor
        # crosses its play
        lead = chunk.P_cmd - chunk.P_ideal
        # arcs kept as arcs (rule 5): found before the kernel decides, refitted by it
        # where it must (a later start, known only as it goes: after a stop, or where
        # A or B leave the held tilt)
        arcs = self._arcs(q_arr, chunk, fn, lead)
        start_q = self.state.last_q.copy()  # where the chunk's first move starts
        ops = kernel.gcode_ops(
            self.state,
            q_arr,
            chunk.dt,
            chunk.line,
            chunk.speed,
            chunk.block_end,
            fn,
            fn_end,
            chunk.dwell,
            lead,
            False,
            arcs.arc_of,
            arcs.k_i,
            arcs.k_f,
            (self.tol, self.tilt_chord, self.dec),
        )
        # the arcs it refitted, numbered on from the chunk's
        arcs.add((self.state.fit_i, self.state.fit_f), arc_of=False)
        self._lines(ops, q_arr, chunk, arcs, start_q)
        return self._hand_out()

    def _arcs(self, q: np.ndarray, chunk: PointChunk, fn: np.ndarray, lead: np.ndarray) -> ArcTable:
        """The arcs among the chunk's points (:func:`.arcs.find_arcs`, rule 5) and,
        for each point, the arc it lies on after its start (-1: none); ``lead``
        (n, 5) [mm] what the real-axis tables add to each motor."""
        n = len(q)
        if self.tol <= 0.0 or n < 2:
            return ArcTable((np.zeros((0, 4), dtype=np.int64), np.zeros((0, 6))), n)
        moving = (chunk.speed > 0.0) & ~chunk.dwell & ~fn
        step = _step_lengths(q)
        rate = np.divide(step, chunk.dt, out=np.zeros(n), where=chunk.dt > 0.0)
        found = kernel.find_arcs(
            q,
            moving & ~chunk.block_end,
            moving & chunk.block_end,
            rate,
            lead,
            self.tol,
            self.tilt_chord,
            self.dec,
            DIP_SHARE,
            # where the tilt is held, an arc is split where it changes (rule 5)
            2.0 * self.arc_hold if self.arc_hold > 0.0 else math.inf,
        )
        return ArcTable(found, n)

    def _lines(
        self,
        ops: gwrite.Ops,
        q_arr: np.ndarray,
        chunk: PointChunk | None,
        arcs: ArcTable | None,
        start_q: np.ndarray,
    ) -> None:
        """Append the lines of the kernel's ops (each with its line end) to ``buf``,
        after what they did to the line carried in it, and keep the points (and the
        arc) the next chunk may name. ``start_q``: the last point written before."""
        code, arg, abi, _, val, tilts = ops
        st = self.state
        patch = int(st.i[_I["patch"]])
        if patch == gwrite.PATCH_F:
            row = self.buf[0]
            self.buf[0] = f"{row[: row.rindex(' F')]} F{float(st.f[_F['patch_f']]):.3f}\n"
        elif patch == gwrite.PATCH_STOP:
            self.buf.insert(1, "G4 P0\n")
        st.i[_I["patch"]] = gwrite.PATCH_NONE
        base = len(self.buf)
        # negative indices name the kept points (gwrite.HELD_SRC, CORNER_SRC, RUN_SRC)
        # and N + j the tilts centered before runs of arcs
        tilt_rows = np.zeros((len(tilts), 5))
        tilt_rows[:, 3:] = tilts
        q_all = np.concatenate([q_arr, tilt_rows, self.kept])
        lines = self._const[code]
        g1 = np.flatnonzero(code == gwrite.G1)
        if g1.size:
            # each G1's text in one call: X Y Z of its point, A B of the tilt it writes
            # (np.take: an (n, 5) array's rows gathered faster than fancy indexing)
            xyz, ab = np.take(q_all, arg[g1], axis=0), np.take(q_all, abi[g1], axis=0)
            cols = [("G1 X", xyz[:, 0]), (" Y", xyz[:, 1]), (" Z", xyz[:, 2])]
            cols += [(" A", ab[:, 3]), (" B", ab[:, 4])]
            lines[g1] = format_fixed_rows(
                [(p, v, self.dec) for p, v in cols] + [(" F", val[g1], 3)]
            )
        self._arc_lines(lines, ops, q_all, arcs, start_q)
        if chunk is not None:
            self._point_lines(lines, code, arg, q_arr, chunk)
        self.buf += lines.tolist()
        i_of = st.i
        # the points the kernel may name in the next chunk (as the state holds them)
        self.kept[gwrite.HELD_SRC, 3:] = st.held_ab
        self.kept[gwrite.CORNER_SRC] = st.corner_q
        run_n = int(i_of[_I["run_n"]])
        if run_n:
            self.kept[gwrite.RUN_SRC] = st.run_q[run_n - 1]
        ca_from = int(i_of[_I["ca_from"]])
        if ca_from >= 0:
            assert arcs is not None
            self.kept_arc = arcs.row(ca_from)
        keep = int(i_of[_I["keep"]])
        self.keep = base + keep if keep >= 0 else (0 if keep == gwrite.CARRIED else None)

    def _point_lines(
        self,
        lines: np.ndarray,
        code: np.ndarray,
        arg: np.ndarray,
        q_arr: np.ndarray,
        chunk: PointChunk,
    ) -> None:
        """The lines that name a point of the chunk but are no G1: the first
        point's G0, the line comments, machine functions and dwells."""
        at = np.flatnonzero(code == gwrite.LINE)
        if at.size:
            line_no = chunk.line[arg[at]].astype(float)
            lines[at] = format_fixed_rows([("(line ", line_no, 0)], end=")\n")
        named = (code == gwrite.G0) | (code == gwrite.FN) | (code == gwrite.DWELL)
        for i in np.flatnonzero(named).tolist():
            k = int(arg[i])
            if code[i] == gwrite.G0:
                cols = [(" " + a, q_arr[k : k + 1, j], self.dec) for j, a in enumerate("XYZAB")]
                lines[i] = "G0" + format_fixed_rows(cols)[0]
            elif code[i] == gwrite.DWELL:
                lines[i] = f"G4 P{float(chunk.dt[k]):.4f}\n"
            else:
                words = chunk.fn[k]
                text = words_text(words)
                lines[i] = text + "\n"
                if any(w in (("M", 2.0), ("M", 30.0)) for w in words):
                    self.ended_by = text

    def _arc_lines(
        self,
        lines: np.ndarray,
        ops: gwrite.Ops,
        q_all: np.ndarray,
        arcs: ArcTable | None,
        start_q: np.ndarray,
    ) -> None:
        """The G2/G3 lines (:func:`.arcs.arc_lines`: the end's X Y Z, the A B the
        op names, the center words as offsets from the point written before) and
        the plane words."""
        code, arg, abi, aux, val, _ = ops
        for i in np.flatnonzero(code == gwrite.PLANE).tolist():
            lines[i] = f"G{int(aux[i])}\n"
        # each arc's start: the point of the move written before it (G0, G1 or an
        # arc), or the chunk's start
        moves = np.flatnonzero((code == gwrite.ARC) | (code == gwrite.G1) | (code == gwrite.G0))
        pos = np.flatnonzero(code[moves] == gwrite.ARC)
        if not pos.size:
            return
        at = moves[pos]
        start = np.take(q_all, arg[moves[np.maximum(pos - 1, 0)]], axis=0)
        if pos[0] == 0:
            start[0] = start_q
        end = np.take(q_all, arg[at], axis=0)
        end[:, 3:] = np.take(q_all, abi[at], axis=0)[:, 3:]
        a = aux[at]
        kept = a == gwrite.CORNER_SRC
        ai = np.zeros((len(at), 4), dtype=np.int64)
        af = np.zeros((len(at), 6))
        if arcs is not None:
            ai[~kept], af[~kept] = arcs.ai[a[~kept]], arcs.af[a[~kept]]
        if kept.any():
            assert self.kept_arc is not None
            ai[kept], af[kept] = self.kept_arc
        lines[at] = arc_lines(end, val[at], start, ai, af, self.dec)

    @property
    def _const(self) -> np.ndarray:
        """Each op's line where it names no point (:data:`gwrite.OPS`), as an object
        array to take the ops' lines from."""
        out = np.full(len(gwrite.OPS), "", dtype=object)
        out[gwrite.G93], out[gwrite.G61], out[gwrite.G4P0] = "G93\n", "G61\n", "G4 P0\n"
        out[gwrite.G64], out[gwrite.G94] = f"G64 P{self.blend:g}\n", "G94\n"
        return out

    def _hand_out(self) -> list[Piece]:
        """The lines written so far, but for a last G1 that LinuxCNC may blend into
        the next line, whose F or stop that line decides (it and the lines after it
        stay in ``buf``: the kernel's ``keep``)."""
        if self.keep is None:
            out, self.buf = self.buf, []
        else:
            out, self.buf = self.buf[: self.keep], self.buf[self.keep :]
        return [(0, "".join(out))] if out else []

    def _line_accel(self, d_xyz: list[float], d_ab: list[float]) -> float:
        """A line's acceleration limit along its X Y Z path [mm/s²], as LinuxCNC's
        canon sets it (:func:`prsxy_post.kernel.gwrite.line_accel`): up to √3 times
        the axes' limit on a diagonal (random 11's five-axis.ngc: 2175 mm/s², its
        blend 1.0031 x F at the 2000 mm/s² bound, measured)."""
        return gwrite.line_accel(d_xyz, d_ab, self.accel, self.accel_deg)

    def finish(self) -> list[Piece]:
        empty = np.zeros(0)
        ops = kernel.gcode_ops(
            self.state,
            np.zeros((0, 5)),
            empty,
            np.zeros(0, dtype=np.int64),
            empty,
            np.zeros(0, dtype=bool),
            np.zeros(0, dtype=bool),
            np.zeros(0, dtype=bool),
            np.zeros(0, dtype=bool),
            np.zeros((0, 5)),
            True,
            np.zeros(0, dtype=np.int64),
            np.zeros((0, 4), dtype=np.int64),
            np.zeros((0, 2)),
        )
        self._lines(ops, np.zeros((0, 5)), None, None, self.state.last_q.copy())
        lines = self.buf
        self.buf = []
        if self.ended_by is None:
            lines += ["G94\n", "M2\n"]
        n, t_total = int(self.state.i[_I["n"]]), float(self.state.f[_F["t_total"]])
        lines.append(f"(end: {n} points, {t_total:.3f} s)\n")
        lines.append("%\n")
        return [(0, "".join(lines))]


_I = {n: j for j, n in enumerate(gwrite.I_NAMES)}
_F = {n: j for j, n in enumerate(gwrite.F_NAMES)}


def _make(profile: Profile, settings: Mapping[str, Any], prov: Provenance) -> GcodeWriter:
    return GcodeWriter(profile, settings, prov)


DIALECT = Dialect(
    name="gcode",
    extension=".ngc",
    summary="corrected Cartesian G-code for LinuxCNC running the machine's kinematics",
    segment="chord",
    settings=SETTINGS,
    space="pose",
    make=_make,
    # its writer solves the controller's FK at every point, the largest share of
    # the conversion's CPU, and keeps the second core busy: a third process would add
    # the copies of every point through a pipe (bench/process_layout.py, bench.py's
    # program: 1.360 s and 2.38 s of CPU apart against 1.269 s and 2.19 s here at
    # 200 000 lines, medians of five runs; 12.09 s against 11.45 s at 2 M; PMAC
    # output the other way, 0.674 s against 0.895 s)
    interpreter_apart=False,
)


def _step_lengths(q: np.ndarray) -> np.ndarray:
    """(n,) the length of the step to each of the points ``q`` (n, 5) from the one
    before, sqrt(Σ_j Δq_j²) (0 at the first): np.linalg.norm(np.diff(q), axis=1)'s
    bits (its row sums of five squares run in column order, so do these), with
    the columns summed a whole column at a time (norm's reduction over rows of
    five takes several times as long)."""
    n = len(q)
    out = np.zeros(n)
    if n < 2:
        return out
    d = q[1:] - q[:-1]
    d *= d
    s = d[:, 0] + d[:, 1]
    for j in range(2, d.shape[1]):
        s += d[:, j]
    np.sqrt(s, out=out[1:])
    return out
