"""PD attitude controller node (``ros2 run attitude_controller pd_controller``).

For each stamp it waits for the four inputs of that stamp, ``/spacecraft/attitude``,
``/spacecraft/angular_velocity``, ``/planner/target_mrp`` and ``/planner/target_rate``,
then publishes ``/controller/torque`` (body axes, N m) with the same stamp:
``u = -Kp sigma_B/R - Kd (omega_B - C_BR omega_t)`` (paper eq. 11, ``Kp = kp_over_j J``,
``Kd = kd_over_j J``). Matching by stamp makes the answer the same in lockstep, in real
time and behind a hardware bridge. Messages with non-finite values, an unusable
quaternion or a stamp older than the last torque are rejected, logged and counted,
never turned into torque.

The state watchdog (:mod:`attitude_core.fsw.fdir`) ticks on the stack's clock
(:mod:`attitude_ros.loop_clock`: each ``/clock`` from a lockstep plant, else a wall timer
of the loop's step): once the newest state is older than ``fdir.state_timeout_s`` the
controller answers each tick itself, stamped with the tick, from its prediction of the
body (:mod:`attitude_core.fsw.fdir.outage_control`). Deactivated in real time, it sends
a zero torque at once, so a plant that holds the last command holds a zero.

With a reaction wheel array (``wheels.*``) it also waits for ``/spacecraft/wheel_states``
of the stamp, turns the eq. 11 torque into motor torques on the wheels still answering
(:class:`attitude_core.fsw.control.wheel_control.WheelControl`: minimum-norm allocation
with saturation and redistribution) and publishes them on ``/controller/wheel_torque``,
the plant's command; ``/controller/torque`` is then the body torque they make.

``fault.drop_torque_fraction`` (test mode, default 0) drops that fraction of the torque
messages (seeded by ``fault.seed``), to test that a lossy link neither deadlocks a
lockstep run nor breaks a constraint.
"""

from __future__ import annotations

from typing import Any

from attitude_core.config import node_graph
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.fsw.control.wheel_control import WheelControl
from attitude_core.fsw.fdir.outage_control import OutageControl
from attitude_core.fsw.fdir.state_watchdog import FdirMode
from attitude_core.runtime.stamp_gate import StampGate
from attitude_core.runtime.stamp_pairing import StampPairing
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.convert import log_faults
from attitude_ros.intake import (
    attitude_value,
    rate_value,
    subscribe_paired,
    target_mrp_value,
    target_rate_value,
)
from attitude_ros.loop_clock import LoopClock
from attitude_ros.node_base import StackNode
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard
from attitude_ros.runner import run
from attitude_ros.torque_out import TorqueOut
from attitude_ros.wheel_msgs import wheel_inputs


