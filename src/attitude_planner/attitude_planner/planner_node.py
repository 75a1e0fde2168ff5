"""FEPF planner node (``ros2 run attitude_planner fepf_planner``).

Subscribes the measured state, ``/spacecraft/attitude`` and
``/spacecraft/angular_velocity``, and answers each stamp once both messages of that
stamp are in: one guidance update (:class:`attitude_core.guidance.Guidance`: the FEPF,
paper eqs. 6-10, 12, moved for the real time between stamps, time-scaled to the
actuator limits, closed on the measured state) and publishes, stamped with that
state's stamp: ``/planner/target_mrp`` (``sigma_t`` = sigma_RN),
``/planner/target_rate`` (``omega_t``, target-frame axes, rad/s),
``/planner/keep_out_margin_deg`` (the smallest keep-out margin of the measured
attitude, eq. 5) and ``/diagnostics``; ``/planner/status`` (a ``PlannerStatus`` value,
``arrived`` only when the body is on the goal) is latched and published on change.

Before the first state it prepares the global route (the roadmap and the route from the
scenario's start; :mod:`attitude_core.route`): a slew with no route is reported
``infeasible`` at the first state, with the reason in ``/diagnostics`` (``reason``)
and in the log, and the target holds the start. Routes planned again during the run
(when the target stalls) are computed in a worker thread, off the message callbacks.

It only reacts to messages, so lockstep simulation, real time and a hardware bridge
look the same to it. The planner starts from the first measured attitude (equal to the
scenario's ``initial_mrp`` on a fresh run), so a restarted planner resumes from where
the spacecraft is. A repeated stamp (a lockstep re-send) gets the same answer again;
an older stamp, a non-finite rate or an unusable quaternion is rejected, logged and
counted.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from rclpy.node import Node
from std_msgs.msg import Float64, String

from attitude_core import diagnostics, node_graph
from attitude_core.fepf import FepfPlanner
from attitude_core.guidance import Guidance, GuidanceOutput
from attitude_core.stamp_gate import StampGate
from attitude_core.stamp_pairing import StampPairing
from attitude_core.status import PlannerStatus
from attitude_core.topics import NS_PER_S
from attitude_ros import contract as c
from attitude_ros.convert import set_vector3
from attitude_ros.intake import attitude_value, rate_value, subscribe_paired
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard, diagnostics_events
from attitude_ros.runner import run


class FepfPlannerNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__(node_graph.PLANNER.node_name, **kwargs)
        _, self.scenario = declare_scenario_node(self, node_graph.PLANNER.parameters)
        self.exact = self.scenario.cone_geometry(samples=16)
        # Up front: the FIS lookup tables, the roadmap and the route from the scenario's
        # start (taken as is when the first measured attitude is that start).
        prepared = FepfPlanner.from_scenario(self.scenario)
        prepared.prepare()
        self.routes = Guidance.route_planner(self.scenario, prepared.geometry.inflation_deg)
        self.initial_route = self.routes.plan(self.scenario.initial_mrp, self.scenario.desired_mrp)
        self.route_thread = ThreadPoolExecutor(max_workers=1, thread_name_prefix="route")
        self.guidance: Guidance | None = None
        self.first_stamp_ns = 0
        self.last_stamp_ns: int | None = None
        self.intake = StampPairing(2, StampGate(self.scenario.sim_time_s))  # sigma_BN, omega_B
        self.done, self.exit_code = False, 0
        self.guard = RunGuard(
            self,
            node_graph.PLANNER,
            self.scenario,
            self.stop,
            stamp_ns=lambda: self.last_stamp_ns or 0,
        )
        self.status: PlannerStatus | None = None
        self.derating = 1.0
        pub = self.create_publisher
        self.pub_mrp = pub(Vector3Stamped, c.TARGET_MRP, c.qos(c.topic(c.TARGET_MRP)))
        self.pub_rate = pub(Vector3Stamped, c.TARGET_RATE, c.qos(c.topic(c.TARGET_RATE)))
        self.pub_status = pub(String, c.PLANNER_STATUS, c.qos(c.topic(c.PLANNER_STATUS)))
        self.pub_margin = pub(Float64, c.KEEP_OUT_MARGIN, c.qos(c.topic(c.KEEP_OUT_MARGIN)))
        self.pub_diag = pub(
            DiagnosticArray,
            c.DIAGNOSTICS,
            c.qos(c.topic(c.DIAGNOSTICS)),
            event_callbacks=diagnostics_events(self, publisher=True),
        )
        self.out_mrp, self.out_rate = Vector3Stamped(), Vector3Stamped()
        self.out_mrp.header.frame_id = c.INERTIAL_FRAME
        self.out_rate.header.frame_id = c.TARGET_FRAME
        self.out_margin = Float64()
        self.out_diag = None
        subscribe_paired(
            self,
            self.guard,
            self.intake,
            (
                (c.ATTITUDE, QuaternionStamped, attitude_value),
                (c.ANGULAR_VELOCITY, Vector3Stamped, rate_value),
            ),
            self.answer,
            self.publish,  # a lockstep re-send: same state, same answer
        )
        self.get_logger().info(
            f"scenario '{self.scenario.name}': FEPF variant {self.scenario.planner.variant}, "
            f"{len(self.scenario.instrument_names)} instrument(s), "
            f"{len(self.scenario.bright_object_names)} bright object(s)"
        )

    def answer(self, stamp: int, stamp_msg, state: tuple) -> None:
        sigma_bn, omega_b = state
        if self.guidance is None:
            fresh = np.allclose(sigma_bn, self.scenario.initial_mrp, rtol=0.0, atol=1e-9)
            self.guidance = Guidance.from_scenario(
                self.scenario,
                sigma_0=sigma_bn,
                executor=self.route_thread,
                routes=self.routes,
                initial_route=self.initial_route if fresh else None,
            )
            self.first_stamp_ns = stamp
            self.get_logger().info(f"planning from sigma_BN = {sigma_bn.round(6).tolist()}")
            route = self.guidance.route
            if route is not None and route.feasible:
                self.get_logger().info(
                    f"global route: {route.legs} leg(s), {np.degrees(route.rotation_rad):.1f} deg "
                    f"of rotation, clearance {route.clearance_deg:.2f} deg"
                )
            elif route is not None:
                self.get_logger().error(f"infeasible: {route.reason}")
        t0 = time.perf_counter()
        t_s = (stamp - self.first_stamp_ns) / NS_PER_S
        result = self.guidance.update(t_s, sigma_bn, omega_b)
        step_s = time.perf_counter() - t0
        out = result.target
        self.last_stamp_ns = stamp
        self.out_mrp.header.stamp = stamp_msg
        self.out_rate.header.stamp = stamp_msg
        set_vector3(self.out_mrp.vector, out.sigma_t)
        set_vector3(self.out_rate.vector, out.omega_t)
        self.out_margin.data = float(self.exact.min_margin_deg_single(sigma_bn))
        self.out_diag = self.diagnostics(stamp_msg, result, step_s)
        self.publish()
        if result.derating != self.derating:
            self.derating = result.derating
            self.get_logger().warning(
                f"the body fell behind a profile within the declared actuator limits: "
                f"the plant is weaker than the scenario says; profile acceleration now "
                f"{result.derating:g} of the declared at stamp {stamp / 1e9:.3f} s"
            )
        if out.status != self.status:
            self.status = out.status
            self.pub_status.publish(String(data=out.status.value))
            self.get_logger().info(f"status {out.status} at stamp {stamp / 1e9:.3f} s")

    @property
    def rejected(self) -> int:
        """Refused input messages, for their stamp or their content."""
        return self.intake.rejected

    def stop(self, code: int, reason: str) -> None:
        """The run guard's verdict: stop answering, exit with ``code``."""
        self.done, self.exit_code = True, code

    def close(self) -> None:
        """On every way out: stop the route thread (a route in progress is dropped)."""
        self.route_thread.shutdown(wait=False, cancel_futures=True)

    def route_values(self) -> tuple[float, int, str]:
        """The route followed and the infeasibility reason, for ``/diagnostics``."""
        guidance = self.guidance
        route = None if guidance is None else guidance.route
        if route is None or not route.feasible:
            return float("nan"), 0, "" if guidance is None else guidance.reason
        return float(np.degrees(route.rotation_rad)), len(route.waypoints), ""

    def publish(self) -> None:
        self.pub_mrp.publish(self.out_mrp)
        self.pub_rate.publish(self.out_rate)
        self.pub_margin.publish(self.out_margin)
        self.pub_diag.publish(self.out_diag)

    def diagnostics(self, stamp, result: GuidanceOutput, step_s: float) -> DiagnosticArray:
        out = result.target
        report = diagnostics.PlannerDiagnostics(
            out.status,
            step_s,
            out.obstacle_distance_mrp,
            self.out_margin.data,
            out.m_a,
            out.m_r,
            self.rejected,
            result.tracking_error_deg,
            result.goal_error_deg,
            result.speed_factor,
            result.derating,
            *self.route_values(),
        )
        status = DiagnosticStatus(
            level=bytes([out.status.level]),
            name=diagnostics.STATUS_NAME,
            message=out.status.value,
            hardware_id=diagnostics.HARDWARE_ID,
            values=[KeyValue(key=k, value=v) for k, v in report.values()],
        )
        diag = DiagnosticArray(status=[status])
        diag.header.stamp = stamp
        return diag


def main(args: list[str] | None = None) -> int:
    return run(FepfPlannerNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
