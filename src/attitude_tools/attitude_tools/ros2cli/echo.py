"""``ros2 topic echo TOPIC [MSG_TYPE]`` of the shim: each message as YAML, then ``---``.

Options as ros2topic's: ``--once``, ``--timeout N`` (stop after N s), ``--qos-profile``,
``--qos-reliability``, ``--qos-durability``, ``--qos-depth``, ``--qos-history``,
``--full-length``/``-f``, ``--truncate-length``/``-l``, ``--flow-style``. Without QoS options the
subscription adapts to the publishers as ros2topic's does (reliable if all of them are,
transient local if all are; otherwise best effort, volatile, with ros2topic's notice).
Differs from ros2cli: the type is taken from the graph after waiting up to
``--topic-wait`` s (ours; ros2cli does not wait) for the topic; no ``--csv``,
``--field``, ``--filter``, ``--raw``, ``--no-arr``, ``--no-str``, ``-i``, nor the
lost-message notice; Ctrl-C exits 0.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import rclpy
from rclpy.expand_topic_name import expand_topic_name
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSPresetProfiles,
    QoSProfile,
    ReliabilityPolicy,
)
from rclpy.validate_full_topic_name import validate_full_topic_name

from attitude_tools.ros2cli.cli import add_spin_time, fail, positive_float
from attitude_tools.ros2cli.graph import graph_node, load_interface, wait_for
from attitude_tools.ros2cli.msgyaml import message_to_yaml

TOPIC_WAIT_S = 10.0


def add_parser(verbs: Any) -> None:
    """Add ``echo`` to the ``ros2 topic`` sub-verbs."""
    p = verbs.add_parser("echo", help="Output messages from a topic")
    p.add_argument("topic_name", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument(
        "message_type", nargs="?", help="Type of the ROS message (e.g. 'std_msgs/msg/String')"
    )
    p.add_argument(
        "--once", action="store_true", help="Print the first message received and then exit."
    )
    p.add_argument(
        "--timeout", type=positive_float, metavar="N", help="Set a timeout in seconds for waiting"
    )
    add_qos_arguments(p)
    p.add_argument(
        "--full-length", "-f", action="store_true", help="Do not truncate arrays, bytes and strings"
    )
    p.add_argument(
        "--truncate-length", "-l", type=int, default=128, help="Truncation length (default: 128)"
    )
    p.add_argument("--flow-style", action="store_true", help="Print collections in the flow style")
    p.add_argument(
        "--topic-wait",
        type=float,
        default=TOPIC_WAIT_S,
        metavar="S",
        help=f"(shim option) seconds to wait for the topic to appear (default: {TOPIC_WAIT_S:g})",
    )
    add_spin_time(p)
    p.set_defaults(handler=_echo)


def _keys(enum: Any) -> list[str]:
    """The short keys (e.g. ``best_effort``) of an rclpy QoS enum or preset table."""
    keys: list[str] = enum.short_keys()
    return keys


def _from_key(enum: Any, key: str) -> Any:
    return enum.get_from_short_key(key)


def add_qos_arguments(p: argparse.ArgumentParser) -> None:
    """ros2topic's subscription QoS options (preset profile plus overrides)."""
    p.add_argument("--qos-profile", choices=_keys(QoSPresetProfiles), default="sensor_data")
    p.add_argument("--qos-depth", type=int, metavar="N")
    p.add_argument("--qos-history", choices=_keys(HistoryPolicy))
    p.add_argument("--qos-reliability", choices=_keys(ReliabilityPolicy))
    p.add_argument("--qos-durability", choices=_keys(DurabilityPolicy))


