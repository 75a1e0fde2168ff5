"""In-process tests of the estimator node shell (see ``shells.py``): real DDS, the node
fed gyro and star tracker messages by a probe.

Each gyro sample is one filter step: the estimate comes with the measurements' stamp and
equals the core filter's on the same samples (the node is a shell); a due star tracker
sample is waited for, whichever topic arrives first; a re-sent state gets the same
estimate again; malformed messages are refused and counted, never filtered.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from shells import DT_NS, QUIET_S, ROOT, RosSession

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.diagnostics import ATTITUDE_3SIGMA_DEG, ESTIMATOR_STATUS_NAME
from attitude_core.fsw.estimation.mekf import Mekf, MekfConfig
from attitude_core.models.sensor_spec import star_tracker_due
from attitude_core.world.sensors import SensorSuite
from attitude_estimation.estimator_node import MekfEstimatorNode
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.convert import stamp_ns
from attitude_ros.endpoints import message

pytestmark = pytest.mark.ros
SENSING = ROOT / "scenarios" / "case1_wheels_sensors.yaml"


class EstimatorProbe:
    def __init__(self, ros: RosSession) -> None:
        self.ros = ros
        self.node = ros.add(MekfEstimatorNode())
        self.imu, self.tracker = ros.publisher(c.IMU), ros.publisher(c.STAR_TRACKER)
        self.att, self.rate = ros.subscribe(c.ATTITUDE), ros.subscribe(c.ANGULAR_VELOCITY)
        self.diag = ros.subscribe(c.DIAGNOSTICS)
        ros.wait_connected(self.node, [self.imu, self.tracker])

    def gyro(self, ns: int, w) -> None:
        msg = message(c.IMU)
        cv.set_stamp(msg.header.stamp, ns)
        cv.set_vector3(msg.angular_velocity, w)
        self.imu.publish(msg)

    def star(self, ns: int, q, frame: str = c.INERTIAL_FRAME) -> None:
        msg = message(c.STAR_TRACKER)
        msg.header.frame_id = frame
        cv.set_stamp(msg.header.stamp, ns)
        o = msg.pose.pose.orientation
        o.x, o.y, o.z, o.w = (float(x) for x in q)
        self.tracker.publish(msg)

    def wait_estimates(self, n: int) -> None:
        self.ros.spin_until(lambda: len(self.att) >= n and len(self.rate) >= n, f"{n} estimates")


def test_the_node_filters_like_the_core_and_answers_a_resend_alike(ros):
    ros.init(SENSING)
    p = EstimatorProbe(ros)
    sc = load_scenario(SENSING)
    spec = sc.sensors
    sensors = SensorSuite(spec, sc.dt_s)
    core = Mekf(MekfConfig.from_spec(spec, sc.dt_s))
    sigma = np.asarray(sc.initial_mrp)
    expected = []
    for k in range(12):
        m = sensors.measure(k * sc.dt_s, sigma, np.array([0.001, 0.0, -0.002]))
        assert (m.star_tracker_quat is not None) == star_tracker_due(
            k * sc.dt_s, spec.star_tracker_rate_hz, sc.dt_s
        )
        est = core.step(k * sc.dt_s, m.gyro_rad_s, m.star_tracker_quat)
        expected.append(est)
        # the gyro first on even steps, the star tracker first on odd ones
        if m.star_tracker_quat is not None and k % 2:
            p.star(k * DT_NS, m.star_tracker_quat)
            ros.spin_for(0.05)
        p.gyro(k * DT_NS, m.gyro_rad_s)
        if m.star_tracker_quat is not None and not k % 2:
            ros.spin_for(0.05)
            assert len(p.att) == k  # a due sample is waited for
            p.star(k * DT_NS, m.star_tracker_quat)
        p.wait_estimates(k + 1)
    for k, est in enumerate(expected):
        assert stamp_ns(p.att[k].header.stamp) == k * DT_NS
        np.testing.assert_allclose(cv.mrp_from_quaternion(p.att[k].quaternion), est.sigma_bn,
                                   atol=1e-12)  # fmt: skip
        np.testing.assert_allclose(cv.vector3(p.rate[k].vector), est.omega_b, atol=1e-15)
    ros.spin_until(
        lambda: any(s.name == ESTIMATOR_STATUS_NAME for m in p.diag for s in m.status),
        "the estimator's diagnostics",
    )
    values = {kv.key: kv.value for m in p.diag for s in m.status
              if s.name == ESTIMATOR_STATUS_NAME for kv in s.values}  # fmt: skip
    assert float(values[ATTITUDE_3SIGMA_DEG]) > 0.0
    # a re-sent state (the same gyro stamp): the same estimate again
    n = len(p.att)
    p.gyro(11 * DT_NS, np.zeros(3))
    p.wait_estimates(n + 1)
    assert p.att[-1].quaternion == p.att[n - 1].quaternion


def test_malformed_samples_are_refused_and_counted(ros):
    ros.init(SENSING)
    p = EstimatorProbe(ros)
    q0 = (0.0, 0.0, 0.0, 1.0)
    p.star(0, q0)
    p.gyro(0, np.zeros(3))
    p.wait_estimates(1)
    bad = [
        lambda: p.gyro(DT_NS, (math.nan, 0.0, 0.0)),
        lambda: p.gyro(DT_NS, (100.0, 0.0, 0.0)),  # beyond the plausible rate
        lambda: p.star(DT_NS, (0.0, 0.0, 0.6, 0.6)),  # not a unit quaternion
        lambda: p.star(DT_NS, q0, frame=c.BODY_FRAME),  # another frame
        lambda: p.gyro(10**20, np.zeros(3)),  # off the run's timeline
    ]
    for k, send in enumerate(bad, start=1):
        send()
        ros.spin_until(lambda k=k: p.node.rejected >= k, f"refusal {k}")
    ros.spin_for(QUIET_S)
    assert len(p.att) == 1  # nothing filtered
    p.gyro(DT_NS, np.zeros(3))  # a good sample (no star tracker due at 0.1 s at 4 Hz)
    p.wait_estimates(2)
    assert stamp_ns(p.att[-1].header.stamp) == DT_NS
