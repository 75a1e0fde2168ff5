"""In-process tests of the planner node shell (see ``shells.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from geometry_msgs.msg import QuaternionStamped
from shells import (
    CASE1,
    DT_NS,
    HAND_FED,
    QUIET_S,
    RosSession,
    assert_close,
    attitude_msg,
    vector_msg,
    xyz,
)

from attitude_core.assembly.guidance import guidance_from_scenario, planner_from_scenario
from attitude_core.contract import diagnostics
from attitude_core.contract.status import PlannerStatus
from attitude_core.models.mrp import mrp_from_quat, quat_from_mrp
from attitude_planner.planner_node import FepfPlannerNode
from attitude_ros import contract as c
from attitude_ros.convert import stamp_ns

pytestmark = pytest.mark.ros


# --- planner shell ------------------------------------------------------------------------


class PlannerProbe:
    """The planner node, an attitude publisher and subscriptions to all its outputs."""

    def __init__(self, ros: RosSession) -> None:
        self.ros = ros
        self.node = ros.add(FepfPlannerNode())
        self.pub = ros.publisher(c.ATTITUDE)
        self.pub_rate = ros.publisher(c.ANGULAR_VELOCITY)
        self.mrp = ros.subscribe(c.TARGET_MRP)
        self.rate = ros.subscribe(c.TARGET_RATE)
        self.margin = ros.subscribe(c.KEEP_OUT_MARGIN)
        # The planner's per-step diagnostics, not its run identity (same topic).
        planner = lambda m: m.status[0].hardware_id == diagnostics.HARDWARE_ID
        self.diag = ros.subscribe(c.DIAGNOSTICS, keep=planner)
        self.status = ros.subscribe(c.PLANNER_STATUS, history=True)
        ros.wait_connected(self.node, [self.pub, self.pub_rate])

    def answers(self) -> int:
        return min(len(self.mrp), len(self.rate), len(self.margin), len(self.diag))

    def send(self, ns: int, quat) -> None:
        self.pub.publish(attitude_msg(ns, quat))

    def send_and_wait(self, ns: int, quat, omega=(0.0, 0.0, 0.0)) -> int:
        """Publish a state (rate, then attitude) and wait for the full answer; returns
        its index."""
        n = self.answers()
        self.pub_rate.publish(vector_msg(ns, omega, c.BODY_FRAME))
        self.send(ns, quat)
        self.ros.spin_until(lambda: self.answers() >= n + 1, f"the planner's answer to {ns} ns")
        assert self.answers() == n + 1
        return n

    def send_rejected(self, ns: int, quat) -> None:
        n = self.node.rejected
        self.send(ns, quat)
        self.ros.spin_until(lambda: self.node.rejected == n + 1, f"rejection of {ns} ns")


def test_planner_answers_each_stamp_with_the_core_planner(ros, scenario):
    ros.init(CASE1, **HAND_FED)
    p = PlannerProbe(ros)
    path = planner_from_scenario(scenario)
    exact = scenario.cone_geometry()
    # Measured attitudes: the start, then along the FEPF's own target path; the node's
    # answers are the core guidance's for those states (at rest: zero rate).
    n_steps = 12
    fepf = [path.step() for _ in range(n_steps + 2)]
    measured = [scenario.initial_mrp] + [o.sigma_t for o in fepf[1:]]
    reference = guidance_from_scenario(scenario)
    expected = [
        reference.update(k * DT_NS / 1e9, measured[k], np.zeros(3)).target
        for k in range(n_steps + 2)
    ]

    def check_answer(i: int, ns: int, k: int, sigma_measured) -> None:
        mrp, rate = p.mrp[i], p.rate[i]
        assert stamp_ns(mrp.header.stamp) == stamp_ns(rate.header.stamp) == ns
        assert stamp_ns(p.diag[i].header.stamp) == ns
        assert mrp.header.frame_id == c.INERTIAL_FRAME == "inertial"
        assert rate.header.frame_id == c.TARGET_FRAME == "target"
        assert_close(xyz(mrp.vector), expected[k].sigma_t)
        assert_close(xyz(rate.vector), expected[k].omega_t)
        sigma_node = mrp_from_quat(quat_from_mrp(sigma_measured))  # what the node decodes
        assert_close(p.margin[i].data, exact.min_margin_deg(sigma_node), 1e-9)
        assert p.margin[i].data > 0.0
        assert p.diag[i].status[0].message == expected[k].status

    for k in range(n_steps):
        i = p.send_and_wait(k * DT_NS, quat_from_mrp(measured[k]))
        check_answer(i, k * DT_NS, k, measured[k])
    # The target moves (the test is not vacuous).
    assert np.linalg.norm(xyz(p.mrp[-1].vector) - scenario.initial_mrp) > 1e-3
    assert all(o.status == PlannerStatus.TRACKING for o in expected[:n_steps])
    ros.spin_until(lambda: len(p.status) >= 1, "/planner/status")
    # latched, published on change only
    assert [m.data for m in p.status] == [PlannerStatus.TRACKING]

    # A repeated stamp: the identical answer again, the planner does not advance.
    last = n_steps - 1
    i = p.send_and_wait(last * DT_NS, quat_from_mrp(measured[last]))
    for topic in (p.mrp, p.rate):
        assert topic[i] == topic[i - 1]
    assert p.margin[i].data == p.margin[i - 1].data
    i = p.send_and_wait(n_steps * DT_NS, quat_from_mrp(measured[n_steps]))
    check_answer(i, n_steps * DT_NS, n_steps, measured[n_steps])

    # Rejected: an older stamp, a NaN, a zero and a non-unit quaternion. Nothing answers.
    answered, rejected = p.answers(), p.node.rejected
    next_ns = (n_steps + 1) * DT_NS
    good = quat_from_mrp(measured[n_steps + 1])
    p.send_rejected(3 * DT_NS, good)
    p.send_rejected(next_ns, (math.nan, 0.0, 0.0, 1.0))
    p.send_rejected(next_ns, (0.0, 0.0, 0.0, 0.0))
    p.send_rejected(next_ns, 1.01 * good)
    p.send_rejected(next_ns, (0.0, math.inf, 0.0, 1.0))
    assert p.node.rejected == rejected + 5
    ros.spin_for(QUIET_S)
    assert p.answers() == answered
    # The next valid state is answered as the next planner step: the rejected ones did
    # not advance it, and (same-topic order) nothing was published for them before it.
    i = p.send_and_wait(next_ns, good)
    assert i == answered
    check_answer(i, next_ns, n_steps + 1, measured[n_steps + 1])
    diag_values = {kv.key: kv.value for kv in p.diag[i].status[0].values}
    assert diag_values[diagnostics.REJECTED_MESSAGES] == str(rejected + 5)
    assert [m.data for m in p.status] == [PlannerStatus.TRACKING]


def test_planner_rejects_an_attitude_in_another_frame(ros, scenario):
    ros.init(CASE1, **HAND_FED)
    p = PlannerProbe(ros)
    quat = quat_from_mrp(scenario.initial_mrp)
    for frame in ("body", "", "map"):
        msg = attitude_msg(0, quat)
        msg.header.frame_id = frame
        n = p.node.rejected
        p.pub.publish(msg)
        ros.spin_until(lambda n=n: p.node.rejected == n + 1, f"rejection of frame {frame!r}")
    assert p.answers() == 0 and p.node.guidance is None  # not even started from it
    p.send_and_wait(0, quat)
    assert p.node.rejected == 3


def test_best_effort_state_publisher_connects_through_qos_overrides(ros, scenario):
    """A sensor-data (best-effort) driver: refused by the default reliable subscription,
    connected with ROS 2's standard ``qos_overrides`` parameter."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    override = "qos_overrides./spacecraft/attitude.subscription.reliability"
    ros.init(CASE1, **HAND_FED, **{override.replace(".", "__"): "best_effort"})
    planner = ros.add(FepfPlannerNode())
    driver = ros.probe.create_publisher(
        QuaternionStamped,
        c.ATTITUDE,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
    )
    ros.spin_until(lambda: driver.get_subscription_count() >= 1, "the best-effort match")
    rate = ros.publisher(c.ANGULAR_VELOCITY)  # the other half of the state, reliable
    ros.wait_connected(planner, [rate])
    answers = ros.subscribe(c.TARGET_MRP)
    ros.spin_until(lambda: planner.pub_mrp.get_subscription_count() >= 1, "the answer's match")
    quat = quat_from_mrp(scenario.initial_mrp)
    ns = 0

    def answered() -> bool:  # best effort may drop a sample: publish until one is answered
        nonlocal ns
        if not answers:
            rate.publish(vector_msg(ns, (0.0, 0.0, 0.0), c.BODY_FRAME))
            driver.publish(attitude_msg(ns, quat))
            ns += DT_NS
        return bool(answers)

    ros.spin_until(answered, "the planner's answer to a best-effort state")
    assert planner.get_parameter(override).value == "best_effort"


def test_best_effort_state_publisher_does_not_connect_by_default(ros):
    """Without the override the state subscription stays reliable: lossless lockstep with
    the project's simulator; a best-effort publisher is incompatible and never matches."""
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    ros.init(CASE1, **HAND_FED)
    planner = ros.add(FepfPlannerNode())
    reliable = ros.publisher(c.ATTITUDE)  # a contract publisher matches: discovery works
    driver = ros.probe.create_publisher(
        QuaternionStamped,
        c.ATTITUDE,
        QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
    )
    ros.spin_until(lambda: reliable.get_subscription_count() >= 1, "the reliable match")
    ros.spin_for(QUIET_S)
    assert driver.get_subscription_count() == 0
    assert planner.count_publishers(c.ATTITUDE) == 2  # both are seen, only one matches
