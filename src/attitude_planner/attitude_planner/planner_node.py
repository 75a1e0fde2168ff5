"""FEPF planner node (``ros2 run attitude_planner fepf_planner``).

Wiring only: :class:`attitude_core.runtime.planner_stepper.PlannerStepper` decides (the
guidance from the first measured state, its clock, the target held while inactive,
status and derating changes). Subscribes the measured state, ``/spacecraft/attitude``
and ``/spacecraft/angular_velocity``, and answers each stamp once both messages of that
stamp are in, stamped with that state's stamp: ``/planner/target_mrp`` (``sigma_t`` =
sigma_RN), ``/planner/target_rate`` (``omega_t``, target-frame axes, rad/s),
``/planner/keep_out_margin_deg`` (the smallest keep-out margin of the measured
attitude, eq. 5) and ``/diagnostics``; ``/planner/status`` (a ``PlannerStatus`` value,
``arrived`` only when the body is on the goal) is latched and published on change.
A slew with no route is reported ``infeasible`` at the first state, with the reason in
``/diagnostics`` and in the log, and the target holds the start.

The state watchdog ticks on the stack's clock (:mod:`attitude_ros.loop_clock`: each
``/clock`` from a lockstep plant, else a wall timer of the loop's step): a lost state's faults go to
``/diagnostics`` (``fdir/<kind>``: WARN, then OK when states come back) and, after
``fdir.safe_after_s`` without a state, ``safe_mode`` to ``/planner/status`` (ERROR);
the guidance goes on from the first state after a gap.

With a reaction wheel array (``wheels.*``) each state pairs with its
``/spacecraft/wheel_states``, and the controller's ``/controller/wheel_torque`` tells
what each wheel was asked: a wheel that stops answering is taken out and the rest of
the slew re-budgeted on the wheels left, from their measured speeds
(:class:`attitude_core.assembly.guidance_limits.WheelBudget`).

It otherwise only reacts to messages, so lockstep simulation, real time and a hardware
bridge look the same to it. A repeated stamp (a lockstep re-send) gets the same answer again;
an older stamp, a non-finite rate or an unusable quaternion is rejected, logged and
counted.
"""

from __future__ import annotations

from typing import Any

from std_msgs.msg import String

from attitude_core.config import node_graph
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.runtime.planner_stepper import PlannerStepper
from attitude_core.runtime.stamp_gate import StampGate
from attitude_core.runtime.stamp_pairing import StampPairing
from attitude_ros import contract as c
from attitude_ros.convert import (
    DiagnosticsOut,
    event_diagnostics,
    fault_diagnostics,
    log_events,
    log_faults,
    set_vector3,
    stamp_msg,
)
from attitude_ros.endpoints import message, publisher
from attitude_ros.goal_intake import subscribe_goal
from attitude_ros.intake import (
    attitude_value,
    rate_value,
    subscribe_paired,
    subscribe_wheel_torque,
)
from attitude_ros.loop_clock import LoopClock
from attitude_ros.node_base import StackNode
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard, diagnostics_events
from attitude_ros.runner import run
from attitude_ros.wheel_msgs import wheel_inputs


