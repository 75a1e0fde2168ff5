"""``ros2 topic pub TOPIC MSG_TYPE [VALUES]`` of the shim: publish a message built from a
YAML mapping, as ros2topic's does.

Options as ros2topic's: ``--once``/``-1`` (publish one message, then exit), ``--times``/``-t N``,
``--rate``/``-r HZ`` (default 1), ``--wait-matching-subscriptions``/``-w N`` (default 1 with
``--once`` or ``--times``, else 0), ``--keep-alive S``, ``--qos-reliability``,
``--qos-durability``, ``--qos-depth``, ``--print``/``-p N``. VALUES is YAML in ros2cli's
format (``"{header: {frame_id: inertial}, quaternion: {w: 1.0}}"``); a ``builtin_interfaces/Time``
field given as ``now`` (or a ``header`` given as ``auto``: stamp now, ``frame_id`` empty)
takes the node's clock. The publisher is reliable and volatile (keep last ``--qos-depth``,
10) by default. A message of ``--once`` is acknowledged by the matched subscribers before
the process exits (``wait_for_all_acked``), up to ``--keep-alive`` s. Differs from
ros2cli: no ``--node-name``, ``--qos-profile`` nor ``--use-sim-time``; Ctrl-C exits 0.
"""

from __future__ import annotations

import argparse
import time
from typing import Any

import rclpy
import yaml
from rclpy.duration import Duration
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from attitude_tools.ros2cli.cli import fail, positive_float
from attitude_tools.ros2cli.echo import full_topic_name
from attitude_tools.ros2cli.graph import graph_node, load_interface, wait_for
from attitude_tools.ros2cli.msgyaml import message_to_yaml

MATCH_WAIT_S = 30.0  # how long --wait-matching-subscriptions waits at most (ours)
_RELIABILITY = {
    "reliable": ReliabilityPolicy.RELIABLE,
    "best_effort": ReliabilityPolicy.BEST_EFFORT,
}
_DURABILITY = {
    "volatile": DurabilityPolicy.VOLATILE,
    "transient_local": DurabilityPolicy.TRANSIENT_LOCAL,
}


def add_parser(verbs: Any) -> None:
    """Add ``pub`` to the ``ros2 topic`` sub-verbs."""
    p = verbs.add_parser("pub", help="Publish a message to a topic")
    p.add_argument("topic_name", help="Name of the ROS topic to publish to (e.g. '/chatter')")
    p.add_argument("message_type", help="Type of the ROS message (e.g. 'std_msgs/msg/String')")
    p.add_argument("values", nargs="?", default="{}", help="Values to fill the message, in YAML")
    p.add_argument("-r", "--rate", type=positive_float, default=1.0, metavar="N", help="Hz")
    p.add_argument("-p", "--print", type=int, default=1, metavar="N", help="print every N-th")
    p.add_argument("-1", "--once", action="store_true", help="Publish one message and exit")
    p.add_argument("-t", "--times", type=int, default=0, help="Publish this many, then exit")
    p.add_argument("-w", "--wait-matching-subscriptions", type=int, default=None, metavar="N")
    p.add_argument("--keep-alive", type=positive_float, default=0.1, metavar="S")
    p.add_argument("--qos-depth", type=int, default=10, metavar="N")
    p.add_argument("--qos-reliability", choices=("reliable", "best_effort"), default="reliable")
    p.add_argument("--qos-durability", choices=("volatile", "transient_local"), default="volatile")
    p.add_argument("--spin-time", type=float, default=0.5, metavar="S", help=argparse.SUPPRESS)
    p.set_defaults(handler=_pub)


def fill(msg: Any, values: Any, node: Node, where: str = "") -> None:
    """Set ``msg``'s fields from the mapping ``values`` (ValueError naming a bad field)."""
    if not isinstance(values, dict):
        raise ValueError(f"{where or 'the message'}: expected a mapping, got {values!r}")
    fields = msg.get_fields_and_field_types()
    for key, value in values.items():
        path = f"{where}.{key}" if where else str(key)
        if key not in fields:
            raise ValueError(f"{path}: no such field in {type(msg).__name__} {sorted(fields)}")
        current = getattr(msg, key)
        kind = fields[key]
        if kind == "builtin_interfaces/Time" and value == "now":
            setattr(msg, key, node.get_clock().now().to_msg())
        elif kind == "std_msgs/Header" and value == "auto":
            current.stamp = node.get_clock().now().to_msg()
            current.frame_id = ""
        elif hasattr(current, "get_fields_and_field_types"):
            fill(current, value, node, path)
        else:
            try:
                setattr(msg, key, _plain(value, current))
            except (TypeError, ValueError, AssertionError) as err:
                raise ValueError(f"{path}: cannot take {value!r} ({kind}): {err}") from None


def _plain(value: Any, current: Any) -> Any:
    """``value`` as the field's Python type: an int given to a float field becomes a float."""
    if isinstance(current, float) and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    return value


def _qos(args: argparse.Namespace) -> QoSProfile:
    return QoSProfile(  # type: ignore[no-untyped-call]
        history=HistoryPolicy.KEEP_LAST,
        depth=max(args.qos_depth, 1),
        reliability=_RELIABILITY[args.qos_reliability],
        durability=_DURABILITY[args.qos_durability],
    )


def _pub(args: argparse.Namespace) -> int:
    try:
        with graph_node(args.spin_time) as node:
            return _publish(node, args)
    except KeyboardInterrupt:
        return 0


def _publish(node: Node, args: argparse.Namespace) -> int:
    try:
        topic = full_topic_name(node, args.topic_name)
        msg_type = load_interface(args.message_type)
        values = yaml.safe_load(args.values)
        msg = msg_type()
        fill(msg, {} if values is None else values, node)
    except (ValueError, yaml.YAMLError) as e:
        return fail(f"ros2 topic pub: {e}")
    publisher = node.create_publisher(msg_type, topic, _qos(args))
    times = 1 if args.once else args.times
    wait_n = args.wait_matching_subscriptions
    if wait_n is None:
        wait_n = 1 if times else 0
    if wait_n > 0:
        print(f"Waiting for at least {wait_n} matching subscription(s)...", flush=True)
        if not wait_for(node, lambda: publisher.get_subscription_count() >= wait_n, MATCH_WAIT_S):
            return fail(f"no {wait_n} matching subscription(s) on {topic} in {MATCH_WAIT_S:g} s")
    count = 0
    period = 1.0 / args.rate
    print("publisher: beginning loop", flush=True)
    while times == 0 or count < times:
        if args.print > 0 and count % args.print == 0:
            print(f"publishing #{count + 1}: {message_to_yaml(msg, 128, False)}", flush=True)
        publisher.publish(msg)
        count += 1
        if times and count >= times:
            break
        end = time.monotonic() + period
        while time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=max(end - time.monotonic(), 0.0))
    publisher.wait_for_all_acked(Duration(seconds=args.keep_alive + 5.0))
    return 0
