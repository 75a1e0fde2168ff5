"""The example hardware-in-the-loop bridge (src/spacecraft_bridge_example, docs/hil_bridge.md).

Its SciPy rigid body against the project's RK4/MRP ``RigidBody``, and a lockstep run of the
bridge process with the real planner and controller processes over DDS (a reserved
``ROS_DOMAIN_ID``, localhost only), observed by an in-process probe and compared with the
offline closed loop. As a wheel plant (``case1_rw_pyramid``) behind ``attitude-run
--plant external``, its recorded run is the offline wheel loop's.
"""

import json
import time
from pathlib import Path

import numpy as np
import pytest
from ros_helpers import run_with_bridge
from support import needs_workspace

from attitude_core.config import node_graph
from attitude_core.config.node_graph import NodeSpec
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.topics import ANGULAR_VELOCITY, APPLIED_TORQUE, ATTITUDE, CLOCK, TORQUE
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import mrp_from_quat, principal_angle, quat_from_mrp, relative
from attitude_core.world.rigid_body import RigidBody
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.run.cli import NodeGraph, ros_environment

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
T_CHECK_S = 20.0  # simulated time compared with the offline closed loop
WAIT_S = 180.0  # wall-time deadline for reaching it (planner start-up included)
pytestmark = [
    pytest.mark.ros,
    pytest.mark.slow,
    needs_workspace,
]

BRIDGE = NodeSpec(
    "bridge",
    "spacecraft_bridge_example",
    "bridge",
    "spacecraft_bridge",
    subscribes=(TORQUE,),
    publishes=(CLOCK, ATTITUDE, ANGULAR_VELOCITY, APPLIED_TORQUE),
    parameters=node_graph.SIMULATOR.parameters,
)


def _angle(sigma_a, sigma_b) -> np.ndarray:
    """Rotation angle between two attitudes given as MRPs, rad."""
    return principal_angle(relative(np.asarray(sigma_a), np.asarray(sigma_b)))


def test_scipy_rigid_body_matches_the_project_rigid_body():
    from spacecraft_bridge_example.plant import ScipyRigidBody

    inertia = np.array([[12.0, 0.5, -0.3], [0.5, 9.0, 0.2], [-0.3, 0.2, 7.0]])
    sigma0, omega0 = np.array([0.1, -0.3, 0.25]), np.array([0.1, -0.05, 0.15])
    reference = RigidBody(inertia, sigma0, omega0)
    plant = ScipyRigidBody(inertia.ravel(), quat_from_mrp(sigma0), omega0)
    dt = 0.1
    worst_angle = worst_rate = 0.0
    for k in range(40):  # 4 s of torque-driven tumbling, the torque held over each step
        t = k * dt
        u = np.array([0.2 * np.sin(0.7 * t), 0.1 * np.cos(1.3 * t), -0.15])
        reference.step(u, dt)
        state = plant.step(u, dt)
        assert state.q_bn_xyzw.shape == (4,) and state.omega_b.shape == (3,)
        assert abs(np.linalg.norm(state.q_bn_xyzw) - 1.0) < 1e-14
        np.testing.assert_array_equal(plant.state().q_bn_xyzw, state.q_bn_xyzw)
        worst_angle = max(
            worst_angle, float(_angle(reference.sigma_bn, mrp_from_quat(state.q_bn_xyzw)))
        )
        worst_rate = max(worst_rate, float(np.abs(reference.omega_b - state.omega_b).max()))
    assert np.linalg.norm(reference.omega_b) > 0.1  # it did tumble
    assert worst_angle < 1e-8
    assert worst_rate < 1e-8


