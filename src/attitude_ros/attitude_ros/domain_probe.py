"""``python -m attitude_ros.domain_probe [--wait-s S]``: the nodes alive on this ROS domain.

Joins the domain of ``ROS_DOMAIN_ID`` with a hidden node, lets discovery run for
``--wait-s`` seconds (default 1.0) and until the node list has not changed for
:data:`SETTLE_S` (at most :data:`MAX_WAIT_S` in all), and prints the nodes it found as JSON,
``[[namespace, name], ...]`` (itself excluded). ``attitude-run`` calls it before it
starts a run, to refuse a domain where another run's nodes are alive.
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import rclpy
from rclpy.signals import SignalHandlerOptions

from attitude_ros import dds_profile

_NAME = "_attitude_run_domain_probe"  # a leading underscore: hidden from other tools
SETTLE_S = 0.5
"""The node list must stay unchanged this long (discovery still arriving otherwise)."""
MAX_WAIT_S = 5.0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="domain_probe")
    parser.add_argument("--wait-s", type=float, default=1.0)
    args = parser.parse_args(argv)
    dds_profile.apply()  # announces as the stack's nodes do (they answer it at once)
    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node(_NAME)
        start = changed = time.monotonic()
        nodes: list[tuple[str, str]] = []
        while True:  # discovery runs on the middleware's threads
            now = time.monotonic()
            found = sorted(
                (namespace, name)
                for name, namespace in node.get_node_names_and_namespaces()
                if name != _NAME
            )
            if found != nodes:
                nodes, changed = found, now
            settled = now - changed >= SETTLE_S
            if (now - start >= args.wait_s and settled) or now - start >= MAX_WAIT_S:
                break
            time.sleep(0.05)
        node.destroy_node()  # type: ignore[no-untyped-call]  # unannotated in rclpy
    finally:
        rclpy.try_shutdown()
    json.dump([list(n) for n in nodes], sys.stdout)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
