"""Rigid-body spacecraft simulator node (``ros2 run spacecraft_sim rigid_body_sim``).

Integrates Euler's equation and the MRP kinematics with shadow-set switching (paper
eqs. 3-4, RK4, torque held over each step) and publishes, each step ``k`` with the
same stamp: ``/clock`` (simulated time ``k dt``), ``/spacecraft/attitude``
(``geometry_msgs/QuaternionStamped``, body orientation in the inertial frame, x, y, z,
w, frame ``inertial``) and ``/spacecraft/angular_velocity``
(``geometry_msgs/Vector3Stamped``, ``omega_BN`` in body axes, rad/s, frame ``body``).
It consumes ``/controller/torque`` (``geometry_msgs/WrenchStamped``, body axes, N m)
and publishes the torque it applied over ``[t_k, t_k+1)`` on
``/spacecraft/applied_torque``, stamped ``k`` (the commanded one, or a held or zero
torque after a timeout), so a recording shows what the body felt.

Time modes (parameter ``time_mode``):

* ``lockstep`` (default): stamps are simulated time. The state of step ``k`` is
  published, and the body advances only when the torque stamped for step ``k`` has
  arrived, so a run goes as fast as DDS allows and is the same every time. The state
  is re-sent every ``lockstep.resend_period_s`` while the torque is missing (the
  planner and controller answer a repeated stamp identically); after
  ``lockstep.torque_timeout_s`` the last torque is held for the step, with a warning,
  for at most ``lockstep.max_held_steps`` steps in a row; then the torque is stale and
  zero torque is applied (logged) until a controller answers again.
* ``realtime``: a wall-clock timer steps every ``dt_s`` with the latest torque held,
  as a hardware bridge would; stamps are the node's clock. A torque older than
  ``realtime.torque_stale_s`` (wall time since it arrived) is stale: zero torque.

Torques with non-finite values, or (real time) stamped before the torque already
applied, are rejected, logged and counted.

Before the first step it waits until the graph is connected: ``lockstep.expected_subscribers``
listeners on the state topics (planner, controller, and a recorder if any) and a torque
publisher. It exits with code 0 at the end of the scenario time.
"""

from __future__ import annotations

import time

import numpy as np
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rosgraph_msgs.msg import Clock as ClockMsg

from attitude_core.dynamics import RigidBody
from attitude_core.scenario import ScenarioError
from attitude_ros import contract as c
from attitude_ros.convert import (NS_PER_S, bad_vector, reject, set_quaternion_from_mrp,
                                  set_stamp, set_vector3, stamp_ns, vector3)
from attitude_ros.params import declare, declare_scenario
from attitude_ros.runner import EXIT_FAILURE, run

LOCKSTEP, REALTIME = "lockstep", "realtime"


