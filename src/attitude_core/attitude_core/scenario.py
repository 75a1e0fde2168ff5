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
:mod:`attitude_core.scenario_schema` (one row per key).

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
  attitude, :func:`attitude_core.mrp.to_principal`), so ``Scenario.initial_mrp`` and
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
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from .constraints import ConeGeometry, KeepInCones
from .parameters import Param, ParameterError, convert, type_name
from .scenario_schema import (
    GROUP_PARAMETERS,
    GROUPS,
    MAX_STEPS,
    OPTIONAL_GROUPS,
    SCENARIO_PARAMETERS,
    group_names_param,
)
from .yamlio import load_strict

__all__ = [
    "ScenarioError",
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


class ScenarioError(ParameterError):
    """Invalid scenario; ``key`` is the dotted parameter name (None for file-level errors)."""


@dataclass(frozen=True)
class PlannerConfig:
    variant: str
    direction_axis: str
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
    planning_frame: str
    global_route: bool
    roadmap_nodes: int


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


def _no_rows(width: int | None = 3) -> np.ndarray:
    return _frozen(np.zeros((0, width) if width else (0,)))


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
    instrument_names: tuple[str, ...]
    boresights_body: np.ndarray
    half_angles_deg: np.ndarray
    bright_object_names: tuple[str, ...]
    directions_inertial: np.ndarray
    kp_over_j: float
    kd_over_j: float
    planner: PlannerConfig
    arrival: ArrivalConfig
    actuators: ActuatorLimits = ActuatorLimits()
    # Keep-in cones k: body axis a_k within max_angle_k of inertial d_k (none by default).
    keep_in_names: tuple[str, ...] = ()
    keep_in_axes_body: np.ndarray = field(default_factory=_no_rows)  # (n_k, 3)
    keep_in_directions_inertial: np.ndarray = field(default_factory=_no_rows)  # (n_k, 3)
    keep_in_max_angles_deg: np.ndarray = field(default_factory=lambda: _no_rows(None))  # (n_k,)

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
        """Keep-out and keep-in geometry of this scenario (``samples`` defaults to
        planner.obstacle_samples); its constraints are numbered as :attr:`constraint_names`."""
        return ConeGeometry(
            self.boresights_body,
            self.half_angles_deg,
            self.directions_inertial,
            inflation_deg=inflation_deg,
            samples=self.planner.obstacle_samples if samples is None else samples,
            keep_in=KeepInCones(
                self.keep_in_axes_body,
                self.keep_in_directions_inertial,
                self.keep_in_max_angles_deg,
            ),
        )

    @property
    def constraint_names(self) -> tuple[str, ...]:
        """A label per constraint, in the geometry's numbering
        (:meth:`ConeGeometry.constraint_margins_deg`): keep-out pairs
        ``"<instrument>/<object>"`` (``i n_j + j``), then keep-in cones
        ``"keep_in/<name>"``."""
        return tuple(
            f"{inst}/{obj}" for inst in self.instrument_names for obj in self.bright_object_names
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
        instrument_names=groups["instruments"],
        boresights_body=_frozen(np.array([d["boresight_body"] for d in per_name["instruments"]])),
        half_angles_deg=_frozen(np.array([d["half_angle_deg"] for d in per_name["instruments"]])),
        bright_object_names=groups["bright_objects"],
        directions_inertial=_frozen(
            np.array([d["direction_inertial"] for d in per_name["bright_objects"]])
        ),
        kp_over_j=values["controller.kp_over_j"],
        kd_over_j=values["controller.kd_over_j"],
        planner=planner,
        arrival=ArrivalConfig(values["arrival.attitude_tol_deg"], values["arrival.rate_tol_rad_s"]),
        actuators=ActuatorLimits(
            _torque_bound(values["actuators.max_torque_nm"]), values["actuators.max_rate_rad_s"]
        ),
        keep_in_names=groups["keep_in"],
        keep_in_axes_body=_rows(per_name["keep_in"], "axis_body", 3),
        keep_in_directions_inertial=_rows(per_name["keep_in"], "direction_inertial", 3),
        keep_in_max_angles_deg=_rows(per_name["keep_in"], "max_angle_deg", None),
    )

    # 4. Start and goal must satisfy the keep-out constraints (eq. 5) and the keep-in cones.
    geometry = scenario.cone_geometry(samples=16)  # exact margins do not depend on samples
    for key in ("initial_mrp", "desired_mrp"):
        margins = geometry.margins_deg(getattr(scenario, key))
        i, j = np.unravel_index(int(np.argmin(margins)), margins.shape)
        if margins[i, j] <= 0.0:
            raise ScenarioError(
                source,
                key,
                (
                    f"attitude is inside the keep-out cone of instrument "
                    f"{scenario.instrument_names[i]!r} and bright object "
                    f"{scenario.bright_object_names[j]!r} (margin {margins[i, j]:.1f} deg)"
                ),
            )
        if geometry.n_keep_in == 0:
            continue
        keep_in = geometry.keep_in_margins_deg(getattr(scenario, key))
        k = int(np.argmin(keep_in))
        if keep_in[k] <= 0.0:
            gamma = float(scenario.keep_in_max_angles_deg[k])
            raise ScenarioError(
                source,
                key,
                (
                    f"attitude is outside the keep-in cone keep_in.{scenario.keep_in_names[k]}: "
                    f"its axis is {gamma - keep_in[k]:.1f} deg from the direction, more than "
                    f"max_angle_deg {gamma:g} (margin {keep_in[k]:.1f} deg)"
                ),
            )
    return scenario


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


def _rows(members: list[dict[str, Any]], key: str, width: int | None) -> np.ndarray:
    """One row per group member of ``key``: ``(n, width)``, or ``(n,)`` for scalars."""
    if not members:
        return _no_rows(width)
    return _frozen(np.array([m[key] for m in members]))


def _torque_bound(v: Any) -> tuple[float, float, float] | None:
    return None if v is None else (float(v[0]), float(v[1]), float(v[2]))


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.setflags(write=False)
    return a
