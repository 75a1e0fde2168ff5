"""In-process tests of the controller node shell (see ``shells.py``)."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from geometry_msgs.msg import WrenchStamped
from shells import (
    CASE1,
    DT_NS,
    HAND_FED,
    QUIET_S,
    RosSession,
    assert_close,
    attitude_msg,
    stamps,
    vector_msg,
    xyz,
)

from attitude_controller.controller_node import PdControllerNode
from attitude_core.config import node_graph
from attitude_core.config.scenario import Scenario
from attitude_core.fsw.control.pd import PdGains, pd_torque
from attitude_core.models.mrp import mrp_from_quat, quat_from_mrp
from attitude_ros import contract as c
from attitude_ros.convert import stamp_ns

pytestmark = pytest.mark.ros


# --- controller shell ---------------------------------------------------------------------


class ControllerProbe:
    """The controller node, a publisher per input and a torque subscription."""

    def __init__(self, ros: RosSession, scenario: Scenario) -> None:
        self.ros = ros
        self.node = ros.add(PdControllerNode())
        self.gains = PdGains(scenario.kp, scenario.kd)
        self.pubs = [ros.publisher(name) for name in node_graph.CONTROLLER.subscribes]
        self.torque = ros.subscribe(c.TORQUE)
        ros.wait_connected(self.node, self.pubs)

    @staticmethod
    def message(slot: int, ns: int, value):
        if slot == 0:
            return attitude_msg(ns, value)
        frame = (c.BODY_FRAME, c.INERTIAL_FRAME, c.TARGET_FRAME)[slot - 1]
        return vector_msg(ns, value, frame)

    def filled(self, ns: int) -> int:
        return sum(x is not None for x in self.node.intake.pending.get(ns, ()))

    def feed(self, slot: int, ns: int, value) -> None:
        """Publish one input and wait until the node holds it (it is then pending)."""
        n = self.filled(ns)
        self.pubs[slot].publish(self.message(slot, ns, value))
        self.ros.spin_until(lambda: self.filled(ns) == n + 1, f"input {slot} of {ns} ns")

    def feed_rejected(self, slot: int, ns: int, value) -> None:
        n = self.node.rejected
        self.pubs[slot].publish(self.message(slot, ns, value))
        self.ros.spin_until(lambda: self.node.rejected == n + 1, f"rejection of {slot}")

    def feed_last(self, slot: int, ns: int, value) -> WrenchStamped:
        """Publish the input that completes a stamp and wait for its torque."""
        n = len(self.torque)
        self.pubs[slot].publish(self.message(slot, ns, value))
        self.ros.spin_until(lambda: len(self.torque) > n, f"the torque of {ns} ns")
        assert len(self.torque) == n + 1
        return self.torque[-1]

    def expected(self, inputs) -> np.ndarray:
        quat, omega, sigma_t, omega_t = inputs
        return pd_torque(self.gains, mrp_from_quat(np.asarray(quat)), omega, sigma_t, omega_t)


def random_inputs(rng) -> list:
    """(quaternion of the body, omega_B, sigma_t, omega_t) for one stamp."""

    def mrp():
        v = rng.normal(size=3)
        return v / np.linalg.norm(v) * rng.uniform(0.05, 0.8)

    return [
        quat_from_mrp(mrp()),
        rng.normal(scale=0.1, size=3),
        mrp(),
        rng.normal(scale=0.05, size=3),
    ]


def check_torque(msg: WrenchStamped, ns: int, expected) -> None:
    assert stamp_ns(msg.header.stamp) == ns
    assert msg.header.frame_id == c.BODY_FRAME == "body"
    assert_close(xyz(msg.wrench.torque), expected)
    assert xyz(msg.wrench.force).tolist() == [0.0, 0.0, 0.0]


def test_controller_torque_per_stamp_in_any_input_order(ros, scenario):
    ros.init(CASE1, **HAND_FED)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(20240295)
    orders = list(itertools.permutations(range(4)))[::5]  # 5 different orders
    assert len({o[-1] for o in orders}) == 4  # each input comes last once
    for k, order in enumerate(orders, start=1):
        ns = k * DT_NS
        inputs = random_inputs(rng)
        for slot in order[:-1]:
            p.feed(slot, ns, inputs[slot])
        ros.spin_for(QUIET_S)
        assert not any(stamp_ns(m.header.stamp) == ns for m in p.torque), order
        msg = p.feed_last(order[-1], ns, inputs[order[-1]])
        check_torque(msg, ns, p.expected(inputs))
        assert np.linalg.norm(p.expected(inputs)) > 1e-2  # a real torque, not zeros

    # A lockstep re-send of the state (same stamp) gets the identical torque again.
    msg = p.feed_last(0, ns, inputs[0])
    assert msg == p.torque[-2]
    assert stamps(p.torque) == [k * DT_NS for k in range(1, len(orders) + 1)] + [ns]

    # Interleaved stamps: a stamp completed later keeps its own inputs.
    ns_a, ns_b = (len(orders) + 1) * DT_NS, (len(orders) + 2) * DT_NS
    in_a, in_b = random_inputs(rng), random_inputs(rng)
    for slot in (0, 1, 2):
        p.feed(slot, ns_a, in_a[slot])
        p.feed(3 - slot, ns_b, in_b[3 - slot])
    check_torque(p.feed_last(3, ns_a, in_a[3]), ns_a, p.expected(in_a))
    check_torque(p.feed_last(0, ns_b, in_b[0]), ns_b, p.expected(in_b))


def test_controller_rejects_non_finite_inputs(ros, scenario):
    ros.init(CASE1, **HAND_FED)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(7)
    bad_values = {
        0: [(math.nan, 0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.6, 0.6)],
        1: [(0.0, math.nan, 0.0)],
        2: [(0.1, 0.0, math.inf)],
        3: [(-math.inf, 0.0, 0.0)],
    }
    n_bad = 0
    for k, slot in enumerate(sorted(bad_values), start=1):
        ns = k * DT_NS
        inputs = random_inputs(rng)
        for other in range(4):
            if other != slot:
                p.feed(other, ns, inputs[other])
        for bad in bad_values[slot]:
            p.feed_rejected(slot, ns, bad)
            n_bad += 1
        assert p.filled(ns) == 3
        ros.spin_for(QUIET_S)
        assert not any(stamp_ns(m.header.stamp) == ns for m in p.torque)
        # The valid value completes the stamp; the torque is computed from it alone.
        msg = p.feed_last(slot, ns, inputs[slot])
        check_torque(msg, ns, p.expected(inputs))
    assert p.node.rejected == n_bad
    assert stamps(p.torque) == [k * DT_NS for k in range(1, 5)]
    assert all(np.isfinite(xyz(m.wrench.torque)).all() for m in p.torque)


def test_controller_rejects_inputs_stamped_before_its_last_torque(ros, scenario):
    ros.init(CASE1, **HAND_FED)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(11)
    inputs = random_inputs(rng)
    for slot in range(3):
        p.feed(slot, 5 * DT_NS, inputs[slot])
    check_torque(p.feed_last(3, 5 * DT_NS, inputs[3]), 5 * DT_NS, p.expected(inputs))
    old = random_inputs(rng)
    for slot in range(4):  # a whole state from the past: every input refused
        p.feed_rejected(slot, 4 * DT_NS, old[slot])
    assert p.node.rejected == 4
    ros.spin_for(QUIET_S)
    assert stamps(p.torque) == [5 * DT_NS]


def test_controller_rejects_inputs_in_another_frame(ros, scenario):
    """Each input's frame_id is the contract's (attitude ``inertial``, rate ``body``,
    targets ``inertial`` and ``target``): any other is rejected, counted, never torque."""
    ros.init(CASE1, **HAND_FED)
    p = ControllerProbe(ros, scenario)
    rng = np.random.default_rng(11)
    ns = DT_NS
    inputs = random_inputs(rng)
    for slot in range(4):
        wrong = p.message(slot, ns, inputs[slot])
        wrong.header.frame_id = "base_link"
        n = p.node.rejected
        p.pubs[slot].publish(wrong)
        ros.spin_until(lambda n=n: p.node.rejected == n + 1, f"rejection of input {slot}")
    assert p.filled(ns) == 0  # nothing of the stamp was taken
    for slot in range(3):
        p.feed(slot, ns, inputs[slot])
    check_torque(p.feed_last(3, ns, inputs[3]), ns, p.expected(inputs))
    assert p.node.rejected == 4 and len(p.torque) == 1


def test_controller_scales_its_command_into_the_actuator_bound(ros, scenario, tmp_path):
    """With ``actuators.max_torque_nm`` the torque is the eq. 11 torque scaled into the
    per-axis bound, its direction kept."""
    from attitude_core.fsw.control.saturation import scale_to_bound

    bound = (0.03, 0.02, 0.05)
    path = tmp_path / "limited.yaml"
    path.write_text(
        CASE1.read_text().replace(
            "    controller:\n",
            f"    actuators:\n      max_torque_nm: {list(bound)}\n    controller:\n",
        )
    )
    ros.init(path, **HAND_FED)
    p = ControllerProbe(ros, scenario)
    assert p.node.has_parameter("actuators.max_torque_nm")
    assert not p.node.has_parameter("actuators.max_rate_rad_s")  # the planner's, not its
    rng = np.random.default_rng(5)
    saturated = 0
    for k in range(1, 9):
        ns = k * DT_NS
        inputs = random_inputs(rng)
        inputs[1] = inputs[1] * 20.0  # fast body rates: large torques
        for slot in range(3):
            p.feed(slot, ns, inputs[slot])
        msg = p.feed_last(3, ns, inputs[3])
        want, hit = scale_to_bound(p.expected(inputs), bound)
        saturated += hit
        check_torque(msg, ns, want)
        assert np.all(np.abs(xyz(msg.wrench.torque)) <= np.array(bound) * (1 + 1e-12))
    assert saturated >= 4
