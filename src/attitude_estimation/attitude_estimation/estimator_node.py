"""Attitude estimator node (``ros2 run attitude_estimation mekf_estimator``).

Wiring only: :class:`attitude_core.runtime.estimator_stepper.EstimatorStepper` pairs the
gyro (``/spacecraft/imu``) and star tracker (``/spacecraft/star_tracker``) samples by
stamp and runs the multiplicative extended Kalman filter of
:mod:`attitude_core.fsw.estimation.mekf` (Markley and Crassidis, 2014). Each filtered step
publishes, with the measurements' stamp, the estimated attitude on
``/spacecraft/attitude`` (frame ``inertial``), the bias-corrected rate on
``/spacecraft/angular_velocity`` (frame ``body``) and the filter's state on
``/diagnostics`` (status ``mekf_estimator``: attitude 3-sigma, bias, the steps lost).
The planner and the controller read the estimate as they read the simulator's state
without sensors. A star tracker message that declares its covariance is filtered
with it; else with the scenario's ``sensors.star_tracker.noise_arcsec``.

Messages with a stamp off the run's timeline, non-finite values or an unusable
quaternion are rejected, logged and counted.
"""

from __future__ import annotations

import math
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from attitude_core.config import node_graph
from attitude_core.contract.diagnostics import (
    ATTITUDE_3SIGMA_DEG,
    ESTIMATOR_STATUS_NAME,
    GYRO_BIAS_RAD_S,
)
from attitude_core.runtime.estimator_stepper import EstimatorStepper, StampedEstimate
from attitude_core.runtime.plausibility import implausible_rate
from attitude_core.runtime.stamp_gate import StampGate
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.endpoints import message, publisher, subscription
from attitude_ros.node_base import StackNode
from attitude_ros.params import declare_scenario_node
from attitude_ros.run_guard import RunGuard
from attitude_ros.runner import run

POLL_PERIOD_S = 0.02  # the wait for a due star tracker sample is checked this often, s


