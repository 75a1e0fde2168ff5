"""Rigid-body spacecraft simulator node (``ros2 run spacecraft_sim rigid_body_sim``).

Wiring only: :class:`attitude_core.runtime.sim_stepper.SimStepper` decides (lockstep and real
time, eqs. 3-4). Each step ``k`` publishes, with one stamp, the attitude (frame
``inertial``), ``omega_BN`` (frame ``body``) and, in lockstep only, ``/clock`` (``k dt``);
it takes ``/controller/torque`` and publishes the torque applied over ``[t_k, t_k+1)``
on ``/spacecraft/applied_torque``, stamped ``k``. It waits for the graph of
:func:`attitude_core.config.node_graph.readiness` first. Exit 0 at the scenario's end, 1 when
the graph never connects.

With declared sensors (``sensors.*``) the state goes to ``/spacecraft/truth/*`` (for the
record) and the loop gets the measurements instead: the gyro on ``/spacecraft/imu`` each
step and the star tracker on ``/spacecraft/star_tracker`` at its rate
(:mod:`spacecraft_sim.sensor_out`, conventions in :mod:`attitude_core.contract.topics`),
one draw per step, re-sent unchanged.

Behind a rehearsal link (``link.*``) the true state of every step goes to
``/spacecraft/truth/*`` and the loop gets what the link delivers, on the state topics;
``/clock`` is never impaired (the stepping: :mod:`attitude_core.runtime.sim_stepper`).

With a reaction wheel array (``wheels.*``) the command is ``/controller/wheel_torque``
(motor torques, read by wheel name) instead of ``/controller/torque``; each state goes
out with ``/spacecraft/wheel_states``, and ``/spacecraft/applied_torque`` is the body
torque the wheels applied.
"""

from __future__ import annotations

import time

from rclpy.clock import Clock, ClockType

from attitude_core.config import node_graph
from attitude_core.runtime.sim_stepper import Action, Decision, SimStepper
from attitude_ros import cdr
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.endpoints import subscription
from attitude_ros.node_base import StackNode
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard
from attitude_ros.runner import run
from attitude_ros.wheel_msgs import WheelOrder

from .sim_out import SimOutputs

LOOP_PERIOD_S = 0.02  # start-up polling and the lockstep torque-deadline check, s


