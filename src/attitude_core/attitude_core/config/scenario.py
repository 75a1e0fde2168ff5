"""Scenario files: strict loading and validation of a ROS 2 parameters file.

A scenario file is usable as-is with ``--ros-args --params-file`` for every node::

    /**:
      ros__parameters:
        scenario_name: case1
        sim_time_s: 150.0
        ...
        instruments:
          names: [star_tracker]
          star_tracker: {boresight_body: [1.0, 0.0, 0.0], half_angle_deg: 20.0}
        keep_in:                        # optional
          names: [sun_sensor]
          sun_sensor:
            axis_body: [0.0, 0.7071, 0.7071]
            direction_inertial: [0.2802, 0.7698, 0.5736]
            max_angle_deg: 70.0

Nested mappings under ``ros__parameters`` are ROS dotted parameter names
(``instruments.star_tracker.half_angle_deg``). All quantities are SI and frame names
are part of the key. The validation is driven by the parameter table
:mod:`attitude_core.config.scenario_schema` (one row per key).

Decisions:

* Types are strict because ROS 2 parameters are strongly typed and the rcl YAML
  parser rejects arrays mixing ints and floats: a float field must be written as a
  YAML float (``10.0``, not ``10``); integers, strings and booleans likewise.
  NaN and infinity are refused.
* Unknown keys are refused, with a "did you mean ...?" suggestion: a typo in a flight
  scenario must not silently fall back to a default. The only exceptions are the
  parameters every rclpy node declares by itself (``use_sim_time``,
  ``start_type_description_service``, ``qos_overrides.*``), which are ignored so that
  a node can pass all of its parameters to :func:`parse_scenario`.
* An MRP with ``|sigma| > 1`` is accepted and replaced by its shadow set (the same
  attitude, :func:`attitude_core.gnc.mrp.to_principal`), so ``Scenario.initial_mrp`` and
  ``Scenario.desired_mrp`` always satisfy ``|sigma| <= 1``.
* Boresights, bright-object directions and keep-in axes and directions are
  normalised; a norm more than 5 % away from 1 is refused as an almost certain typo
  (the paper's ``c1 = [0, -0.981, -0.196]`` has norm 1.0004 and loads).
* Keep-in cones (``keep_in``) are optional: without ``keep_in.names`` there is none.
  ``keep_in.names: []`` means none too, because that is what the nodes see: rcl leaves
  an empty list in a parameters file unset. (The required ``instruments.names`` and
  ``bright_objects.names`` refuse an empty list.)
* A start or goal attitude inside a keep-out cone (exact margin <= 0, eq. 5), or
  outside a keep-in cone (exact margin <= 0), is refused.
* ``planner.variant`` ("improved" or "paper") selects the defaults of the other
  ``planner.*`` keys; a key given explicitly overrides the variant's default.
"""

from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import numpy as np
import yaml

from attitude_core.config.parameters import Param, ParameterError, convert, type_name
from attitude_core.config.scenario_schema import (
    EXCLUSION_PARAMETER,
    GROUP_PARAMETERS,
    GROUPS,
    MAX_STEPS,
    OPTIONAL_GROUPS,
    ORBIT_PARAMETERS,
    SCENARIO_PARAMETERS,
    SENSOR_PARAMETERS,
    SENSOR_REQUIRED,
    group_names_param,
)
from attitude_core.gnc.constraints import ConeGeometry
from attitude_core.gnc.ephemeris import Orbit, parse_epoch_utc
from attitude_core.gnc.fepf import DirectionAxis, PlannerVariant, PlanningFrame
from attitude_core.gnc.knowledge import PERFECT, Knowledge, knowledge_of
from attitude_core.gnc.sensors import DEFAULT_BIAS_PRIOR_RAD_S, SensorSpec
from attitude_core.gnc.sky import Motion, Sky
from attitude_core.yamlio import load_strict

