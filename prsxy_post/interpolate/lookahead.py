"""Look-ahead: the speed at every junction between blocks, planned over a stream.

A controller running PVT segments is told one velocity at each point, the same
for the segment before and the segment after it. Where the path turns a corner
at speed v, the planned velocity jumps by Δ = v (t_out − t_in) (t: the tangents
dq/ds of the two blocks); the point carries the mean of the two sides, so each
side's cubic is off by Δ/2 at its end. A Hermite cubic whose end velocity is off
by δ over a step h leaves its intended course by at most (4/27) h |δ| (the basis
function s³ − s² peaks at 4/27) and its acceleration changes by up to 4 |δ| / h.
So a corner may be taken at speed v only while

    (4/27) · period · v |t_out − t_in| / 2  ≤  CORNER_SHARE · tolerance     (path)
    4 · v |t_out − t_in| / 2 / h_lo        ≤  κ · a                         (accel)

(h_lo: the shortest step next to the corner), both for XYZ (mm) and for A/B
(degrees). A sharp corner is therefore a stop, a slight bend of a polyline is
taken at speed, and a tangent junction (a line into a tangent arc) costs nothing.
The cubics next to a corner carry the mean velocity, shorter than v by cos(θ/2),
while they cover their chords: their speed bulges by up to 1/cos(θ/2) over the
larger speed at their ends, so the blocks next to a corner keep below cos(θ/2) of
their speed limits (:func:`corner_bend`).
The blocks next to a corner keep κ of their acceleration for it: their own
tangential acceleration is limited to sqrt(1 − κ²) of the limit, so the vector
sum stays within the profile's limit.

Junctions next to a dwell, a machine function, a rotary-only move, a change of
tool length or a G61.1 block are stops, and so are those where a motor with play
must cross its play and its part, standing meanwhile, would run the tip off the
path at speed (``Blocks.dP_in``/``dP_out``/``cross_in``, told by the chain): a head
motor reversing; a table motor reversing where the head sets off or stops, or
where the table cancels the head's motion along its axis; any of them setting off
against the way it last moved where the head sets off or stops. It crosses its
play at rest.
Then a backward and a forward pass make every block able to slow down and speed up
in time (v² changes by at most 2aL).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..gcode import EXACT_STOP
from ..kernel import backward_pass, forward_pass, junction_speeds, play_stops
from ..kernel.timelaw import JunctionRules, row_norm
from .geometry import CORNER_SHARE, Blocks, PlanLimits, segment_limit
from .timelaw import TimeLaw, time_law

#: Share of the acceleration limit a corner's blend may use (module docstring).
KAPPA = 0.5

#: Tangents closer than this are one direction (a tangent junction).
TANGENT_EPS = 1e-9

#: A motor that moves more than this [mm per mm of path] on one side of a junction,
#: and the other way on the other side (by more than STAND_SLOPE: it creeps there,
#: and its part is on that side), reverses there: it crosses its play at rest. A
#: part standing while its motor moves slower costs the tip under 1e-3 of its speed,
#: even through the head's lever.
REVERSAL_SLOPE = 1e-3
#: A motor moving less than this [mm per mm of path] on a side of a junction stands
#: there (the blend of reversals.corners, not a stop).
STAND_SLOPE = 1e-6
#: The motors (columns) that move the head: the contract's first three.
HEAD_MOTORS = 3
#: A table motor (X, Y: the contract's last two) whose part stands while it crosses
#: its play takes its share out of the tip's velocity along its axis; where the
#: head's tilt moves the tip along that axis the other way (the table cancelling
#: it), the tip runs faster than the path, by sqrt(1 − 2 t p + p²) with t the
#: path's tangent along the axis and p the motor's dP/ds: a junction where one
#: reverses is a stop when that is more than this share on either side. (The
#: points of a written program keep within 1e-4 of F: test_tracking.)
TABLE_STAND_SHARE = 1e-4


def junction_limits(b: Blocks, limits: PlanLimits) -> tuple[np.ndarray, np.ndarray]:
    """Speed limit at the end of each block (its junction with the next one).

    The fastest each junction's corner may be taken with the mean velocity, within
    both blocks' speed limits, the path tolerance and κ of the acceleration (the
    module docstring's two bounds, XYZ and A/B; next to an arc the blend shares the
    normal acceleration v²/r spends: v²/r + 2 v d / h_lo ≤ sqrt(1 − ½²) a, h_lo the
    shortest step beside the junction: a phase lasts at least ``min_phase_s``, or
    the whole block, and curves cut steps shorter); 0 at a stop: a corner of 90° or
    more (taking it at the speed the tolerance allows, tenths of a mm/s, gains
    nothing, and a motor reversing there is best turned at rest), a dwell or a
    machine function, a rotary-only move, a change of tool length, G61.1
    (``EXACT_STOP``), or a motor crossing its play at rest (:func:`_play_stops`).
    The arithmetic is the kernel's (:func:`prsxy_post.kernel.junction_speeds`,
    compiled when built).

    Returns
    -------
    vj : (n,) [mm/s or deg/s]; the last block ends at rest
    corner : (n + 1,) bool, junction j (before block j) is a corner taken with
        the mean velocity: the blocks on both sides leave κ of their acceleration
        for it. corner[0] and corner[n] are False.
    """
    if len(b) < 2:
        return np.zeros(len(b)), np.zeros(len(b) + 1, dtype=bool)
    rules = JunctionRules(
        period=limits.period_s,
        min_phase=limits.min_phase_s,
        a_xyz=KAPPA * limits.accel_mm_s2,
        a_ab=KAPPA * limits.accel_deg_s2,
        an=math.sqrt(0.75) * limits.accel_mm_s2,
        tol_gain=27.0 * CORNER_SHARE,
        eps=TANGENT_EPS,
        exact=EXACT_STOP,
    )
    # the XYZ tangents' dot product at each junction, as einsum sums it (its sign
    # makes a corner of 90° or more a stop)
    dot = np.einsum("ij,ij->i", b.dq_in[1:, :3], b.dq_out[:-1, :3])
    return junction_speeds(
        b.dq_in, b.dq_out, dot, b.vmax, b.length, segment_limit(b, limits), b.stops,
        b.angular, b.tool_length, b.tol, b.tol_deg, b.curv_r, _play_stops(b), rules,
    )  # fmt: skip


def _play_stops(b: Blocks) -> np.ndarray:
    """(n − 1,) bool, the junctions where a motor with play must cross its play at
    rest (``Blocks.dP_in``/``dP_out`` [mm/mm], ``cross_in``: the module docstring)."""
    # a head motor with play that reverses at a junction crosses its play at rest:
    # its part stands while it crosses, and at speed the other motors tilt the head
    # meanwhile (test_controller_truth's found programs: 13 % over F60). A table
    # motor's crossing slows the tip, unless the head sets off or stops there too
    # (its crossing window then takes the place of the head's blend,
    # reversals.blend_shift, and the table's blend reached the tip: 8 % over F60),
    # or the table cancels the head's motion along its axis (TABLE_STAND_SHARE:
    # 2.9 % over F60; the table motors X, Y move the tip along x, y one for one,
    # the contract's table equation, to its scale and squareness errors). A motor
    # with play that sets off against the way it last moved crosses its play at
    # the junction; where the head sets off or stops there too, its window would
    # take the place of the head's blend (reversals.corners), and the blend's mean
    # cubics swing the head's motors back where their parts cannot follow (a tilt
    # starting after a straight at F300: 4.6 % over F60)
    return play_stops(
        b.dq_out,
        b.dq_in,
        b.dP_out,
        b.dP_in,
        b.cross_in,
        HEAD_MOTORS,
        REVERSAL_SLOPE,
        STAND_SLOPE,
        (1.0 + TABLE_STAND_SHARE) ** 2,
    )


def corner_bend(b: Blocks) -> np.ndarray:
    """(n + 1,) cos(θ/2) of the turn at each junction (1 where tangent, at the ends).

    Next to a corner taken at speed a the cubics bulge: over a step whose far end
    has speed b, the speed reaches up to max(a, b) / cos(θ/2), but never exceeds b
    while a ≤ b/2 (both measured over random turns and speeds up to 90°). So a
    corner taken at no more than cos(θ/2)/2 of the blocks' limit needs nothing more,
    and a faster one (a slight bend of a polyline, where cos(θ/2) is within a hair
    of 1) holds the blocks beside it to cos(θ/2) of their limit."""
    out = np.ones(len(b) + 1)
    if len(b) > 1:
        out[1:-1] = np.minimum(1.0, 0.5 * row_norm(b.dq_in[1:, :3] + b.dq_out[:-1, :3]))
    return out


def effective_accel(b: Blocks, corner: np.ndarray) -> np.ndarray:
    """Each block's tangential acceleration: sqrt(1 − κ²) of its limit next to a
    corner (module docstring), its limit elsewhere."""
    near = corner[:-1] | corner[1:]
    return np.where(near & ~b.stops, b.accel * math.sqrt(1.0 - KAPPA**2), b.accel)


class Planner:
    """Look-ahead speed planning over a stream of blocks, in bounded memory.

    Blocks wait until the path after them is long enough to stop from any speed
    (1.5 · v_max² / 2a) or a stop follows; then their junction speeds cannot
    change with anything further in the program, and they are committed. The
    last two blocks always wait for the next one (the junction after a block's
    successor sets the successor's speed limit, which the block's exit speed
    depends on).
    The result is the same, bit for bit, as planning the whole program at once.
    """

    def __init__(self, limits: PlanLimits) -> None:
        self.limits = limits
        self.pending: Blocks | None = None
        self.v_start = 0.0
        # the junction before the first pending block is a corner (it was planned
        # with the blocks committed before it)
        self.start_corner = False
        self.start_bend = 1.0
        self.start_slow = True

    def push(self, new: Blocks, final: bool = False) -> Plan | None:
        """Add blocks; return the plan of the blocks that became final, if any."""
        if self.pending is None or len(self.pending) == 0:
            b = new
        elif len(new) == 0:
            b = self.pending
        else:
            b = Blocks.concat([self.pending, new])
        n = len(b)
        if n == 0:
            self.pending = b
            return None
        vj, corner = junction_limits(b, self.limits)
        corner[0] = self.start_corner
        accel = effective_accel(b, corner)
        bend = corner_bend(b)
        bend[0] = self.start_bend
        # a corner taken at more than half the blocks' limit times cos(θ/2) holds the
        # blocks beside it to cos(θ/2) of their limit; slower ones need nothing
        # (corner_bend)
        slow = np.ones(n + 1, dtype=bool)
        if n > 1:
            lim = np.minimum(b.vmax[:-1], b.vmax[1:])
            slow[1:-1] = vj[:-1] <= 0.5 * bend[1:-1] * lim
        slow[0] = self.start_slow
        near = np.where(corner & ~slow, bend, 1.0)
        vmax = b.vmax * np.minimum(near[:-1], near[1:])
        vj = np.minimum(vj, np.concatenate([np.minimum(vmax[:-1], vmax[1:]), [0.0]]))
        length = np.where(b.stops, 0.0, b.length)
        v_back = backward_pass(length, accel, vj)
        if final:
            c = n - 1
        else:
            moving = ~b.stops
            lin = moving & ~b.angular
            run = np.where(lin, b.length, 0.0)
            remaining = np.cumsum(run[::-1])[::-1]  # remaining[k]: blocks k..n-1
            after = np.concatenate([remaining[1:], [0.0]])
            top = float(np.max(b.vmax[lin])) if np.any(lin) else 0.0
            amin = float(np.min(accel[lin])) if np.any(lin) else 1.0
            need = 1.5 * top * top / (2.0 * amin)
            # a block's speed limit near a corner depends on the junction after the
            # next block (corner_bend), so two blocks must follow the last committed
            ok = np.nonzero(after[:-2] >= need)[0]
            c = int(ok[-1]) if ok.size else -1
            stops = np.nonzero(vj[:-1] == 0.0)[0]
            if stops.size:
                c = max(c, int(stops[-1]))
        if c < 0:
            self.pending = b
            return None
        done = b.take(slice(0, c + 1))
        v_out = forward_pass(length[: c + 1], accel[: c + 1], v_back[: c + 1], self.v_start)
        done.accel = accel[: c + 1]
        done.vmax = vmax[: c + 1]
        law = time_law(done, v_out, self.v_start, self.limits.min_phase_s)
        nxt = b.dq_in[c + 1] if c + 1 < n else np.zeros(5)
        plan = Plan(done, law, nxt)
        self.v_start = float(v_out[-1])
        self.start_corner = bool(corner[c + 1])
        self.start_bend = float(bend[c + 1])
        self.start_slow = bool(slow[c + 1])
        self.pending = b.take(slice(c + 1, n))
        return plan


class Plan:
    """Committed blocks with their time law.

    blocks : Blocks (accel and vmax are the effective ones the plan used)
    law : TimeLaw
    next_dq_in : (5,) tangent of the block after the last one (for the mean velocity
        of the junction at the last block's end)
    """

    def __init__(self, blocks: Blocks, law: TimeLaw, next_dq_in: np.ndarray):
        self.blocks = blocks
        self.law = law
        self.next_dq_in = next_dq_in

    def head(self, k: int) -> Plan:
        """The plan of its first k blocks (where the rest is cut off)."""
        law = TimeLaw._make(v[:k] for v in self.law)
        nxt = self.blocks.dq_in[k] if k < len(self.blocks) else self.next_dq_in
        return Plan(self.blocks.take(slice(0, k)), law, nxt)

    def tail(self, k: int) -> Plan:
        """The plan of its blocks from the k-th on."""
        law = TimeLaw._make(v[k:] for v in self.law)
        return Plan(self.blocks.take(slice(k, None)), law, self.next_dq_in)

    @staticmethod
    def concat(plans: Sequence[Plan]) -> Plan:
        """Consecutive plans as one (the last one's next tangent)."""
        law = TimeLaw._make(map(np.concatenate, zip(*(p.law for p in plans), strict=True)))
        return Plan(Blocks.concat([p.blocks for p in plans]), law, plans[-1].next_dq_in)


__all__ = [
    "KAPPA",
    "Plan",
    "Planner",
    "TimeLaw",
    "backward_pass",
    "effective_accel",
    "forward_pass",
    "junction_limits",
]
