"""Every physical effect the project models, in one registry.

A *family* is one kind of effect (a strut's length, a bowed guide, a motor's
backlash); its *members* are the named instances a report and a profile speak of
(``kinematics.legs[2].strut_length``, ``effects.guide_bow[1]``, ``backlash[5]``).
Each family says, in one place:

- its name pattern and the members it has;
- its unit and its prior: the typical size on a machine as built (1 σ), which
  scales calibration steps and identifiability, and sizes random test machines;
- its profile home (where a size is written) and, for the project's ``[effects]``
  section, how its keys are read and checked;
- how the simulator applies it and how the conversion compensates it (the
  functions named in ``simulated_by`` / ``compensated_by``; the tests hold the
  names to real functions);
- how diagnosis sees it: a geometry term enters the forward kinematics (its
  signature is ∂y/∂θ), a motor term displaces the driven part of a motor by
  ``size × motor_term`` (its signature is the motor sensitivity ∂y/∂P times that);
- how a report names it (one sentence a machine-tool engineer would write).

``diagnose``, ``calibrate``, ``simulate``, ``profile`` and the conversion chain
read this registry; nothing else dispatches on effect names. Adding an effect is
one :class:`Family` entry in :data:`FAMILIES` (see ``docs/architecture.md``,
"Adding an effect").
"""

from __future__ import annotations

import copy
from collections.abc import Collection, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from .profile import (
    LEG_OPTIONAL,
    LEG_REQUIRED,
    MOTORS,
    Effects,
    KinematicParams,
    Leg,
    Profile,
    TableParams,
)

if TYPE_CHECKING:
    from . import axiscomp, kinematics

LEG_KEYS = LEG_REQUIRED + LEG_OPTIONAL
MOTOR_INDEX = {m: i for i, m in enumerate(MOTORS)}

#: Pitches scanned for cyclic errors [mm]: ball screws, encoders, linear-motor poles.
CYCLIC_PERIODS = (1.0, 2.0, 2.5, 4.0, 5.0, 6.0, 8.0, 10.0, 12.0, 16.0, 20.0, 25.0, 32.0, 40.0, 50.0)


@dataclass(frozen=True)
class Change:
    """A change to one member: ``delta`` added to its size (a new term for a motor
    family); ``period`` [mm] and ``phase`` [deg] for periodic terms."""

    name: str
    delta: float
    period: float | None = None
    phase: float | None = None


# ---------------------------------------------------------------- families


@dataclass(frozen=True)
class Family:
    """One kind of effect (module docstring). Subclasses fill in the behaviour."""

    key: str
    pattern: str
    unit: str
    prior: float
    home: str
    simulated_by: str
    compensated_by: str
    #: "geometry": a term of the forward kinematics; "motor": a displacement of a motor
    stage: ClassVar[str] = "geometry"
    #: the keys of the ``[effects]`` section this family owns
    effects_keys: ClassVar[tuple[str, ...]] = ()

    def members(self) -> tuple[str, ...]:
        raise NotImplementedError

    def owns(self, name: str) -> bool:
        return name in self.members()

    def index(self, name: str) -> int:
        """Position of a member in :meth:`members` (leg, motor or axis number order)."""
        return self.members().index(name)

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        return f"{name} differs from the profile by {size:+.4g} {self.unit}."

    def random_change(self, name: str, rng: np.random.Generator, scale: float = 1.0) -> Change:
        """A realistic error of this member: 0.5 to 2 times its prior (× scale),
        either sign."""
        return Change(name, _signed(rng) * _magnitude(rng, self.prior * scale))

    def lower_bound(self, name: str, profile: Profile) -> float:
        """The least change ``profile`` can take for this member: below it the
        model does not go on (it folds back), so no estimate may lie there."""
        return -np.inf

    # geometry families: a member is a number of the profile, held in a list or
    # dict of Parts (``slot``) and of the profile document (``doc_slot``)
    def slot(self, parts: Parts, name: str) -> tuple[Any, Any]:
        """The container in ``parts`` holding member ``name``, and its key there."""
        raise NotImplementedError

    def doc_slot(self, doc: dict[str, Any], name: str) -> tuple[Any, Any]:
        """The container in a profile document holding member ``name`` (made where
        missing), and its key there."""
        raise NotImplementedError

    def value(self, parts: Parts, name: str) -> float:
        c, k = self.slot(parts, name)
        return float(c[k])

    def set_value(self, parts: Parts, name: str, value: float) -> None:
        c, k = self.slot(parts, name)
        c[k] = value

    def fd_step(self, value: float) -> float:
        """Central-difference step for its signature."""
        return 1e-6

    # every family
    def write(self, doc: dict[str, Any], profile: Profile, change: Change) -> None:
        """Add ``change`` to a profile document, at the family's profile home (a
        geometry member: its value in ``profile`` plus the change)."""
        c, k = self.doc_slot(doc, change.name)
        c[k] = float(self.value(Parts.of(profile), change.name) + change.delta)