class FepfPlannerNode(StackNode):
    spec = node_graph.PLANNER

    def configure(self) -> None:
        _, sc = declare_scenario_node(self, node_graph.PLANNER.parameters)
        self.scenario = sc
        self.stepper = PlannerStepper(sc)  # prepares the guidance: before the first state
        names = None if sc.wheels is None else sc.wheels.names
        state = [(c.ATTITUDE, attitude_value), (c.ANGULAR_VELOCITY, rate_value)]
        state += wheel_inputs(names)  # ... and the stamp's wheel state
        self.intake = StampPairing(len(state), StampGate(sc.sim_time_s))
        wired, stepper = node_graph.with_wheels(self.spec, bool(names)), self.stepper
        self.guard = RunGuard(self, wired, sc, self.stop, lambda: stepper.last_stamp_ns)
        self.pub_mrp = publisher(self, c.TARGET_MRP)
        self.pub_rate = publisher(self, c.TARGET_RATE)
        self.pub_status = publisher(self, c.PLANNER_STATUS)
        self.pub_margin = publisher(self, c.KEEP_OUT_MARGIN)
        self.pub_diag = publisher(
            self, c.DIAGNOSTICS, event_callbacks=diagnostics_events(self, publisher=True)
        )
        self.out_mrp, self.out_rate = message(c.TARGET_MRP), message(c.TARGET_RATE)
        self.out_margin = message(c.KEEP_OUT_MARGIN)
        self.out_diag: Any = None
        self.diag = DiagnosticsOut()  # the one /diagnostics message, refilled each step
        if names is not None:  # which wheels answer: the controller's commands
            subscribe_wheel_torque(self, self.guard, self.intake, names, self.on_wheel_torque)
        # A lockstep re-send (same state) gets the same answer again: self.publish.
        subscribe_paired(self, self.guard, self.intake, state, self.answer, self.publish)
        subscribe_goal(self, self.stepper.command)  # <run namespace>/planner/goal
        self.clock = LoopClock(self, sc.dt_s, self.on_tick, self.stepper.rebase_watchdog)
        self.get_logger().info(
            f"scenario '{sc.name}': FEPF variant {sc.planner.variant}, "
            f"{len(sc.instruments)} instrument(s), {len(sc.bright_objects)} bright object(s)"
        )

    @property
    def rejected(self) -> int:
        return self.intake.rejected

    @property
    def guidance(self) -> Guidance | None:
        return self.stepper.guidance

    @property
    def takes_input(self) -> bool:
        """Active, or deactivated after its first target: it then holds that target."""
        return self.stepper.takes_input(self.active)

    def on_tick(self, now: int) -> None:
        """The watchdog's tick: the faults of a stale state, safe mode."""
        if self.guidance is None or not self.active:
            return
        tick = self.stepper.tick(now)
        log_faults(self.get_logger(), tick.faults)
        for fault in tick.faults:
            self.pub_diag.publish(fault_diagnostics(stamp_msg(now), fault))
        if tick.status is not None:
            self.get_logger().error(f"status {tick.status}: no measured state; zero torque")
            self.pub_status.publish(String(data=tick.status.value))

    def on_wheel_torque(self, stamp: int, motor_torque_nm: Any) -> None:
        log_events(self.get_logger(), self.stepper.wheel_command(stamp, motor_torque_nm))

    def answer(self, stamp: int, stamp_msg: Any, state: tuple[Any, ...]) -> None:
        at, wheels = self.clock.state_time_ns(stamp), state[2] if len(state) > 2 else None
        step = self.stepper.step(stamp, state[0], state[1], self.active, at, wheels)
        log_events(self.get_logger(), step.logs)
        for msg in event_diagnostics(stamp_msg, step.faults, step.goals):  # faults, goals
            self.pub_diag.publish(msg)
        self.out_mrp.header.stamp = self.out_rate.header.stamp = stamp_msg
        set_vector3(self.out_mrp.vector, step.sigma_t)
        set_vector3(self.out_rate.vector, step.omega_t)
        if step.held:  # deactivated: the last target held, at rest (a safe stop)
            if self.out_diag is not None:
                self.out_diag.header.stamp = stamp_msg
            self.publish()
            return
        self.publish(report=False)  # what the controller waits for, before the report
        report = self.stepper.report(step, self.rejected)
        self.out_margin.data = report.margin_deg
        self.out_diag = self.diag.fill(stamp_msg, report.diagnostics)
        self.publish(target=False)
        if report.status is not None:
            self.pub_status.publish(String(data=report.status.value))
        log_events(self.get_logger(), report.logs)

    def close(self) -> None:
        """Stop the route thread (a route in progress is dropped)."""
        self.stepper.close()

    def publish(self, target: bool = True, report: bool = True) -> None:
        if target:
            self.pub_mrp.publish(self.out_mrp)
            self.pub_rate.publish(self.out_rate)
        if report:
            self.pub_margin.publish(self.out_margin)
            self.pub_diag.publish(self.out_diag)


def main(args: list[str] | None = None) -> int:
    return run(FepfPlannerNode, args, fast_exit=True)


if __name__ == "__main__":
    raise SystemExit(main())