class PdControllerNode(StackNode):
    spec = node_graph.CONTROLLER

    def configure(self) -> None:
        own, self.scenario = declare_scenario_node(self, node_graph.CONTROLLER.parameters)
        self.gains = PdGains(self.scenario.kp, self.scenario.kd)
        self.last_stamp: int | None = None  # stamp of the last torque
        self.first_stamp: int | None = None  # t = 0 of the watchdog's fault times
        array = self.scenario.wheels
        wheels = None if array is None else WheelControl(array, self.scenario.dt_s)
        self.out = TorqueOut(self, wheels, own.fault.drop_torque_fraction, own.fault.seed)
        inputs = [
            (c.ATTITUDE, attitude_value),
            (c.ANGULAR_VELOCITY, rate_value),
            (c.TARGET_MRP, target_mrp_value),
            (c.TARGET_RATE, target_rate_value),
            *wheel_inputs(None if array is None else array.names),
        ]
        # sigma_BN, omega_B, sigma_RN, omega_t (and the wheel state) of one stamp
        self.intake = StampPairing(len(inputs), StampGate(self.scenario.sim_time_s))
        wired = node_graph.with_wheels(self.spec, array is not None)
        self.guard = RunGuard(
            self, wired, self.scenario, self.stop, stamp_ns=lambda: self.last_stamp or 0
        )
        self.outage = self.new_outage()
        self.mode: FdirMode | None = None
        self.clock = LoopClock(self, self.scenario.dt_s, self.on_tick, self.on_rebase)
        subscribe_paired(
            self,
            self.guard,
            self.intake,
            inputs,
            self.answer,
            self.out.resend,  # a lockstep re-send: the same answer again
        )
        self.get_logger().info(
            f"scenario '{self.scenario.name}': Kp = {self.scenario.kp_over_j} J, "
            f"Kd = {self.scenario.kd_over_j} J"
        )

    @property
    def rejected(self) -> int:
        return self.intake.rejected

    def new_outage(self, origin_ns: int | None = None) -> OutageControl:
        sc = self.scenario
        bound, j = sc.actuators.max_torque_nm, sc.inertia_kgm2
        return OutageControl(sc.watchdog, self.gains, bound, j, sc.dt_s, origin_ns)

    def on_rebase(self) -> None:
        """The first ``/clock``: the watchdog starts again on sim time (stamps)."""
        self.outage = self.new_outage(self.first_stamp)

    def answer(self, stamp: int, stamp_msg, inputs) -> None:
        sigma_bn, omega_b, sigma_t, omega_t = inputs[:4]
        limit = self.scenario.actuators.max_torque_nm
        t = self.clock.state_time_ns(stamp)
        self.first_stamp = stamp if self.first_stamp is None else self.first_stamp
        ended = self.outage.measured(t, sigma_bn, omega_b, max(self.clock.now_ns(), t))
        log_faults(self.get_logger(), ended, "states back: ")
        u = commanded_torque(self.gains, sigma_bn, omega_b, sigma_t, omega_t, limit)
        u = u if self.active and not self.outage.safe else 0.0 * u
        u = self.out.answer(stamp_msg, u, inputs[4] if len(inputs) > 4 else None)
        self.outage.answered(t, sigma_t, u)  # the body torque sent (with wheels, theirs)
        self.last_stamp = stamp

    def on_tick(self, now: int) -> None:
        """The watchdog's answer to a tick when the state is stale (not the target)."""
        if not self.takes_input:
            return
        waiting = self.intake.newest_with((0, 1))
        if waiting is not None:
            stamp, (sigma_bn, omega_b, *_) = waiting
            self.outage.measured(self.clock.state_time_ns(stamp), sigma_bn, omega_b, now)
        answer = self.outage.tick(now)
        if answer is None:
            return
        log_faults(self.get_logger(), answer.opened)
        if answer.mode != self.mode:
            self.mode = answer.mode
            self.get_logger().warning(f"state watchdog: {answer.mode} at {now / 1e9:.3f} s")
        self.send_tick(now, answer.torque_b if self.active else 0.0 * answer.torque_b)

    def send_tick(self, stamp_ns: int, torque_b: Any) -> None:
        """A torque of its own, stamped with a tick of the stack's clock (with wheels,
        allocated at the last measured wheel speeds)."""
        self.out.answer(cv.stamp_msg(stamp_ns), torque_b, tick=True)

    @property
    def takes_input(self) -> bool:
        """Active, or deactivated after a run began: then every state gets zero torque
        (a safe stop the plant applies at once, in both time modes)."""
        return self.active or self.last_stamp is not None

    def deactivate(self) -> None:
        self.get_logger().info("deactivated: zero torque from now on")
        if self.last_stamp is not None and not self.clock.lockstep:
            self.send_tick(self.clock.now_ns(), (0.0, 0.0, 0.0))  # a plant holds the last


def main(args: list[str] | None = None) -> int:
    return run(PdControllerNode, args, fast_exit=True)


if __name__ == "__main__":
    raise SystemExit(main())
