"""The scenario as a record: ``Scenario`` and its ``Instrument``, ``BrightObject`` and
``KeepIn`` records, SI units, frames in the names.

A scenario is loaded and checked by :mod:`attitude_core.config.scenario_loader`; this
module only holds what it loads, with the views every consumer shares (the sky, the
cone geometry, the arrival bands, the knowledge of the declared sensors). The flight
software never sees a scenario: :mod:`attitude_core.assembly` builds it from one.
"""

import dataclasses
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np

from attitude_core.config.parameters import ParameterError
from attitude_core.fsw.estimation.knowledge import PERFECT, Knowledge, knowledge_of
from attitude_core.fsw.fdir.fdir_config import FdirConfig
from attitude_core.fsw.guidance.planner_config import PlannerConfig
from attitude_core.models.constraints import ConeGeometry
from attitude_core.models.ephemeris import Orbit, parse_epoch_utc
from attitude_core.models.link_spec import LinkSpec
from attitude_core.models.sensor_spec import SensorSpec
from attitude_core.models.sky import Motion, Sky
from attitude_core.models.wheel_array import WheelArray
from attitude_core.world.disturbances import Disturbances

__all__ = [
    "ScenarioError",
    "Instrument",
    "BrightObject",
    "KeepIn",
    "PlanTarget",
    "ArrivalConfig",
    "ActuatorLimits",
    "Scenario",
    "SKY_HORIZON_EXTRA_S",
    "frozen_array",
]


class ScenarioError(ParameterError):
    """Invalid scenario; ``key`` is the dotted parameter name (None for file-level errors)."""


SKY_HORIZON_EXTRA_S = 600.0
"""Time beyond ``sim_time_s`` over which the sky's rate bounds hold, s."""


@dataclass(frozen=True)
class ActuatorLimits:
    """Actuator bounds; None is unlimited (the paper's case)."""

    max_torque_nm: tuple[float, float, float] | None = None  # per body axis, N m
    max_rate_rad_s: float | None = None  # body rate, rad/s

    @property
    def limited(self) -> bool:
        return self.max_torque_nm is not None or self.max_rate_rad_s is not None


@dataclass(frozen=True)
class ArrivalConfig:
    attitude_tol_deg: float
    rate_tol_rad_s: float


class _Record:
    """Value equality for records holding arrays (a dataclass's ``==`` would compare
    arrays element-wise and fail on their truth value)."""

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return all(
            np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b
            for a, b in zip(vars(self).values(), vars(other).values(), strict=True)
        )

    __hash__ = None  # type: ignore[assignment]  # mutable arrays inside: not hashable


@dataclass(frozen=True, eq=False)
class Instrument(_Record):
    """``instruments.<name>``: a light-sensitive instrument (eq. 5)."""

    name: str
    boresight_body: np.ndarray  # s_i, unit vector, body axes
    half_angle_deg: float | None  # beta_i: its default exclusion half-angle, deg
    avoids: tuple[str, ...] = ()  # the objects it must avoid, in bright_objects order
    exclusion_deg: tuple[tuple[str, float], ...] = ()  # per-object exclusions, deg

    def exclusion_of(self, obj: str) -> float:
        """Its exclusion half-angle from ``obj``'s limb, deg (NaN: it need not avoid it)."""
        if obj not in self.avoids:
            return math.nan
        own = dict(self.exclusion_deg)
        return own[obj] if obj in own else float(cast(float, self.half_angle_deg))


@dataclass(frozen=True, eq=False)
class BrightObject(_Record):
    """``bright_objects.<name>``: a bright object (eq. 5): a fixed or turning inertial
    direction, or an ephemeris body."""

    name: str
    direction_inertial: np.ndarray | None  # c_j at t = 0, unit vector, inertial axes
    ephemeris: str | None = None  # sun, moon or earth, seen from the spacecraft
    rate_inertial_rad_s: np.ndarray | None = None  # constant turn of direction_inertial

    @property
    def motion(self) -> Motion:
        return Motion(_vec(self.direction_inertial), _vec(self.rate_inertial_rad_s), self.ephemeris)


@dataclass(frozen=True, eq=False)
class KeepIn(_Record):
    """``keep_in.<name>``: body axis ``a_k`` within ``max_angle_deg`` of inertial ``d_k``
    (fixed, or an ephemeris body's centre)."""

    name: str
    axis_body: np.ndarray  # a_k, unit vector, body axes
    direction_inertial: np.ndarray | None  # d_k, unit vector, inertial axes
    max_angle_deg: float
    ephemeris: str | None = None

    @property
    def motion(self) -> Motion:
        return Motion(_vec(self.direction_inertial), None, self.ephemeris)


@dataclass(frozen=True, eq=False)
class PlanTarget(_Record):
    """``plan.<name>``: one target of an observation plan, flown in order."""

    name: str
    desired_mrp: np.ndarray  # sigma_DN, MRP, |sigma| <= 1
    dwell_s: float  # held within the arrival band this long before the next, s