@dataclass
class Parts:
    """A profile's geometry terms in an editable form (for θ vectors)."""

    tool: dict[str, float]
    legs: list[dict[str, float]]
    table: dict[str, float]
    guide_bow: list[float]
    table_straightness: list[float]
    effects: Effects
    origin: np.ndarray

    @classmethod
    def of(cls, profile: Profile) -> Parts:
        kp, tb, e = profile.kinematics, profile.table, profile.effects
        return cls(
            {
                "tool_length": kp.tool_length,
                "tool_offset_x": kp.tool_offset_x,
                "tool_offset_y": kp.tool_offset_y,
            },
            [{k: float(getattr(leg, k)) for k in LEG_KEYS} for leg in kp.legs],
            {"scale_x": tb.scale_x, "scale_y": tb.scale_y, "squareness": tb.squareness},
            list(e.guide_bow),
            list(e.table_straightness),
            e,
            profile.origin,
        )

    def copy(self) -> Parts:
        return Parts(
            dict(self.tool),
            [dict(leg) for leg in self.legs],
            dict(self.table),
            list(self.guide_bow),
            list(self.table_straightness),
            self.effects,
            self.origin,
        )

    def kinematic_params(self) -> KinematicParams:
        legs = tuple(Leg(**leg) for leg in self.legs)
        return KinematicParams(
            self.tool["tool_length"],
            (legs[0], legs[1], legs[2]),
            self.tool["tool_offset_x"],
            self.tool["tool_offset_y"],
        )

    def table_params(self) -> TableParams:
        return TableParams(self.table["scale_x"], self.table["scale_y"], self.table["squareness"])

    def effects_value(self) -> Effects:
        b, s = self.guide_bow, self.table_straightness
        return Effects(
            (b[0], b[1], b[2]),
            (s[0], s[1]),
            self.effects.servo_lag_ms,
            self.effects.cyclic,
        )

    def geometry(self) -> kinematics.Geometry:
        from . import kinematics

        return kinematics.Geometry.from_params(
            self.kinematic_params(), self.origin, self.table_params(), self.effects_value()
        )


_CONTRACT_SIM = "kinematics.Geometry.from_params"
_CONTRACT_COMP = "kinematics.inverse"


def _effects_vector(doc: dict[str, Any], key: str, n: int) -> list[float]:
    """The ``[effects]`` vector ``key`` of a profile document as a list of floats
    (n zeros where absent), put back into the document."""
    eff = doc.setdefault("effects", {})
    eff[key] = [float(x) for x in eff.get(key, [0.0] * n)]
    return eff[key]


@dataclass(frozen=True)
class ToolTerm(Family):
    """``kinematics.tool_length``, ``tool_offset_x``, ``tool_offset_y`` (contract)."""

    def members(self) -> tuple[str, ...]:
        return (f"kinematics.{self.key}",)

    def slot(self, parts: Parts, name: str) -> tuple[Any, Any]:
        return parts.tool, self.key

    def doc_slot(self, doc: dict[str, Any], name: str) -> tuple[Any, Any]:
        return doc.setdefault("kinematics", {}), self.key

    def fd_step(self, value: float) -> float:
        return 1e-6 * max(1.0, abs(value))

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        return f"The tool's {self.key.replace('_', ' ')} is off by {size:+.4f} mm."


@dataclass(frozen=True)
class LegTerm(Family):
    """A contract key of each leg: ``kinematics.legs[i].<key>``."""

    def members(self) -> tuple[str, ...]:
        return tuple(f"kinematics.legs[{i}].{self.key}" for i in (1, 2, 3))

    def slot(self, parts: Parts, name: str) -> tuple[Any, Any]:
        return parts.legs[self.index(name)], self.key

    def doc_slot(self, doc: dict[str, Any], name: str) -> tuple[Any, Any]:
        return doc["kinematics"]["legs"][self.index(name)], self.key

    def fd_step(self, value: float) -> float:
        return 1e-6 * max(1.0, abs(value))

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        leg = self.index(name) + 1
        if self.key == "strut_length":
            return (
                f"Strut {leg} is {abs(size) * 1000:.1f} µm "
                f"{'longer' if size > 0 else 'shorter'} than the profile says."
            )
        what = self.key.replace("_", " ")
        return f"Leg {leg}: the {what} is off by {size:+.4g} {self.unit} from the profile."