def choose_qos(node: Node, topic: str, args: argparse.Namespace) -> QoSProfile:
    """The subscription QoS: the user's overrides, else compatible with every publisher."""
    profile: QoSProfile = _from_key(QoSPresetProfiles, args.qos_profile)
    overrides = (args.qos_reliability, args.qos_durability, args.qos_depth, args.qos_history)
    if any(o is not None for o in overrides):
        if args.qos_history:
            profile.history = _from_key(HistoryPolicy, args.qos_history)
        if args.qos_reliability:
            profile.reliability = _from_key(ReliabilityPolicy, args.qos_reliability)
        if args.qos_durability:
            profile.durability = _from_key(DurabilityPolicy, args.qos_durability)
        if args.qos_depth is not None and args.qos_depth >= 0:
            profile.depth = args.qos_depth
        elif profile.durability == DurabilityPolicy.TRANSIENT_LOCAL and profile.depth == 0:
            profile.depth = 1
        return profile
    pubs = [i.qos_profile for i in node.get_publishers_info_by_topic(topic)]
    if not pubs:
        return profile
    reliable = sum(q.reliability == ReliabilityPolicy.RELIABLE for q in pubs)
    latched = sum(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in pubs)
    if reliable == len(pubs):
        profile.reliability = ReliabilityPolicy.RELIABLE
    else:
        if reliable:
            print(
                "Some, but not all, publishers are offering QoSReliabilityPolicy.RELIABLE. "
                "Falling back to QoSReliabilityPolicy.BEST_EFFORT as it will connect to all "
                "publishers"
            )
        profile.reliability = ReliabilityPolicy.BEST_EFFORT
    if latched == len(pubs):
        profile.durability = DurabilityPolicy.TRANSIENT_LOCAL
    else:
        if latched:
            print(
                "Some, but not all, publishers are offering "
                "QoSDurabilityPolicy.TRANSIENT_LOCAL. Falling back to "
                "QoSDurabilityPolicy.VOLATILE as it will connect to all publishers"
            )
        profile.durability = DurabilityPolicy.VOLATILE
    return profile


def full_topic_name(node: Node, topic: str) -> str:
    """``topic`` expanded against the node's namespace (ValueError if invalid)."""
    try:
        name = expand_topic_name(topic, node.get_name(), node.get_namespace())
        validate_full_topic_name(name)
    except Exception as e:  # noqa: BLE001 - rclpy raises several kinds for a bad name
        raise ValueError(f"Invalid topic name '{topic}': {e}") from None
    return name


def topic_type(node: Node, topic: str, wait_s: float) -> str | None:
    """The one type of ``topic`` once it is in the graph (None after ``wait_s``).

    ValueError if the topic has several types.
    """
    types: list[str] = []

    def found() -> bool:
        types[:] = dict(node.get_topic_names_and_types()).get(topic, [])
        return bool(types)

    if not wait_for(node, found, wait_s):
        return None
    if len(types) > 1:
        raise ValueError(
            f"Cannot echo topic '{topic}', as it contains more than one type: [{', '.join(types)}]"
        )
    return types[0]


def _echo(args: argparse.Namespace) -> int:
    try:
        with graph_node(args.spin_time) as node:
            return _subscribe_and_spin(node, args)
    except KeyboardInterrupt:
        return 0


def _subscribe_and_spin(node: Node, args: argparse.Namespace) -> int:
    try:
        topic = full_topic_name(node, args.topic_name)
        type_name = args.message_type or topic_type(node, topic, args.topic_wait)
        if type_name is None:
            return fail(
                f"Could not determine the type for the passed topic: '{topic}' did not "
                f"appear within {args.topic_wait:g} s"
            )
        msg_type = load_interface(type_name)
    except ValueError as e:
        return fail(str(e))
    limit = None if args.full_length else args.truncate_length
    received: list[int] = []

    def on_message(msg: Any) -> None:
        if args.once and received:
            return
        received.append(1)
        print(message_to_yaml(msg, limit, args.flow_style), end="---\n", flush=True)

    node.create_subscription(msg_type, topic, on_message, choose_qos(node, topic, args))
    end = None if args.timeout is None else time.monotonic() + args.timeout
    while not (args.once and received) and (end is None or time.monotonic() < end):
        rclpy.spin_once(node, timeout_sec=0.1)
    return 0
