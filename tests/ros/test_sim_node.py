"""In-process tests of the simulator node shell, lockstep and real time (see ``shells.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shells import CASE1, DT_NS, QUIET_S, RosSession, assert_close, stamps, torque_msg, xyz, xyzw

from attitude_core.config import node_graph
from attitude_core.config.scenario import Scenario
from attitude_core.models.mrp import mrp_from_quat, quat_from_mrp
from attitude_core.world.rigid_body import RigidBody
from attitude_ros import contract as c
from attitude_ros.convert import stamp_ns
from spacecraft_sim.sim_node import RigidBodySimNode

pytestmark = pytest.mark.ros


# --- simulator shell (lockstep) -----------------------------------------------------------


class SimProbe:
    """The simulator in lockstep with the smallest graph its start-up wait accepts.

    ``node_graph.readiness(e)`` asks for ``e`` attitude listeners, ``e - 1`` listeners of
    the rate, target and torque topics (the simulator's own torque subscription counts),
    a torque publisher and the two target publishers. With ``e = 1``: the probe's
    attitude subscription, its torque publisher and two target publishers.
    The probe's state subscriptions are transient-local, so they see every sample even
    if one of them matches after the simulator has started.
    """

    def __init__(self, ros: RosSession, scenario: Scenario) -> None:
        self.ros = ros
        self.attitude = ros.subscribe(c.ATTITUDE, history=True)
        self.rate = ros.subscribe(c.ANGULAR_VELOCITY, history=True)
        self.clock = ros.subscribe(c.CLOCK, history=True)
        self.pub_torque = ros.publisher(c.TORQUE)
        self.pub_target = ros.publisher(c.TARGET_MRP)
        self.pub_target_rate = ros.publisher(c.TARGET_RATE)
        self.node = ros.add(RigidBodySimNode())
        assert self.node.ready == node_graph.readiness(1)
        assert self.node.stepper.cfg.torque_timeout_s == 600.0
        self.reference = RigidBody(
            scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s
        )
        self.dt_s = scenario.dt_s

    def wait_state(self, ns: int) -> None:
        def arrived():
            return all(
                ns in s
                for s in (
                    stamps(self.attitude),
                    stamps(self.rate),
                    [stamp_ns(m.clock) for m in self.clock],
                )
            )

        self.ros.spin_until(arrived, f"the state stamped {ns} ns")

    def state(self, ns: int):
        """The first attitude and rate messages stamped ``ns``."""
        att = next(m for m in self.attitude if stamp_ns(m.header.stamp) == ns)
        rate = next(m for m in self.rate if stamp_ns(m.header.stamp) == ns)
        return att, rate

    def check_state(self, ns: int) -> None:
        """The state stamped ``ns`` is the reference body's, with the contract's frames."""
        att, rate = self.state(ns)
        assert att.header.frame_id == c.INERTIAL_FRAME
        assert rate.header.frame_id == c.BODY_FRAME
        assert_close(xyzw(att.quaternion), quat_from_mrp(self.reference.sigma_bn))
        assert_close(mrp_from_quat(xyzw(att.quaternion)), self.reference.sigma_bn)
        assert_close(xyz(rate.vector), self.reference.omega_b)

    def newest(self) -> int:
        return max(stamps(self.attitude), default=-1)

    def torque(self, ns: int, u) -> None:
        self.pub_torque.publish(torque_msg(ns, u))

    def reject_torque(self, ns: int, u) -> None:
        n = self.node.rejected
        self.torque(ns, u)
        self.ros.spin_until(lambda: self.node.rejected == n + 1, "the torque's rejection")


LOCKSTEP_ARGS = {"lockstep__expected_subscribers": 1, "lockstep__torque_timeout_s": 600.0}


def test_simulator_lockstep_advances_only_on_the_matching_torque(ros, scenario):
    ros.init(CASE1, lockstep__resend_period_s=60.0, **LOCKSTEP_ARGS)
    s = SimProbe(ros, scenario)
    s.wait_state(0)
    s.check_state(0)
    assert_close(xyzw(s.state(0)[0].quaternion), quat_from_mrp(scenario.initial_mrp))
    assert_close(xyz(s.state(0)[1].vector), scenario.initial_rate_rad_s)
    assert s.node.stepper.k == 0

    torques = [
        np.array([0.3, -0.2, 0.1]),
        np.array([-0.5, 0.05, 0.4]),
        np.array([0.0, 0.0, 0.0]),
        np.array([1.0, 2.0, -1.5]),
    ]
    for k, u in enumerate(torques):
        ns, next_ns = k * DT_NS, (k + 1) * DT_NS
        # Torques that must not advance it: future and past stamps, then a NaN with the
        # right stamp (rejected). Same topic and publisher, so they are consumed in order:
        # once the NaN is counted, the wrong stamps have been seen and ignored.
        s.torque(next_ns, -10.0 * u + 1.0)
        s.torque(ns + 7 * DT_NS, -10.0 * u + 1.0)
        if k > 0:
            s.torque(ns - DT_NS, -10.0 * u + 1.0)
        s.reject_torque(ns, (math.nan, 0.0, 0.0))
        ros.spin_for(QUIET_S)
        assert s.node.stepper.k == k and s.newest() == ns
        # The right torque: exactly one step of the core's rigid body.
        s.torque(ns, u)
        s.wait_state(next_ns)
        s.reference.step(u, s.dt_s)
        s.check_state(next_ns)
        assert s.node.stepper.k == k + 1
    # Every state stamp in order, each once (no re-sends with a 60 s period), /clock too.
    expected = [k * DT_NS for k in range(len(torques) + 1)]
    assert stamps(s.attitude) == stamps(s.rate) == expected
    assert [stamp_ns(m.clock) for m in s.clock] == expected
    assert s.node.stepper.timeouts == 0 and s.node.stepper.resends == 0
    # Physics, not a constant: the body turned and spins.
    assert np.linalg.norm(s.reference.omega_b) > 1e-3
    assert np.linalg.norm(s.reference.sigma_bn - scenario.initial_mrp) > 1e-5


def test_simulator_lockstep_resends_the_state_while_the_torque_is_missing(ros, scenario):
    ros.init(CASE1, lockstep__resend_period_s=0.05, **LOCKSTEP_ARGS)
    s = SimProbe(ros, scenario)

    def resent(ns: int, times: int = 3):
        s.ros.spin_until(
            lambda: stamps(s.attitude).count(ns) >= times and stamps(s.rate).count(ns) >= times,
            f"{times} sends of the state stamped {ns} ns",
        )
        same = [m for m in s.attitude if stamp_ns(m.header.stamp) == ns]
        assert all(m == same[0] for m in same)
        same = [m for m in s.rate if stamp_ns(m.header.stamp) == ns]
        assert all(m == same[0] for m in same)

    resent(0)
    assert s.node.stepper.k == 0 and s.node.stepper.resends >= 2
    s.check_state(0)
    u = np.array([0.2, 0.1, -0.3])
    s.torque(0, u)
    s.wait_state(DT_NS)
    s.reference.step(u, s.dt_s)
    s.check_state(DT_NS)
    resent(DT_NS)
    assert s.node.stepper.k == 1 and s.node.stepper.timeouts == 0
    # Stamps never go back: 0 (several times), then dt (several times).
    got = stamps(s.attitude)
    assert got == sorted(got) and set(got) == {0, DT_NS}
    assert [stamp_ns(m.clock) for m in s.clock] == sorted(stamp_ns(m.clock) for m in s.clock)


def test_simulator_realtime_refuses_torques_from_the_past_and_non_finite(ros, scenario):
    ros.init(CASE1, time_mode="realtime", realtime__torque_stale_s=600.0, **LOCKSTEP_ARGS)
    s = SimProbe(ros, scenario)
    ros.spin_until(lambda: s.newest() >= 0, "the first real-time state")
    now = s.newest()
    u = np.array([0.01, -0.02, 0.03])
    s.torque(now, u)
    ros.spin_until(lambda: s.node.stepper.torque_stamp == now, "the torque to be taken")
    np.testing.assert_array_equal(s.node.stepper.torque, u)
    s.torque(now - DT_NS, -u)  # stamped before the applied one
    s.torque(now + DT_NS, (math.nan, 0.0, 0.0))  # not finite
    ros.spin_until(lambda: s.node.rejected == 2, "two rejections")
    np.testing.assert_array_equal(s.node.stepper.torque, u)  # still the good one
