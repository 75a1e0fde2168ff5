"""Declare a node's parameter table (:mod:`attitude_core.config.node_parameters`) on the node.

Each row becomes one declared parameter with a descriptor built from the row: type,
description with its rule, read-only flag, and a floating-point or integer range when
the row has closed bounds. A row without a default is declared typed and unset.

A node that reads the scenario validates the whole scenario with the one loader
(:func:`attitude_core.config.scenario_loader.parse_scenario`): the rows it declares, plus
every other parameter given to it (file or ``-p``) that it did not declare. So a scenario file is
accepted or refused by every node exactly as by ``load_scenario``, including a typo
in a key the node does not read. Relative data-file paths are resolved against the
node's working directory (``attitude-run`` starts the nodes in the scenario's directory,
so they resolve as ``load_scenario`` resolves them).
"""

from __future__ import annotations

import os
from typing import Any, TypeVar

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.exceptions import ParameterUninitializedException
from rclpy.node import Node
from rclpy.parameter import Parameter

from attitude_core.config.node_parameters import NodeParameters
from attitude_core.config.parameters import NodeParameterError, Param, ParameterError
from attitude_core.config.scenario import Scenario, ScenarioError
from attitude_core.config.scenario_flatten import scenario_keys
from attitude_core.config.scenario_loader import parse_scenario
from attitude_core.config.scenario_schema import GROUPS

P = TypeVar("P")

__all__ = [
    "descriptor",
    "declare_rows",
    "declare_node_parameters",
    "declare_scenario_node",
    "plain_value",
    "undeclared_parameters",
]

_TYPES = {
    "double": (Parameter.Type.DOUBLE, ParameterType.PARAMETER_DOUBLE),
    "double_array": (Parameter.Type.DOUBLE_ARRAY, ParameterType.PARAMETER_DOUBLE_ARRAY),
    "integer": (Parameter.Type.INTEGER, ParameterType.PARAMETER_INTEGER),
    "string": (Parameter.Type.STRING, ParameterType.PARAMETER_STRING),
    "string_array": (Parameter.Type.STRING_ARRAY, ParameterType.PARAMETER_STRING_ARRAY),
    "bool": (Parameter.Type.BOOL, ParameterType.PARAMETER_BOOL),
}


def descriptor(row: Param) -> ParameterDescriptor:
    """The ROS 2 descriptor of a row (closed bounds as a range; the exact rule in text)."""
    d = ParameterDescriptor(
        name=row.key,
        type=_TYPES[row.ros_type][1],
        description=row.full_description,
        read_only=row.read_only,
    )
    closed = row.bounds.closed() if row.bounds is not None else None
    if closed is not None and row.ros_type == "double":
        d.floating_point_range = [
            FloatingPointRange(from_value=float(closed[0]), to_value=float(closed[1]), step=0.0)
        ]
    elif closed is not None and row.ros_type == "integer":
        d.integer_range = [IntegerRange(from_value=int(closed[0]), to_value=int(closed[1]), step=1)]
    return d


def plain_value(value: Any) -> Any:
    """rclpy arrays (array.array, numpy) -> lists, as the YAML loader would give them."""
    if isinstance(value, (str, bool, int, float)) or value is None:
        return value
    return list(value)


def _declare(
    node: Node, row: Param, source: str, error: type[ParameterError], with_default: bool
) -> Any:
    """Declare one row; its value (None when unset). Scenario rows are declared without
    their default (``with_default`` False): unset, the loader supplies it. rclpy's
    refusals (wrong type, out of range) become ``error`` naming the key."""
    value: object  # a Parameter.Type (declared typed and unset) or the default value
    if row.required or not with_default:
        value = _TYPES[row.ros_type][0]  # typed and unset
    else:
        value = list(row.default) if isinstance(row.default, tuple) else row.default
    try:
        if not node.has_parameter(row.key):  # declared: a configure after cleanup
            node.declare_parameter(row.key, value, descriptor(row))
        return plain_value(node.get_parameter(row.key).value)
    except ParameterUninitializedException:
        return None
    except Exception as exc:  # rclpy: InvalidParameterTypeException, ...ValueException
        raise error(source, row.key, f"{type(exc).__name__}: {exc}") from exc


def declare_rows(node: Node, table: NodeParameters[P]) -> P:
    """Declare only ``table``'s own rows on ``node`` (the other parameters are the
    node's own table's to judge); their values as ``table.values``."""
    source = f"node '{node.get_fully_qualified_name()}' parameters"
    given: dict[str, Any] = {}
    for row in table.own:
        value = _declare(node, row, source, NodeParameterError, with_default=True)
        if value is not None:
            given[row.key] = value
    return table.own_values(given, source)


def declare_node_parameters(node: Node, table: NodeParameters[P]) -> tuple[P, Scenario | None]:
    """Declare ``table`` on ``node``; return (its own values as ``table.values``, the
    validated scenario or None when the node takes none).

    Raises :class:`~attitude_core.config.parameters.NodeParameterError` or
    :class:`~attitude_core.config.scenario.ScenarioError` (both :class:`ParameterError`) naming
    the key on a missing, unknown or invalid value.
    """
    source = f"node '{node.get_fully_qualified_name()}' parameters"
    given: dict[str, Any] = {}
    for row in table.own:
        value = _declare(node, row, source, NodeParameterError, with_default=True)
        if value is not None:
            given[row.key] = value
    own = table.own_values(given, source)  # rclpy checked type and range; the rows the rest
    if table.scenario is None:
        table.refuse_unknown(undeclared_parameters(node), source)
        return own, None

    flat: dict[str, Any] = {}

    def declare_scenario_row(row: Param) -> None:
        value = _declare(node, row, source, ScenarioError, with_default=False)
        if value is not None:
            flat[row.key] = value

    rows = scenario_keys()
    names_rows = [r for r in rows if r.key.endswith(".names")]
    for row in names_rows:
        if table.reads_scenario_key(row.key):
            declare_scenario_row(row)

    given_names = undeclared_parameters(node)  # the name lists this node does not read

    def listed(group: str) -> tuple[str, ...]:
        names = flat.get(f"{group}.names", given_names.get(f"{group}.names"))
        # Each distinct name once: a duplicate is the loader's to report, on the list.
        return tuple(dict.fromkeys(n for n in (names or ()) if isinstance(n, str)))

    for row in scenario_keys(*(listed(g) for g in GROUPS)):
        if row not in names_rows and table.reads_scenario_key(row.key):
            declare_scenario_row(row)
    # Every other parameter given to this node: scenario keys it does not read, and typos.
    flat.update(undeclared_parameters(node))
    scenario = parse_scenario(
        flat, source, base_dir=os.getcwd(), also_known=tuple(r.key for r in table.own)
    )
    return own, scenario


def undeclared_parameters(node: Node) -> dict[str, Any]:
    """The parameters given to ``node`` (file or ``-p``) that it has not declared, as the
    YAML loader would give their values."""
    overrides = getattr(node, "_parameter_overrides", {})  # rclpy keeps no public getter
    return {
        name: plain_value(parameter.value)
        for name, parameter in overrides.items()
        if not node.has_parameter(name)
    }


def declare_scenario_node(node: Node, table: NodeParameters[P]) -> tuple[P, Scenario]:
    """:func:`declare_node_parameters` for a node that reads the scenario."""
    own, scenario = declare_node_parameters(node, table)
    if scenario is None:
        raise TypeError("declare_scenario_node: the table reads no scenario")
    return own, scenario
