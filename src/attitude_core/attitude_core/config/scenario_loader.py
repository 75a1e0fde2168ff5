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
  attitude, :func:`attitude_core.models.mrp.to_principal`), so ``Scenario.initial_mrp`` and
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

import difflib
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from attitude_core.config.parameters import Param, convert, type_name
from attitude_core.config.scenario import (
    ActuatorLimits,
    ArrivalConfig,
    Scenario,
    ScenarioError,
    frozen_array,
)
from attitude_core.config.scenario_flatten import (
    ROS_BUILTIN_BOOLS,
    flatten_parameters,
    is_ros_builtin,
    scenario_keys,
)
from attitude_core.config.scenario_groups import (
    check_sky,
    parse_bright_object,
    parse_fdir,
    parse_instruments,
    parse_keep_in,
    parse_link,
    parse_orbit,
    parse_sensors,
)
from attitude_core.config.scenario_plan import parse_plan
from attitude_core.config.scenario_schema import (
    GROUP_PARAMETERS,
    GROUPS,
    MAX_STEPS,
    OPTIONAL_GROUPS,
    SCENARIO_PARAMETERS,
    group_names_param,
)
from attitude_core.config.scenario_wheels import parse_disturbances, parse_wheels
from attitude_core.fsw.guidance.planner_config import PlannerConfig
from attitude_core.yamlio import load_strict

__all__ = ["load_scenario", "loads_scenario", "parse_scenario", "scenario_yaml"]


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
            if key in ROS_BUILTIN_BOOLS and not isinstance(flat[key], bool):
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
    sensors = parse_sensors(values, source)
    fdir = parse_fdir(values, source, values["dt_s"])
    link = parse_link(values, source, fdir, sensors)
    orbit = parse_orbit(values, source)
    wheels = parse_wheels(groups["wheels"], per_name["wheels"], values, source, sensors, link)
    plan = parse_plan(groups["plan"], per_name["plan"], values, source, wheels, link)
    scenario = Scenario(
        name=values["scenario_name"],
        source=str(source),
        sim_time_s=values["sim_time_s"],
        dt_s=values["dt_s"],
        inertia_kgm2=frozen_array(values["inertia_kgm2"]),
        initial_mrp=frozen_array(values["initial_mrp"]),
        desired_mrp=frozen_array(plan[0].desired_mrp if plan else values["desired_mrp"]),
        initial_rate_rad_s=frozen_array(values["initial_rate_rad_s"]),
        instruments=parse_instruments(groups, per_name["instruments"], flat, value, source),
        bright_objects=tuple(
            parse_bright_object(name, d, source)
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
            parse_keep_in(name, d, source)
            for name, d in zip(groups["keep_in"], per_name["keep_in"], strict=True)
        ),
        epoch_utc=values["epoch_utc"],
        orbit=orbit,
        sensors=sensors,
        fdir=fdir,
        link=link,
        wheels=wheels,
        disturbances=parse_disturbances(values, source, orbit, wheels),
        plan=plan,
    )
    check_sky(scenario, source)

    # 4. Start and goal must satisfy the keep-out constraints (eq. 5) and the keep-in cones
    #    (at t = 0). On a moving sky the goal may be covered now and clear later: the
    #    guidance reports it blocked while it is.
    #    A plan's targets are judged when they come up (a refused one is recorded, skipped).
    static_goal = scenario.sky.static and not plan
    keys = ("initial_mrp", "desired_mrp") if static_goal else ("initial_mrp",)
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