__all__ = [
    "ScenarioError",
    "Instrument",
    "BrightObject",
    "KeepIn",
    "PlannerConfig",
    "ArrivalConfig",
    "ActuatorLimits",
    "Scenario",
    "load_scenario",
    "loads_scenario",
    "parse_scenario",
    "flatten_parameters",
    "scenario_keys",
    "scenario_yaml",
    "is_ros_builtin",
]

_ROS_BUILTIN_BOOLS = ("use_sim_time", "start_type_description_service")
SKY_HORIZON_EXTRA_S = 600.0
"""Time beyond ``sim_time_s`` over which the sky's rate bounds hold, s."""


class ScenarioError(ParameterError):
    """Invalid scenario; ``key`` is the dotted parameter name (None for file-level errors)."""


@dataclass(frozen=True)
class PlannerConfig:
    """``planner.*``: the FEPF's and the global route's settings (modes as enums)."""

    variant: PlannerVariant
    direction_axis: DirectionAxis
    gamma_deg: float
    fis_attractive: str
    fis_repulsive: str
    max_attractive_rate_mrp_s: float
    max_repulsive_rate_mrp_s: float
    influence_distance_mrp: float
    safety_margin_deg: float
    max_accel_mrp_s2: float
    terminal_time_constant_s: float
    goal_tolerance_mrp: float
    stuck_timeout_s: float
    obstacle_samples: int
    planning_frame: PlanningFrame
    global_route: bool
    roadmap_nodes: int

    def __post_init__(self) -> None:  # defaults arrive as their strings
        object.__setattr__(self, "variant", PlannerVariant(self.variant))
        object.__setattr__(self, "direction_axis", DirectionAxis(self.direction_axis))
        object.__setattr__(self, "planning_frame", PlanningFrame(self.planning_frame))


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


def _vec(v: np.ndarray | None) -> tuple[float, float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]), float(v[2]))


def _stack(rows: Sequence[np.ndarray], width: int = 3) -> np.ndarray:
    """One row per member, ``(n, width)`` (``(0, width)`` for none), read-only."""
    return _frozen(np.array(rows) if rows else np.zeros((0, width)))


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

    @functools.cached_property
    def knowledge(self) -> Knowledge:
        """How well the loop knows the state: the estimator's steady 3-sigma from the
        declared sensors (:mod:`attitude_core.gnc.knowledge`; perfect without them)."""
        return PERFECT if self.sensors is None else knowledge_of(self.sensors, self.dt_s)

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
        """The constraints' sky over time (:mod:`attitude_core.gnc.sky`)."""
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
        return _frozen(
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
        return _frozen(self.sky.object_directions(0.0)[0])

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
        return _frozen(self.sky.keep_in_directions(0.0))

    @functools.cached_property
    def keep_in_max_angles_deg(self) -> np.ndarray:
        """``(n_k,)``, deg."""
        return _frozen(np.array([k.max_angle_deg for k in self.keep_in]))

    @property
    def n_steps(self) -> int:
        return int(round(self.sim_time_s / self.dt_s))

    @property
    def kp(self) -> np.ndarray:
        """Proportional gain matrix ``Kp = kp_over_j * J`` (paper Table 1)."""
        return _frozen(self.kp_over_j * self.inertia_kgm2)

    @property
    def kd(self) -> np.ndarray:
        """Derivative gain matrix ``Kd = kd_over_j * J`` (paper Table 1)."""
        return _frozen(self.kd_over_j * self.inertia_kgm2)

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
        sampling: :data:`~attitude_core.gnc.constraints.EXACT_SAMPLES`): the sky's own,
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


def flatten_parameters(params: dict[Any, Any], source: str = "<dict>") -> dict[str, object]:
    """Nested parameter mapping -> ROS dotted names (``{"a": {"b": 1}} -> {"a.b": 1}``)."""
    flat: dict[str, object] = {}

    def walk(node: dict[Any, Any], prefix: str) -> None:
        for k, v in node.items():
            if not isinstance(k, str) or not k:
                raise ScenarioError(
                    source,
                    prefix.rstrip(".") or None,
                    f"parameter names must be non-empty strings, got {k!r}",
                )
            key = prefix + k
            if isinstance(v, dict):
                walk(v, key + ".")
            elif key in flat:
                raise ScenarioError(source, key, "given twice")
            else:
                flat[key] = v

    walk(params, "")
    return flat