class RigidBodySimNode(Node):
    def __init__(self) -> None:
        super().__init__("rigid_body_sim")
        self.time_mode = declare(self, "time_mode", "string",
                                 "lockstep (sim time, waits for each torque) or realtime", LOCKSTEP)
        if self.time_mode not in (LOCKSTEP, REALTIME):
            raise ScenarioError(f"node '{self.get_name()}' parameters", "time_mode",
                                f"must be 'lockstep' or 'realtime', got {self.time_mode!r}")
        self.expected_subscribers = declare(
            self, "lockstep.expected_subscribers", "integer",
            "listeners of /spacecraft/attitude to wait for before the first step "
            "(planner, controller, recorder)", 2)
        self.resend_period_s = declare(
            self, "lockstep.resend_period_s", "double",
            "re-send the state when its torque has not arrived after this wall time, s",
            0.2, value_range=(0.001, 60.0))
        self.torque_timeout_s = declare(
            self, "lockstep.torque_timeout_s", "double",
            "hold the last torque and advance after this wall time without torque, s",
            2.0, value_range=(0.001, 600.0))
        self.max_held_steps = declare(
            self, "lockstep.max_held_steps", "integer",
            "steps in a row the last torque is held after timeouts before zero torque", 1)
        self.torque_stale_s = declare(
            self, "realtime.torque_stale_s", "double",
            "real time: a torque older than this (wall time since arrival) is stale, s",
            0.5, value_range=(0.0, 3600.0))
        self.startup_timeout_s = declare(
            self, "startup_timeout_s", "double",
            "give up when the graph is not connected after this wall time, s",
            60.0, value_range=(0.0, 3600.0))

        self.scenario = sc = declare_scenario(self)  # after the node's own parameters
        self.body = RigidBody(sc.inertia_kgm2, sc.initial_mrp, sc.initial_rate_rad_s)
        self.dt_ns = int(round(sc.dt_s * NS_PER_S))
        self.n_steps = sc.n_steps
        self.k = 0
        self.torque = np.zeros(3)
        self.waiting_stamp = None
        self.sent_at = self.first_sent_at = 0.0
        self.resends = self.timeouts = self.rejected = 0
        self.held_steps = 0            # lockstep: consecutive timed-out steps
        self.torque_stamp = -1         # stamp of the torque applied last (real time)
        self.torque_received_at = None
        self.stale = False
        self.done = False
        self.exit_code = 0
        self.wall_start = None

        self.pub_clock = self.create_publisher(ClockMsg, c.CLOCK, c.qos(c.topic(c.CLOCK)))
        self.pub_att = self.create_publisher(QuaternionStamped, c.ATTITUDE,
                                             c.qos(c.topic(c.ATTITUDE)))
        self.pub_rate = self.create_publisher(Vector3Stamped, c.ANGULAR_VELOCITY,
                                              c.qos(c.topic(c.ANGULAR_VELOCITY)))
        self.pub_applied = self.create_publisher(WrenchStamped, c.APPLIED_TORQUE,
                                                 c.qos(c.topic(c.APPLIED_TORQUE)))
        self.msg_applied = WrenchStamped()
        self.msg_applied.header.frame_id = c.BODY_FRAME
        self.sub_torque = self.create_subscription(
            WrenchStamped, c.TORQUE, self.on_torque, c.qos(c.topic(c.TORQUE), subscriber=True))
        self.msg_clock, self.msg_att, self.msg_rate = ClockMsg(), QuaternionStamped(), Vector3Stamped()
        self.msg_att.header.frame_id = c.INERTIAL_FRAME
        self.msg_rate.header.frame_id = c.BODY_FRAME

        self.steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.created = time.monotonic()
        self.ready_since = None
        self.wait_timer = self.create_timer(0.02, self.wait_for_graph, clock=self.steady)
        self.step_timer = None
        self.get_logger().info(
            f"scenario '{sc.name}': {self.n_steps} steps of {sc.dt_s} s, {self.time_mode} mode; "
            f"waiting for {self.expected_subscribers} state listeners and a torque publisher")

    # -- start-up ---------------------------------------------------------------------

    def graph_ready(self) -> bool:
        e = self.expected_subscribers
        return (self.pub_att.get_subscription_count() >= e
                and self.pub_rate.get_subscription_count() >= e - 1  # not the planner
                and self.sub_torque.get_publisher_count() >= 1
                and self.count_publishers(c.TARGET_MRP) >= 1
                and self.count_subscribers(c.TARGET_MRP) >= e - 1
                and self.count_subscribers(c.TARGET_RATE) >= e - 1
                and self.count_subscribers(c.TORQUE) >= e - 1)

    def wait_for_graph(self) -> None:
        now = time.monotonic()
        if not self.graph_ready():
            self.ready_since = None
            if now - self.created > self.startup_timeout_s:
                self.get_logger().error(
                    f"graph not connected after {self.startup_timeout_s} s: "
                    f"{self.pub_att.get_subscription_count()} state listener(s), "
                    f"{self.sub_torque.get_publisher_count()} torque publisher(s)")
                self.finish(EXIT_FAILURE)
            return
        if self.ready_since is None:
            self.ready_since = now
        if now - self.ready_since < 0.2:  # let every endpoint finish matching
            return
        self.wait_timer.cancel()
        self.get_logger().info("graph connected; starting")
        self.wall_start = now
        if self.time_mode == LOCKSTEP:
            self.publish_state()
            self.step_timer = self.create_timer(0.02, self.check_torque_deadline,
                                                clock=self.steady)
        else:
            self.step_timer = self.create_timer(self.scenario.dt_s, self.realtime_tick,
                                                clock=self.steady)
            self.realtime_tick()

    # -- stepping ---------------------------------------------------------------------

    def publish_state(self) -> None:
        sim_ns = self.k * self.dt_ns
        stamp = sim_ns if self.time_mode == LOCKSTEP else self.get_clock().now().nanoseconds
        set_stamp(self.msg_clock.clock, sim_ns)
        set_stamp(self.msg_att.header.stamp, stamp)
        set_stamp(self.msg_rate.header.stamp, stamp)
        set_quaternion_from_mrp(self.msg_att.quaternion, self.body.sigma_bn)
        set_vector3(self.msg_rate.vector, self.body.omega_b)
        self.pub_clock.publish(self.msg_clock)
        self.pub_att.publish(self.msg_att)
        self.pub_rate.publish(self.msg_rate)
        self.waiting_stamp = stamp
        self.sent_at = self.first_sent_at = time.monotonic()

    def publish_applied(self, torque) -> None:
        """The torque applied from the state last published to the next one."""
        self.msg_applied.header.stamp = self.msg_att.header.stamp
        set_vector3(self.msg_applied.wrench.torque, torque)
        self.pub_applied.publish(self.msg_applied)

    def advance(self, torque) -> None:
        """Lockstep: the torque for step k is known; integrate to k + 1 and publish it."""
        self.torque = torque
        self.waiting_stamp = None
        self.publish_applied(torque)
        if self.k >= self.n_steps:
            self.finish(0)
            return
        self.body.step(torque, self.scenario.dt_s)
        self.k += 1
        self.publish_state()

    def on_torque(self, msg: WrenchStamped) -> None:
        u = vector3(msg.wrench.torque)
        reason = bad_vector(u, "torque")
        if reason:
            reject(self, c.TORQUE, reason)
            return
        stamp = stamp_ns(msg.header.stamp)
        if self.time_mode == REALTIME:
            if stamp < self.torque_stamp:
                reject(self, c.TORQUE, f"stamp {stamp} ns is older than the applied "
                                       f"torque's {self.torque_stamp} ns")
                return
            self.torque, self.torque_stamp = u, stamp
            self.torque_received_at = time.monotonic()
            self.set_stale(False)
        elif stamp == self.waiting_stamp:
            self.held_steps = 0
            self.set_stale(False)
            self.advance(u)

    def set_stale(self, stale: bool) -> None:
        if stale and not self.stale:
            self.get_logger().error("torque is stale: applying zero torque until a "
                                    "controller answers again")
        elif self.stale and not stale:
            self.get_logger().info("torque received again")
        self.stale = stale

    def check_torque_deadline(self) -> None:
        if self.waiting_stamp is None or self.done:
            return
        now = time.monotonic()
        if now - self.first_sent_at > self.torque_timeout_s:
            self.timeouts += 1
            self.held_steps += 1
            if self.held_steps > self.max_held_steps:
                self.set_stale(True)
                self.torque = np.zeros(3)
            else:
                self.get_logger().warning(
                    f"no torque for step {self.k} after {self.torque_timeout_s} s; "
                    f"holding the last torque {self.torque.tolist()} N m")
            self.advance(self.torque)
        elif now - self.sent_at > self.resend_period_s:
            self.resends += 1
            self.pub_clock.publish(self.msg_clock)
            self.pub_att.publish(self.msg_att)
            self.pub_rate.publish(self.msg_rate)
            self.sent_at = now

    def realtime_tick(self) -> None:
        if self.k > self.n_steps:
            self.finish(0)
            return
        if (self.torque_received_at is not None
                and time.monotonic() - self.torque_received_at > self.torque_stale_s):
            self.set_stale(True)
            self.torque = np.zeros(3)
            self.torque_received_at = None
        if self.k > 0:
            self.publish_applied(self.torque)
            self.body.step(self.torque, self.scenario.dt_s)
        self.publish_state()
        self.k += 1

    def close(self) -> None:
        self.get_logger().info(
            f"stopped at step {self.k}: {self.resends} state re-sends, {self.timeouts} torque "
            f"timeouts, {self.rejected} rejected torques")

    def finish(self, code: int) -> None:
        if self.done:
            return
        self.done, self.exit_code = True, code
        if self.step_timer is not None:
            self.step_timer.cancel()
        if code == 0 and self.wall_start is not None:
            wall = time.monotonic() - self.wall_start
            self.get_logger().info(
                f"scenario time ended: {self.n_steps} steps in {wall:.3f} s wall "
                f"({self.n_steps / max(wall, 1e-9):.0f} steps/s); {self.resends} re-sends, "
                f"{self.timeouts} torque timeouts, {self.rejected} rejected torques")


def main(args=None) -> int:
    return run(RigidBodySimNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