class MekfEstimatorNode(StackNode):
    spec = node_graph.ESTIMATOR

    def configure(self) -> None:
        own, sc = declare_scenario_node(self, node_graph.ESTIMATOR.parameters)
        if sc.sensors is None:
            raise ValueError(
                f"scenario '{sc.name}' declares no sensors (sensors.*): nothing to estimate"
            )
        self.scenario = sc
        self.stepper = EstimatorStepper(sc.sensors, sc.dt_s, own.star_tracker_wait_s)
        self.gate = StampGate(sc.sim_time_s)
        self._rejected = 0
        self.guard = RunGuard(
            self, self.spec, sc, self.stop, stamp_ns=lambda: max(self.stepper.last_stamp_ns, 0)
        )
        self.pub_att = publisher(self, c.ATTITUDE)
        self.pub_rate = publisher(self, c.ANGULAR_VELOCITY)
        self.pub_diag = publisher(self, c.DIAGNOSTICS)
        self.msg_att = message(c.ATTITUDE)
        self.msg_rate = message(c.ANGULAR_VELOCITY)
        self.guard.watch(c.IMU, subscription(self, c.IMU, self.on_imu))
        self.guard.watch(c.STAR_TRACKER, subscription(self, c.STAR_TRACKER, self.on_star_tracker))
        self.create_timer(POLL_PERIOD_S, self.on_timer)
        spec = sc.sensors
        self.get_logger().info(
            f"scenario '{sc.name}': MEKF on a star tracker at {spec.star_tracker_rate_hz:g} Hz "
            f"and a gyro every {sc.dt_s:g} s; steady attitude 3-sigma "
            f"{sc.knowledge.attitude_3sigma_deg:.4f} deg"
        )

    @property
    def rejected(self) -> int:
        return self._rejected + self.gate.rejected

    def _stamp(self, msg: Any, topic: str) -> int | None:
        """The message's stamp (ns) if the gate takes it (new or the last one), else None."""
        stamp = msg.header.stamp
        verdict = self.gate.screen(stamp.sec, stamp.nanosec, time.time_ns())
        if not verdict.accept and not verdict.repeat:
            cv.reject(self, topic, verdict.reason, count=self.rejected)
            return None
        return int(cv.stamp_ns(stamp))

    def on_imu(self, msg: Any) -> None:
        if not self.active or not self.guard.admit(c.IMU):
            return
        gyro = cv.vector3(msg.angular_velocity)
        reason = cv.bad_frame(msg, c.IMU) or implausible_rate(gyro, "gyro rate")
        if reason:
            self._rejected += 1
            cv.reject(self, c.IMU, reason, count=self.rejected)
            return
        stamp = self._stamp(msg, c.IMU)
        if stamp is not None:
            self.publish(self.stepper.on_gyro(time.monotonic(), stamp, gyro))

    def on_star_tracker(self, msg: Any) -> None:
        if not self.active or not self.guard.admit(c.STAR_TRACKER):
            return
        q = msg.pose.pose.orientation
        reason = cv.bad_frame(msg, c.STAR_TRACKER) or cv.bad_quaternion(q)
        if reason:
            self._rejected += 1
            cv.reject(self, c.STAR_TRACKER, reason, count=self.rejected)
            return
        stamp = self._stamp(msg, c.STAR_TRACKER)
        if stamp is None:
            return
        noise = cv.star_tracker_noise_rad(msg)
        if noise is not None:
            self.stepper.filter.set_star_tracker_noise(noise)
        quat = cv.quaternion_xyzw(q)
        self.publish(self.stepper.on_star_tracker(time.monotonic(), stamp, quat))

    def on_timer(self) -> None:
        self.publish(self.stepper.poll(time.monotonic()) if self.active else [])

    def publish(self, estimates: list[StampedEstimate]) -> None:
        for s in estimates:
            self.gate.take(s.stamp_ns, time.time_ns())
            for m in (self.msg_att, self.msg_rate):
                cv.set_stamp(m.header.stamp, s.stamp_ns)
            cv.set_quaternion_from_mrp(self.msg_att.quaternion, s.estimate.sigma_bn)
            cv.set_vector3(self.msg_rate.vector, s.estimate.omega_b)
            self.pub_att.publish(self.msg_att)
            self.pub_rate.publish(self.msg_rate)
            self.pub_diag.publish(self.report(s))

    def report(self, s: StampedEstimate) -> Any:
        est = s.estimate
        values = {
            ATTITUDE_3SIGMA_DEG: f"{est.attitude_3sigma_deg:.9g}",
            GYRO_BIAS_RAD_S: " ".join(f"{b:.9g}" for b in est.bias_rad_s),
            "star_tracker_used": str(s.star_tracker_used).lower(),
            "star_tracker_lost": str(self.stepper.lost),
            "star_tracker_late": str(self.stepper.late),
            "gyro_stale": str(self.stepper.stale),
        }
        ok = math.isfinite(est.attitude_3sigma_deg)
        status = DiagnosticStatus(
            level=DiagnosticStatus.OK if ok else DiagnosticStatus.ERROR,
            name=ESTIMATOR_STATUS_NAME,
            message="estimating" if ok else "covariance not finite",
            hardware_id=self.get_fully_qualified_name(),
            values=[KeyValue(key=k, value=v) for k, v in values.items()],
        )
        msg = DiagnosticArray(status=[status])
        cv.set_stamp(msg.header.stamp, s.stamp_ns)
        return msg

    def close(self) -> None:
        st = self.stepper
        self.get_logger().info(
            f"stopped after {st.last_stamp_ns} ns: {st.updates} star tracker updates, "
            f"{st.lost} lost, {st.late} late, {st.stale} stale gyro samples, "
            f"{self.rejected} rejected messages"
        )


def main(args: list[str] | None = None) -> int:
    return run(MekfEstimatorNode, args, fast_exit=True)


if __name__ == "__main__":
    raise SystemExit(main())