def _vec(v: np.ndarray | None) -> tuple[float, float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]), float(v[2]))


def _stack(rows: Sequence[np.ndarray], width: int = 3) -> np.ndarray:
    """One row per member, ``(n, width)`` (``(0, width)`` for none), read-only."""
    return frozen_array(np.array(rows) if rows else np.zeros((0, width)))


TRACKER_RATE_USE = 0.8
"""Share of the star tracker's rate limit the guidance lets the body reach (the rest is
the body's overshoot of its target)."""


@dataclass(frozen=True, eq=False)  # eq=False: ndarray fields have no truth value
class Scenario:
    name: str
    source: str
    sim_time_s: float
    dt_s: float
    inertia_kgm2: np.ndarray
    initial_mrp: np.ndarray
    desired_mrp: np.ndarray
    initial_rate_rad_s: np.ndarray
    instruments: tuple[Instrument, ...]
    bright_objects: tuple[BrightObject, ...]
    kp_over_j: float
    kd_over_j: float
    planner: PlannerConfig
    arrival: ArrivalConfig
    actuators: ActuatorLimits = ActuatorLimits()
    keep_in: tuple[KeepIn, ...] = ()  # keep-in cones (none by default)
    epoch_utc: str | None = None  # ISO 8601 UTC of t = 0
    orbit: Orbit | None = None  # two-body orbit at the epoch, GCRS
    sensors: SensorSpec | None = None  # None: perfect knowledge (the true state is fed)
    fdir: FdirConfig | None = None  # the state watchdog's limits (None: the defaults)
    link: LinkSpec | None = None  # the rehearsal link (None: states go out as made)
    wheels: WheelArray | None = None  # reaction wheels (None: actuators.*, a torque box)
    disturbances: Disturbances | None = None  # external torques (None: none)
    plan: tuple[PlanTarget, ...] = ()  # an observation plan (desired_mrp: its first)

    def retargeted(self, desired_mrp: np.ndarray) -> "Scenario":
        """This scenario with another goal (a plan's next target, a commanded goal): its
        cached views (the sky, the knowledge, the stacked members; none depends on the
        goal) shared, not rebuilt."""
        other = dataclasses.replace(self, desired_mrp=frozen_array(desired_mrp))
        fields = {f.name for f in dataclasses.fields(self)}
        for name, cached in self.__dict__.items():
            if name not in fields:
                other.__dict__[name] = cached
        return other

    @property
    def watchdog(self) -> FdirConfig:
        """The state watchdog's limits: ``fdir.*``, or the defaults for ``dt_s``."""
        return FdirConfig.for_step(self.dt_s) if self.fdir is None else self.fdir

    @functools.cached_property
    def knowledge(self) -> Knowledge:
        """How well the loop knows the state: the estimator's steady 3-sigma from the
        declared sensors (:mod:`attitude_core.fsw.estimation.knowledge`; perfect without them)."""
        return PERFECT if self.sensors is None else knowledge_of(self.sensors, self.dt_s)

    @property
    def guidance_max_rate_rad_s(self) -> float | None:
        """The body-rate bound the guidance keeps: ``actuators.max_rate_rad_s`` and
        :data:`TRACKER_RATE_USE` of the star tracker's rate limit, the smaller (None:
        neither)."""
        bounds = [self.actuators.max_rate_rad_s]
        if self.sensors is not None and self.sensors.star_tracker_max_rate_rad_s is not None:
            bounds.append(TRACKER_RATE_USE * self.sensors.star_tracker_max_rate_rad_s)
        given = [b for b in bounds if b is not None]
        return min(given) if given else None

    def tracker_blinded(self, t_s: float, sigma_bn: np.ndarray) -> bool:
        """A bright object is inside the exclusion of the instrument that is the star
        tracker (``sensors.star_tracker.instrument``) at ``t_s`` (False without one)."""
        name = None if self.sensors is None else self.sensors.star_tracker_instrument
        if name is None:
            return False
        i = self.instrument_names.index(name)
        pairs = self.sky.pair_instrument == i
        if not pairs.any():
            return False
        margins = self.sky.constraint_margins_deg(t_s, sigma_bn)[: len(pairs)]
        return bool(np.min(margins[pairs]) < 0.0)

    @property
    def guidance_arrival(self) -> ArrivalConfig:
        """The tolerances the guidance judges the *estimate* against: the declared ones,
        at least the knowledge 3-sigma (noise alone must not keep an arrival out)."""
        k = self.knowledge
        return ArrivalConfig(
            max(self.arrival.attitude_tol_deg, k.attitude_3sigma_deg),
            max(self.arrival.rate_tol_rad_s, k.rate_3sigma_rad_s),
        )

    @property
    def true_arrival(self) -> ArrivalConfig:
        """The tolerances the *true* body is judged against: the guidance's plus the
        knowledge 3-sigma (the declared ones with perfect knowledge)."""
        k, g = self.knowledge, self.guidance_arrival
        return ArrivalConfig(
            g.attitude_tol_deg + k.attitude_3sigma_deg, g.rate_tol_rad_s + k.rate_3sigma_rad_s
        )

    @functools.cached_property
    def sky(self) -> Sky:
        """The constraints' sky over time (:mod:`attitude_core.models.sky`)."""
        return Sky(
            self.boresights_body,
            [[i.exclusion_of(o.name) for o in self.bright_objects] for i in self.instruments],
            [o.motion for o in self.bright_objects],
            self.keep_in_axes_body,
            self.keep_in_max_angles_deg,
            [k.motion for k in self.keep_in],
            None if self.epoch_utc is None else parse_epoch_utc(self.epoch_utc),
            self.orbit,
            horizon_s=self.sim_time_s + SKY_HORIZON_EXTRA_S,
        )

    # The members' fields as arrays, in list order, for the vectorised geometry.
    @property
    def instrument_names(self) -> tuple[str, ...]:
        return tuple(i.name for i in self.instruments)

    @functools.cached_property
    def boresights_body(self) -> np.ndarray:
        """``(n_i, 3)``: ``s_i``, body axes."""
        return _stack([i.boresight_body for i in self.instruments])

    @functools.cached_property
    def half_angles_deg(self) -> np.ndarray:
        """``(n_i,)``: ``beta_i``, deg (NaN for an instrument with none)."""
        return frozen_array(
            np.array(
                [np.nan if i.half_angle_deg is None else i.half_angle_deg for i in self.instruments]
            )
        )

    @property
    def bright_object_names(self) -> tuple[str, ...]:
        return tuple(o.name for o in self.bright_objects)

    @functools.cached_property
    def directions_inertial(self) -> np.ndarray:
        """``(n_j, 3)``: ``c_j`` at ``t = 0``, inertial axes."""
        return frozen_array(self.sky.object_directions(0.0)[0])

    @property
    def keep_in_names(self) -> tuple[str, ...]:
        return tuple(k.name for k in self.keep_in)

    @functools.cached_property
    def keep_in_axes_body(self) -> np.ndarray:
        """``(n_k, 3)``: ``a_k``, body axes."""
        return _stack([k.axis_body for k in self.keep_in])

    @functools.cached_property
    def keep_in_directions_inertial(self) -> np.ndarray:
        """``(n_k, 3)``: ``d_k`` at ``t = 0``, inertial axes."""
        if not self.keep_in:
            return _stack([])
        return frozen_array(self.sky.keep_in_directions(0.0))

    @functools.cached_property
    def keep_in_max_angles_deg(self) -> np.ndarray:
        """``(n_k,)``, deg."""
        return frozen_array(np.array([k.max_angle_deg for k in self.keep_in]))

    @property
    def n_steps(self) -> int:
        return int(round(self.sim_time_s / self.dt_s))

    @property
    def kp(self) -> np.ndarray:
        """Proportional gain matrix ``Kp = kp_over_j * J`` (paper Table 1)."""
        return frozen_array(self.kp_over_j * self.inertia_kgm2)

    @property
    def kd(self) -> np.ndarray:
        """Derivative gain matrix ``Kd = kd_over_j * J`` (paper Table 1)."""
        return frozen_array(self.kd_over_j * self.inertia_kgm2)

    def cone_geometry(self, inflation_deg: float = 0.0, samples: int | None = None) -> ConeGeometry:
        """Keep-out and keep-in geometry of this scenario's sky at ``t = 0`` (of every
        time on a static sky; ``samples`` defaults to planner.obstacle_samples); its
        constraints are numbered as :attr:`constraint_names`."""
        return self.sky.geometry(
            0.0,
            0.0,
            inflation_deg,
            self.planner.obstacle_samples if samples is None else samples,
        )

    def exact_geometry(self) -> ConeGeometry:
        """The uninflated geometry, for exact margins (which do not depend on the rim
        sampling: :data:`~attitude_core.models.constraints.EXACT_SAMPLES`): the sky's own,
        made once and shared."""
        return self.sky.exact_geometry

    @property
    def constraint_names(self) -> tuple[str, ...]:
        """A label per constraint, in the geometry's numbering
        (:meth:`ConeGeometry.constraint_margins_deg`): the keep-out pairs each
        instrument avoids ``"<instrument>/<object>"`` (instrument-major), then keep-in cones
        ``"keep_in/<name>"``."""
        sky = self.sky
        return tuple(
            f"{self.instrument_names[i]}/{self.bright_object_names[j]}"
            for i, j in zip(sky.pair_instrument.tolist(), sky.pair_object.tolist(), strict=True)
        ) + tuple(f"keep_in/{name}" for name in self.keep_in_names)


# --- parsing -----------------------------------------------------------------------------


def frozen_array(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
