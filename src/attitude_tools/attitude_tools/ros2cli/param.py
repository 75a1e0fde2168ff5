"""``ros2 param list|get`` of the shim, through the node's ``rcl_interfaces`` parameter services.

* ``list [NODE] [--param-type] [--filter REGEX] [--param-prefixes P ...]``: the sorted
  names, two spaces in, as ros2param (every node under a ``/node:`` line without NODE);
* ``get NODE NAME [--hide-type]``: ros2param's line, e.g. ``String value is: x``,
  ``Double value is: 0.1``, ``Integer values are: [1, 2]``.

Differs from ros2cli: ``list`` waits for a named node up to ``--timeout`` s too (as
``get`` does; default 1); no daemon; no ``set``, ``dump``, ``load``, ``describe``.
"""

from __future__ import annotations

import argparse
import re
from collections.abc import Sequence
from typing import Any

import rclpy
from rcl_interfaces.msg import ParameterType
from rclpy.node import Node
from rclpy.parameter_client import AsyncParameterClient

from attitude_tools.ros2cli.cli import add_spin_time, fail, run_subverb
from attitude_tools.ros2cli.graph import absolute_name, graph_node, node_names, wait_for

SERVICE_WAIT_S = 5.0

_LABELS = {
    ParameterType.PARAMETER_BOOL: ("Boolean value is:", "bool_value", "boolean"),
    ParameterType.PARAMETER_INTEGER: ("Integer value is:", "integer_value", "integer"),
    ParameterType.PARAMETER_DOUBLE: ("Double value is:", "double_value", "double"),
    ParameterType.PARAMETER_STRING: ("String value is:", "string_value", "string"),
    ParameterType.PARAMETER_BYTE_ARRAY: ("Byte values are:", "byte_array_value", "byte array"),
    ParameterType.PARAMETER_BOOL_ARRAY: (
        "Boolean values are:",
        "bool_array_value",
        "boolean array",
    ),
    ParameterType.PARAMETER_INTEGER_ARRAY: (
        "Integer values are:",
        "integer_array_value",
        "integer array",
    ),
    ParameterType.PARAMETER_DOUBLE_ARRAY: (
        "Double values are:",
        "double_array_value",
        "double array",
    ),
    ParameterType.PARAMETER_STRING_ARRAY: (
        "String values are:",
        "string_array_value",
        "string array",
    ),
    ParameterType.PARAMETER_NOT_SET: ("Parameter not set.", "", "not set"),
}
"""ParameterType -> (ros2param's label, ParameterValue field, type name of ``--param-type``)."""


def format_value(pvalue: Any, hide_type: bool = False) -> str:
    """A ``rcl_interfaces/msg/ParameterValue`` as ``ros2 param get`` prints it."""
    if pvalue.type not in _LABELS:
        raise ValueError(f"Unknown parameter type '{pvalue.type}'")
    label, field, _ = _LABELS[pvalue.type]
    if not field:
        return label
    value = getattr(pvalue, field)
    value = value.tolist() if hasattr(value, "tolist") else value
    return str(value) if hide_type else f"{label} {value}"


def _result(node: Node, future: Any, what: str) -> Any:
    rclpy.spin_until_future_complete(node, future, timeout_sec=SERVICE_WAIT_S)
    if not future.done() or future.result() is None:
        raise RuntimeError(
            f"Exception while calling service of node '{what}': {future.exception()}"
        )
    return future.result()


def _client(node: Node, name: str) -> AsyncParameterClient:
    client = AsyncParameterClient(node, name)
    if not client.wait_for_services(timeout_sec=SERVICE_WAIT_S):
        raise TimeoutError(
            f"Wait for service timed out waiting for parameter services for node {name}"
        )
    return client


def _found(node: Node, args: argparse.Namespace) -> str | None:
    name = absolute_name(args.node_name)
    visible = lambda: name in node_names(node, args.include_hidden_nodes)
    return name if wait_for(node, visible, args.timeout) else None


def _names(node: Node, name: str, args: argparse.Namespace) -> list[str]:
    client = _client(node, name)
    names = sorted(_result(node, client.list_parameters(args.param_prefixes), name).result.names)
    if args.filter is not None:
        names = [n for n in names if re.match(args.filter, n)]
    if not args.param_type:
        return [f"  {n}" for n in names]
    descriptors = _result(node, client.describe_parameters(names), name).descriptors
    types = {d.name: _LABELS.get(d.type, ("", "", "unknown"))[2] for d in descriptors}
    return [f"  {n} (type: {types.get(n, 'unknown')})" for n in names]


def _list(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        if args.node_name is None:
            targets = sorted(node_names(node, args.include_hidden_nodes))
        elif (one := _found(node, args)) is None:
            return fail("Node not found")
        else:
            targets = [one]
        for name in targets:
            try:
                lines = _names(node, name, args)
            except TimeoutError as e:
                print(e)
                continue
            except RuntimeError as e:
                return fail(str(e))
            if args.node_name is None and lines:
                print(f"{name}:")
            for line in lines:
                print(line)
    return 0


def _get(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        if (name := _found(node, args)) is None:
            return fail("Node not found")
        try:
            future = _client(node, name).get_parameters([args.parameter_name])
            values = _result(node, future, name).values
        except (TimeoutError, RuntimeError) as e:
            return fail(str(e))
    if not values:
        return fail("Parameter not set")
    try:
        print(format_value(values[0], args.hide_type))
    except ValueError as e:
        return fail(str(e))
    return 0


def _common(p: argparse.ArgumentParser, required: bool) -> None:
    p.add_argument("node_name", nargs=None if required else "?", help="Name of the ROS node")
    p.add_argument(
        "--include-hidden-nodes", action="store_true", help="Consider hidden nodes as well"
    )
    p.add_argument(
        "--timeout",
        metavar="N",
        type=float,
        default=1.0,
        help="Wait for N seconds until node becomes available (default 1 sec)",
    )
    add_spin_time(p)


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(
        prog="ros2 param", description="Various param related sub-commands"
    )
    verbs = top.add_subparsers(title="Commands", metavar="<command>")
    p = verbs.add_parser("list", help="Output a list of available parameters")
    _common(p, required=False)
    p.add_argument("--filter", help="Only parameters matching the regex expression")
    p.add_argument(
        "--param-prefixes", nargs="+", default=[], help="Only list parameters with these prefixes"
    )
    p.add_argument(
        "--param-type", action="store_true", help="Print parameter types with parameter names"
    )
    p.set_defaults(handler=_list)
    p = verbs.add_parser("get", help="Get parameter")
    _common(p, required=True)
    p.add_argument("parameter_name", help="Name of the parameter")
    p.add_argument("--hide-type", action="store_true", help="Hide the type information")
    p.set_defaults(handler=_get)
    return top


def main(argv: Sequence[str]) -> int:
    return run_subverb(parser(), argv)
