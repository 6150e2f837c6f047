"""What else may explain the data besides the library's members: never named, never
written (calibration's physical stage; diagnose's test of what is left).

A real-axis table made from laser runs holds each value as the mean of n
readings, known to σ / √n (σ the motor's pooled repeat spread, ISO 230-2's
repeatability); a member that only looks like errors of that size in the tables
is not told apart from them by the data. A servo lag common to every motor moves
the tip along its own path, which position data cannot see (to first order).
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import effects as registry
from ..measure import AxisData
from ..profile import Profile


@dataclass(frozen=True)
class Nuisance:
    """What else may explain the data, never named nor written (calibration's
    physical stage):

    table_knots : motor -> the positions of its table, for motors whose table the
        laser runs made: each value is known only to the laser's standard error
    table_sd : table-error column key (:func:`.model.table_error_keys`) -> that
        standard error [mm], the prior of the value's error (:meth:`.selection.Gram.build`'s
        ``known``)
    common_lag : a servo lag common to every motor is free: it moves the tip along
        its own path, which position data cannot see (to first order), so only
        lags relative to the others are candidates
    """

    table_knots: Mapping[int, np.ndarray] = field(default_factory=dict)
    table_sd: Mapping[str, float] = field(default_factory=dict)
    common_lag: bool = False

    def keys(self, columns: Mapping[str, np.ndarray]) -> list[str]:
        out = [k for k in self.table_sd if k in columns]
        return out + ([COMMON_LAG] if self.common_lag and COMMON_LAG in columns else [])

    def add_columns(self, columns: dict[str, np.ndarray]) -> None:
        """The common lag's column (the sum of every motor's), when asked for."""
        lags = [k for k in columns if k in _LAG_MEMBERS]
        if self.common_lag and lags:
            columns[COMMON_LAG] = np.sum([columns[k] for k in lags], axis=0)


#: The servo-lag members (one column each).
_LAG_MEMBERS = frozenset(registry.SERVO_LAG.members())

#: Column key of a servo lag common to every motor (:class:`Nuisance`).
COMMON_LAG = "servo_lag:common"


def table_nuisance(
    now: Profile, axis: Sequence[AxisData], motors: Collection[int], *, common_lag: bool = False
) -> Nuisance:
    """What the laser-made tables leave open, for the physical stage: each table
    value of ``motors`` is the mean of n readings, so it is known to σ / √n (σ the
    motor's pooled spread of repeated readings, ISO 230-2's repeatability), and a
    servo lag common to every motor, which position data cannot see, when
    ``common_lag``."""
    knots: dict[int, np.ndarray] = {}
    sd: dict[str, float] = {}
    tables = {c.motor: np.asarray(c.positions, dtype=float) for c in now.axis_comp}
    for m in sorted(int(x) for x in motors):
        at = tables.get(m)
        rows = [
            (a.target[a.motor == m], a.measured[a.motor == m], a.direction[a.motor == m])
            for a in axis
        ]
        if at is None or not rows:
            continue
        t = np.concatenate([r[0] for r in rows])
        v = np.concatenate([r[1] for r in rows])
        d = np.concatenate([r[2] for r in rows])
        ss, dof = 0.0, 0
        count: dict[tuple[float, int], int] = {}
        for x in np.unique(t):
            for way in (1, -1):
                grp = v[(t == x) & (d == way)]
                count[(float(x), way)] = len(grp)
                if len(grp) > 1:
                    ss += float(np.sum((grp - grp.mean()) ** 2))
                    dof += len(grp) - 1
        if not dof:
            continue
        sigma = float(np.sqrt(ss / dof))
        knots[m] = at
        for side, sign in (("+", 1), ("-", -1)):
            for j, x in enumerate(at):
                n = count.get((float(x), sign), 0)
                # a position the laser did not read is as uncertain as one reading
                sd[f"table[{m}]{side}{j}"] = sigma / np.sqrt(max(n, 1))
    return Nuisance(knots, sd, common_lag=common_lag)
