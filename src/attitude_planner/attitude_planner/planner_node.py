"""FEPF planner node (``ros2 run attitude_planner fepf_planner``).

Subscribes the measured state, ``/spacecraft/attitude`` and
``/spacecraft/angular_velocity``, and answers each stamp once both messages of that
stamp are in: one guidance update (:class:`attitude_core.gnc.guidance.Guidance`: the
FEPF, paper eqs. 6-10, 12, moved for the real time between stamps, time-scaled to the
actuator limits, closed on the measured state) and publishes, stamped with that
state's stamp: ``/planner/target_mrp`` (``sigma_t`` = sigma_RN),
``/planner/target_rate`` (``omega_t``, target-frame axes, rad/s),
``/planner/keep_out_margin_deg`` (the smallest keep-out margin of the measured
attitude, eq. 5) and ``/diagnostics``; ``/planner/status`` (a ``PlannerStatus`` value,
``arrived`` only when the body is on the goal) is latched and published on change.

Before the first state it prepares the guidance (``Guidance.prepare``: the FIS tables,
the roadmap and the route from the scenario's start): a slew with no route is reported
``infeasible`` at the first state, with the reason in ``/diagnostics`` and in the log,
and the target holds the start. Routes planned again during the run are computed in a
worker thread, off the message callbacks.

It only reacts to messages, so lockstep simulation, real time and a hardware bridge
look the same to it. It starts from the first measured attitude (a restarted planner
resumes from where the spacecraft is). A repeated stamp (a lockstep re-send) gets the
same answer again; an older stamp, a non-finite rate or an unusable quaternion is
rejected, logged and counted.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from std_msgs.msg import String

from attitude_core.contract import node_graph
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import NS_PER_S
from attitude_core.gnc.guidance import Guidance, GuidanceOutput
from attitude_core.runtime.planner_report import planner_diagnostics
from attitude_core.runtime.stamp_gate import StampGate
from attitude_core.runtime.stamp_pairing import StampPairing
from attitude_ros import contract as c
from attitude_ros.convert import DiagnosticsOut, set_vector3
from attitude_ros.endpoints import message, publisher
from attitude_ros.intake import attitude_value, rate_value, subscribe_paired
from attitude_ros.node_base import StackNode
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard, diagnostics_events
from attitude_ros.runner import run


class FepfPlannerNode(StackNode):
    spec = node_graph.PLANNER

    def configure(self) -> None:
        _, sc = declare_scenario_node(self, node_graph.PLANNER.parameters)
        self.scenario, self.sky = sc, sc.sky
        self.prepared = Guidance.prepare(sc)  # before the first state, once
        self.route_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="route")
        self.guidance: Guidance | None = None
        self.first_stamp_ns, self.last_stamp_ns = 0, 0
        self.intake = StampPairing(2, StampGate(sc.sim_time_s))  # sigma_BN, omega_B
        self.guard = RunGuard(self, self.spec, sc, self.stop, stamp_ns=lambda: self.last_stamp_ns)
        self.status: PlannerStatus | None = None
        self.derating = 1.0
        self.pub_mrp, self.pub_rate = publisher(self, c.TARGET_MRP), publisher(self, c.TARGET_RATE)
        self.pub_status = publisher(self, c.PLANNER_STATUS)
        self.pub_margin = publisher(self, c.KEEP_OUT_MARGIN)
        self.pub_diag = publisher(
            self, c.DIAGNOSTICS, event_callbacks=diagnostics_events(self, publisher=True)
        )
        self.out_mrp, self.out_rate = message(c.TARGET_MRP), message(c.TARGET_RATE)
        self.out_margin, self.out_diag = message(c.KEEP_OUT_MARGIN), None
        self.diag = DiagnosticsOut()  # the one /diagnostics message, refilled each step
        state = ((c.ATTITUDE, attitude_value), (c.ANGULAR_VELOCITY, rate_value))
        # A lockstep re-send (same state) gets the same answer again: self.publish.
        subscribe_paired(self, self.guard, self.intake, state, self.answer, self.publish)
        self.get_logger().info(
            f"scenario '{sc.name}': FEPF variant {sc.planner.variant}, "
            f"{len(sc.instruments)} instrument(s), {len(sc.bright_objects)} bright object(s)"
        )

    @property
    def rejected(self) -> int:
        return self.intake.rejected

    def start(self, stamp: int, sigma_bn: np.ndarray) -> Guidance:
        """The guidance from the first measured attitude."""
        guidance = Guidance.from_scenario(
            self.scenario, sigma_0=sigma_bn, executor=self.route_thread, prepared=self.prepared
        )
        self.first_stamp_ns = stamp
        log = self.get_logger()
        log.info(f"planning from sigma_BN = {sigma_bn.round(6).tolist()}")
        route = guidance.route
        if route is not None and route.feasible:
            log.info(
                f"global route: {route.legs} leg(s), {np.degrees(route.rotation_rad):.1f} deg "
                f"of rotation, clearance {route.clearance_deg:.2f} deg"
            )
        elif route is not None:
            log.error(f"infeasible: {route.reason}")
        return guidance

    @property
    def takes_input(self) -> bool:
        """Active, or deactivated after its first target: it then holds that target."""
        return self.active or self.guidance is not None

    def answer(self, stamp: int, stamp_msg: Any, state: tuple[Any, ...]) -> None:
        sigma_bn, omega_b = state
        if not self.active:  # deactivated: the last target held, at rest (a safe stop)
            self.out_mrp.header.stamp = self.out_rate.header.stamp = stamp_msg
            set_vector3(self.out_rate.vector, (0.0, 0.0, 0.0))
            if self.out_diag is not None:
                self.out_diag.header.stamp = stamp_msg
            self.publish()
            return
        if self.guidance is None:
            self.guidance = self.start(stamp, sigma_bn)
        t0 = time.perf_counter()
        # The sky's time: epoch_utc plus the stamps' time since the first state.
        t_s = (stamp - self.first_stamp_ns) / NS_PER_S
        result = self.guidance.update(t_s, sigma_bn, omega_b)
        step_s = time.perf_counter() - t0
        self.last_stamp_ns = stamp
        self.out_mrp.header.stamp = self.out_rate.header.stamp = stamp_msg
        set_vector3(self.out_mrp.vector, result.target.sigma_t)
        set_vector3(self.out_rate.vector, result.target.omega_t)
        self.publish(report=False)  # what the controller waits for, before the report
        self.out_margin.data = self.sky.min_margin_deg_single(t_s, sigma_bn)
        report = planner_diagnostics(
            self.guidance, result, step_s, self.out_margin.data, self.rejected
        )
        self.out_diag = self.diag.fill(stamp_msg, report)
        self.publish(target=False)
        self.log_changes(stamp, result)

    def log_changes(self, stamp: int, result: GuidanceOutput) -> None:
        """Log a new acceleration derating; publish and log a new status."""
        if result.derating != self.derating:
            self.derating = result.derating
            self.get_logger().warning(
                f"the body fell behind a profile within the declared actuator limits: "
                f"the plant is weaker than the scenario says; profile acceleration now "
                f"{result.derating:g} of the declared at stamp {stamp / NS_PER_S:.3f} s"
            )
        status = result.target.status
        if status != self.status:
            self.status = status
            self.pub_status.publish(String(data=status.value))
            self.get_logger().info(f"status {status} at stamp {stamp / NS_PER_S:.3f} s")

    def close(self) -> None:
        """Stop the route thread (a route in progress is dropped)."""
        self.route_thread.shutdown(wait=False, cancel_futures=True)

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