@dataclass(frozen=True)
class TableTerm(Family):
    """``table.scale_x``, ``table.scale_y``, ``table.squareness`` (contract)."""

    def members(self) -> tuple[str, ...]:
        return (f"table.{self.key}",)

    def slot(self, parts: Parts, name: str) -> tuple[Any, Any]:
        return parts.table, self.key

    def doc_slot(self, doc: dict[str, Any], name: str) -> tuple[Any, Any]:
        return doc.setdefault("table", {}), self.key

    def fd_step(self, value: float) -> float:
        return 1e-7

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        if self.key == "squareness":
            return (
                f"The X-Y table is out of square by {size * 1000:+.4f} mm/m "
                "(positive: the Y motion leans towards +X)."
            )
        axis = self.key[-1].upper()
        return f"The table's {axis} axis scale is off by {size * 1e6:+.2f} µm/m."


@dataclass(frozen=True)
class GuideBow(Family):
    """A guide bowed in its radial direction: hinge centre
    a_i = g_i + P_i d_i + b_i (P_i / 100 mm)² r_i (``effects.guide_bow``, mm)."""

    effects_keys: ClassVar[tuple[str, ...]] = ("guide_bow",)

    def members(self) -> tuple[str, ...]:
        return tuple(f"effects.guide_bow[{i}]" for i in (1, 2, 3))

    def slot(self, parts: Parts, name: str) -> tuple[Any, Any]:
        return parts.guide_bow, self.index(name)

    def doc_slot(self, doc: dict[str, Any], name: str) -> tuple[Any, Any]:
        return _effects_vector(doc, "guide_bow", 3), self.index(name)

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        return (
            f"Guide {self.index(name) + 1} is bowed by {size * 1000:+.2f} µm at 100 mm of travel."
        )


@dataclass(frozen=True)
class TableStraightness(Family):
    """Curved table axes: the X motion bends towards +Y by k_x (P5 / 1000)², the Y
    motion towards +X by k_y (P6 / 1000)² (``effects.table_straightness``, mm/m²)."""

    effects_keys: ClassVar[tuple[str, ...]] = ("table_straightness",)

    def members(self) -> tuple[str, ...]:
        return ("effects.table_straightness[1]", "effects.table_straightness[2]")

    def slot(self, parts: Parts, name: str) -> tuple[Any, Any]:
        return parts.table_straightness, self.index(name)

    def doc_slot(self, doc: dict[str, Any], name: str) -> tuple[Any, Any]:
        return _effects_vector(doc, "table_straightness", 2), self.index(name)

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        axis = "XY"[self.index(name)]
        return f"The table's {axis} motion is curved by {size:+.4f} mm/m²."


@dataclass(frozen=True)
class MotorContext:
    """What a motor term may need beyond the part's positions: the motor's
    commands (N,) [mm], the model's table of that motor (its play model), how
    the points were approached (None: one continuous motion; ±1: each point on its
    own from that side), and the points of the motor's table when that table was
    measured on the machine as it is (calibration's laser runs: the table holds
    every static position error sampled at its points and interpolated between
    them; None when the table is the profile's own, whatever the machine does)."""

    commands: np.ndarray
    table: axiscomp.MotorTable | None
    approach: int | None
    measured_at: np.ndarray | None = None


