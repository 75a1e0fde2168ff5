"""Fixtures of the ROS 2 tests: a probe that follows the plant's state steps, and the
ROS 2 session and scenario of the in-process node-shell tests (``shells.py``).

The reserved domain (``ros_domain``, ``ros_env``) is in ``tests/conftest.py``: tests of
the other folders use it too. ROS 2 and the project's modules are imported inside the
fixtures, as in :class:`StepProbe`: a module that fails to import fails the tests that
use it, not the loading of this file (and with it the whole session).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import pytest

if TYPE_CHECKING:
    from attitude_core.config.scenario import Scenario


class StepProbe:
    """An rclpy node (in a context of its own) on a reserved domain that follows the
    plant's state steps: the distinct stamps of ``/spacecraft/attitude`` (simulated time
    in lockstep, the plant's clock in real time). Best effort: it never holds back a
    publisher, and may miss a sample, never invent one."""

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from geometry_msgs.msg import QuaternionStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        from attitude_core.contract.topics import ATTITUDE

        self.stamps: set[int] = set()  # state stamps seen, ns
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain_id)
        self.node = rclpy.create_node("step_probe", context=self.ctx)
        self.node.create_subscription(
            QuaternionStamped,
            ATTITUDE,
            self._on_state,
            QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT),
        )
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def _on_state(self, msg) -> None:
        self.stamps.add(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec)

    def wait_steps(self, n: int, timeout_s: float = 120.0, alive=lambda: True) -> int:
        """Spin until ``n`` distinct states were seen; fail after ``timeout_s`` of wall
        time, or as soon as ``alive()`` is false (e.g. the process under test exited).
        Returns the number seen."""
        deadline = time.monotonic() + timeout_s
        while len(self.stamps) < n:
            if not alive():
                pytest.fail(
                    f"the process under test exited after {len(self.stamps)} states, "
                    f"waiting for {n}",
                    pytrace=False,
                )
            if time.monotonic() > deadline:
                pytest.fail(
                    f"{len(self.stamps)} states after {timeout_s} s, waiting for {n}",
                    pytrace=False,
                )
            self.executor.spin_once(timeout_sec=0.05)
        return len(self.stamps)

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()


@pytest.fixture
def step_probe(ros_domain, monkeypatch):
    """A :class:`StepProbe` on the test's reserved domain (localhost discovery, like the
    environment of ``ros_env``); closed after the test."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    probe = StepProbe(ros_domain)
    yield probe
    probe.close()


@pytest.fixture
def ros(monkeypatch, ros_domain):
    """A fresh ROS 2 session on a reserved domain, local discovery only; shut down after."""
    from shells import RosSession

    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.delenv("ROS_DOMAIN_ID", raising=False)
    session = RosSession(domain_id=ros_domain)
    yield session
    session.close()


@pytest.fixture(scope="module")
def scenario() -> Scenario:
    """``scenarios/case1.yaml``, loaded (the node-shell tests' scenario)."""
    from shells import CASE1, DT_NS

    from attitude_core.config.scenario_loader import load_scenario

    sc = load_scenario(CASE1)
    assert round(sc.dt_s * 1e9) == DT_NS
    return sc
