"""``ros2 node list [-a|--all] [-c|--count-nodes] [--spin-time S]`` of the shim.

Fully qualified names, sorted, one a line, with ros2node's warning (stderr) when two
nodes share a name. Differs from ros2cli: no daemon (``--spin-time`` of discovery, 1 s
by default), no ``info``; ``ros2 node`` without a sub-verb is a usage error (status 2).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from attitude_tools.ros2cli.cli import add_spin_time, run_subverb
from attitude_tools.ros2cli.graph import graph_node, node_names


def _list(args: argparse.Namespace) -> int:
    with graph_node(args.spin_time) as node:
        names = sorted(node_names(node, include_hidden=args.all))
    if args.count_nodes:
        print(len(names))
        return 0
    if len(set(names)) < len(names):
        print(
            "WARNING: Be aware that there are nodes in the graph that share an exact name, "
            "which can have unintended side effects.",
            file=sys.stderr,
        )
    for name in names:
        print(name)
    return 0


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(prog="ros2 node", description="Various node related sub-commands")
    verbs = top.add_subparsers(title="Commands", metavar="<command>")
    p = verbs.add_parser("list", help="Output a list of available nodes")
    p.add_argument("-a", "--all", action="store_true", help="Display all nodes even hidden ones")
    p.add_argument(
        "-c",
        "--count-nodes",
        action="store_true",
        help="Only display the number of nodes discovered",
    )
    add_spin_time(p)
    p.set_defaults(handler=_list)
    return top


def main(argv: Sequence[str]) -> int:
    return run_subverb(parser(), argv)
