"""The profile's types: its sections as frozen dataclasses, the motor order and
the defaults. Nothing here reads a file; :mod:`prsxy_post.profile` validates a
document into these."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from typing import Any, NamedTuple

import numpy as np

#: The motors, by number, in the column order of every motor-space array
#: (``P: (N, 5) ndarray [mm]`` holds P1, P2, P3, P5, P6). There is no motor 4.
MOTORS = (1, 2, 3, 5, 6)
DEFAULT_AXIS_NAMES = {1: "U", 2: "V", 3: "W", 5: "X", 6: "Y"}

LEG_REQUIRED = (
    "guide_radius",
    "guide_angle",
    "guide_height",
    "strut_length",
    "platform_radius",
    "platform_angle",
)
LEG_OPTIONAL = ("guide_tilt_x", "guide_tilt_y", "hinge_twist", "platform_z")
KIN_REQUIRED = ("tool_length",)
KIN_OPTIONAL = ("tool_offset_x", "tool_offset_y")
TABLE_KEYS = ("scale_x", "scale_y", "squareness")


@dataclass(frozen=True)
class MachineLimits:
    """The ``[limits]`` section: what the machine can do and what a job may cost.

    max_tilt_deg : largest tool-axis tilt from vertical [deg]
    max_feed_mm_min : largest programmed feed F [mm/min]
    rapid_mm_min : G0 speed along the XYZ path [mm/min]
    rapid_deg_min : G0 speed of A/B-only moves, and the cap on A/B rates [deg/min]
    max_accel_mm_s2 : path acceleration the look-ahead plans with [mm/s²]
    max_accel_deg_s2 : A/B acceleration [deg/s²]
    max_points : a program that would interpolate to more points is refused
    max_time_s : ... or one that would run longer [s]
    """

    max_tilt_deg: float = 30.0
    max_feed_mm_min: float = 30000.0
    rapid_mm_min: float = 10000.0
    rapid_deg_min: float = 3600.0
    max_accel_mm_s2: float = 2000.0
    max_accel_deg_s2: float = 3600.0
    max_points: int = 50_000_000
    max_time_s: float = 360_000.0


@dataclass(frozen=True)
class Interpolation:
    """``[interpolation]``: how programs become points.

    period_ms : the coarse interpolation period [ms]
    path_tolerance_mm : how far the motion the controller runs between points may
        leave the programmed path where the program sets no ``G64 P`` [mm]
    path_tolerance_arcsec : the same for the tool axis [arcsec]
    reversal_ms : the longest window in which a motor with play crosses it [ms]
    """

    period_ms: float = 10.0
    path_tolerance_mm: float = 0.0005
    path_tolerance_arcsec: float = 0.5
    reversal_ms: float = 1.0


class Tool(NamedTuple):
    """One ``[[tools]]`` entry: G43 H<number> adds ``length`` [mm] to the tool length."""

    length: float
    diameter: float = 0.0


#: Defaults of the project's own sections. Each key is documented in profiles/README.md.
DEFAULTS: dict[str, dict[str, Any]] = {
    "limits": {f.name: f.default for f in fields(MachineLimits)},
    "interpolation": {f.name: f.default for f in fields(Interpolation)},
    "start": {"pose": [0.0, 0.0, 0.0, 0.0, 0.0]},
    "gcode": {
        "g28": [0.0, 0.0, 0.0, 0.0, 0.0],
        "g30": [0.0, 0.0, 0.0, 0.0, 0.0],
        "subroutine_path": [],  # directories (relative: to the profile's folder)
        "max_loop_passes": 10_000_000,
        "user_m_codes": [],  # M100..M199 the controller has
    },
}

DEFAULT_MOTOR_LIMITS = {1: (-200.0, 200.0), 2: (-200.0, 200.0), 3: (-200.0, 200.0)}
DEFAULT_TABLE_LIMITS = (-300.0, 300.0)


@dataclass(frozen=True)
class Leg:
    """One PRS leg, in the units of the file (mm, degrees)."""

    guide_radius: float
    guide_angle: float
    guide_height: float
    strut_length: float
    platform_radius: float
    platform_angle: float
    guide_tilt_x: float = 0.0
    guide_tilt_y: float = 0.0
    hinge_twist: float = 0.0
    platform_z: float = 0.0


@dataclass(frozen=True)
class KinematicParams:
    """The ``[kinematics]`` (or ``[controller_kinematics]``) section."""

    tool_length: float
    legs: tuple[Leg, Leg, Leg]
    tool_offset_x: float = 0.0
    tool_offset_y: float = 0.0


@dataclass(frozen=True)
class TableParams:
    """The ``[table]`` section: scale errors (dimensionless), squareness (rad)."""

    scale_x: float = 0.0
    scale_y: float = 0.0
    squareness: float = 0.0


@dataclass(frozen=True)
class Effects:
    """Physical effects beyond the contract's terms (the ``[effects]`` section).

    guide_bow : per leg, radial bow of the guide [mm] at 100 mm of travel
        (hinge centre a_i = g_i + P_i d_i + b_i (P_i / 100)² r_i)
    table_straightness : (k_x, k_y) [mm/m²]: the X motion bends towards +Y by
        k_x (P5 / 1000)², the Y motion towards +X by k_y (P6 / 1000)²
    servo_lag_ms : per motor 1, 2, 3, 5, 6: how far the motor follows behind its
        command [ms]; the part is where the command was that long ago, so on a
        moving axis the error is −lag · velocity and flips with direction
    cyclic : periodic positioning errors per motor, added to both directions of
        its real-axis error: amplitude · sin(2π p / period + phase)
    """

    guide_bow: tuple[float, float, float] = (0.0, 0.0, 0.0)
    table_straightness: tuple[float, float] = (0.0, 0.0)
    servo_lag_ms: tuple[float, float, float, float, float] = (0.0, 0.0, 0.0, 0.0, 0.0)
    cyclic: tuple[Cyclic, ...] = ()


@dataclass(frozen=True)
class Cyclic:
    """A periodic error of one motor [mm, mm, deg]."""

    motor: int
    amplitude: float
    period: float
    phase: float = 0.0


@dataclass(frozen=True)
class AxisComp:
    """One ``[[axis_comp]]`` table (contract: real-axis error per motor)."""

    motor: int
    positions: np.ndarray
    forward: np.ndarray
    reverse: np.ndarray


@dataclass(frozen=True)
class MotorConfig:
    """Output name, resolution and travel of one motor."""

    motor: int
    axis: str
    counts_per_mm: float
    min: float
    max: float


@dataclass(frozen=True)
class Profile:
    """A validated machine profile.

    ``raw`` is the parsed document as the user wrote it (no defaults filled in),
    with the keys this version only carries along (the error map, provenance
    notes); treat it as read-only. The tool changes a profile file with
    :func:`prsxy_post.profile.update.update_text` on ``text``.
    """

    name: str
    origin: np.ndarray  # (3,) mm, machine frame
    kinematics: KinematicParams
    table: TableParams
    axis_comp: tuple[AxisComp, ...]
    controller_kinematics: KinematicParams | None
    effects: Effects
    motors: tuple[MotorConfig, ...]
    limits: MachineLimits
    period_ms: float
    start: np.ndarray  # (5,) workpiece frame
    work_offsets: Mapping[int, tuple[float, float, float, float, float]]
    g28: tuple[float, float, float, float, float]
    g30: tuple[float, float, float, float, float]
    tools: Mapping[int, Tool]  # by tool number
    #: ``[output.<dialect>]`` sections, validated, with their defaults
    output: Mapping[str, Mapping[str, Any]]
    raw: dict[str, Any] = field(repr=False)
    #: ``[interpolation]`` with its defaults
    interpolation: Interpolation = field(default_factory=Interpolation)
    #: what the user should know about the file: deprecated keys and where they went
    notes: tuple[str, ...] = ()
    source: str = "<profile>"
    #: the [gcode] section as read (with its defaults)
    gcode: Mapping[str, Any] = field(default_factory=dict)
    #: the TOML text it was read from ("" when made from a document), for
    #: :func:`prsxy_post.profile.update.update_text`
    text: str = field(default="", repr=False)

    def motor(self, m: int) -> MotorConfig:
        for mc in self.motors:
            if mc.motor == m:
                return mc
        raise KeyError(m)
