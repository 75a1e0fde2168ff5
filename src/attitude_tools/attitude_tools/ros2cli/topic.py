"""``ros2 topic list|echo|hz|pub`` of the shim (ros2topic's output; echo, hz and pub in
own modules).

``list [-t|--show-types] [-c|--count-topics] [--include-hidden-topics] [--spin-time S]``:
sorted names, with ``-t`` as ``name [pkg/msg/Type]``. Differs from ros2cli: no ``-v``
and no daemon (each call discovers the graph itself: ``--spin-time``, 1 s by default);
``ros2 topic`` without a sub-verb is a usage error (status 2, ros2cli prints help, 0).
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from rclpy.node import Node
from rclpy.topic_or_service_is_hidden import topic_or_service_is_hidden

from attitude_tools.ros2cli import echo, hz, pub
from attitude_tools.ros2cli.cli import add_spin_time, run_subverb
from attitude_tools.ros2cli.graph import graph_node


def topics(node: Node, include_hidden: bool) -> list[tuple[str, list[str]]]:
    """(name, types) of the graph's topics, sorted, hidden ones only if asked."""
    return sorted(
        (name, types)
        for name, types in node.get_topic_names_and_types()
        if include_hidden or not topic_or_service_is_hidden(name)
    )


def _list(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        found = topics(node, args.include_hidden_topics)
    if args.count_topics:
        print(len(found))
        return 0
    for name, types in found:
        print(f"{name} [{', '.join(types)}]" if args.show_types else name)
    return 0


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(
        prog="ros2 topic", description="Various topic related sub-commands"
    )
    verbs = top.add_subparsers(title="Commands", metavar="<command>")
    p = verbs.add_parser("list", help="Output a list of available topics")
    p.add_argument(
        "-t", "--show-types", action="store_true", help="Additionally show the topic type"
    )
    p.add_argument(
        "-c", "--count-topics", action="store_true", help="Only display the number of topics"
    )
    p.add_argument(
        "--include-hidden-topics", action="store_true", help="Consider hidden topics as well"
    )
    add_spin_time(p)
    p.set_defaults(handler=_list)
    echo.add_parser(verbs)
    hz.add_parser(verbs)
    pub.add_parser(verbs)
    return top


def main(argv: Sequence[str]) -> int:
    return run_subverb(parser(), argv)
