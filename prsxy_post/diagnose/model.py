"""The model of the measurements: predictions and each library member's signature.

For a model profile (geometry, real-axis tables, effects; optionally its
virtual-axis error map e) and measurements taken while a known profile commanded
the machine (its chain made the motor commands P_cmd):

    pose tip, axis:  y = FK_model(P)                     (+ e(y) with the map)
    ballbar:         d = |tip(P) − pivot| − length        (+ e on the tip)
    laser:           p = lo(target) or hi(target) of the model's table

where P is where the model's motors put their driven parts for P_cmd (servo lag,
then the play model of the tables with their cyclic terms; poses and laser
targets are approached on their own from one side).

A member's signature is the change of every prediction per unit of its size:

- a geometry member θ_j: ∂y/∂θ_j, by the implicit-function theorem on the FK
  constraints (:func:`prsxy_post.measurement_model.fk_with_jacobian`);
- a motor member of motor m: ∂y/∂P_m × its motor term (the registry's
  :meth:`~prsxy_post.effects.MotorFamily.motor_term`), and the motor term itself
  on that motor's laser rows.

Along a ballbar run the FK sensitivities change smoothly with the pose, so they
are computed on every k-th sample (about :data:`JACOBIAN_POINTS` a run) and
interpolated linearly in time (the error of that at one-degree spacing is about
1e-5 of the sensitivity); motor terms (signs, periodic terms) are taken at every
sample.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .. import axiscomp, errormap, kinematics, simulate
from .. import effects as registry
from ..measure import AxisData, BallbarRun, PoseData
from ..measurement_model import fk_with_jacobian
from ..profile import MOTORS, Profile

#: FK sensitivities are computed on about this many samples of each ballbar run.
JACOBIAN_POINTS = 360


def column_keys(names: Sequence[str] | None = None) -> list[str]:
    """Column keys of members: the name, or ``name@period`` for each scanned period."""
    out = []
    for n in registry.members() if names is None else names:
        fam = registry.family(n)
        variants = getattr(fam, "variants", ())
        out += [f"{n}@{p:g}" for p in variants] if variants else [n]
    return out


def split_key(key: str) -> tuple[str, float | None]:
    """(member name, period or None) of a column key."""
    name, _, per = key.partition("@")
    return name, (float(per) if per else None)


@dataclass
class Segment:
    """One measurement file's rows in the stacked vector of measured values."""

    kind: str  # "pose_tip", "pose_axis", "ballbar", "axis"
    source: str
    name: str
    start: int
    stop: int
    unit: str  # "mm" or "deg"


@dataclass
class Data:
    """Measurements and the motor commands the machine was given for them.

    P_pose, P_run : motor commands (N, 5) [mm] the commanding profile's chain made
    v_run : command velocities (N, 5) [mm/s]; dir_run : the side (±1) each motor
    last moved from (N, 5)
    """

    poses: list[PoseData]
    runs: list[BallbarRun]
    axis: list[AxisData]
    commanded: Profile
    P_pose: list[np.ndarray] = field(default_factory=list)
    P_run: list[np.ndarray] = field(default_factory=list)
    v_run: list[np.ndarray] = field(default_factory=list)
    dir_run: list[np.ndarray] = field(default_factory=list)
    #: platform poses of the last prediction, per file: the next one starts there
    guess: dict[tuple[str, int], np.ndarray] = field(
        default_factory=dict, repr=False, compare=False
    )

    @classmethod
    def build(
        cls,
        commanded: Profile,
        poses: Sequence[PoseData],
        runs: Sequence[BallbarRun],
        axis: Sequence[AxisData],
    ) -> Data:
        d = cls(list(poses), list(runs), list(axis), commanded)
        for p in poses:
            d.P_pose.append(simulate.pose_commands(commanded, p.commanded))
        for r in runs:
            P = simulate.motion_commands(commanded, r.commanded, t=r.t)
            d.P_run.append(P)
            d.v_run.append(registry.SERVO_LAG.velocity(P, r.t))
            d.dir_run.append(last_direction(P))
        return d

    def measured(self) -> tuple[np.ndarray, list[Segment]]:
        """Stacked measured values [mm or deg] and the segment of each file."""
        vals: list[np.ndarray] = []
        segs: list[Segment] = []
        n = 0

        def add(kind: str, src: str, name: str, v: np.ndarray, unit: str) -> None:
            nonlocal n
            vals.append(v)
            segs.append(Segment(kind, src, name, n, n + len(v), unit))
            n += len(v)

        for p in self.poses:
            add("pose_tip", p.source, "tip", p.tip.ravel(), "mm")
            add("pose_axis", p.source, "axis", p.axis.ravel(), "deg")
        for r in self.runs:
            add("ballbar", r.source, r.name or r.source, r.dev_um * 1e-3, "mm")
        for a in self.axis:
            add("axis", a.source, "laser", a.measured, "mm")
        return (np.concatenate(vals) if vals else np.zeros(0)), segs


