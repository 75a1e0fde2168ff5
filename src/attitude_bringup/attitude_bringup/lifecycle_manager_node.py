"""Lifecycle manager of one run (``ros2 run attitude_bringup lifecycle_manager``).

Drives the managed nodes ``node_names`` (fully qualified, in activation order) through
the standard ``lifecycle_msgs`` services, as nav2's lifecycle manager does, in the order
of :mod:`attitude_core.runtime.bringup`:

1. ``configure`` each node as soon as its lifecycle services are there, in parallel (a
   refused scenario fails its configure: the node names the key and exits 2);
2. check: every loop node publishes its run identity with one scenario fingerprint;
   the plant is there: the named ``plant_nodes``, or the single node publishing every
   one of ``plant_topics`` (adopted: a second one is foreign), within
   ``plant_timeout_s``; ``plant_nodes`` is then set on every managed node;
3. with ``hold``, wait for a line ``activate`` on stdin (an operator's check point);
4. ``activate`` each in order; then watch: a transition the manager did not ask for is
   a failure; a line ``stop [NODE ...]`` on stdin (the nodes named there have exited),
   SIGINT or SIGTERM brings the nodes down:
   ``deactivate``, then ``shutdown``, in reverse order.

Progress and failures go to stdout as :func:`attitude_core.runtime.bringup.event_line`
lines (``attitude-run`` reads them) and to the log. Exit 0 after a clean bring-down, 1
after a failure.
"""

from __future__ import annotations

import os
import queue
import signal
import sys
import threading
import time
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from attitude_core.config.parameters import ParameterError
from attitude_core.contract import node_graph
from attitude_core.runtime import run_identity as ri
from attitude_core.runtime.bringup import (
    TRANSITION_GOALS,
    TransitionWatch,
    bring_down_order,
    event_line,
)
from attitude_ros import contract as c
from attitude_ros import dds_profile
from attitude_ros.lifecycle_client import LifecycleClient
from attitude_ros.params import declare_node_parameters
from attitude_ros.run_guard import diagnostics_events, identity_qos
from attitude_ros.runner import exit_process

POLL_S = 0.05
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"  # rmw's name of an endpoint whose node is not known yet


class Failure(Exception):
    """The run cannot go on: the reason names the node."""


