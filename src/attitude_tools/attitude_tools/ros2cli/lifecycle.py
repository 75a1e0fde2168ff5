"""``ros2 lifecycle nodes|get|set|list`` of the shim, through the nodes' lifecycle services.

* ``nodes [-a] [-c]``: nodes offering ``<node>/get_state`` (``lifecycle_msgs/srv/GetState``);
* ``get [NODE]``: ``label [id]`` (e.g. ``unconfigured [1]``), ``/node: label [id]`` for all;
* ``set NODE TRANSITION``: by label (``configure``, ``activate``, ``deactivate``,
  ``cleanup``, ``shutdown``) or id among the available transitions, as ros2lifecycle;
  also (ours) by ``lifecycle_msgs/msg/Transition`` constant name, e.g.
  ``unconfigured_shutdown``. Prints ``Transitioning successful``, or ``Transitioning
  failed`` to stderr;
* ``list NODE [-a]``: ``- label [id]`` with its start and goal states.

Differs from ros2cli: a failed transition exits 1 (ros2lifecycle: 0); a named node is
waited for up to ``--timeout`` s (ours, default 2) after discovery; no daemon.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from rclpy.node import Node

from attitude_tools.ros2cli.cli import add_spin_time, fail, positive_float, run_subverb
from attitude_tools.ros2cli.graph import (
    absolute_name,
    call,
    graph_node,
    load_interface,
    node_names,
    wait_for,
)

CALL_TIMEOUT_S = 10.0


def lifecycle_nodes(node: Node, include_hidden: bool = False) -> list[str]:
    """Sorted names of the nodes that offer the lifecycle ``get_state`` service."""
    services = dict(node.get_service_names_and_types())
    return sorted(
        {
            name
            for name in node_names(node, include_hidden)
            if "lifecycle_msgs/srv/GetState" in services.get(f"{name}/get_state", [])
        }
    )


def _find(node: Node, args: argparse.Namespace) -> str | None:
    name = absolute_name(args.node_name)
    found = wait_for(node, lambda: name in lifecycle_nodes(node, True), args.timeout)
    return name if found else None


def get_state(node: Node, name: str) -> Any:
    srv = load_interface("lifecycle_msgs/srv/GetState", "srv")
    return call(node, srv, f"{name}/get_state", srv.Request(), CALL_TIMEOUT_S).current_state


def transitions(node: Node, name: str, all_: bool = False) -> list[Any]:
    """The node's transition descriptions: those available now, or the whole graph."""
    srv = load_interface("lifecycle_msgs/srv/GetAvailableTransitions", "srv")
    service = f"{name}/get_transition_graph" if all_ else f"{name}/get_available_transitions"
    return list(call(node, srv, service, srv.Request(), CALL_TIMEOUT_S).available_transitions)


def _nodes(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        names = lifecycle_nodes(node, args.all)
    for line in [str(len(names))] if args.count_nodes else names:
        print(line)
    return 0


def _get(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        names = lifecycle_nodes(node, args.include_hidden_nodes)
        if args.node_name is not None:
            if (one := _find(node, args)) is None:
                return fail("Node not found")
            names = [one]
        try:
            states = {n: get_state(node, n) for n in names}
        except RuntimeError as e:
            return fail(f"Exception while calling service: {e}")
    for name, state in states.items():
        prefix = "" if args.node_name is not None else f"{name}: "
        print(f"{prefix}{state.label} [{state.id}]")
    return 0


def _pick(available: list[Any], wanted: str) -> Any:
    for match in (
        lambda t: t.label == wanted,
        lambda t: str(t.id) == wanted,
        lambda t: t.id == getattr(_transition_msg(), f"TRANSITION_{wanted.upper()}", None),
    ):
        for transition in (d.transition for d in available):
            if match(transition):
                return transition
    return None


def _transition_msg() -> Any:
    return load_interface("lifecycle_msgs/msg/Transition")


def _set(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        if (name := _find(node, args)) is None:
            return fail("Node not found")
        try:
            available = transitions(node, name)
            transition = _pick(available, args.transition)
            if transition is None:
                return fail(
                    "Unknown transition requested, available ones are:"
                    + "".join(f"\n- {d.transition.label} [{d.transition.id}]" for d in available)
                )
            srv = load_interface("lifecycle_msgs/srv/ChangeState", "srv")
            request = srv.Request(transition=transition)
            ok = call(node, srv, f"{name}/change_state", request, CALL_TIMEOUT_S).success
        except RuntimeError as e:
            return fail(f"Exception while calling service of node '{args.node_name}': {e}")
    if not ok:
        return fail("Transitioning failed")
    print("Transitioning successful")
    return 0


def _list(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        if (name := _find(node, args)) is None:
            return fail("Node not found")
        try:
            found = transitions(node, name, args.all)
        except RuntimeError as e:
            return fail(f"Exception while calling service of node '{args.node_name}': {e}")
    for d in found:
        t = d.transition
        print(f"- {t.label} [{t.id}]\n\tStart: {d.start_state.label}\n\tGoal: {d.goal_state.label}")
    return 0


def _common(p: argparse.ArgumentParser, node_arg: str | None) -> None:
    if node_arg == "?":
        p.add_argument("node_name", nargs="?", help="Name of the ROS node (default: all nodes)")
    elif node_arg:
        p.add_argument("node_name", help="Name of the ROS node")
    p.add_argument(
        "--include-hidden-nodes", action="store_true", help="Consider hidden nodes as well"
    )
    p.add_argument(
        "--timeout",
        type=positive_float,
        default=2.0,
        help="(shim option) seconds to wait for a named node (default: 2)",
    )
    add_spin_time(p)


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(
        prog="ros2 lifecycle", description="Various lifecycle related sub-commands"
    )
    verbs = top.add_subparsers(title="Commands", metavar="<command>")
    p = verbs.add_parser("nodes", help="Output a list of nodes with lifecycle")
    p.add_argument("-a", "--all", action="store_true", help="Display all nodes even hidden ones")
    p.add_argument(
        "-c", "--count-nodes", action="store_true", help="Only display the number of nodes"
    )
    add_spin_time(p)
    p.set_defaults(handler=_nodes)
    p = verbs.add_parser("get", help="Get lifecycle state for one or more nodes")
    _common(p, "?")
    p.set_defaults(handler=_get)
    p = verbs.add_parser("set", help="Trigger lifecycle state transition")
    _common(p, "node")
    p.add_argument("transition", help="The lifecycle transition")
    p.set_defaults(handler=_set)
    p = verbs.add_parser("list", help="Output a list of available transitions")
    _common(p, "node")
    p.add_argument("-a", "--all", action="store_true", help="Display all existing transitions")
    p.set_defaults(handler=_list)
    return top


def main(argv: Sequence[str]) -> int:
    return run_subverb(parser(), argv)
