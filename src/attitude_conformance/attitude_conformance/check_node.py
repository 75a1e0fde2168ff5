"""``ros2 run attitude_conformance bridge_check``: the node that checks a bridge.

It stands in for the planner and the controller (publishers of ``/controller/torque``,
``/planner/target_mrp`` and ``/planner/target_rate``, the latter two silent), listens to
what the bridge publishes, plays :class:`.driver.Driver`'s script, then prints one line
per contract point (:mod:`.checker`, :mod:`.checks_process`) and a summary. Exit code 0
when every point passes (or is skipped), 1 when one fails, 2 on bad parameters.
Parameters: ``mode``, ``scenario``, ``timeout_s``, ``launch`` (see :data:`PARAMETERS`).
"""

from __future__ import annotations

import os
import signal
import sys
import time
from typing import Any

import rclpy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from rclpy._rclpy_pybind11 import RCLError
from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import qos_policy_name_from_kind
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock

from attitude_core import node_graph
from attitude_core.node_parameters import TIME_MODES, NodeParameters
from attitude_core.parameters import Bounds, NodeParameterError, Param, ParameterError
from attitude_core.scenario import load_scenario
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.params import declare_node_parameters

from .bridge_process import BridgeProcess, bridge_command
from .checker import judge
from .checks_process import TopicQos, check_qos, check_sigint
from .driver import Driver
from .record import FAIL, Recording, Sample, Setup, summary

PARAMETERS = NodeParameters(
    own=(
        Param("mode", "str", "time mode of the bridge", "lockstep", choices=TIME_MODES),
        Param("scenario", "path", "scenario file the bridge runs (dt_s, inertia, initial state)"),
        Param(
            "timeout_s", "float", "wall-time limit of the whole check, s", 60.0, Bounds(1.0, 3600.0)
        ),
        Param("launch", "str", "command starting the bridge (empty: it is already running)", ""),
    ),
    scenario=None,
)
PARAMETERS_SOURCE = "node 'bridge_check' parameters"
DISCOVERY_GRACE_S = 2.0  # wait this long for the rate's match before listening to the attitude
INCOMPATIBLE_WAIT_S = 3.0  # give up this long after an incompatible-QoS event without state
DRAIN_S = 0.3  # spin this long after the script, for messages still in flight


class BridgeCheckNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("bridge_check", **kwargs)
        own, _ = declare_node_parameters(self, PARAMETERS)
        self.mode, self.timeout_s = own["mode"], own["timeout_s"]
        self.scenario = load_scenario(own["scenario"])
        self.rec = Recording(Setup.from_scenario(self.scenario, self.mode))
        self.driver = Driver(self.rec)
        self.started = time.monotonic()
        self.done = False
        self.incompatible: dict[str, list[str]] = {}
        self.incompatible_since: float | None = None
        self.pubs = {
            name: self.create_publisher(
                WrenchStamped if name == c.TORQUE else Vector3Stamped,
                name,
                c.qos(c.topic(name)),
                event_callbacks=PublisherEventCallbacks(incompatible_qos=self._incompatible(name)),
            )
            for name in node_graph.readiness(1).min_publishers
        }
        self.subs = {
            name: self._subscribe(name) for name in (c.ANGULAR_VELOCITY, c.APPLIED_TORQUE, c.CLOCK)
        }
        self.attitude_seen_s: float | None = None
        self.stamps: dict[str, set[int]] = {c.ATTITUDE: set(), c.ANGULAR_VELOCITY: set()}
        self.complete: set[int] = set()
        self.bridge = None
        if own["launch"]:
            command = bridge_command(own["launch"], os.path.abspath(own["scenario"]), self.mode)
            try:
                self.bridge = BridgeProcess(command)
            except OSError as err:
                raise NodeParameterError(PARAMETERS_SOURCE, "launch", str(err)) from err

    # -- endpoints ------------------------------------------------------------------

    def _incompatible(self, name: str):
        def record(info: Any) -> None:
            policy = qos_policy_name_from_kind(info.last_policy_kind)
            self.incompatible.setdefault(name, []).append(policy)

        return record

    def _subscribe(self, name: str):
        kind = {
            c.ATTITUDE: QuaternionStamped,
            c.ANGULAR_VELOCITY: Vector3Stamped,
            c.APPLIED_TORQUE: WrenchStamped,
            c.CLOCK: Clock,
        }[name]
        events = SubscriptionEventCallbacks(incompatible_qos=self._incompatible(name))
        return self.create_subscription(
            kind,
            name,
            lambda msg: self.on_message(name, msg),
            c.qos(c.topic(name), subscriber=True),
            event_callbacks=events,
        )

    def _listen_to_attitude(self, now: float) -> None:
        """Subscribe the attitude last: the bridge starts when it is matched, so the rate
        (and clock, applied torque) subscriptions are matched by then."""
        if c.ATTITUDE in self.subs:
            return
        if self.count_publishers(c.ATTITUDE) and self.attitude_seen_s is None:
            self.attitude_seen_s = now
        others = [n for n in self.subs if self.count_publishers(n)]
        matched = bool(others) and all(self.subs[n].get_publisher_count() for n in others)
        grace = self.attitude_seen_s is not None and now - self.attitude_seen_s > DISCOVERY_GRACE_S
        if matched or grace or self.incompatible:
            self.subs[c.ATTITUDE] = self._subscribe(c.ATTITUDE)

    # -- messages -------------------------------------------------------------------

    def on_message(self, name: str, msg: Any) -> None:
        now = time.monotonic()
        if name == c.CLOCK:
            self.rec.clock.append(Sample(cv.stamp_ns(msg.clock), "", (), now))
            return
        stamp, frame = cv.stamp_ns(msg.header.stamp), msg.header.frame_id
        if name == c.APPLIED_TORQUE:
            self.rec.applied.append(Sample(stamp, frame, tuple(cv.vector3(msg.wrench.torque)), now))
            return
        if name == c.ATTITUDE:
            q = msg.quaternion
            self.rec.attitude.append(Sample(stamp, frame, (q.x, q.y, q.z, q.w), now))
        else:
            self.rec.rate.append(Sample(stamp, frame, tuple(cv.vector3(msg.vector)), now))
        self.stamps[name].add(stamp)
        if all(stamp in s for s in self.stamps.values()):
            first = stamp not in self.complete
            self.complete.add(stamp)
            if first or name == c.ATTITUDE:  # a re-send is answered once, on its attitude
                self.send(self.driver.on_state(stamp, now), now)

    def send(self, torques: list, now: float) -> None:
        for stamp, u in torques:
            msg = WrenchStamped()
            cv.set_stamp(msg.header.stamp, stamp)
            msg.header.frame_id = c.BODY_FRAME
            cv.set_vector3(msg.wrench.torque, u)
            self.pubs[c.TORQUE].publish(msg)
            self.rec.torques.append(Sample(stamp, c.BODY_FRAME, tuple(float(x) for x in u), now))

    def tick(self) -> None:
        """Called by the loop between callbacks."""
        now = time.monotonic()
        self._listen_to_attitude(now)
        self.send(self.driver.on_tick(now), now)
        if self.incompatible and not self.rec.attitude:
            self.incompatible_since = self.incompatible_since or now
            if now - self.incompatible_since > INCOMPATIBLE_WAIT_S:
                self.driver.abort("no state: a bridge endpoint has an incompatible QoS", now)
        if self.bridge is not None and self.bridge.exited() is not None:
            self.driver.abort(f"the bridge exited with code {self.bridge.exited()}", now)
        elif now - self.started > self.timeout_s:
            self.driver.abort(f"timeout after {self.timeout_s:g} s", now)
        self.done = self.driver.done

    # -- report ---------------------------------------------------------------------

    def qos_topics(self) -> list[TopicQos]:
        me = self.get_name()
        out = []
        wanted = [(c.ATTITUDE, True), (c.ANGULAR_VELOCITY, True), (c.APPLIED_TORQUE, False)]
        wanted += [(c.CLOCK, False)] + [(name, name == c.TORQUE) for name in self.pubs]
        for name, required in wanted:
            ours = name in self.pubs
            infos = (
                self.get_subscriptions_info_by_topic if ours else self.get_publishers_info_by_topic
            )(name)
            matched = 0
            if ours:
                matched = self.pubs[name].get_subscription_count()
            elif name in self.subs:
                matched = self.subs[name].get_publisher_count()
            out.append(
                TopicQos(
                    name,
                    "subscription" if ours else "publisher",
                    required,
                    matched,
                    self.incompatible.get(name, []),
                    [
                        (i.node_name, i.qos_profile.reliability.name, i.qos_profile.durability.name)
                        for i in infos
                        if i.node_name != me
                    ],
                )
            )
        return [t for t in out if t.required or t.endpoints or t.incompatible]

    def report(self) -> int:
        """Judge, stop a launched bridge, print; the exit code."""
        exited = self.bridge is not None and self.bridge.exited() is not None
        if not self.rec.attitude and self.rec.aborted and not self.incompatible and not exited:
            self.rec.aborted += (
                "; no state received: is the bridge running on this ROS_DOMAIN_ID, started with "
                "lockstep.expected_subscribers:=1?"
            )
        results = [check_qos(self.qos_topics(), os.environ.get("ROS_DOMAIN_ID", "0"))]
        results += judge(self.rec)
        before, code, took, output = None, None, 0.0, ""
        if self.bridge is not None:
            before = self.bridge.exited()
            if before is None:
                code, took = self.bridge.interrupt()
            output = self.bridge.output()
        results.append(check_sigint(self.bridge is not None, before, code, took, output))
        for r in results:
            print(r.line(), flush=True)
        what = f"{self.mode}, scenario {self.scenario.name}"
        print(summary(results, what), flush=True)
        failed = any(r.status == FAIL for r in results)
        if failed and self.bridge is not None:
            print(f"bridge output (last lines):\n{self.bridge.tail()}", file=sys.stderr, flush=True)
        return 1 if failed else 0

    def close(self) -> None:
        if self.bridge is not None:
            self.bridge.close()


def main(args: list[str] | None = None) -> int:
    """Spin until the script ends (or SIGINT/SIGTERM), drain, report."""
    stop: list[int] = []
    previous = {
        s: signal.signal(s, lambda n, f: stop.append(n)) for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        rclpy.init(
            args=sys.argv if args is None else args, signal_handler_options=SignalHandlerOptions.NO
        )
    except RCLError as err:  # rcl refuses the command line
        print(f"[bridge_check] error: {err}", file=sys.stderr, flush=True)
        for s, handler in previous.items():
            signal.signal(s, handler)
        return 2
    node = None
    try:
        node = BridgeCheckNode()
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        while not stop and not node.done:
            executor.spin_once(timeout_sec=0.005)
            node.tick()
        if stop:
            node.driver.abort("interrupted", time.monotonic())
        deadline = time.monotonic() + DRAIN_S
        while time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.02)
        return node.report()
    except ParameterError as err:
        print(f"[bridge_check] error: {err}", file=sys.stderr, flush=True)
        return 2
    finally:
        if node is not None:
            node.close()
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
        for s, handler in previous.items():
            signal.signal(s, handler)


if __name__ == "__main__":
    raise SystemExit(main())