def last_direction(P: np.ndarray) -> np.ndarray:
    """The direction (±1) each motor last moved in, (N, 5): the side of the play its
    part sits on (+1 before the first move)."""
    step = np.diff(P, axis=0, prepend=P[:1])
    sgn = np.sign(np.where(np.abs(step) > 1e-12, step, 0.0))
    idx = np.where(sgn != 0, np.arange(len(P))[:, None], -1)
    idx = np.maximum.accumulate(idx, axis=0)
    last = np.take_along_axis(sgn, np.maximum(idx, 0), axis=0)
    last[idx < 0] = 1.0
    return last


@dataclass
class Linearised:
    """Predictions and signatures.

    pred : (n,) predicted values, stacked as :meth:`Data.measured`
    columns : column key -> (n, d) change of the predictions per unit of the member
        (d = 2 for a periodic term: its sine and cosine parts)
    """

    pred: np.ndarray
    columns: dict[str, np.ndarray]
    segments: list[Segment]


def table_error_keys(knots: Mapping[int, np.ndarray]) -> list[str]:
    """Column keys of table-value errors: ``table[m]+j`` (forward value at the j-th
    position of motor m's table) and ``table[m]-j`` (reverse)."""
    return [
        f"table[{m}]{side}{j}" for m, at in knots.items() for side in "+-" for j in range(len(at))
    ]


def _hats(p: np.ndarray, at: np.ndarray) -> np.ndarray:
    """(N, K) weights of the K table positions ``at`` in the linear interpolation at
    p (constant beyond the ends, as the table is)."""
    out = np.zeros((len(p), len(at)))
    if len(at) == 1:
        out[:, 0] = 1.0
        return out
    x = np.clip(p, at[0], at[-1])
    j = np.clip(np.searchsorted(at, x, side="right") - 1, 0, len(at) - 2)
    f = (x - at[j]) / (at[j + 1] - at[j])
    rows = np.arange(len(p))
    out[rows, j] = 1.0 - f
    out[rows, j + 1] += f
    return out


def _held_side(
    commands: np.ndarray,
    direction: np.ndarray,
    table: axiscomp.MotorTable | None,
    approach: int | None,
) -> np.ndarray:
    """(N,) ±1: the table side (forward +1, reverse −1) a part's position is held by.

    Moving, the side of the last move; after a reversal the part stands where it
    left its side until the motor has crossed the play, and is still held by that
    side: the sign of the play model's derivative with respect to the play
    (:meth:`prsxy_post.effects.Backlash.motor_term`: −1/2 forward, +1/2 reverse)."""
    if approach is not None or table is None or not table.max_play:
        return np.where(direction >= 0, 1.0, -1.0)
    fam = next(f for f in registry.FAMILIES if isinstance(f, registry.Backlash))
    ctx = registry.MotorContext(commands, table, None)
    d = fam.motor_term(commands, direction, np.zeros_like(commands), None, ctx)[:, 0]
    return np.where(d < 0, 1.0, np.where(d > 0, -1.0, np.where(direction >= 0, 1.0, -1.0)))


def _interp_rows(idx: np.ndarray, values: np.ndarray, n: int) -> np.ndarray:
    """Values (k, m) at sample indices ``idx``, linearly interpolated to 0..n-1."""
    if len(idx) == n:
        return values
    x = np.arange(n)
    return np.column_stack([np.interp(x, idx, values[:, j]) for j in range(values.shape[1])])


