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
``TILT_CHORD_SHARE`` of the tolerance. (3) LinuxCNC ramps a line's speed up and
down by its own acceleration limit (the profile's, as the plan's), so a chord is
timed at its fastest piece, not its mean speed (timed at the mean a stop-to-stop
line cruised below the plan), and its X Y Z no faster than the plan's fastest speed
on the piece that stretches the planned path least; a chord never spans a dip of
the plan's speed, nor a play crossing (what the real-axis tables add to a motor
moving by more than the chord tolerance), whose points carry its timing. Measured:
``bench/linuxcnc_speed.py``, docs/measurements.md.

(4) A parabolic blend runs over F where written naively, and the writer keeps it
within F (``_blend_within_f``). Where LinuxCNC blends a line ``tc`` parabolically
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
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import kinematics
from ..interpolate.geometry import CORNER_SHARE
from ..profile.output import OUTPUT_SETTINGS
from .base import Dialect, Piece, Provenance, header, words_text
from .cartesian import feed_words, written_points
from .numbers import format_fixed_rows, round_clean

if TYPE_CHECKING:
    from ..points import PointChunk
    from ..profile import Profile

SETTINGS = OUTPUT_SETTINGS["gcode"]
#: the share of the tool-axis tolerance a written tilt may stay from the compensated one
TILT_HOLD_SHARE = 0.6
#: the share of it a chord's A and B may stray from the points it replaces
TILT_CHORD_SHARE = 0.2
#: LinuxCNC's servo period [s] (its sample configurations' SERVO_PERIOD, as the
#: tests' harness runs it): a parabolic blend's next line leads by one
SERVO_PERIOD_S = 1e-3
#: how much a chord's pieces may slow down and speed up again (a share of their rate)
DIP_SHARE = 1e-3


def corner_cut(
    q_in: Sequence[float],
    q_at: Sequence[float],
    q_out: Sequence[float],
    t_in: float,
    t_out: float,
    accel: float,
) -> tuple[float, float]:
    """How far LinuxCNC's parabolic blend of the lines q_in → q_at → q_out may cut
    the corner at q_at: (X Y Z [mm], A B [deg]).

    Poses (5,) [mm, mm, mm, deg, deg], line times t_in, t_out [s], the path
    acceleration ``accel`` [mm/s²]. The blend lasts t = min(t_in, t_out, 2 v / a)
    at the larger X Y Z speed v, and the pose's direction per mm of X Y Z turns
    from d_in to d_out over it: |d_out − d_in| v t / 8 (lines that turn A or B
    alone: |r_out − r_in| t / 8). An upper bound with the written speeds (module
    docstring). Plain floats: the writer calls it at every block end in motion.
    """
    r_in = [(b - a) / t_in for a, b in zip(q_in, q_at, strict=True)]
    r_out = [(b - a) / t_out for a, b in zip(q_at, q_out, strict=True)]
    v_in, v_out = math.hypot(*r_in[:3]), math.hypot(*r_out[:3])
    v = max(v_in, v_out)
    t_blend = min(t_in, t_out, 2.0 * v / accel) if v > 0.0 else min(t_in, t_out)
    if v_in > 0.0 and v_out > 0.0:
        # the turn of the path's direction (per mm of X Y Z travel): a change of
        # speed along the same line cuts nothing
        turn = [(o / v_out - i / v_in) * v for i, o in zip(r_in, r_out, strict=True)]
    else:
        turn = [o - i for i, o in zip(r_in, r_out, strict=True)]
    return math.hypot(*turn[:3]) * t_blend / 8.0, math.hypot(*turn[3:]) * t_blend / 8.0


