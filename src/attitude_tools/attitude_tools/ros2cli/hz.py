"""``ros2 topic hz TOPIC`` of the shim: the receive rate, ros2topic's report about once a second.

Each report is ros2topic's two lines, ``average rate: %.3f`` and
``\\tmin: %.3fs max: %.3fs std dev: %.5fs window: %d``, over the last ``--window`` intervals
between messages (received best effort, as ros2topic does), once at least one second of
messages passed since the previous report (the first one a second after the second
message, as in ros2topic). Runs until Ctrl-C (exit 0). Differs from ros2cli:
``--count N`` (ours) stops after N reports; the topic must appear within
``--topic-wait`` s (ours; ros2cli waits forever); no ``--filter`` nor ``--wall-time``
(receive times are this host's monotonic clock, never sim time).
"""

from __future__ import annotations

import argparse
import math
import time
from collections import deque
from typing import Any

import rclpy
from rclpy.qos import qos_profile_sensor_data

from attitude_tools.ros2cli.cli import add_spin_time, fail, positive_int
from attitude_tools.ros2cli.echo import TOPIC_WAIT_S, full_topic_name, topic_type
from attitude_tools.ros2cli.graph import graph_node, load_interface

DEFAULT_WINDOW = 10000


class RateStats:
    """Intervals between receive times (ns), at most ``window`` of them, and when to report."""

    def __init__(self, window: int) -> None:
        self.intervals: deque[int] = deque(maxlen=window)
        self.last_ns: int | None = None
        self.reported_ns = 0

    def add(self, now_ns: int) -> None:
        """One message received at ``now_ns``."""
        if self.last_ns is not None and now_ns >= self.last_ns:
            self.intervals.append(now_ns - self.last_ns)
        else:  # first message, or the clock went back: start over
            self.intervals.clear()
        self.last_ns = now_ns

    def report(self) -> str | None:
        """ros2topic's report if one is due (1 s of messages since the last), else None."""
        if not self.intervals or self.last_ns is None:
            return None
        if self.reported_ns == 0:
            self.reported_ns = self.last_ns
            return None
        if self.last_ns < self.reported_ns + 1_000_000_000:
            return None
        self.reported_ns = self.last_ns
        n = len(self.intervals)
        mean = sum(self.intervals) / n
        rate = 1.0 / mean if mean > 0 else 0.0
        std = math.sqrt(sum((x - mean) ** 2 for x in self.intervals) / n)
        return (
            f"average rate: {rate * 1e9:.3f}\n\tmin: {min(self.intervals) * 1e-9:.3f}s "
            f"max: {max(self.intervals) * 1e-9:.3f}s std dev: {std * 1e-9:.5f}s window: {n}"
        )


def add_parser(verbs: Any) -> None:
    """Add ``hz`` to the ``ros2 topic`` sub-verbs."""
    p = verbs.add_parser("hz", help="Print the average publishing rate to screen")
    p.add_argument("topic_name", help="Name of the ROS topic to listen to (e.g. '/chatter')")
    p.add_argument(
        "--window",
        "-w",
        dest="window_size",
        type=positive_int,
        default=DEFAULT_WINDOW,
        metavar="WINDOW",
        help=f"window size, in # of messages, for calculating rate (default: {DEFAULT_WINDOW})",
    )
    p.add_argument(
        "--count",
        type=positive_int,
        metavar="N",
        help="(shim option) exit 0 after N reports (default: run until Ctrl-C)",
    )
    p.add_argument(
        "--topic-wait",
        type=float,
        default=TOPIC_WAIT_S,
        metavar="S",
        help=f"(shim option) seconds to wait for the topic to appear (default: {TOPIC_WAIT_S:g})",
    )
    add_spin_time(p)
    p.set_defaults(handler=_hz)


def _hz(args: argparse.Namespace) -> int:
    try:
        with graph_node(args.spin_time) as node:
            try:
                topic = full_topic_name(node, args.topic_name)
                if not dict(node.get_topic_names_and_types()).get(topic):
                    print(
                        f"WARNING: topic [{topic}] does not appear to be published yet", flush=True
                    )
                type_name = topic_type(node, topic, args.topic_wait)
                if type_name is None:
                    return fail(f"Topic '{topic}' did not appear within {args.topic_wait:g} s")
                msg_type = load_interface(type_name)
            except ValueError as e:
                return fail(str(e))
            stats = RateStats(args.window_size)
            node.create_subscription(
                msg_type,
                topic,
                lambda _msg: stats.add(time.monotonic_ns()),
                qos_profile_sensor_data,
            )
            reports = 0
            while args.count is None or reports < args.count:
                rclpy.spin_once(node, timeout_sec=0.1)
                if (text := stats.report()) is not None:
                    print(text, flush=True)
                    reports += 1
    except KeyboardInterrupt:
        pass
    return 0