def _thin(n: int) -> np.ndarray:
    stride = max(1, n // JACOBIAN_POINTS)
    idx = np.arange(0, n, stride)
    return idx if idx[-1] == n - 1 else np.append(idx, n - 1)


def predict(
    model: Profile,
    data: Data,
    keys: Sequence[str] | None = None,
    *,
    with_map: bool = False,
    tables_measured: Collection[int] = (),
    table_knots: Mapping[int, np.ndarray] | None = None,
) -> Linearised:
    """Every measurement as ``model`` predicts it, and the signatures of ``keys``.

    keys : column keys (:func:`column_keys`); None for every member of the library
    with_map : add the model's virtual-axis error map to the predicted poses
    tables_measured : motors whose tables in ``model`` were measured on the machine
        as it is (calibration's laser runs): a member's signature is what it adds
        beyond what such a table already holds (:class:`prsxy_post.effects.MotorContext`)
    table_knots : motor -> the positions of its table (mm): the signatures of an
        error of each table value, per approach side (:func:`table_error_keys`):
        hat functions of the table's linear interpolation, forward values where the
        part last moved up (poses: approached from +), reverse where it moved down
    """
    pr = _Predictor(model, keys, with_map, tables_measured, table_knots)
    for n_pose, P_cmd in enumerate(data.P_pose):
        pr.poses(data, n_pose, P_cmd)
    for n_run, (r, P_cmd, vel, direction) in enumerate(
        zip(data.runs, data.P_run, data.v_run, data.dir_run, strict=True)
    ):
        pr.run(data, n_run, r, P_cmd, vel, direction)
    for a in data.axis:
        pr.axis_run(a)
    _, segs = data.measured()
    columns = {k: np.concatenate(v) for k, v in pr.cols.items()} if pr.want else {}
    return Linearised(np.concatenate(pr.preds) if pr.preds else np.zeros(0), columns, segs)


def _stacked(a: np.ndarray) -> np.ndarray:
    """(N, 5, d) per pose -> (3N + 2N, d): positions, then angles (as predicted)."""
    d = a.shape[2]
    return np.concatenate([a[:, :3, :].reshape(-1, d), a[:, 3:, :].reshape(-1, d)])


class _Predictor:
    """:func:`predict`'s work: the model's pieces, and the predictions and columns
    gathered measurement set by measurement set."""

    def __init__(
        self,
        model: Profile,
        keys: Sequence[str] | None,
        with_map: bool,
        tables_measured: Collection[int],
        table_knots: Mapping[int, np.ndarray] | None,
    ) -> None:
        keys = column_keys() if keys is None else list(keys)
        self.model = model
        self.knots = dict(table_knots or {})
        self.geo_names = [k for k in keys if registry.family(split_key(k)[0]).stage == "geometry"]
        self.motor_keys = [k for k in keys if k not in set(self.geo_names)]
        self.motor_fams = {k: registry.family(split_key(k)[0]) for k in self.motor_keys}
        self.basis_keys = table_error_keys(self.knots)
        self.want = bool(keys) or bool(self.basis_keys)
        self.theta = registry.theta_of(model, self.geo_names)
        self.steps = registry.fd_steps(self.geo_names, self.theta)
        self.emap = errormap.from_profile(model) if with_map else None
        self.tables = axiscomp.profile_tables(model)
        self.points = {
            c.motor: np.asarray(c.positions, dtype=float)
            for c in model.axis_comp
            if c.motor in tables_measured
        }
        self.preds: list[np.ndarray] = []
        self.cols: dict[str, list[np.ndarray]] = {k: [] for k in [*keys, *self.basis_keys]}
        self.motors = bool(self.motor_keys) or bool(self.knots)

    def make_geo(self, t: np.ndarray) -> kinematics.Geometry:
        return registry.geometry_at(self.model, self.geo_names, t)

    def _family(self, k: str) -> registry.MotorFamily:
        fam = self.motor_fams[k]
        assert isinstance(fam, registry.MotorFamily)
        return fam

    def motor_columns(
        self,
        sens: np.ndarray,
        P: np.ndarray,
        P_cmd: np.ndarray,
        direction: np.ndarray,
        velocity: np.ndarray,
        approach: int | None,
    ) -> dict[str, np.ndarray]:
        """(N, r, d) per key: sensitivities (N, r, 5) times each motor term (N, d)."""
        out = {}
        tables, points = self.tables, self.points
        for k in self.motor_keys:
            name, period = split_key(k)
            fam = self._family(k)
            i = MOTORS.index(fam.motor(name))
            ctx = registry.MotorContext(
                P_cmd[:, i], tables.get(MOTORS[i]), approach, points.get(MOTORS[i])
            )
            term = fam.motor_term(P[:, i], direction[:, i], velocity[:, i], period, ctx)
            out[k] = sens[:, :, i, None] * term[:, None, :]
        for m, at in self.knots.items():
            i = MOTORS.index(m)
            hats = _hats(P[:, i], at)
            held = _held_side(P_cmd[:, i], direction[:, i], tables.get(m), approach)
            for side, sign in (("+", 1.0), ("-", -1.0)):
                on = (held == sign)[:, None]
                for j in range(len(at)):
                    out[f"table[{m}]{side}{j}"] = (
                        sens[:, :, i, None] * (hats[:, j : j + 1] * on)[:, None, :]
                    )
        return out

    def poses(self, data: Data, n_pose: int, P_cmd: np.ndarray) -> None:
        """A pose set: the poses (approached from +) and their signatures."""
        Pm = simulate.actual_motors(self.model, P_cmd, approach=+1)
        y, J, xv, JP = fk_with_jacobian(
            self.make_geo, self.theta, Pm, data.guess.get(("pose", n_pose)), self.want,
            self.steps, motors=self.motors,
        )  # fmt: skip
        data.guess[("pose", n_pose)] = xv
        if self.emap is not None:
            y = y + self.emap(y)
        self.preds += [y[:, :3].ravel(), y[:, 3:].ravel()]
        if not self.want:
            return
        assert J is not None
        for j, nm in enumerate(self.geo_names):
            self.cols[nm].append(_stacked(J[:, :, j : j + 1]))
        if self.motors:
            assert JP is not None
            ones = np.ones_like(Pm)
            for k, c in self.motor_columns(JP, Pm, P_cmd, ones, np.zeros_like(Pm), +1).items():
                self.cols[k].append(_stacked(c))

    def run(
        self,
        data: Data,
        n_run: int,
        r: BallbarRun,
        P_cmd: np.ndarray,
        vel: np.ndarray,
        direction: np.ndarray,
    ) -> None:
        """A ballbar run: the bar's length less its nominal, and its signatures
        (the FK sensitivities on a thinned set of points, interpolated between)."""
        model, make_geo, theta, steps = self.model, self.make_geo, self.theta, self.steps
        Pm = simulate.actual_motors(model, P_cmd, t=r.t)
        followed = registry.SERVO_LAG.follow(model, P_cmd, r.t)  # what the play model sees
        y, _, xv, _ = fk_with_jacobian(
            make_geo, theta, Pm, data.guess.get(("run", n_run)), False, steps
        )
        data.guess[("run", n_run)] = xv
        tip = y[:, :3] + (self.emap(y)[:, :3] if self.emap is not None else 0.0)
        vec = tip - r.pivot
        dist = np.linalg.norm(vec, axis=1)
        self.preds.append(dist - r.length)
        if not self.want:
            return
        idx = _thin(len(Pm))
        _, J, _, JP = fk_with_jacobian(
            make_geo, theta, Pm[idx], xv[idx], True, steps, motors=self.motors
        )
        unit = vec[idx] / dist[idx, None]
        assert J is not None
        if self.geo_names:
            Jr = _interp_rows(idx, np.einsum("ni,nim->nm", unit, J[:, :3, :]), len(Pm))
            for j, nm in enumerate(self.geo_names):
                self.cols[nm].append(Jr[:, j : j + 1])
        if self.motors:
            assert JP is not None
            JPr = _interp_rows(idx, np.einsum("ni,nim->nm", unit, JP[:, :3, :]), len(Pm))
            sens = JPr[:, None, :]
            for k, c in self.motor_columns(sens, Pm, followed, direction, vel, None).items():
                self.cols[k].append(c[:, 0, :])

    def axis_run(self, a: AxisData) -> None:
        """A laser run along one motor: each target approached from its side, and the
        motor members' terms there (geometry and table errors do not enter)."""
        tables = self.tables
        pa = np.empty(len(a.target))
        for m in np.unique(a.motor):
            for d in (1, -1):
                sel = (a.motor == m) & (a.direction == d)
                pa[sel] = axiscomp.approach(tables.get(int(m)), a.target[sel], d)
        self.preds.append(pa)
        if not self.want:
            return
        for nm in [*self.geo_names, *self.basis_keys]:
            self.cols[nm].append(np.zeros((len(pa), 1)))
        for k in self.motor_keys:
            name, period = split_key(k)
            fam = self._family(k)
            m = fam.motor(name)
            c = np.zeros((len(pa), fam.columns()))
            for d in (1, -1):
                sel = (a.motor == m) & (a.direction == d)
                if np.any(sel):
                    ctx = registry.MotorContext(a.target[sel], tables.get(m), d, self.points.get(m))
                    c[sel] = fam.motor_term(
                        a.target[sel],
                        np.full(int(sel.sum()), float(d)),
                        np.zeros(int(sel.sum())),
                        period,
                        ctx,
                    )
            self.cols[k].append(c)