class StateProbe:
    """An rclpy node in a context of its own that records every state, ``/clock`` and
    applied torque message the bridge publishes (reliable, keep-all)."""

    def __init__(self, domain_id: int) -> None:
        import rclpy
        from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy
        from rosgraph_msgs.msg import Clock

        self.attitude, self.rate, self.clock, self.applied = [], [], [], []
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain_id)
        self.node = rclpy.create_node("bridge_probe", context=self.ctx)
        qos = QoSProfile(history=HistoryPolicy.KEEP_ALL, reliability=ReliabilityPolicy.RELIABLE)
        sub = self.node.create_subscription
        sub(QuaternionStamped, ATTITUDE, self._on_attitude, qos)
        sub(Vector3Stamped, ANGULAR_VELOCITY, self._on_rate, qos)
        sub(Clock, CLOCK, lambda m: self.clock.append(_ns(m.clock)), qos)
        sub(WrenchStamped, APPLIED_TORQUE, self._on_applied, qos)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def _on_attitude(self, m) -> None:
        q = m.quaternion
        self.attitude.append((_ns(m.header.stamp), m.header.frame_id, (q.x, q.y, q.z, q.w)))

    def _on_rate(self, m) -> None:
        v = m.vector
        self.rate.append((_ns(m.header.stamp), m.header.frame_id, (v.x, v.y, v.z)))

    def _on_applied(self, m) -> None:
        u = m.wrench.torque
        self.applied.append((_ns(m.header.stamp), m.header.frame_id, (u.x, u.y, u.z)))

    def progress_ns(self, dt_ns: int) -> int:
        """Simulated time up to which every topic has been seen: the attitude, the rate,
        ``/clock`` and the torque applied from the state before (-1: not started)."""
        if not (self.attitude and self.rate and self.clock and self.applied):
            return -1
        return min(
            max(s for s, _, _ in self.attitude),
            max(s for s, _, _ in self.rate),
            max(self.clock),
            max(s for s, _, _ in self.applied) + dt_ns,
        )

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()


def _ns(stamp) -> int:
    return stamp.sec * 10**9 + stamp.nanosec


def _by_stamp(records, limit_ns: int) -> dict[int, tuple]:
    """Stamp -> content, up to ``limit_ns``; every re-send of a stamp must be identical."""
    out: dict[int, tuple] = {}
    for stamp, frame, values in records:
        if stamp <= limit_ns:
            assert out.setdefault(stamp, (frame, values)) == (frame, values), stamp
    return out