class LifecycleManager:
    def __init__(self, node: Node, parent_pid: int) -> None:
        """``parent_pid``: the process that started this one (attitude-run), whose
        death ends the run without a bring-down."""
        own, _ = declare_node_parameters(node, node_graph.MANAGER.parameters)
        self.node, self.p, self.parent_pid = node, own, parent_pid
        self.names = [n for n in own.node_names if n]
        self.watch = TransitionWatch()
        self.failures: list[str] = []
        self.fingerprints: dict[str, tuple[str, str]] = {}  # node -> (role, fingerprint)
        self.nodes = {n: LifecycleClient(node, n, self.on_event) for n in self.names}
        node.create_subscription(
            DiagnosticArray,
            c.DIAGNOSTICS,
            self.on_identity,
            identity_qos(64),
            event_callbacks=diagnostics_events(node, publisher=False),
        )
        self.commands: queue.Queue[str] = queue.Queue()
        self.gone: set[str] = set()  # nodes whose processes have ended (attitude-run says)
        threading.Thread(target=self._read_stdin, daemon=True).start()

    # -- events ------------------------------------------------------------------------

    def emit(self, event: str, **fields: Any) -> None:
        try:
            print(event_line(event, **fields), flush=True)
        except (BrokenPipeError, OSError):  # attitude-run is gone: the log still has it
            self.node.get_logger().info(f"event {event} {fields} (no reader)")

    def on_event(self, name: str, start: str, goal: str) -> None:
        failure = self.watch.judge(name, start, goal)
        if failure is not None and failure not in self.failures:
            self.failures.append(failure)
            self.node.get_logger().error(failure)
            self.emit("failure", reason=failure)

    def on_identity(self, msg: DiagnosticArray) -> None:
        for status in msg.status:
            if status.hardware_id == ri.IDENTITY_HARDWARE_ID and status.name in self.nodes:
                values = {kv.key: kv.value for kv in status.values}
                self.fingerprints[status.name] = (
                    values.get(ri.ROLE, ""),
                    values.get(ri.FINGERPRINT, ""),
                )

    def _read_stdin(self) -> None:
        for line in sys.stdin:
            self.commands.put(line.strip())

    # -- steps ------------------------------------------------------------------------

    def spin_until(self, done: Any, timeout_s: float, what: str) -> None:
        deadline = time.monotonic() + timeout_s
        while not done():
            if self.failures:
                raise Failure(self.failures[0])
            if time.monotonic() > deadline:
                raise Failure(f"{what} within {timeout_s:g} s")
            rclpy.spin_once(self.node, timeout_sec=POLL_S)

    def transition(self, name: str, label: str) -> None:
        self.watch.request(name, label)
        ok = self.nodes[name].transition(label, self.p.transition_timeout_s)
        if not ok:
            why = "no answer" if ok is None else "failed"
            raise Failure(f"{name}: {label} {why} (see its log)")
        self.watch.settle(name, TRANSITION_GOALS[label])
        self.emit("transition", node=name, transition=label)

    def configure_all(self) -> None:
        """Configure every node, each as soon as its lifecycle services are there: the
        nodes configure in parallel (configure does not depend on the order; activate
        does, and stays in order)."""
        deadline = time.monotonic() + self.p.transition_timeout_s
        pending: dict[str, Any] = {}
        while len(pending) < len(self.names) or not all(f.done() for f in pending.values()):
            for name in self.names:
                if name not in pending and self.nodes[name].ready():
                    self.watch.request(name, "configure")
                    pending[name] = self.nodes[name].transition_async("configure")
            if self.failures:
                raise Failure(self.failures[0])
            if time.monotonic() > deadline:
                late = [n for n in self.names if n not in pending]
                if late:
                    raise Failure(
                        f"no lifecycle services of {late[0]} within "
                        f"{self.p.transition_timeout_s:g} s"
                    )
                silent = next(n for n in self.names if not pending[n].done())
                raise Failure(f"{silent}: configure no answer (see its log)")
            rclpy.spin_once(self.node, timeout_sec=POLL_S)
        for name in self.names:  # in table order: the first refusal is the one named
            if not pending[name].result().success:
                raise Failure(f"{name}: configure failed (see its log)")
            self.watch.settle(name, TRANSITION_GOALS["configure"])
            self.emit("transition", node=name, transition="configure")

    def set_plant(self, plants: list[str]) -> None:
        """``plant_nodes`` on every node, in parallel."""
        timeout = self.p.transition_timeout_s
        for name in self.names:
            self.spin_until(self.nodes[name].params_ready, timeout, f"{name}: plant_nodes not set")
        futures = {n: self.nodes[n].set_strings_async("plant_nodes", plants) for n in self.names}
        for name, future in futures.items():
            self.spin_until(future.done, timeout, f"{name}: plant_nodes not set")
            result = future.result()
            if result is None or not all(r.successful for r in result.results):
                raise Failure(f"{name}: plant_nodes not set")

    def bring_up(self, stop: list[int]) -> None:
        self.configure_all()
        self.check_identities()
        plants = self.find_plant()
        self.set_plant(plants)
        self.emit("configured", plant_nodes=plants)
        if self.p.hold:
            self.emit("holding")
            self.spin_until(lambda: stop or self.command() == "activate", 1e9, "activate")
            if stop:
                return
        for name in self.names:
            self.transition(name, "activate")
        self.emit("active")

    def check_identities(self) -> None:
        def heard() -> bool:
            return all(n in self.fingerprints for n in self.names)

        self.spin_until(heard, self.p.transition_timeout_s, "no run identity from every node")
        loop = {
            n: fp
            for n, (role, fp) in self.fingerprints.items()
            if role != node_graph.RECORDER.role and fp
        }
        if len(set(loop.values())) > 1:
            listed = ", ".join(f"{n} {fp}" for n, fp in sorted(loop.items()))
            raise Failure(f"scenario mismatch: the nodes run different scenarios ({listed})")

    def find_plant(self) -> list[str]:
        named = [n for n in self.p.plant_nodes if n]
        topics = [t for t in self.p.plant_topics if t]
        if named:
            self.spin_until(
                lambda: set(named) <= self.alive(),
                self.p.plant_timeout_s,
                f"plant node {', '.join(sorted(set(named) - self.alive()))} not found",
            )
            self.emit("plant", nodes=named, adopted=False)
            return named
        if not topics:
            return []
        found: list[ri.Endpoint] = []

        def one() -> bool:
            found[:] = self.candidates(topics)
            return bool(found)

        self.spin_until(one, self.p.plant_timeout_s, f"no plant published {topics[0]}")
        if len(found) > 1:
            names = ", ".join(e.node for e in found)
            raise Failure(
                f"{len(found)} nodes publish {' and '.join(topics)} ({names}): name the "
                "plant with --plant-node"
            )
        self.emit("plant", nodes=[found[0].node], adopted=True)
        return [found[0].node]

    def alive(self) -> set[str]:
        return {ri.Endpoint(ns, n).node for n, ns in self.node.get_node_names_and_namespaces()}

    def candidates(self, topics: list[str]) -> list[ri.Endpoint]:
        """The plants a run may adopt now; none while a publisher's node is still being
        discovered (its name comes a little after its endpoint)."""
        pubs: dict[str, list[ri.Endpoint]] = {}
        for t in topics:
            infos = self.node.get_publishers_info_by_topic(t)
            if any(i.node_name == UNKNOWN_NODE for i in infos):
                return []
            pubs[t] = [ri.Endpoint(i.node_namespace, i.node_name) for i in infos]
        return ri.plant_candidates(pubs, topics, self.node.get_namespace())

    def command(self) -> str | None:
        try:
            return self.commands.get_nowait()
        except queue.Empty:
            return None

    def run(self, stop: list[int]) -> None:
        """Watch until ``stop`` or a line ``stop [NODE ...]`` (the nodes named there
        have exited already: attitude-run saw their processes end)."""
        while not stop:
            words = (self.command() or "").split()
            if words[:1] == ["stop"]:
                self.gone.update(words[1:])
                return
            rclpy.spin_once(self.node, timeout_sec=POLL_S)

    def orphaned(self) -> bool:
        """Whether the process that started this one has died (its nodes get the same
        parent-death signal and end with it). Asked again at every wait of the
        bring-down: the kernel sends that signal when the *thread* that started the
        process exits, so it can come while the parent's other threads are still
        ending, and this process is reparented only after the last one."""
        return os.getppid() != self.parent_pid

    def has_gone(self, name: str) -> bool:
        """Whether ``name`` is no longer there to bring down: attitude-run says its
        process has ended with a line ``gone NODE ...`` (a node may end by itself, e.g.
        the simulator at the scenario's end); or the node has left the graph (a node
        leaves it when it is destroyed: stopped by the same signal as this manager);
        or attitude-run itself has died (:meth:`orphaned`). No waiting on its services
        then."""
        while (line := self.command()) is not None:
            words = line.split()
            if words[:1] == ["gone"]:
                self.gone.update(words[1:])
        return name in self.gone or name not in self.alive() or self.orphaned()

    def bring_down(self) -> None:
        """Deactivate, then shut down, in reverse order; a node that is gone (exited,
        or not in the graph) is skipped; nothing is done once attitude-run has died."""
        order = bring_down_order(self.names)
        for label in ("deactivate", "shutdown"):
            for name in order:
                gone = lambda name=name: self.has_gone(name)
                state = None if gone() else self.nodes[name].state(1.0, gone)
                if (
                    state is None
                    or state == "finalized"
                    or (label == "deactivate" and state != "active")
                ):
                    continue
                self.watch.request(name, label)
                if self.nodes[name].transition(label, 5.0, gone):
                    self.watch.settle(name, TRANSITION_GOALS[label])


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
    code = 0
    try:
        manager = LifecycleManager(node, parent_pid)
    except ParameterError as err:
        print(f"[{node.get_name()}] error: parameter: {err}", file=sys.stderr, flush=True)
        rclpy.try_shutdown()
        return 2
    try:
        manager.bring_up(stop)
        manager.run(stop)
        code = 1 if manager.failures else 0
    except Failure as err:
        node.get_logger().error(str(err))
        if str(err) not in manager.failures:
            manager.emit("failure", reason=str(err))
        code = 1
        manager.run(stop)  # attitude-run decides when the nodes go down
    finally:
        manager.bring_down()  # none when attitude-run died: the nodes have gone with it
        manager.emit("down")
        node.destroy_node()
        rclpy.try_shutdown()
    exit_process(code)  # the process ends here: no interpreter teardown (see there)


if __name__ == "__main__":
    raise SystemExit(main())
