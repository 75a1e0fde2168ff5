"""The check's main loop: spin until the script ends (or SIGINT/SIGTERM), drain, report.

Like :func:`attitude_ros.runner.run` (SIGINT and SIGTERM only set a flag; ``done``,
``exit_code`` and ``close`` on every way out), but the node acts between callbacks
(``tick``), an interrupt ends the script (``abort``) and is still reported, and the
report (``report``, which sets ``exit_code``) comes after the messages still in flight.
"""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable

import rclpy
from rclpy._rclpy_pybind11 import RCLError
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from attitude_core.config.parameters import ParameterError

SPIN_S = 0.005  # longest wait for a callback between two ticks
DRAIN_S = 0.3  # spin this long after the script, for messages still in flight
DRAIN_SPIN_S = 0.02


class CheckNode(Node):
    """What the loop drives: an rclpy node with a script to tick (the bridge check's,
    :class:`attitude_conformance.check_node.BridgeCheckNode`, is one)."""

    done: bool
    exit_code: int

    def tick(self) -> None:
        """Act between callbacks (the script's next step)."""
        raise NotImplementedError

    def abort(self, reason: str) -> None:
        """End the script early (an interrupt), still reported."""
        raise NotImplementedError

    def report(self) -> None:
        """Report the verdict and set ``exit_code``."""
        raise NotImplementedError

    def close(self) -> None:
        """Release what the node holds besides its ROS entities."""
        raise NotImplementedError


def _error(err: Exception) -> None:
    print(f"[bridge_check] error: {err}", file=sys.stderr, flush=True)


def run(node_factory: Callable[[], CheckNode], args: list[str] | None = None) -> int:
    """Create the node, spin it, report; the exit code (2 on a bad command line)."""
    stop: list[int] = []
    previous = {
        s: signal.signal(s, lambda n, f: stop.append(n)) for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        rclpy.init(
            args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO
        )
    except RCLError as err:  # rcl refuses the command line
        _error(err)
        for s, handler in previous.items():
            signal.signal(s, handler)
        return 2
    node = None
    try:
        node = node_factory()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop and not node.done:
            executor.spin_once(timeout_sec=SPIN_S)
            node.tick()
        if stop:
            node.abort("interrupted")
        deadline = time.monotonic() + DRAIN_S
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=DRAIN_SPIN_S)
        node.report()
        return node.exit_code
    except ParameterError as err:
        _error(err)
        return 2
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
        for s, handler in previous.items():
            signal.signal(s, handler)