@pytest.fixture
def lockstep_run(tmp_path, ros_domain, monkeypatch):
    """Planner, controller and the example bridge (``ros2 run``) plus the probe; yields
    (probe, graph) and stops whatever is still running afterwards."""
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")  # the probe's too
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    env = ros_environment()
    env["ROS_DOMAIN_ID"] = str(ros_domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    (tmp_path / "logs").mkdir()
    graph = NodeGraph(env, tmp_path / "logs", ROOT / "scenarios")
    probe = StateProbe(ros_domain)
    try:
        params = ["--params-file", str(CASE1)]
        graph.start(node_graph.PLANNER, params)
        graph.start(node_graph.CONTROLLER, params)
        bridge_params = {
            "time_mode": "lockstep",
            "lockstep.expected_subscribers": 3,  # planner, controller and the probe
            "lockstep.torque_timeout_s": 30.0,  # a busy machine must not cause a held step
            "startup_timeout_s": 120.0,
            "sim_time_s": 3600.0,  # still running when it is interrupted
        }
        graph.start(
            BRIDGE, params + [a for k, v in bridge_params.items() for a in ("-p", f"{k}:={v}")]
        )
        yield probe, graph
    finally:
        probe.close()
        graph.stop(list(graph.procs), grace_s=5.0)


def test_lockstep_bridge_with_the_real_planner_and_controller(lockstep_run):
    probe, graph = lockstep_run
    scenario = load_scenario(CASE1)
    dt_ns = round(scenario.dt_s * 1e9)
    limit_ns = round(T_CHECK_S * 1e9)
    deadline = time.monotonic() + WAIT_S
    while probe.progress_ns(dt_ns) < limit_ns:  # wait for simulated time T_CHECK_S
        exited = graph.exited()
        assert not exited, {name: (code, graph.tail(name)) for name, code in exited.items()}
        assert time.monotonic() < deadline, (
            f"simulated time at {probe.progress_ns(dt_ns) / 1e9} s after {WAIT_S} s:\n"
            + graph.tail("bridge")
        )
        probe.executor.spin_once(timeout_sec=0.05)
    assert graph.procs["bridge"].poll() is None  # still running: it is interrupted below
    codes = graph.stop(["bridge", "planner", "controller"], grace_s=5.0)
    log = (graph.log_dir / "bridge.log").read_text()
    assert codes["bridge"] == 0, log
    assert "Traceback" not in log and "graph connected; starting" in log

    # Stamps: exactly k dt, from 0, no gap; attitude and rate with the same stamps;
    # /clock carries the same times; a re-sent state is the same message again.
    n = limit_ns // dt_ns
    expected = [k * dt_ns for k in range(n + 1)]
    assert all(s % dt_ns == 0 for s, _, _ in probe.attitude + probe.rate + probe.applied)
    arrival = [s for s, _, _ in probe.attitude]
    assert arrival == sorted(arrival)
    attitude = _by_stamp(probe.attitude, limit_ns)
    rate = _by_stamp(probe.rate, limit_ns)
    applied = _by_stamp(probe.applied, limit_ns - dt_ns)
    assert sorted(attitude) == expected and sorted(rate) == expected
    assert sorted({c for c in probe.clock if c <= limit_ns}) == expected
    assert sorted(applied) == expected[:-1]
    # Frames, unit quaternions with w >= 0.
    assert {f for f, _ in attitude.values()} == {"inertial"}
    assert {f for f, _ in rate.values()} == {"body"}
    assert {f for f, _ in applied.values()} == {"body"}
    quats = np.array([attitude[s][1] for s in expected])
    assert np.abs(np.linalg.norm(quats, axis=1) - 1.0).max() < 1e-12
    assert (quats[:, 3] >= 0.0).all()

    # The trajectory is the offline closed loop's (RK4 there, SciPy here).
    offline = run_closed_loop(scenario)
    assert np.round(offline.t[: n + 1] * 1e9).astype(int).tolist() == expected
    angle = _angle(offline.sigma_bn[: n + 1], mrp_from_quat(quats))
    assert angle.max() < 1e-6, angle.max()
    omega = np.array([rate[s][1] for s in expected])
    assert np.abs(omega - offline.omega_b[: n + 1]).max() < 1e-6
    torque = np.array([applied[s][1] for s in expected[:-1]])
    assert np.abs(torque - offline.torque_b[:n]).max() < 1e-5  # no held or zero step
    assert principal_angle(relative(offline.sigma_bn[n], offline.sigma_bn[0])) > 0.05  # moved


def test_wheel_bridge_with_the_real_graph_is_the_offline_wheel_loop(tmp_path, ros_env):
    """The example bridge as a wheel plant (``case1_rw_pyramid``: its own RK4 on
    quaternions) behind ``attitude-run --plant external`` (recorder, planner and wheeled
    controller over DDS, lockstep): the recorded run is the offline wheel loop's (MRPs)."""
    path = ROOT / "scenarios" / "case1_rw_pyramid.yaml"
    out = tmp_path / "run"
    env = ros_env(ros_environment())
    run, bridge_code = run_with_bridge(path, out, env, tmp_path / "bridge.log")
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert bridge_code == 0, (tmp_path / "bridge.log").read_text()[-2000:]
    rec = run_from_bag(str(out / "bag")).run
    offline = run_closed_loop(load_scenario(path))
    assert rec.wheels is not None and offline.wheels is not None
    n = len(rec.t)  # the run ends --settle-s after the planner's arrived
    assert n > 2000
    np.testing.assert_allclose(rec.t, offline.t[:n], rtol=0.0, atol=1e-9)
    angle = max(_angle(a, b) for a, b in zip(rec.sigma_bn, offline.sigma_bn[:n], strict=True))
    assert angle < 1e-8, angle
    np.testing.assert_allclose(rec.omega_b, offline.omega_b[:n], rtol=0.0, atol=1e-10)
    speeds, speeds_offline = rec.wheels.speed_rad_s, offline.wheels.speed_rad_s[:n]
    np.testing.assert_allclose(speeds, speeds_offline, rtol=0.0, atol=1e-8)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["t_reach_s"] is not None and summary["momentum_error_nms"] < 1e-9