@dataclass(frozen=True)
class MotorFamily(Family):
    """An effect acting on one motor's driven part (members ``<key>[m]``)."""

    stage: ClassVar[str] = "motor"
    #: extra values a member is scanned over (periods of a cyclic error)
    variants: tuple[float, ...] = field(default=())

    def members(self) -> tuple[str, ...]:
        return tuple(f"{self.key}[{m}]" for m in MOTORS)

    def motor(self, name: str) -> int:
        return MOTORS[self.index(name)]

    def motor_term(
        self,
        position: np.ndarray,
        direction: np.ndarray,
        velocity: np.ndarray,
        period: float | None = None,
        context: MotorContext | None = None,
    ) -> np.ndarray:
        """Displacement of the driven part per unit size, (N, d) [mm per unit].

        position : (N,) where the part is [mm]; direction : (N,) ±1, the side the
        motor last moved from; velocity : (N,) command velocity [mm/s] (0 for
        points approached on their own); period : of a periodic term [mm];
        context : the commands and the model's table of this motor."""
        raise NotImplementedError

    def columns(self) -> int:
        return 1

    def held_by_table(self, change: Change, points: np.ndarray) -> np.ndarray | None:
        """What a table measured at ``points`` [mm] holds of ``change`` (N,) [mm],
        forward and reverse alike: the static position error it adds there; None
        for an effect a laser run does not see as such (the play is held as the
        table's reversal value, and an extra backlash is what the table lacks)."""
        return None


@dataclass(frozen=True)
class Backlash(MotorFamily):
    """Play of a motor: forward error − b/2, reverse + b/2 (full reversal value b)."""

    def motor_term(
        self,
        position: np.ndarray,
        direction: np.ndarray,
        velocity: np.ndarray,
        period: float | None = None,
        context: MotorContext | None = None,
    ) -> np.ndarray:
        table = context.table if context is not None else None
        if context is None or context.approach is not None or table is None or not table.max_play:
            return (-0.5 * direction)[:, None]
        # a motion through a table with play: after a reversal the part stands
        # until the motor has crossed the play, so the sign of the last move is
        # not yet the side the part sits on. Differentiate the play model itself.
        from . import axiscomp

        eps = 1e-6
        wide = axiscomp.MotorTable(
            table.motor, table.breaks, table.lo_err - eps / 2, table.hi_err + eps / 2, table.cyclic
        )
        narrow = axiscomp.MotorTable(
            table.motor, table.breaks, table.lo_err + eps / 2, table.hi_err - eps / 2, table.cyclic
        )
        y_w = axiscomp.play_model(wide, context.commands)
        y_n = axiscomp.play_model(narrow, context.commands)
        return ((y_w - y_n) / (2 * eps))[:, None]

    def write(self, doc: dict[str, Any], profile: Profile, change: Change) -> None:
        m = self.motor(change.name)
        comps = doc.setdefault("axis_comp", [])
        entry = next((c for c in comps if c["motor"] == m), None)
        if entry is None:
            mc = profile.motor(m)
            entry = {
                "motor": m,
                "positions": [mc.min, mc.max],
                "forward": [0.0, 0.0],
                "reverse": [0.0, 0.0],
            }
            comps.append(entry)
            comps.sort(key=lambda c: c["motor"])
        entry["forward"] = [float(x) - change.delta / 2 for x in entry["forward"]]
        entry["reverse"] = [float(x) + change.delta / 2 for x in entry["reverse"]]

    def random_change(self, name: str, rng: np.random.Generator, scale: float = 1.0) -> Change:
        return Change(name, _magnitude(rng, self.prior * scale))  # play is never negative

    def lower_bound(self, name: str, profile: Profile) -> float:
        """Minus the least play of the motor's table (0 without one): a table's
        play is |reverse − forward| (:meth:`prsxy_post.axiscomp.MotorTable.from_comp`),
        so a change taking reverse − forward below zero anywhere does not take
        play away but adds it on the other side, where the signature −direction/2
        is of the wrong sign."""
        m = self.motor(name)
        comp = next((c for c in profile.axis_comp if c.motor == m), None)
        if comp is None:
            return 0.0
        play = np.asarray(comp.reverse, dtype=float) - np.asarray(comp.forward, dtype=float)
        return -max(float(np.min(play)), 0.0)

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        return (
            f"Motor {self.motor(name)} has {size * 1000:.2f} µm "
            f"{'more' if size >= 0 else 'less'} backlash than its table holds."
        )