def is_ros_builtin(key: str) -> bool:
    """A parameter every rclpy node declares by itself (ignored by the loader)."""
    return key in _ROS_BUILTIN_BOOLS or key.startswith("qos_overrides.")


def scenario_keys(
    instrument_names: Sequence[str] = (),
    bright_object_names: Sequence[str] = (),
    keep_in_names: Sequence[str] = (),
) -> list[Param]:
    """Every scenario row under its dotted key: the name lists first, then the table,
    then the per-name rows of the given names (in :data:`GROUPS` order)."""
    rows = [group_names_param(g) for g in GROUPS]
    rows += list(SCENARIO_PARAMETERS)
    listed = (instrument_names, bright_object_names, keep_in_names)
    for group, names in zip(GROUPS, listed, strict=True):
        rows += [p.renamed(f"{group}.{n}.{p.key}") for n in names for p in GROUP_PARAMETERS[group]]
    rows += [
        EXCLUSION_PARAMETER.renamed(f"instruments.{i}.exclusion_deg.{o}")
        for i in instrument_names
        for o in bright_object_names
    ]
    return rows


def parse_scenario(
    params: dict[Any, Any],
    source: str = "<dict>",
    base_dir: str | Path | None = None,
    also_known: tuple[str, ...] = (),
) -> Scenario:
    """Validate a ``ros__parameters`` mapping (nested or dotted) and build a :class:`Scenario`.

    Relative data-file paths are resolved against ``base_dir`` (default: the directory
    of ``source``). ``also_known`` names keys that are valid elsewhere (a node's own
    parameters) and are only offered as "did you mean" suggestions.
    """
    if not isinstance(params, dict):
        raise ScenarioError(
            source, None, f"ros__parameters must be a mapping, got {type_name(params)}"
        )
    flat = flatten_parameters(params, source)
    base = Path(source).parent if base_dir is None else Path(base_dir)

    def value(row: Param, default: Any) -> Any:
        if row.key not in flat:
            if row.required:
                raise ScenarioError(source, row.key, "missing required key")
            return default
        return convert(row, flat[row.key], source, base, error=ScenarioError)

    # 1. The name lists define the set of known keys; refuse unknown keys next. An
    #    optional group without its list, or with an empty one (rcl leaves an empty list
    #    unset, so the nodes see it absent), has no member.
    def names_of(group: str) -> tuple[str, ...]:
        row = group_names_param(group)
        if group in OPTIONAL_GROUPS and flat.get(row.key) == []:
            return ()
        names: tuple[str, ...] = value(row, None) or ()
        return names

    groups = {g: names_of(g) for g in GROUPS}
    known = {p.key for p in scenario_keys(*(groups[g] for g in GROUPS))}
    for key in flat:
        if key in known:
            continue
        if is_ros_builtin(key):
            if key in _ROS_BUILTIN_BOOLS and not isinstance(flat[key], bool):
                raise ScenarioError(source, key, f"expected boolean, got {type_name(flat[key])}")
            continue
        group, _, rest = key.partition(".")
        if group in groups and "." in rest and rest.split(".")[0] not in groups[group]:
            hint = f"; {rest.split('.')[0]!r} is not listed in {group}.names"
        else:
            close = difflib.get_close_matches(key, sorted(known | set(also_known)), n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
        raise ScenarioError(source, key, "unknown key" + hint)

    # 2. Top-level and planner rows, in table order (planner.variant precedes its defaults).
    values: dict[str, Any] = {}
    for row in SCENARIO_PARAMETERS:
        values[row.key] = value(row, row.default_for(values.get("planner.variant", "improved")))
    if values["sim_time_s"] < values["dt_s"]:
        raise ScenarioError(
            source,
            "sim_time_s",
            f"must be >= dt_s ({values['dt_s']!r}), got {values['sim_time_s']!r}",
        )
    steps = values["sim_time_s"] / values["dt_s"]
    if steps > MAX_STEPS:
        raise ScenarioError(
            source,
            "sim_time_s",
            (
                f"too many steps: sim_time_s / dt_s = {steps:.3g}, at most {MAX_STEPS:,} "
                "(a run keeps every step in memory)"
            ),
        )

    # 3. Per-instrument, per-object and per-keep-in-cone rows.
    per_name = {
        g: [
            {p.key: value(p.renamed(f"{g}.{n}.{p.key}"), None) for p in GROUP_PARAMETERS[g]}
            for n in groups[g]
        ]
        for g in GROUPS
    }
    planner = PlannerConfig(
        **{k.split(".", 1)[1]: v for k, v in values.items() if k.startswith("planner.")}
    )
    scenario = Scenario(
        name=values["scenario_name"],
        source=str(source),
        sim_time_s=values["sim_time_s"],
        dt_s=values["dt_s"],
        inertia_kgm2=_frozen(values["inertia_kgm2"]),
        initial_mrp=_frozen(values["initial_mrp"]),
        desired_mrp=_frozen(values["desired_mrp"]),
        initial_rate_rad_s=_frozen(values["initial_rate_rad_s"]),
        instruments=_instruments(groups, per_name["instruments"], flat, value, source),
        bright_objects=tuple(
            _bright_object(name, d, source)
            for name, d in zip(groups["bright_objects"], per_name["bright_objects"], strict=True)
        ),
        kp_over_j=values["controller.kp_over_j"],
        kd_over_j=values["controller.kd_over_j"],
        planner=planner,
        arrival=ArrivalConfig(values["arrival.attitude_tol_deg"], values["arrival.rate_tol_rad_s"]),
        actuators=ActuatorLimits(
            _torque_bound(values["actuators.max_torque_nm"]), values["actuators.max_rate_rad_s"]
        ),
        keep_in=tuple(
            _keep_in(name, d, source)
            for name, d in zip(groups["keep_in"], per_name["keep_in"], strict=True)
        ),
        epoch_utc=values["epoch_utc"],
        orbit=_orbit(values, source),
        sensors=_sensors(values, source),
    )
    _check_sky(scenario, source)

    # 4. Start and goal must satisfy the keep-out constraints (eq. 5) and the keep-in cones
    #    (at t = 0). On a moving sky the goal may be covered now and clear later: the
    #    guidance reports it blocked while it is.
    keys = ("initial_mrp",) if not scenario.sky.static else ("initial_mrp", "desired_mrp")
    names = scenario.constraint_names
    n_out = len(scenario.sky.pair_exclusion_deg)
    for key in keys:
        margins = scenario.sky.constraint_margins_deg(0.0, getattr(scenario, key))
        c = int(np.argmin(margins))
        if margins[c] > 0.0:
            continue
        if c < n_out:
            inst, obj = names[c].split("/")
            raise ScenarioError(
                source,
                key,
                (
                    f"attitude is inside the keep-out cone of instrument {inst!r} and bright "
                    f"object {obj!r} (margin {margins[c]:.1f} deg)"
                ),
            )
        k = c - n_out
        gamma = float(scenario.keep_in_max_angles_deg[k])
        raise ScenarioError(
            source,
            key,
            (
                f"attitude is outside the keep-in cone keep_in.{scenario.keep_in_names[k]}: "
                f"its axis is {gamma - margins[c]:.1f} deg from the direction, more than "
                f"max_angle_deg {gamma:g} (margin {margins[c]:.1f} deg)"
            ),
        )
    return scenario


def _instruments(
    groups: dict[str, tuple[str, ...]],
    rows: list[dict[str, Any]],
    flat: dict[str, object],
    value: Any,
    source: str,
) -> tuple[Instrument, ...]:
    """The instruments, their ``avoids`` lists (default: every object, in list order)
    and their per-object exclusions; an instrument needs ``half_angle_deg`` when one
    object it avoids has no ``exclusion_deg`` of its own."""
    objects = groups["bright_objects"]
    out = []
    for name, d in zip(groups["instruments"], rows, strict=True):
        avoids = objects if d["avoids"] is None else d["avoids"]
        unknown = [o for o in avoids if o not in objects]
        if unknown:
            raise ScenarioError(
                source,
                f"instruments.{name}.avoids",
                f"{unknown[0]!r} is not listed in bright_objects.names",
            )
        own = []
        for o in objects:
            key = f"instruments.{name}.exclusion_deg.{o}"
            if key in flat:
                if o not in avoids:
                    raise ScenarioError(
                        source,
                        key,
                        f"{name!r} does not avoid {o!r} (see instruments.{name}.avoids)",
                    )
                own.append((o, float(value(EXCLUSION_PARAMETER.renamed(key), None))))
        listed = {o for o, _ in own}
        bare = [o for o in avoids if o not in listed]
        if bare and d["half_angle_deg"] is None:
            raise ScenarioError(
                source,
                f"instruments.{name}.half_angle_deg",
                f"missing required key (the exclusion of {', '.join(bare)}, which have no "
                f"instruments.{name}.exclusion_deg.<object>)",
            )
        ordered = tuple(o for o in objects if o in avoids)
        out.append(
            Instrument(name, _frozen(d["boresight_body"]), d["half_angle_deg"], ordered, tuple(own))
        )
    return tuple(out)


def _one_direction(group: str, name: str, d: dict[str, Any], source: str) -> None:
    if (d["direction_inertial"] is None) == (d["ephemeris"] is None):
        raise ScenarioError(
            source,
            f"{group}.{name}",
            "give exactly one of direction_inertial and ephemeris",
        )


def _bright_object(name: str, d: dict[str, Any], source: str) -> BrightObject:
    _one_direction("bright_objects", name, d, source)
    rate = d["rate_inertial_rad_s"]
    if rate is not None and d["ephemeris"] is not None:
        raise ScenarioError(
            source,
            f"bright_objects.{name}.rate_inertial_rad_s",
            "turns direction_inertial; an ephemeris body moves by itself",
        )
    direction = d["direction_inertial"]
    return BrightObject(
        name,
        None if direction is None else _frozen(direction),
        d["ephemeris"],
        None if rate is None else _frozen(rate),
    )


def _keep_in(name: str, d: dict[str, Any], source: str) -> KeepIn:
    _one_direction("keep_in", name, d, source)
    direction = d["direction_inertial"]
    return KeepIn(
        name,
        _frozen(d["axis_body"]),
        None if direction is None else _frozen(direction),
        d["max_angle_deg"],
        d["ephemeris"],
    )


def _orbit(values: dict[str, Any], source: str) -> Orbit | None:
    """The ``orbit.*`` elements: all six or none, and a physical orbit."""
    keys = [p.key for p in ORBIT_PARAMETERS]
    given = [k for k in keys if values[k] is not None]
    if not given:
        return None
    if len(given) != len(keys):
        missing = [k for k in keys if values[k] is None]
        raise ScenarioError(source, missing[0], "missing: an orbit needs all six orbit.* elements")
    orbit = Orbit(*(float(values[k]) for k in keys))
    problem = orbit.problem()
    if problem is not None:
        raise ScenarioError(source, "orbit", problem)
    return orbit


def _sensors(values: dict[str, Any], source: str) -> SensorSpec | None:
    """The ``sensors.*`` keys: none (perfect knowledge), or at least the required ones."""
    keys = [p.key for p in SENSOR_PARAMETERS]
    if all(values[k] is None for k in keys):
        return None
    for key in SENSOR_REQUIRED:
        if values[key] is None:
            raise ScenarioError(source, key, f"missing: sensors need {', '.join(SENSOR_REQUIRED)}")
    arcsec = math.radians(1.0 / 3600.0)
    bias = values["sensors.gyro.bias_rad_s"]
    walk = values["sensors.gyro.bias_walk_rad_s2"]
    prior = values["sensors.gyro.bias_prior_rad_s"]
    spec = SensorSpec(
        seed=int(values["sensors.seed"]),
        star_tracker_noise_rad=tuple(  # type: ignore[arg-type]
            float(x) * arcsec for x in values["sensors.star_tracker.noise_arcsec"]
        ),
        star_tracker_rate_hz=float(values["sensors.star_tracker.rate_hz"]),
        gyro_noise_rad_s=float(values["sensors.gyro.noise_rad_s"]),
        gyro_bias_rad_s=(0.0, 0.0, 0.0) if bias is None else tuple(float(x) for x in bias),  # type: ignore[arg-type]
        gyro_bias_walk_rad_s2=0.0 if walk is None else float(walk),
        gyro_bias_prior_rad_s=DEFAULT_BIAS_PRIOR_RAD_S if prior is None else float(prior),
    )
    problem = spec.problem()
    if problem is not None:
        raise ScenarioError(source, "sensors", problem)
    return spec


def _check_sky(scenario: Scenario, source: str) -> None:
    """Ephemeris bodies need the epoch, ``earth`` the orbit too."""
    for group, members in (
        ("bright_objects", scenario.bright_objects),
        ("keep_in", scenario.keep_in),
    ):
        for m in members:
            if m.ephemeris is None:
                continue
            key = f"{group}.{m.name}.ephemeris"
            if scenario.epoch_utc is None:
                raise ScenarioError(source, key, f"{m.ephemeris!r} needs epoch_utc")
            if m.ephemeris == "earth" and scenario.orbit is None:
                raise ScenarioError(source, key, "'earth' (nadir) needs an orbit (orbit.*)")
    for inst in scenario.instruments:
        for o, excl in inst.exclusion_deg:
            if not math.isfinite(excl):
                raise ScenarioError(
                    source, f"instruments.{inst.name}.exclusion_deg.{o}", "must be finite"
                )


def scenario_yaml(flat: dict[str, Any]) -> str:
    """A scenario file's text (``/**: ros__parameters:``) from dotted parameter values,
    e.g. those a node was given: ``loads_scenario`` reads it back to the same values."""
    nested: dict[str, Any] = {}
    for key, value in sorted(flat.items()):
        node = nested
        *parents, leaf = key.split(".")
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = list(value) if isinstance(value, tuple) else value
    text: str = yaml.safe_dump({"/**": {"ros__parameters": nested}}, sort_keys=False)
    return text


def load_scenario(path: str | Path) -> Scenario:
    """Read and validate a scenario file (a ROS 2 parameters file, see module docstring)."""
    source = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ScenarioError(source, None, f"cannot read file: {exc}") from exc
    return loads_scenario(text, source)


def loads_scenario(text: str, source: str = "<text>") -> Scenario:
    """Validate the text of a scenario file (e.g. the copy stored in a bag)."""
    try:
        doc = load_strict(text)
    except yaml.YAMLError as exc:
        duplicate = isinstance(exc, yaml.constructor.ConstructorError)
        kind = "invalid YAML" if duplicate else "YAML syntax error"
        message = str(exc).replace('in "<unicode string>", ', "")
        raise ScenarioError(source, None, f"{kind}: {message}") from exc
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError) as exc:
        # PyYAML's constructors of explicit tags (``!!float abc``, ``!!bool maybe``) and
        # its recursive composer (very deep nesting) raise these, not a YAMLError.
        raise ScenarioError(source, None, f"invalid YAML: {type(exc).__name__}: {exc}") from exc
    if doc is None:
        raise ScenarioError(source, None, "file is empty")
    if (
        not isinstance(doc, dict)
        or list(doc) != ["/**"]
        or not isinstance(doc["/**"], dict)
        or list(doc["/**"]) != ["ros__parameters"]
    ):
        raise ScenarioError(
            source,
            None,
            "top level must be exactly {'/**': "
            "{'ros__parameters': {...}}} (a ROS 2 parameters file for all nodes)",
        )
    return parse_scenario(doc["/**"]["ros__parameters"], source)


def _torque_bound(v: Any) -> tuple[float, float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]), float(v[2]))


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
