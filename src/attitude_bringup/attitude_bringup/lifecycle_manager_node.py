"""Lifecycle manager of one run (``ros2 run attitude_bringup lifecycle_manager``).

Wiring only: :class:`attitude_core.runtime.lifecycle_manager.LifecycleManager` drives
the managed nodes ``node_names`` (fully qualified, in activation order) through the
standard ``lifecycle_msgs`` services (:class:`attitude_ros.lifecycle_client.LifecycleClient`),
as nav2's lifecycle manager does; this node gives it the graph, the run identities on
``/diagnostics``, the command lines on stdin and SIGINT/SIGTERM. Progress and failures
go to stdout as :func:`attitude_core.runtime.bringup.event_line` lines (``attitude-run``
reads them) and to the log. Exit 0 after a clean bring-down, 1 after a failure, 2 on a
refused parameter.
"""

from __future__ import annotations

import os
import signal
import sys
import threading

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from attitude_core.config import node_graph
from attitude_core.config.parameters import ParameterError
from attitude_core.runtime import run_identity as ri
from attitude_core.runtime.lifecycle_manager import LifecycleManager
from attitude_ros import contract as c
from attitude_ros import dds_profile
from attitude_ros.convert import log_events
from attitude_ros.lifecycle_client import LifecycleClient
from attitude_ros.params import declare_node_parameters
from attitude_ros.run_guard import diagnostics_events, identity_qos
from attitude_ros.runner import exit_process


class RosGraph:
    """The manager's view of the graph through the rclpy node ``node``
    (:class:`attitude_core.runtime.lifecycle_manager.ManagerGraph`)."""

    def __init__(self, node: Node) -> None:
        self.node = node

    def spin(self, timeout_s: float) -> None:
        rclpy.spin_once(self.node, timeout_sec=timeout_s)

    def alive(self) -> set[str]:
        return {ri.Endpoint(ns, n).node for n, ns in self.node.get_node_names_and_namespaces()}

    def publishers(self, topic: str) -> list[ri.Endpoint]:
        infos = self.node.get_publishers_info_by_topic(topic)
        return [ri.Endpoint(i.node_namespace, i.node_name) for i in infos]

    def namespace(self) -> str:
        return self.node.get_namespace()

    def log(self, level: str, text: str) -> None:
        log_events(self.node.get_logger(), [(level, text)])


def manager(node: Node, parent_pid: int) -> LifecycleManager:
    """The manager of the nodes named by ``node``'s parameters, with its inputs wired:
    the nodes' lifecycle clients, their run identities, the command lines on stdin."""
    own, _ = declare_node_parameters(node, node_graph.MANAGER.parameters)
    client = lambda name, on_event: LifecycleClient(node, name, on_event)
    m = LifecycleManager(own, RosGraph(node), client, parent_pid)

    def on_identity(msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.hardware_id == ri.IDENTITY_HARDWARE_ID:
                m.on_identity(status.name, {kv.key: kv.value for kv in status.values})

    node.create_subscription(
        DiagnosticArray,
        c.DIAGNOSTICS,
        on_identity,
        identity_qos(64),
        event_callbacks=diagnostics_events(node, publisher=False),
    )
    threading.Thread(target=m.read_commands, args=(sys.stdin,), daemon=True).start()
    return m


def main(args: list[str] | None = None) -> int:
    stop: list[int] = []
    parent_pid = os.getppid()
    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, lambda n, f: stop.append(n))
    dds_profile.apply()  # before rclpy.init: the stack's discovery timing
    rclpy.init(
        args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO
    )
    node = rclpy.create_node(node_graph.MANAGER.node_name)
    try:
        m = manager(node, parent_pid)
    except ParameterError as err:
        print(f"[{node.get_name()}] error: parameter: {err}", file=sys.stderr, flush=True)
        rclpy.try_shutdown()
        return 2
    try:
        code = m.session(stop)  # ends with the bring-down and the event 'down'
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    exit_process(code)  # the process ends here: no interpreter teardown (see there)


if __name__ == "__main__":
    raise SystemExit(main())