@dataclass(frozen=True)
class CyclicError(MotorFamily):
    """A periodic positioning error, both directions alike:
    amplitude · sin(2π p / period + phase) (``[[effects.cyclic]]``)."""

    effects_keys: ClassVar[tuple[str, ...]] = ("cyclic",)

    def columns(self) -> int:
        return 2

    def motor_term(
        self,
        position: np.ndarray,
        direction: np.ndarray,
        velocity: np.ndarray,
        period: float | None = None,
        context: MotorContext | None = None,
    ) -> np.ndarray:
        assert period is not None

        def term(p: np.ndarray) -> np.ndarray:
            ph = 2 * np.pi * p / period
            return np.column_stack([np.sin(ph), np.cos(ph)])

        out = term(position)
        pts = context.measured_at if context is not None else None
        if pts is not None and len(pts) > 1:
            # a table measured with the error present holds it at its points and
            # interpolates linearly between them (constant beyond them), and the
            # table is made again without it once it is named: what the term adds
            # is the error less that interpolation (a pitch shorter than twice the
            # spacing of the points shows in the table as its alias)
            at = term(pts)
            out = out - np.column_stack([np.interp(position, pts, at[:, j]) for j in range(2)])
        return out

    def held_by_table(self, change: Change, points: np.ndarray) -> np.ndarray | None:
        from . import axiscomp

        term = (change.delta, float(change.period or 0.0), float(change.phase or 0.0))
        return np.asarray(axiscomp.cyclic_error(points, (term,)))

    def write(self, doc: dict[str, Any], profile: Profile, change: Change) -> None:
        eff = doc.setdefault("effects", {})
        eff.setdefault("cyclic", []).append(
            {
                "motor": self.motor(change.name),
                "amplitude": float(change.delta),
                "period": float(change.period or 0.0),
                "phase": float(change.phase or 0.0),
            }
        )

    def random_change(self, name: str, rng: np.random.Generator, scale: float = 1.0) -> Change:
        amp = _magnitude(rng, self.prior * scale)
        return Change(
            name,
            amp,
            period=float(rng.choice(self.variants)),
            phase=float(rng.uniform(-180.0, 180.0)),
        )

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        return (
            f"Motor {self.motor(name)} has a periodic error of {size * 1000:.2f} µm amplitude "
            f"with a {period or 0:g} mm pitch."
        )