class RigidBodySimNode(StackNode):
    spec = node_graph.SIMULATOR

    def configure(self) -> None:
        own, sc = declare_scenario_node(self, node_graph.SIMULATOR.parameters)
        self.scenario = sc
        sensing, wheeled = sc.sensors is not None, sc.wheels is not None
        self.wired = node_graph.with_wheels(self.spec, wheeled)  # the run's variant
        self.ready = node_graph.readiness(own.lockstep.expected_subscribers, sensing, wheeled)
        self.stepper = SimStepper.from_scenario(sc, own, created=time.monotonic())
        self.out = SimOutputs(self, sc, self.stepper.lockstep)
        self.steady = Clock(clock_type=ClockType.STEADY_TIME)
        stamp = lambda: self.stepper.state_stamp or 0
        self.guard = RunGuard(self, self.wired, sc, lambda code, _: self.finish(code), stamp)
        self.command = command = c.WHEEL_TORQUE if wheeled else c.TORQUE
        self.wheel_order = None if sc.wheels is None else WheelOrder(sc.wheels.names)
        on_command = self.on_wheel_torque if wheeled else self.on_torque
        self.sub_torque = self.guard.watch(
            command, subscription(self, command, on_command, raw=True)
        )
        self.timer = self.create_timer(LOOP_PERIOD_S, self.on_wait_timer, clock=self.steady)
        self.get_logger().info(
            f"scenario '{sc.name}': {sc.n_steps} steps of {sc.dt_s} s, {own.time_mode} mode; "
            f"waiting for {own.lockstep.expected_subscribers} state listeners and a "
            "torque publisher"
        )

    @property
    def rejected(self) -> int:
        return self.stepper.rejected

    def graph_ready(self) -> bool:
        own_pubs = self.out.state_publishers
        for name, n in self.ready.min_subscribers.items():
            pub = own_pubs.get(name)
            count = pub.get_subscription_count() if pub else self.count_subscribers(name)
            if count < n:
                return False
        for name, n in self.ready.min_publishers.items():
            sub = self.sub_torque if name == self.command else None
            count = sub.get_publisher_count() if sub is not None else self.count_publishers(name)
            if count < n:
                return False
        return True

    def on_wait_timer(self) -> None:
        if self.done or not self.active:  # inactive: no stepping (a safe stop)
            return
        ready = self.graph_ready() and self.guard.peers_agree(self.ready.min_readers)
        decision = self.stepper.poll_graph(time.monotonic(), ready)
        if decision.action == Action.FAIL:
            self.get_logger().error(
                f"{decision.logs[0][1]}: {self.out.state.pub_att.get_subscription_count()} state "
                f"listener(s), {self.sub_torque.get_publisher_count()} torque publisher(s)"
            )
            self.finish(decision.exit_code or 1)
        elif decision.action == Action.START:
            self.timer.cancel()
            self.do(decision)
            period = LOOP_PERIOD_S if self.stepper.lockstep else self.scenario.dt_s
            self.timer = self.create_timer(period, self.on_step_timer, clock=self.steady)
            if not self.stepper.lockstep:
                self.on_step_timer()  # the first real-time step at once

    def on_step_timer(self) -> None:
        if self.active:
            self.do(self.stepper.on_timer(time.monotonic(), self.get_clock().now().nanoseconds))

    def on_torque(self, data: bytes) -> None:
        if not self.active or not self.guard.admit(c.TORQUE):
            return
        stamp, frame_id, w, malformed = cdr.read(data, 6)  # raw: force, then torque
        decision = self.stepper.on_torque(time.monotonic(), stamp, w[3:], frame_id, malformed)
        if decision.action == Action.REJECT:
            cv.reject(self, c.TORQUE, decision.reason or "", count=self.stepper.rejected)
        self.do(decision)

    def on_wheel_torque(self, data: bytes) -> None:
        """The motor torques of the wheels, by name, in the scenario's order."""
        if not self.active or not self.guard.admit(c.WHEEL_TORQUE) or not self.wheel_order:
            return
        stamp, frame_id, u, reason = self.wheel_order.command(data)
        now = time.monotonic()
        d = self.stepper.on_torque(now, stamp, u, frame_id) if u is not None else None
        d = d or self.stepper.reject(reason or "")
        if d.action == Action.REJECT:
            cv.reject(self, c.WHEEL_TORQUE, d.reason or "", count=self.stepper.rejected)
        self.do(d)

    def do(self, d: Decision) -> None:
        """Publish and log what the stepper decided; the state first (the loop waits).
        Behind a link, steps the stepper takes at once (``more``) are published in turn."""
        self._do(d)
        while d.more and not self.done and self.active:
            d = self.stepper.step_on(time.monotonic())
            self._do(d)

    def _do(self, d: Decision) -> None:
        cv.log_events(self.get_logger(), d.logs)
        self.out.publish(d)
        if d.action == Action.FINISH:
            self.finish(0)
        elif d.action == Action.FAIL:
            self.finish(d.exit_code or 1)

    def finish(self, code: int) -> None:
        if not self.done:
            self.done = True
            self.exit_code = code
            self.timer.cancel()

    def close(self) -> None:
        s = self.stepper
        self.get_logger().info(
            f"stopped at step {s.k}: {s.resends} state re-sends, {s.timeouts} torque timeouts, "
            f"{s.rejected} rejected torques, {s.saturated_steps} saturated torques"
        )


def main(args: list[str] | None = None) -> int:
    return run(RigidBodySimNode, args, fast_exit=True)


if __name__ == "__main__":
    raise SystemExit(main())
