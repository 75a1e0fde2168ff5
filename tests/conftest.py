"""Shared fixtures: a reserved ROS 2 domain per test (or per module fixture).

Tests that start ROS 2 nodes must not share a DDS domain with each other, with a
concurrent test run on the same machine, or with anything else using the
``domain_coordinator`` convention of ROS 2: each test holds the lock of
:mod:`attitude_tools.domain` (the one ``attitude-run`` takes when no ``ROS_DOMAIN_ID`` is
set) on a domain of its own, freed by the kernel however the test process ends.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from attitude_tools.domain import DomainReservation, NoFreeDomain, domain_environment
from attitude_tools.domain import reserve_domain as _reserve_domain

ROOT = Path(__file__).resolve().parents[1]
needs_workspace = pytest.mark.skipif(
    not (ROOT / "ros2_ws" / "install" / "setup.bash").exists(),
    reason="colcon workspace not built (bash tools/bootstrap builds it)",
)
"""Mark for tests that start the project's nodes: they need the built colcon workspace."""


def start_bridge(
    scenario: Path, env: dict[str, str], log: Path, *params: str, namespace: str = "/"
) -> subprocess.Popen[bytes]:
    """The example hardware bridge (``spacecraft_bridge_example``) on ``scenario``, with
    the node table's state listeners and extra ``-p`` parameters (``"time_mode:=realtime"``),
    in ``namespace`` (a run's, to join it), its output in ``log``. The caller stops it
    (SIGINT) and waits for it."""
    from attitude_core.node_graph import state_listeners

    ros2 = shutil.which("ros2", path=env["PATH"])
    assert ros2 is not None
    extra = [arg for param in params for arg in ("-p", param)]
    with open(log, "wb") as out:
        return subprocess.Popen(
            [ros2, "run", "spacecraft_bridge_example", "bridge", "--ros-args",
             "-r", f"__ns:={namespace}", "--params-file", str(scenario), *extra,
             "-p", f"lockstep.expected_subscribers:={state_listeners()}"],
            env=env, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip


def run_env(domain: int) -> dict[str, str]:
    """The caller's environment on ROS domain ``domain``, discovery on this host only, for
    ``attitude-run`` (which finds the workspace itself)."""
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("AMENT_PREFIX_PATH", None)  # attitude-run finds the workspace itself
    return env


ATTITUDE_RUN = str(Path(sys.prefix) / "bin" / "attitude-run")


def _attitude_run_args(scenario: Path | str, out: Path | str, extra: tuple[str, ...]) -> list[str]:
    return [ATTITUDE_RUN, str(scenario), "--out", str(out), "--quiet", *extra]


def attitude_run(
    scenario: Path | str, out: Path | str, domain: int, *extra: str, timeout: float = 180
) -> subprocess.CompletedProcess[str]:
    """``attitude-run SCENARIO --out OUT --quiet EXTRA...`` on ROS domain ``domain``."""
    return subprocess.run(
        _attitude_run_args(scenario, out, extra),
        env=run_env(domain),
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def spawn_attitude_run(
    scenario: Path | str, out: Path | str, env: dict[str, str], *extra: str, **popen: Any
) -> subprocess.Popen[str]:
    """The same, started in the background with ``env`` (:func:`run_env` for a domain of
    its own); stdout and stderr are piped, as text."""
    return subprocess.Popen(
        _attitude_run_args(scenario, out, extra),
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        **popen,
    )


def run_with_bridge(
    scenario: Path,
    out: Path,
    env: dict[str, str],
    log: Path,
    run_args: tuple[str, ...] = (),
    bridge_params: tuple[str, ...] = (),
    timeout_s: float = 600.0,
) -> tuple[subprocess.CompletedProcess[str], int]:
    """``attitude-run --plant external`` on ``scenario`` against :func:`start_bridge`; the
    bridge outlives the run and is stopped (SIGINT) after it, as a user would. Returns
    the run (return code, stdout, stderr) and the bridge's return code."""
    from attitude_core.run_identity import run_namespace

    namespace = run_namespace()  # the bridge joins the run
    args = _attitude_run_args(
        scenario, out, ("--plant", "external", "--run-namespace", namespace, *run_args)
    )
    run = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    bridge = start_bridge(scenario, env, log, *bridge_params, namespace=namespace)
    try:
        stdout, stderr = run.communicate(timeout=timeout_s)
    finally:
        if run.poll() is None:
            run.kill()
        bridge.send_signal(signal.SIGINT)
        bridge.wait(30)
    return subprocess.CompletedProcess(args, run.returncode, stdout, stderr), bridge.returncode


def reserve_domain() -> DomainReservation:
    """Reserve a free ROS domain ID (:func:`attitude_tools.domain.reserve_domain`); fail
    the test if none is free."""
    try:
        return _reserve_domain()
    except NoFreeDomain as err:
        pytest.fail(str(err), pytrace=False)


def listen_like_a_recorder(node, on_state, depth: int = 10) -> None:
    """Subscribe ``node`` (a test's probe) to the state, the target and the torque, with
    ``on_state(msg)`` on ``/spacecraft/attitude``: it listens where a recorder listens,
    so the simulator's graph wait counts it as one (``lockstep.expected_subscribers``)."""
    from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from attitude_core.topics import ANGULAR_VELOCITY, ATTITUDE, TARGET_MRP, TARGET_RATE, TORQUE

    qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(QuaternionStamped, ATTITUDE, on_state, qos)
    for name in (ANGULAR_VELOCITY, TARGET_MRP, TARGET_RATE):
        node.create_subscription(Vector3Stamped, name, lambda msg: None, qos)
    node.create_subscription(WrenchStamped, TORQUE, lambda msg: None, qos)


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

        from attitude_core.topics import ATTITUDE

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


@pytest.fixture(scope="session")
def reserve_ros_domain():
    """The reservation function, for module- or session-scoped fixtures::

    with reserve_ros_domain() as domain:   # domain.id, domain.env()
        ...
    """
    return reserve_domain


@pytest.fixture
def ros_domain() -> Iterator[int]:
    """A ROS domain ID reserved for this test only (released after its teardown)."""
    with reserve_domain() as domain:
        yield domain.id


@pytest.fixture
def ros_env(ros_domain):
    """``ros_env(base=None)``: a copy of ``base`` (default ``os.environ``) set to the test's
    reserved domain, localhost discovery only."""
    return lambda base=None: domain_environment(ros_domain, base)


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
