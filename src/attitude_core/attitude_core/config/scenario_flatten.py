"""A ROS 2 parameters file's nested mappings as dotted parameter names, and which names
belong to a scenario (the rest: what every rclpy node declares by itself)."""

from collections.abc import Sequence
from typing import Any

from attitude_core.config.parameters import Param
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_schema import (
    EXCLUSION_PARAMETER,
    GROUP_PARAMETERS,
    GROUPS,
    SCENARIO_PARAMETERS,
    group_names_param,
)

__all__ = ["ROS_BUILTIN_BOOLS", "flatten_parameters", "is_ros_builtin", "scenario_keys"]

ROS_BUILTIN_BOOLS = ("use_sim_time", "start_type_description_service")


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
    return key in ROS_BUILTIN_BOOLS or key.startswith("qos_overrides.")


def scenario_keys(
    instrument_names: Sequence[str] = (),
    bright_object_names: Sequence[str] = (),
    keep_in_names: Sequence[str] = (),
    wheel_names: Sequence[str] = (),
    plan_names: Sequence[str] = (),
) -> list[Param]:
    """Every scenario row under its dotted key: the name lists first, then the table,
    then the per-name rows of the given names (in :data:`GROUPS` order)."""
    rows = [group_names_param(g) for g in GROUPS]
    rows += list(SCENARIO_PARAMETERS)
    listed = (instrument_names, bright_object_names, keep_in_names, wheel_names, plan_names)
    for group, names in zip(GROUPS, listed, strict=True):
        rows += [p.renamed(f"{group}.{n}.{p.key}") for n in names for p in GROUP_PARAMETERS[group]]
    rows += [
        EXCLUSION_PARAMETER.renamed(f"instruments.{i}.exclusion_deg.{o}")
        for i in instrument_names
        for o in bright_object_names
    ]
    return rows