class GcodeWriter:
    """Corrected Cartesian G-code (module docstring).

    With a tolerance > 0, points are dropped while the chord from the last written
    point stays within it of every point in between (XYZ in mm, A/B read as mm at
    1 mm per degree); a block's end point and every stop are always written.
    """

    def __init__(self, profile: Profile, settings: Mapping[str, Any], prov: Provenance) -> None:
        self.profile = profile
        self.prov = prov
        self.tol = float(settings["tolerance_mm"])
        self.dec = int(settings["decimals"])
        #: every line in G61: LinuxCNC 2.9's parabolic blends run over F (module docstring)
        self.all_exact = bool(settings["g61_every_line"])
        self.cgeo = kinematics.controller_geometry(profile)
        self.blend = CORNER_SHARE * profile.interpolation.path_tolerance_mm
        #: how far LinuxCNC may cut a tilt corner [deg] (module docstring)
        self.tilt_cut = CORNER_SHARE * profile.interpolation.path_tolerance_arcsec / 3600.0
        #: how far a written A or B may stay from the compensated one [deg]: within
        #: it the last written tilt is written again (module docstring)
        self.tilt_hold = TILT_HOLD_SHARE * profile.interpolation.path_tolerance_arcsec / 3600.0
        if any(np.any(a.forward != a.reverse) for a in profile.axis_comp):
            # a held tilt moves the motors by a step and back, and a motor with play
            # that turns back crosses it (0.34 um off the path on the found programs
            # of test_controller_truth): the tilt is held only on machines without
            self.tilt_hold = 0.0
        #: how far a chord's A and B may stray from the points it replaces [deg]
        self.tilt_chord = TILT_CHORD_SHARE * profile.interpolation.path_tolerance_arcsec / 3600.0
        #: the A and B written last [deg], and their words
        self.held: tuple[list[float], str] | None = None
        #: the path acceleration LinuxCNC's axes are set to [mm/s²]
        self.accel = profile.limits.max_accel_mm_s2
        #: A's and B's acceleration limit [deg/s²]
        self.accel_deg = profile.limits.max_accel_deg_s2
        #: the A and B written last [deg], and the acceleration limit LinuxCNC gives
        #: the last line written [mm/s²] (``_line_accel``)
        self.last_ab_deg: list[float] = [0.0, 0.0]
        self.prev_accel = self.accel
        self.n = 0
        self.t_total = 0.0
        self.last_line: int | None = None
        self.last_q: list[float] | None = None
        #: points held back: (point, its dt, its words)
        self.run: list[tuple[list[float], float, str]] = []
        #: the held-back pieces' rates [mm/s, a degree as a mm]: (each piece's length,
        #: its dt), the fastest, and the slowest since the fastest
        self.pieces: list[tuple[float, float]] = []
        self.peak = 0.0
        self.trough = 0.0
        #: the plan's fastest speed over the held-back pieces that move X Y Z [mm/s],
        #: their least stretch (X Y Z rate per planned speed), the last point's speed
        self.plan_peak = 0.0
        self.stretch = math.inf
        self.last_speed = 0.0
        #: what the tables added to the motors at the run's first point [mm]
        self.lead0: list[float] = [0.0] * 5
        self.ended_by: str | None = None
        #: G61 (exact path) is active, for a line ending where the motion stands
        self.exact = False
        #: the last line written was followed by G4 P0, or none was written yet
        #: (LinuxCNC's queue starts empty): the next runs in G61 too
        self.after_settle = True
        #: the lines written but not yet handed out: the last line that turns A or B
        #: in G64 P waits for the next, which may lower its F (``_blend_safe``)
        self.buf: list[str] = []
        #: the last G1 written: its index in ``buf`` (None once handed out), its X Y Z
        #: length [mm] and time [s], whether it turned A or B, and whether LinuxCNC
        #: may blend it into the next line (written in G64 P, no G4 P0 after it)
        self.prev: tuple[int | None, float, float, bool, bool] | None = None
        #: the A and B words of the last G1 written
        self.last_ab = ""
        #: a block's last point in motion, held until the next point shows how
        #: far LinuxCNC would cut the corner there: (point, its segment's time,
        #: its words)
        self.corner: tuple[list[float], float, str] | None = None
        #: the F words of this chunk's segment times (cartesian.feed_words)
        self.f_words: dict[float, str] = {}

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
        self.exact = self.all_exact
        return [(0, "\n".join(lines) + "\n")]

    def feed(self, chunk: PointChunk) -> list[Piece]:
        if len(chunk) == 0:
            return []
        q_arr = round_clean(written_points(self.cgeo, chunk), self.dec)
        # every point's "X.. Y.. Z.. A.. B.." at once (the same text as % per value),
        # and the per-point values as Python lists: a loop over numpy scalars took
        # most of the writer's time
        rows = format_fixed_rows(
            [((" " if i else "") + a, q_arr[:, i], self.dec) for i, a in enumerate("XYZAB")]
        )
        texts = [row[:-1] for row in rows]  # without the newline
        self.f_words = feed_words(chunk.dt)
        q = q_arr.tolist()
        dt = chunk.dt.tolist()
        line_no = chunk.line.tolist()
        speed = chunk.speed.tolist()
        block_end = chunk.block_end.tolist()
        dwell = chunk.dwell.tolist()
        # what the real-axis tables add to each motor [mm]: it ramps where a motor
        # crosses its play
        lead = (chunk.P_cmd - chunk.P_ideal).tolist()
        lines = self.buf
        # the plan's mean speed over each piece (it ramps linearly over a period)
        plan = [0.5 * (a + b) for a, b in zip([self.last_speed, *speed[:-1]], speed, strict=True)]
        self.last_speed = speed[-1]
        for k in range(len(q)):
            qk = q[k]
            if self.n == 0:
                lines.append("G0 " + texts[k])
                lines.append("G93")
                self.last_ab = texts[k][texts[k].index(" A") :]
                self.last_ab_deg = qk[3:5]
                self.last_q = qk
                self.n = 1
                continue
            dtk = dt[k]
            if self.corner is not None:
                self._resolve_corner(lines, qk, dtk)
            if line_no[k] != self.last_line:
                lines.append(f"(line {line_no[k]})")
                self.last_line = line_no[k]
            self.t_total += dtk
            words = chunk.fn[k]
            if words is not None:
                self._write_held(lines)
                self._at_rest()
                if any(w in (("M", 2.0), ("M", 30.0)) for w in words):
                    lines.append("G94")  # back to units per minute before the end
                    self.ended_by = words_text(words)
                lines.append(words_text(words))
                continue
            if dwell[k] and qk == self.last_q:  # the pose stands: a dwell
                self._write_held(lines)
                self._at_rest()
                lines.append(f"G4 P{dtk:.4f}")
                continue
            if self.tol > 0 and not block_end[k] and speed[k] > 0:
                # a point that may be dropped: keep it back while the chord from the
                # last written point to it passes all the held-back ones
                if not self._within(qk) or self._dips(qk, dtk, lead[k]):
                    self._write_held(lines)
                self._hold(qk, dtk, texts[k], lead[k], plan[k])
                continue
            if self.run and (not self._within(qk) or self._dips(qk, dtk, lead[k])):
                self._write_held(lines)
            self._hold(qk, dtk, texts[k], lead[k], plan[k])
            t = self._chord_time()
            self.run = []
            if speed[k] > 0.0 and block_end[k]:
                self.corner = (qk, t, texts[k])  # written once the next point is known
                continue
            self._g1(lines, qk, texts[k], t, exact=speed[k] == 0.0)
        return self._hand_out()

    def _hand_out(self) -> list[Piece]:
        """The lines written so far, but for a last G1 that LinuxCNC may blend into
        the next line, whose F or stop that line decides (it and the lines after it
        stay in ``buf``)."""
        keep = self.prev[0] if self.prev is not None and self.prev[0] is not None else None
        if keep is None or not (self.prev is not None and self.prev[4]):
            out, self.buf = self.buf, []
            if self.prev is not None:
                self.prev = (None, *self.prev[1:])
        else:
            out, self.buf = self.buf[:keep], self.buf[keep:]
            self.prev = (0, *self.prev[1:])
        return [(0, "\n".join(out) + "\n")] if out else []

    def _at_rest(self) -> None:
        """A machine function or a dwell follows: LinuxCNC blends nothing across it."""
        if self.prev is not None:
            self.prev = (*self.prev[:4], False)

    def _resolve_corner(self, lines: list[str], q_next: list[float] | None, dt_next: float) -> None:
        """Write the held block end, in G61 where LinuxCNC's parabolic blend would
        cut the corner there by more than ``blend`` in X Y Z or ``tilt_cut`` in A
        and B (module docstring)."""
        if self.corner is None:
            return
        qc, t, text = self.corner
        self.corner = None
        exact = False
        if q_next is not None and self.last_q is not None and dt_next > 0.0:
            mm, deg = corner_cut(self.last_q, qc, q_next, t, dt_next, self.accel)
            exact = mm > self.blend or deg > self.tilt_cut
        self._g1(lines, qc, text, t, exact=exact)

    def _write_held(self, lines: list[str]) -> None:
        """Write the last held-back point (it becomes the new chord start)."""
        if not self.run:
            return
        qh, _, text = self.run[-1]
        t = self._chord_time()
        self.run = []
        self._g1(lines, qh, text, t, exact=False)  # only points in motion are held back

    def _g1(self, lines: list[str], q: list[float], text: str, t: float, *, exact: bool) -> None:
        """Write the line to ``q`` (its words ``text``) taking ``t`` seconds, in G61
        where ``exact`` (a line ending where the motion stands, or at a corner
        LinuxCNC's blend would cut too far), else in G64 P. Where LinuxCNC would
        blend the line before into this one parabolically, that line is slowed down
        or stopped (``_blend_within_f``), and an exact line goes in G64 P, its G4 P0
        stopping it all the same (module docstring, rule 4)."""
        exact = exact or self.all_exact
        words = self._tilt_held(q, text)
        ab = words[words.index(" A") :]
        turns = ab != self.last_ab
        self.last_ab = ab
        assert self.last_q is not None and self.held is not None
        length = math.dist(self.last_q[:3], q[:3])
        # the written A and B (held or not) and this line's acceleration limit
        ab_now = list(self.held[0])
        accel = self._line_accel(
            [b - a for a, b in zip(self.last_q[:3], q[:3], strict=True)],
            [b - a for a, b in zip(self.last_ab_deg, ab_now, strict=True)],
        )
        self.last_ab_deg = ab_now
        prev = self.prev
        # LinuxCNC blends the line before into this one parabolically where it was
        # written in G64 P (no G4 P0 after it) and one of the two turns A or B
        if prev is not None and prev[4] and (prev[3] or turns):
            # this line's own acceleration is halved where its end is a parabolic
            # join too: it turns A or B, or it is exact (G64 P and G4 P0, below)
            a_n = accel / 2.0 if turns or exact else accel
            self._blend_within_f(lines, prev, length, t, a_n)
        parabolic = self.prev is not None and self.prev[4] and (self.prev[3] or turns)
        # the first line after a dwell runs in G61 too: LinuxCNC refills its queue
        # while it runs (module docstring)
        mode = (exact or self.after_settle) and not (exact and parabolic and not self.all_exact)
        if mode != self.exact:
            lines.append("G61" if mode else f"G64 P{self.blend:g}")
            self.exact = mode
        lines.append(f"G1 {words} {self.f_words.get(t) or f'F{60.0 / t:.3f}'}")
        self.prev = (len(lines) - 1, length, t, turns, not mode and not exact)
        self.prev_accel = accel
        self.after_settle = exact
        if exact:
            # LinuxCNC ends a line mid servo cycle and starts the next in the same
            # cycle; a dwell waits for the motion to end (module docstring)
            lines.append("G4 P0")
        self.last_q = q
        self.n += 1

    def _blend_within_f(
        self,
        lines: list[str],
        prev: tuple[int | None, float, float, bool, bool],
        length_n: float,
        t_n: float,
        a_n: float,
    ) -> None:
        """Keep LinuxCNC's parabolic blend of the previous line into the next one
        (``length_n`` [mm] in ``t_n`` [s], speeding up at ``a_n`` [mm/s²])
        within the larger of the two lines' written speeds: lower the previous
        line's F, or, where that costs more time than a stop or where either line
        is shorter than the blend, stop it there (G4 P0 after it, the next line in
        G61).

        The previous line slows down at a_t = a / 2 from v0 (at most its own
        speed v_p), the next speeds up towards v_n at a_n (a / 2 or a) from a
        servo cycle T earlier: their sum peaks at v0 + v_n (1 − a_t / a_n) + a_t T
        (module docstring, rule 4). So v_p ≤ max(v_p, v_n) − v_n (1 − a_t / a_n)
        − a_t T.
        """
        idx, length, t, _, _ = prev
        if idx is None or t <= 0.0 or length <= 0.0:
            return
        v_p = length / t
        v_n = length_n / t_n if t_n > 0.0 else 0.0
        a_t = self.prev_accel / 2.0
        v = max(v_p, v_n)
        # a blend lasts v / a_t, and the line after it stops or blends again: a line
        # shorter than twice that overlaps the blends, and the next leads by up to a
        # cycle more (1.026 x F on a helix of 9 ms chords at F600 with one cycle's
        # lead; 1.025 x F on pocket.ngc's helix of 8.5 ms chords at F400, blend 6.7 ms)
        lead = SERVO_PERIOD_S * (2.0 if min(t, t_n) < 2.0 * v / a_t else 1.0)
        if a_n >= a_t:
            v_safe = v - v_n * (1.0 - a_t / a_n) - a_t * lead
        else:
            v_safe = v - a_n * lead
        if v_safe >= v_p:
            return
        # the time a stop costs: the previous line slows down at a_t, the next
        # (G61) speeds up from rest at a and stops at its end, the one after it
        # speeds up again
        stop_s = v / (2.0 * a_t) + 3.0 * v / (2.0 * 2.0 * a_t)
        slow_s = t * (v_p / v_safe - 1.0) if v_safe > 0.0 else math.inf
        if slow_s <= stop_s:
            row = lines[idx]
            lines[idx] = f"{row[: row.rindex(' F')]} F{60.0 * v_safe / length:.3f}"
        else:
            lines.insert(idx + 1, "G4 P0")
            self.after_settle = True
            self.prev = (None, length, t, prev[3], False)

    def _line_accel(self, d_xyz: list[float], d_ab: list[float]) -> float:
        """A line's acceleration limit along its X Y Z path [mm/s²], as LinuxCNC's
        canon sets it: the path length over the longest time an axis takes at its
        own limit (``getStraightAcceleration``, emccanon.cc:612-721), up to √3 times the
        axes' limit on a diagonal (random 11's five-axis.ngc: 2175 mm/s², its blend
        1.0031 x F at the 2000 mm/s² bound, measured)."""
        dtot = math.hypot(*d_xyz)
        tmax = max(
            max(abs(d) for d in d_xyz) / self.accel,
            max(abs(d) for d in d_ab) / self.accel_deg,
        )
        return dtot / tmax if dtot > 0.0 and tmax > 0.0 else self.accel

    def _piece(self, qk: list[float], dtk: float) -> tuple[float, float]:
        """The piece from the last held-back (or written) point to qk: (length, rate)."""
        prev = self.run[-1][0] if self.run else self.last_q
        assert prev is not None
        step = math.dist(prev, qk)
        return step, (step / dtk if dtk > 0.0 else 0.0)

    def _dips(self, qk: list[float], dtk: float, lead: list[float]) -> bool:
        """Would the piece to qk speed up again after the held-back pieces slowed
        down, or move what the real-axis tables add to a motor by more than ``tol``
        (a motor crossing its play, whose timing its points carry)? A chord is timed
        at its fastest piece (``_chord_time``): it may hold a rise and a fall of the
        planned speed, not a dip."""
        if not self.run:
            return False
        _, rate = self._piece(qk, dtk)
        moved = max(abs(a - b) for a, b in zip(lead, self.lead0, strict=True))
        dip = self.trough < self.peak * (1.0 - DIP_SHARE) and rate > self.trough * (1.0 + DIP_SHARE)
        return dip or moved > self.tol

    def _hold(self, qk: list[float], dtk: float, text: str, lead: list[float], plan: float) -> None:
        """Hold back the point qk (its piece's time dtk, its words, the tables' lead,
        the plan's mean speed over the piece)."""
        prev = self.run[-1][0] if self.run else self.last_q
        assert prev is not None
        step, rate = self._piece(qk, dtk)
        if not self.run:
            self.pieces, self.peak, self.trough, self.lead0 = [], 0.0, 0.0, lead
            self.plan_peak, self.stretch = 0.0, math.inf
        self.pieces.append((step, dtk))
        xyz_rate = math.dist(prev[:3], qk[:3]) / dtk if dtk > 0.0 else 0.0
        if plan > 0.0 and xyz_rate > 0.5 * plan:
            # a piece that moves X Y Z about as planned (not a turn of A or B alone,
            # planned in degrees per second): how far it stretches the planned path
            self.plan_peak = max(self.plan_peak, plan)
            self.stretch = min(self.stretch, xyz_rate / plan)
        if rate >= self.peak:
            self.peak = self.trough = rate
        else:
            self.trough = min(self.trough, rate)
        self.run.append((qk, dtk, text))

    def _chord_time(self) -> float:
        """The time of the chord through the held-back points: its length at the rate
        of its fastest piece, and its X Y Z no faster than the plan's fastest speed
        times the least stretch of its pieces. LinuxCNC speeds up and slows down along a line by its
        own acceleration limit (the profile's, as the plan's); a line between stops
        timed at its mean speed cruised at the mean, below the plan's speed."""
        length = sum(s for s, _ in self.pieces)
        total = sum(d for _, d in self.pieces)
        if len(self.pieces) == 1 or self.peak <= 0.0 or length <= 0.0:
            return total
        t = min(total, length / self.peak)
        if self.plan_peak > 0.0 and self.run and self.last_q is not None:
            # LinuxCNC runs the chord's X Y Z at one speed; where a piece stretches
            # the planned path less than another, the tool ran faster than planned
            # there: no faster than the plan's fastest speed on the piece that
            # stretches least
            xyz = math.dist(self.last_q[:3], self.run[-1][0][:3])
            t = max(t, xyz / (self.plan_peak * self.stretch))
        return t

    def _tilt_held(self, q: list[float], text: str) -> str:
        """The words of the point ``q`` with A and B as last written while they are
        within ``tilt_hold`` of q's (a line that moves A or B by any amount LinuxCNC
        blends parabolically: module docstring)."""
        cut = text.index(" A")
        if self.held is not None:
            ab, words = self.held
            if abs(q[3] - ab[0]) <= self.tilt_hold and abs(q[4] - ab[1]) <= self.tilt_hold:
                return text[:cut] + words
        self.held = (q[3:5], text[cut:])
        return text

    def _within(self, qk: list[float]) -> bool:
        """Would the chord from the last written point to qk pass the held-back points,
        within ``tol`` in X Y Z and ``tilt_chord`` in A and B?

        Each held point p is taken at its nearest place along the chord a + t d,
        t = clip((p − a)·d / d·d, 0, 1) (A and B read as mm at 1 mm per degree), and
        its offset |p − (a + t d)| judged. In Python's floats, not numpy's: a run
        holds a few points, and numpy's fixed cost per call was most of the G-code
        writer's time."""
        if not self.run or self.last_q is None:
            return True
        a = self.last_q
        d = [x - y for x, y in zip(qk, a, strict=True)]
        dd = math.fsum(x * x for x in d)
        if dd == 0:
            return False
        tol, tilt = self.tol, self.tilt_chord
        for p, _, _ in self.run:
            t = math.fsum((x - y) * z for x, y, z in zip(p, a, d, strict=True)) / dd
            t = 0.0 if t < 0.0 else (1.0 if t > 1.0 else t)
            off = [abs(x - (y + t * z)) for x, y, z in zip(p, a, d, strict=True)]
            if math.sqrt(off[0] * off[0] + off[1] * off[1] + off[2] * off[2]) > tol:
                return False
            if off[3] > tilt or off[4] > tilt:
                return False
        return True

    def finish(self) -> list[Piece]:
        lines = self.buf
        self.buf = []
        self._resolve_corner(lines, None, 0.0)
        self._write_held(lines)
        if self.ended_by is None:
            lines += ["G94", "M2"]
        lines.append(f"(end: {self.n} points, {self.t_total:.3f} s)")
        lines.append("%")
        return [(0, "\n".join(lines) + "\n")]


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
)
