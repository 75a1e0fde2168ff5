"""Helpers of the in-process tests of the rclpy node shells (``test_node_parameters.py``,
``test_planner_node.py``, ``test_controller_node.py``, ``test_sim_node.py``): real rclpy,
real DDS, one process.

Each test gets its own ROS 2 session (``ros`` fixture of ``ros/conftest.py``, a
:class:`RosSession`): the default context initialised with the test's ``--ros-args`` on a
DDS domain reserved for the test (``ros_domain`` of ``tests/conftest.py``), discovery
limited to this host, and shut down afterwards. (The node classes call ``Node.__init__``
without a context, so they live in the default context; a private ``rclpy.Context`` per
test is not possible without changing them.) Everything is driven by one
``SingleThreadedExecutor`` holding the node under test and a test-side ``probe`` node.

Waiting is always for a condition, with a generous deadline (``WAIT_S``), never for a
time; nothing asserts on timing. "Nothing was published" is asserted deterministically
where possible: messages of one topic from one publisher arrive in order, so once the
answer to a later, valid message has arrived, an answer to an earlier rejected one would
have arrived before it. The nodes' own counters (``rejected``, ``pending``) tell when a
message has been consumed.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node

from attitude_ros import contract as c
from attitude_ros.convert import set_stamp, stamp_ns

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
WAIT_S = 10.0  # deadline of every wait for a condition
QUIET_S = 0.3  # extra spinning before a (supplementary) "nothing arrived" check
TOL = 1e-12
HAND_FED = {
    "fdir__state_timeout_s": 3600.0,
    "fdir__predict_s": 7200.0,
    "fdir__safe_after_s": 10800.0,
}
"""Overrides for a node fed states by hand, slower than its loop in wall time: its state
watchdog (tested in ``test_link_ros.py`` and ``tests/core``) would rightly call them
stale and fly on predictions between them; these tests check the answers to the states."""


# --- the ROS session of the ``ros`` fixture, and its helpers ----------------------------


class RosSession:
    """One rclpy session: init with the test's arguments, an executor, a probe node."""

    def __init__(self, domain_id: int) -> None:
        self.domain_id = domain_id
        self.executor = None
        self.probe = None
        self.nodes: list[Node] = []

    def init(self, params_file: Path | str = CASE1, **overrides) -> None:
        """``rclpy.init`` with ``--params-file params_file`` and ``-p key:=value`` overrides
        (keyword names use ``__`` for the dots: ``lockstep__resend_period_s=0.05``)."""
        # Managed nodes configure and activate themselves (autostart) in these tests.
        args = ["--ros-args", "--params-file", str(params_file), "-p", "autostart:=true"]
        for key, value in overrides.items():
            args += ["-p", f"{key.replace('__', '.')}:={value!r}"]
        rclpy.init(args=args, domain_id=self.domain_id)
        self.executor = SingleThreadedExecutor()
        self.probe = self.add(Node("node_shells_probe"))

    def add(self, node: Node) -> Node:
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def close(self) -> None:
        if self.executor is not None:
            self.executor.shutdown(timeout_sec=1.0)
        for node in reversed(self.nodes):
            node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()

    # -- spinning

    def spin_until(self, condition, what: str, timeout: float = WAIT_S) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout} s waiting for {what}")
            self.executor.spin_once(timeout_sec=0.01)

    def spin_for(self, seconds: float) -> None:
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            self.executor.spin_once(timeout_sec=0.01)

    # -- probe endpoints (the contract's QoS)

    def publisher(self, name: str):
        topic = c.topic(name)
        return self.probe.create_publisher(c.message_class(topic.type_name), name, c.qos(topic))

    def subscribe(self, name: str, *, history: bool = False, keep=None) -> list:
        """Subscribe the probe to a contract topic; returns the list the messages go to.
        ``history``: transient-local, so samples published before matching arrive too;
        ``keep``: only the messages for which it is true (e.g. not the run identities
        that share ``/diagnostics``)."""
        topic = c.topic(name)
        received: list = []
        self.probe.create_subscription(
            c.message_class(topic.type_name),
            name,
            received.append if keep is None else lambda m: keep(m) and received.append(m),
            c.qos(topic, subscriber=not history),
        )
        return received

    def wait_connected(self, node: Node, publishers) -> None:
        """Wait until every probe publisher in ``publishers`` is matched by ``node``
        (both ends) and every probe subscription sees a publisher."""

        def node_subscription(name):
            return next(s for s in node.subscriptions if s.topic_name == name)

        def ready():
            return all(
                p.get_subscription_count() >= 1
                and node_subscription(p.topic_name).get_publisher_count() >= 1
                for p in publishers
            ) and all(s.get_publisher_count() >= 1 for s in self.probe.subscriptions)

        self.spin_until(ready, "the probe and the node to be connected")


# --- message helpers --------------------------------------------------------------------

DT_NS = 100_000_000  # case1: dt_s = 0.1


def stamped(msg, ns: int, frame: str = ""):
    set_stamp(msg.header.stamp, ns)
    msg.header.frame_id = frame
    return msg


def attitude_msg(ns: int, quat_xyzw) -> QuaternionStamped:
    msg = stamped(QuaternionStamped(), ns, c.INERTIAL_FRAME)
    q = msg.quaternion
    q.x, q.y, q.z, q.w = (float(x) for x in quat_xyzw)
    return msg


def vector_msg(ns: int, v, frame: str) -> Vector3Stamped:
    msg = stamped(Vector3Stamped(), ns, frame)
    msg.vector.x, msg.vector.y, msg.vector.z = (float(x) for x in v)
    return msg


def torque_msg(ns: int, u) -> WrenchStamped:
    msg = stamped(WrenchStamped(), ns, c.BODY_FRAME)
    t = msg.wrench.torque
    t.x, t.y, t.z = (float(x) for x in u)
    return msg


def xyz(v) -> np.ndarray:
    return np.array((v.x, v.y, v.z))


def xyzw(q) -> np.ndarray:
    return np.array((q.x, q.y, q.z, q.w))


def stamps(messages) -> list[int]:
    return [stamp_ns(m.header.stamp) for m in messages]


def assert_close(actual, expected, tol: float = TOL) -> None:
    np.testing.assert_allclose(
        np.asarray(actual, dtype=float), np.asarray(expected, dtype=float), rtol=0.0, atol=tol
    )
