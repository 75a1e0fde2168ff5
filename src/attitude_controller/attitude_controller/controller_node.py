"""PD attitude controller node (``ros2 run attitude_controller pd_controller``).

For each stamp it waits for the four inputs of that stamp, ``/spacecraft/attitude``,
``/spacecraft/angular_velocity``, ``/planner/target_mrp`` and ``/planner/target_rate``,
then publishes ``/controller/torque`` (body axes, N m) with the same stamp:
``u = -Kp sigma_B/R - Kd (omega_B - C_BR omega_t)`` (paper eq. 11, ``Kp = kp_over_j J``,
``Kd = kd_over_j J``). Matching by stamp makes the answer the same in lockstep, in real
time and behind a hardware bridge. Messages with non-finite values, an unusable
quaternion or a stamp older than the last torque are rejected, logged and counted,
never turned into torque.

``fault.drop_torque_fraction`` (test mode, default 0) drops that fraction of the torque
messages (seeded by ``fault.seed``), to test that a lossy link neither deadlocks a
lockstep run nor breaks a constraint.
"""

from __future__ import annotations

import random
import time
from typing import Any

from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from rclpy.node import Node

from attitude_core import node_graph
from attitude_core.control import PdGains, commanded_torque
from attitude_core.plausibility import implausible_mrp, implausible_rate
from attitude_core.stamp_gate import StampGate
from attitude_ros import contract as c
from attitude_ros.convert import (
    bad_frame,
    bad_quaternion,
    mrp_from_quaternion,
    reject,
    set_vector3,
    stamp_ns,
    vector3,
)
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard
from attitude_ros.runner import run

_PENDING_MAX = 64  # stamps kept while waiting for their other inputs


class PdControllerNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__(node_graph.CONTROLLER.node_name, **kwargs)
        own, self.scenario = declare_scenario_node(self, node_graph.CONTROLLER.parameters)
        self.drop_fraction = own["fault.drop_torque_fraction"]
        self.rng = random.Random(own["fault.seed"])
        self.dropped = 0
        self.gains = PdGains(self.scenario.kp, self.scenario.kd)
        self.pending: dict[int, list] = {}
        self.last_stamp: int | None = None  # stamp of the last torque, and the torque
        self.last_torque: WrenchStamped | None = None
        self.gate = StampGate(self.scenario.sim_time_s)
        self.bad_values = 0  # refused for their content (frame, quaternion, bounds)
        self.done, self.exit_code = False, 0
        self.guard = RunGuard(
            self,
            node_graph.CONTROLLER,
            self.scenario,
            self.stop,
            stamp_ns=lambda: self.last_stamp or 0,
        )
        self.pub_torque = self.create_publisher(WrenchStamped, c.TORQUE, c.qos(c.topic(c.TORQUE)))
        for slot, (name, msg_type, convert) in enumerate(
            (
                (c.ATTITUDE, QuaternionStamped, self.attitude),
                (c.ANGULAR_VELOCITY, Vector3Stamped, self.rate),
                (c.TARGET_MRP, Vector3Stamped, self.target_mrp),
                (c.TARGET_RATE, Vector3Stamped, self.target_rate),
            )
        ):
            self.create_subscription(
                msg_type,
                name,
                self.callback(slot, name, convert),
                c.qos(c.topic(name), subscriber=True),
                qos_overriding_options=c.state_qos_overrides(c.topic(name)),
            )
        self.get_logger().info(
            f"scenario '{self.scenario.name}': Kp = {self.scenario.kp_over_j} J, "
            f"Kd = {self.scenario.kd_over_j} J"
        )

    @staticmethod
    def attitude(msg):
        reason = bad_quaternion(msg.quaternion)
        return (None, reason) if reason else (mrp_from_quaternion(msg.quaternion), None)

    @staticmethod
    def rate(msg):
        v = vector3(msg.vector)
        reason = implausible_rate(v)
        return (None, reason) if reason else (v, None)

    @staticmethod
    def target_mrp(msg):
        v = vector3(msg.vector)
        reason = implausible_mrp(v, "target MRP")
        return (None, reason) if reason else (v, None)

    @staticmethod
    def target_rate(msg):
        v = vector3(msg.vector)
        reason = implausible_rate(v, "target rate")
        return (None, reason) if reason else (v, None)

    @property
    def rejected(self) -> int:
        """Refused input messages: implausible stamps and bad values."""
        return self.gate.rejected + self.bad_values

    @rejected.setter
    def rejected(self, total: int) -> None:  # convert.reject counts through this
        self.bad_values = total - self.gate.rejected

    def stop(self, code: int, reason: str) -> None:
        """The run guard's verdict: stop answering, exit with ``code``."""
        self.done, self.exit_code = True, code

    def callback(self, slot: int, name: str, convert):
        def on_message(msg) -> None:
            if not self.guard.admit(name):
                return
            verdict = self.gate.screen(
                msg.header.stamp.sec, msg.header.stamp.nanosec, time.time_ns()
            )
            if verdict.repeat:  # lockstep re-send: answer again, identically
                if slot == 0:
                    self.publish(self.last_torque)
                return
            if not verdict.accept:
                reject(self, name, verdict.reason, count=self.rejected)
                return
            if verdict.reason:  # accepted, with a note (the gate re-anchored)
                self.get_logger().warning(f"{name}: {verdict.reason}")
            stamp = stamp_ns(msg.header.stamp)
            reason = bad_frame(msg, name)
            if reason is None:
                value, reason = convert(msg)
            if reason:
                reject(self, name, reason)
                return
            inputs = self.pending.setdefault(stamp, [None] * 4)
            inputs[slot] = value
            if all(x is not None for x in inputs):
                self.gate.take(stamp, time.time_ns())
                self.answer(stamp, msg.header.stamp, inputs)
            elif len(self.pending) > _PENDING_MAX:
                del self.pending[min(self.pending)]

        return on_message

    def answer(self, stamp: int, stamp_msg, inputs) -> None:
        sigma_bn, omega_b, sigma_t, omega_t = inputs
        limit = self.scenario.actuators.max_torque_nm
        u = commanded_torque(self.gains, sigma_bn, omega_b, sigma_t, omega_t, limit)
        out = WrenchStamped()
        out.header.stamp = stamp_msg
        out.header.frame_id = c.BODY_FRAME
        set_vector3(out.wrench.torque, u)
        self.publish(out)
        for old in [s for s in self.pending if s <= stamp]:
            del self.pending[old]
        self.last_stamp, self.last_torque = stamp, out

    def publish(self, out: WrenchStamped) -> None:
        if self.drop_fraction and self.rng.random() < self.drop_fraction:
            self.dropped += 1
            return
        self.pub_torque.publish(out)


def main(args: list[str] | None = None) -> int:
    return run(PdControllerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
