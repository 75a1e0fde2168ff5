"""The main loop shared by every node: spin until done or shut down, exit cleanly.

``rclpy.experimental.EventsExecutor`` is several times faster across processes than
the default executor, but its ``spin()`` does not return on SIGINT/SIGTERM; the loop
therefore spins once at a time and checks ``rclpy.ok()``.
"""

from __future__ import annotations

import sys

import rclpy
from rclpy.executors import ExternalShutdownException

from attitude_core.scenario import ScenarioError

EXIT_OK, EXIT_FAILURE, EXIT_BAD_INPUT = 0, 1, 2


def run(node_factory, args=None) -> int:
    """Create the node with ``node_factory()``, spin it, and return the exit code.

    The node may set ``node.done = True`` to end the loop (end of a scenario) and
    ``node.exit_code``; it may define ``close()``, which runs on every way out
    (normal end, SIGINT, SIGTERM, exception), e.g. to finish a recording.
    """
    rclpy.init(args=sys.argv if args is None else args)
    node = None
    code = EXIT_OK
    try:
        node = node_factory()
        from rclpy.experimental import EventsExecutor
        executor = EventsExecutor()
        executor.add_node(node)
        while rclpy.ok() and not getattr(node, "done", False):
            try:
                executor.spin_once(timeout_sec=0.1)
            except RuntimeError:
                # The events executor can raise while SIGINT/SIGTERM tears the context
                # down under it; that is a shutdown, not a failure.
                if rclpy.ok():
                    raise
        code = getattr(node, "exit_code", EXIT_OK)
    except ScenarioError as err:
        name = "node" if node is None else node.get_name()
        print(f"[{name}] error: scenario: {err}", file=sys.stderr, flush=True)
        code = EXIT_BAD_INPUT
    except (KeyboardInterrupt, ExternalShutdownException):
        code = getattr(node, "exit_code", EXIT_OK)
    finally:
        if node is not None:
            close = getattr(node, "close", None)
            if close is not None:
                close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
    return code
