"""The simulator's sensors on ROS: the star tracker and gyro messages of each state.

:class:`attitude_core.world.sensors.SensorSuite` draws the measurements of a state once
(simulated time ``k dt``); :meth:`SensorOut.publish` sends them, the star tracker sample
(when the state has one) before the gyro sample, and sends the same again when the
simulator re-sends the state. Message conventions: :mod:`attitude_core.contract.topics`.
"""

from __future__ import annotations

from typing import Any

from attitude_core.config.scenario import Scenario
from attitude_core.models.sensor_spec import Measurement, SensorSpec
from attitude_core.world.sensors import SensorSuite
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.endpoints import message, publisher

__all__ = ["SensorOut"]


class SensorOut:
    """The sensor publishers of a node whose scenario declares ``sensors``."""

    def __init__(self, node: Any, scenario: Scenario, spec: SensorSpec) -> None:
        self.dt_s = scenario.dt_s
        self.scenario = scenario
        self.suite = SensorSuite(spec, scenario.dt_s)
        self.pub_imu, self.pub_tracker = publisher(node, c.IMU), publisher(node, c.STAR_TRACKER)
        self.msg_imu, self.msg_tracker = message(c.IMU), message(c.STAR_TRACKER)
        cv.init_imu(self.msg_imu, spec.gyro_noise_rad_s)
        cv.init_star_tracker(self.msg_tracker, spec.star_tracker_noise_rad)
        self.measured: Measurement | None = None

    @property
    def publishers(self) -> dict[str, Any]:
        """The state topics the simulator's readiness counts listeners of, with sensors."""
        return {c.IMU: self.pub_imu, c.STAR_TRACKER: self.pub_tracker}

    def measure(self, k: int, stamp_ns: int, sigma_bn: Any, omega_b: Any) -> None:
        """Draw the measurements of state ``k`` (simulated time ``k dt``), once."""
        t_s = k * self.dt_s
        blind = self.scenario.tracker_blinded(t_s, sigma_bn)  # the tracker's own keep-out
        m = self.suite.measure(t_s, sigma_bn, omega_b, blind)
        self.measured = m
        cv.set_stamp(self.msg_imu.header.stamp, stamp_ns)
        cv.set_vector3(self.msg_imu.angular_velocity, m.gyro_rad_s)
        if m.star_tracker_quat is not None:
            cv.set_stamp(self.msg_tracker.header.stamp, stamp_ns)
            q, x = self.msg_tracker.pose.pose.orientation, m.star_tracker_quat
            q.x, q.y, q.z, q.w = float(x[0]), float(x[1]), float(x[2]), float(x[3])

    def publish(self) -> None:
        """The last state's measurements (again, on a re-send)."""
        if self.measured is None:
            return
        if self.measured.star_tracker_quat is not None:
            self.pub_tracker.publish(self.msg_tracker)  # before its gyro sample
        self.pub_imu.publish(self.msg_imu)