@dataclass(frozen=True)
class ServoLag(MotorFamily):
    """A motor following its command τ late: on a moving axis the part is where
    the command was τ ago, an error −τ·v that flips with the direction
    (``effects.servo_lag_ms``, per motor 1, 2, 3, 5, 6)."""

    effects_keys: ClassVar[tuple[str, ...]] = ("servo_lag_ms",)

    def motor_term(
        self,
        position: np.ndarray,
        direction: np.ndarray,
        velocity: np.ndarray,
        period: float | None = None,
        context: MotorContext | None = None,
    ) -> np.ndarray:
        return (-velocity * 1e-3)[:, None]  # per ms

    def write(self, doc: dict[str, Any], profile: Profile, change: Change) -> None:
        eff = doc.setdefault("effects", {})
        v = [float(x) for x in eff.get("servo_lag_ms", [0.0] * len(MOTORS))]
        v[self.index(change.name)] += change.delta
        eff["servo_lag_ms"] = v

    def sentence(self, name: str, size: float, period: float | None = None) -> str:
        return (
            f"Motor {self.motor(name)} lags its command by {size:+.3f} ms more than the "
            "others (servo mismatch)."
        )

    # -- the physics (simulator and conversion both use these)
    @staticmethod
    def lags_s(profile: Profile) -> np.ndarray:
        """Each motor's lag τ (5,) [s] from ``effects.servo_lag_ms``."""
        return np.asarray(profile.effects.servo_lag_ms, dtype=float) / 1000.0

    @staticmethod
    def velocity(P: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Central-difference velocity (P_{k+1} − P_{k−1}) / (t_{k+1} − t_{k−1}); 0 at
        both ends. (N, 5) [mm/s]."""
        v = np.zeros_like(P)
        if len(P) > 2:
            span = np.maximum(t[2:] - t[:-2], 1e-9)
            v[1:-1] = (P[2:] - P[:-2]) / span[:, None]
        return v

    def follow(self, profile: Profile, c: np.ndarray, t: np.ndarray | None) -> np.ndarray:
        """Where lagging motors are for commands c (the simulator): m = c − τ · v(m),
        v as central differences (zero at the ends), solved as a banded system.
        The commanding side leads by the chain's formula, :func:`chain.servo_lead`."""
        from scipy.linalg import solve_banded

        lag = self.lags_s(profile)
        if t is None or not np.any(lag) or len(c) < 3:
            return c
        out = c.copy()
        n = len(c)
        span = np.maximum(t[2:] - t[:-2], 1e-9)
        for col in range(c.shape[1]):
            if not lag[col]:
                continue
            a = lag[col] / span  # rows 1..n-2: −a m_{k−1} + m_k + a m_{k+1} = c_k
            ab = np.zeros((3, n))
            ab[1] = 1.0
            ab[0, 2:] = a  # super-diagonal of row k at column k+1
            ab[2, :-2] = -a  # sub-diagonal of row k at column k−1
            out[:, col] = solve_banded((1, 1), ab, c[:, col])
        return out


def _magnitude(rng: np.random.Generator, typical: float) -> float:
    return float(typical * rng.uniform(0.5, 2.0))


def _signed(rng: np.random.Generator) -> float:
    return float(rng.choice([-1.0, 1.0]))


# ---------------------------------------------------------------- the registry

_SIM_TABLE = "axiscomp.play_model"
_COMP_TABLE = "axiscomp.compensate"


def _contract() -> list[Family]:
    deg = "deg"
    out: list[Family] = [
        ToolTerm("tool_length", "kinematics.tool_length", "mm", 0.04, "kinematics.tool_length",
                 _CONTRACT_SIM, _CONTRACT_COMP),
        ToolTerm("tool_offset_x", "kinematics.tool_offset_x", "mm", 0.02,
                 "kinematics.tool_offset_x", _CONTRACT_SIM, _CONTRACT_COMP),
        ToolTerm("tool_offset_y", "kinematics.tool_offset_y", "mm", 0.02,
                 "kinematics.tool_offset_y", _CONTRACT_SIM, _CONTRACT_COMP),
    ]  # fmt: skip
    leg_units_priors = {
        "guide_radius": ("mm", 0.05),
        "guide_angle": (deg, 0.02),
        "guide_height": ("mm", 0.05),
        "strut_length": ("mm", 0.05),
        "platform_radius": ("mm", 0.05),
        "platform_angle": (deg, 0.02),
        "guide_tilt_x": (deg, 0.01),
        "guide_tilt_y": (deg, 0.01),
        "hinge_twist": (deg, 0.03),
        "platform_z": ("mm", 0.04),
    }
    for key in LEG_KEYS:
        unit, prior = leg_units_priors[key]
        pattern = f"kinematics.legs[i].{key}"
        out.append(LegTerm(key, pattern, unit, prior, pattern, _CONTRACT_SIM, _CONTRACT_COMP))
    for key, unit, prior in (
        ("scale_x", "1", 4e-5),
        ("scale_y", "1", 4e-5),
        ("squareness", "rad", 1e-4),
    ):
        out.append(
            TableTerm(key, f"table.{key}", unit, prior, f"table.{key}", _CONTRACT_SIM,
                      _CONTRACT_COMP)
        )  # fmt: skip
    return out


#: Every family, contract parameters first. Adding an effect: one entry here.
FAMILIES: tuple[Family, ...] = (
    *_contract(),
    GuideBow(
        "guide_bow",
        "effects.guide_bow[i]",
        "mm",
        0.01,
        "effects.guide_bow (per leg)",
        "kinematics.Geometry.hinge_offset",
        "kinematics.inverse",
    ),
    TableStraightness(
        "table_straightness",
        "effects.table_straightness[i]",
        "mm/m^2",
        0.05,
        "effects.table_straightness (X motion, Y motion)",
        "kinematics.table_displacement",
        "kinematics.table_motors",
    ),
    Backlash(
        "backlash",
        "backlash[m]",
        "mm",
        0.004,
        "[[axis_comp]] of motor m: forward − b/2, reverse + b/2",
        _SIM_TABLE,
        _COMP_TABLE,
    ),
    CyclicError(
        "cyclic",
        "cyclic[m]",
        "mm",
        0.003,
        "[[effects.cyclic]] (motor, amplitude, period, phase)",
        "axiscomp.MotorTable.lo",
        "axiscomp.MotorTable.lo_inv",
        CYCLIC_PERIODS,
    ),
    ServoLag(
        "servo_lag",
        "servo_lag[m]",
        "ms",
        1.0,
        "effects.servo_lag_ms (per motor 1, 2, 3, 5, 6)",
        "effects.SERVO_LAG.follow",
        "chain.servo_lead",
    ),
)

_BY_NAME: dict[str, Family] = {n: f for f in FAMILIES for n in f.members()}

#: The servo-lag family (its lags are used by the simulator and the chain).
SERVO_LAG: ServoLag = next(f for f in FAMILIES if isinstance(f, ServoLag))


def family(name: str) -> Family:
    """The family of a member name.

    Raises
    ------
    KeyError
        For a name no family has (the message lists the patterns).
    """
    try:
        return _BY_NAME[name]
    except KeyError:
        raise KeyError(
            f"unknown effect {name!r} (known: {', '.join(f.pattern for f in FAMILIES)})"
        ) from None


def members(stage: str | None = None) -> list[str]:
    """Every member name, in registry order; optionally of one stage only."""
    return [n for f in FAMILIES if stage in (None, f.stage) for n in f.members()]


def unit(name: str) -> str:
    return family(name).unit


def prior(name: str) -> float:
    return family(name).prior


def lower_bound(name: str, profile: Profile) -> float:
    """The least change of a member ``profile`` can take (:meth:`Family.lower_bound`)."""
    return family(name).lower_bound(name, profile)


#: The contract's parameters, in calibration's θ order (tool, legs 1..3, table).
CONTRACT: tuple[str, ...] = (
    "kinematics.tool_length",
    "kinematics.tool_offset_x",
    "kinematics.tool_offset_y",
    *(f"kinematics.legs[{i}].{k}" for i in (1, 2, 3) for k in LEG_KEYS),
    "table.scale_x",
    "table.scale_y",
    "table.squareness",
)
#: Every geometry member: the contract's, then the project's (bows, straightness).
GEOMETRY: tuple[str, ...] = CONTRACT + tuple(
    n for n in members("geometry") if n not in set(CONTRACT)
)
MOTOR_MEMBERS: tuple[str, ...] = tuple(members("motor"))


def theta_of(profile: Profile, names: Sequence[str] = CONTRACT) -> np.ndarray:
    """Values of geometry members in a profile, in the order of ``names``."""
    parts = Parts.of(profile)
    return np.array([family(n).value(parts, n) for n in names], dtype=float)


def geometry_at(profile: Profile, names: Sequence[str], theta: np.ndarray) -> kinematics.Geometry:
    """The profile's geometry with the members ``names`` set to ``theta``."""
    return parts_at(profile, names, theta).geometry()


def parts_at(profile: Profile, names: Sequence[str], theta: np.ndarray) -> Parts:
    parts = Parts.of(profile)
    for n, v in zip(names, theta, strict=True):
        family(n).set_value(parts, n, float(v))
    return parts


def fd_steps(names: Sequence[str], theta: np.ndarray) -> np.ndarray:
    """Central-difference steps of geometry members at values ``theta``."""
    return np.array([family(n).fd_step(float(t)) for n, t in zip(names, theta, strict=True)])


def apply(
    doc: Mapping[str, Any],
    profile: Profile,
    changes: Sequence[Change],
    tables_measured: Collection[int] = (),
) -> dict[str, Any]:
    """A copy of profile document ``doc`` (of ``profile``) with ``changes`` added.

    Geometry members are set to their value in ``profile`` plus the change (all
    changes to one member add up); motor members add their term at their home.
    ``tables_measured``: motors whose ``[[axis_comp]]`` tables were measured on
    the machine as it is (calibration's laser runs); a motor term such a table
    holds at its points (:meth:`MotorFamily.held_by_table`: a cyclic error) is
    taken out of the table as it is added, as making the table again from the
    same runs without it would.
    """
    out = copy.deepcopy(dict(doc))
    total: dict[str, float] = {}
    for ch in changes:
        fam = family(ch.name)
        if fam.stage == "geometry":
            total[ch.name] = total.get(ch.name, 0.0) + ch.delta
            continue
        fam.write(out, profile, ch)
        assert isinstance(fam, MotorFamily)
        m = fam.motor(ch.name)
        entry = next((c for c in out.get("axis_comp", []) if c["motor"] == m), None)
        if m in tables_measured and entry is not None:
            held = fam.held_by_table(ch, np.asarray(entry["positions"], dtype=float))
            if held is not None:
                entry["forward"] = (np.asarray(entry["forward"], dtype=float) - held).tolist()
                entry["reverse"] = (np.asarray(entry["reverse"], dtype=float) - held).tolist()
    if total:
        out.setdefault("kinematics", {}).setdefault("legs", [{}, {}, {}])
        for n, d in total.items():
            family(n).write(out, profile, Change(n, d))
    return out


def iter_families(stage: str | None = None) -> Iterator[Family]:
    return (f for f in FAMILIES if stage in (None, f.stage))
