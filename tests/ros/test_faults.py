"""Faults with real processes over real DDS: a node killed and restarted, the simulator
killed, a lossy torque link. Each test has its own reserved ``ROS_DOMAIN_ID`` (the
``ros_domain`` fixture of conftest.py; localhost only) and checks the outcome from the
recorded bag: no keep-out violation, arrival, and nothing recorded lost.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from ros_helpers import listen_like_a_recorder
from support import needs_workspace

from attitude_core.config import node_graph
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import TARGET_MRP, TORQUE
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import angle_between_single
from attitude_core.record.metrics import arrival_time, dense_min_margin_deg
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.run.cli import NodeGraph, ros_environment

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
WAIT_S = 120.0
pytestmark = [
    pytest.mark.ros,
    pytest.mark.slow,
    needs_workspace,
]


def _stamp(msg) -> int:
    return msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec


class Graph:
    """Recorder, planner, controller and simulator started as ``ros2 run`` starts them, plus an
    in-process probe that follows the state stamps (the simulator waits for it too), all on
    the reserved ROS domain ``domain``."""

    def __init__(self, tmp_path: Path, domain: int, sim_params=()):
        import rclpy
        from rclpy.executors import SingleThreadedExecutor

        self.domain = domain
        env = ros_environment()
        env["ROS_DOMAIN_ID"] = str(self.domain)
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        (tmp_path / "logs").mkdir()
        self.bag = tmp_path / "bag"
        self.graph = NodeGraph(env, tmp_path / "logs", ROOT / "scenarios")
        self.params = ["--params-file", str(CASE1)]
        listeners = node_graph.state_listeners() + 1  # and the probe
        self.sim_params = [
            "-p",
            f"lockstep.expected_subscribers:={listeners}",
            "-p",
            "lockstep.torque_timeout_s:=0.3",
        ]
        for p in sim_params:
            self.sim_params += ["-p", p]
        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=self.domain)
        self.probe = rclpy.create_node("fault_probe", context=self.ctx)
        self.clock_s = -1.0
        self.killed: set[str] = set()
        listen_like_a_recorder(self.probe, self._on_state, depth=10)
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.probe)

    def _on_state(self, msg) -> None:
        self.clock_s = max(self.clock_s, _stamp(msg) * 1e-9)

    def start(self, simulator: bool = True) -> None:
        """Start the nodes (``simulator=False``: all but the simulator, which
        :meth:`start_simulator` starts later; nothing steps before it)."""
        g = self.graph
        g.start(
            node_graph.RECORDER,
            [
                "-p",
                f"output_dir:={self.bag}",
                "-p",
                f"stop_on_planner_status:=[{PlannerStatus.ARRIVED},{PlannerStatus.STUCK}]",
                "-p",
                "stop_delay_s:=5.0",
                "-p",
                f"scenario_file:={CASE1}",
            ],
        )
        g.start(node_graph.PLANNER, self.params)
        g.start(node_graph.CONTROLLER, self.params)
        if simulator:
            self.start_simulator()

    def start_simulator(self) -> None:
        self.graph.start(node_graph.SIMULATOR, self.params + self.sim_params)

    def wait_clock(self, t_s: float) -> None:
        deadline = time.monotonic() + WAIT_S
        while self.clock_s < t_s:
            assert time.monotonic() < deadline, f"simulated time stuck at {self.clock_s} s"
            crashed = {n: c for n, c in self.graph.exited().items() if n not in self.killed}
            assert not crashed, crashed
            self.executor.spin_once(timeout_sec=0.05)

    def kill(self, name: str) -> None:
        """Kill a node. :attr:`clock_s` may still lag the clock of the kill: the probe has
        states it has not handled yet (:meth:`drain`)."""
        self.killed.add(name)
        self.graph.procs[name].kill()
        self.graph.procs[name].wait()

    def drain(self) -> None:
        """Handle the states already delivered to the probe, until none comes for 0.1 s."""
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline:
            before = self.clock_s
            self.executor.spin_once(timeout_sec=0.1)
            if self.clock_s == before:
                return

    def wait_recording_done(self) -> None:
        proc = self.graph.procs["recorder"]
        proc.wait(WAIT_S)
        assert proc.returncode == 0, self.graph.tail("recorder")

    def close(self) -> None:
        self.graph.stop(list(self.graph.procs), grace_s=5.0)
        self.executor.shutdown()
        self.probe.destroy_node()
        self.ctx.try_shutdown()


@pytest.fixture
def graph(tmp_path, ros_domain):
    g = Graph(tmp_path, ros_domain)
    yield g
    g.close()


def assert_safe_arrival(bag_run) -> None:
    run = bag_run.run
    sc = run.scenario
    min_margin, _ = dense_min_margin_deg(sc.cone_geometry(), run.t, run.sigma_bn, run.omega_b)
    assert min_margin > 0.0
    reached, _, _ = arrival_time(
        run.t,
        run.sigma_bn,
        run.omega_b,
        sc.desired_mrp,
        sc.arrival.attitude_tol_deg,
        sc.arrival.rate_tol_rad_s,
    )
    assert reached
    assert bag_run.incomplete_steps <= 1


def test_controller_killed_then_restarted_completes_with_zero_torque_meanwhile(graph):
    graph.start()
    graph.wait_clock(10.0)
    graph.kill("controller")
    killed_at = graph.clock_s
    graph.wait_clock(killed_at + 1.5)  # 0.3 s per step without torque
    restarted_at = graph.clock_s
    graph.graph.start(node_graph.CONTROLLER, graph.params, name="controller_restarted")
    graph.wait_recording_done()
    bag_run = run_from_bag(str(graph.bag))
    assert_safe_arrival(bag_run)
    run = bag_run.run
    # Without a controller: one timed-out step holds the last torque, then zero torque
    # (stale), in one stretch, until the restarted controller answers.
    zero = np.flatnonzero(np.all(run.torque_b == 0.0, axis=1))
    assert len(zero) >= 3 and zero[-1] - zero[0] + 1 == len(zero)
    assert killed_at - 0.05 < run.t[zero[0]] and run.t[zero[-1]] < restarted_at + 5.0
    held = zero[0] - 1
    np.testing.assert_array_equal(run.torque_b[held], run.torque_b[held - 1])
    # Wherever the bag has the controller's torque, it is what the body felt, unless the
    # answer came after the step's timeout (a loaded machine): that step held the torque
    # of the one before. (A node started mid-run is recorded from when the recorder
    # discovers it; the simulator's applied torque has no gap.)
    commanded = {_stamp(m.msg): m.msg.wrench.torque for m in read_bag(str(graph.bag), [TORQUE])}
    settled = (run.t < killed_at - 1.0) | (run.t > restarted_at + 5.0)  # late answers aside
    applied = held_late = 0
    for k, s in enumerate(bag_run.stamps_ns.tolist()):
        if s in commanded and settled[k]:
            q = commanded[s]
            if np.array_equal(run.torque_b[k], (q.x, q.y, q.z)):
                applied += 1
            else:
                np.testing.assert_array_equal(run.torque_b[k], run.torque_b[k - 1])
                held_late += 1
    assert applied > 10 * held_late, (applied, held_late)
    assert run.t[-1] > restarted_at + 30.0 and not np.isnan(run.torque_b).any()
    log = (graph.bag.parent / "logs" / "simulator.log").read_text()
    assert not held_late or "holding the last torque" in log
    assert "torque is stale: applying zero torque" in log and "torque received again" in log


def test_planner_restarted_resumes_from_the_measured_attitude(graph):
    graph.start()
    graph.wait_clock(15.0)
    graph.kill("planner")
    graph.drain()  # without it, the clock of the kill could be steps early: a shorter gap
    killed_at = graph.clock_s
    graph.wait_clock(killed_at + 1.0)
    graph.graph.start(node_graph.PLANNER, graph.params, name="planner_restarted")
    graph.wait_recording_done()
    bag_run = run_from_bag(str(graph.bag))
    assert_safe_arrival(bag_run)
    run = bag_run.run
    # The restarted planner started from the attitude it measured (its log says which),
    # a recorded attitude of the gap, not from sigma_0.
    log = (graph.bag.parent / "logs" / "planner_restarted.log").read_text()
    start = np.array(json.loads(log.split("planning from sigma_BN = ")[1].split("\n")[0]))
    killed = int(np.searchsorted(run.t, killed_at - 1e-9))
    distance = np.linalg.norm(run.sigma_bn[killed:] - start, axis=1)
    resumed_at = killed + int(np.argmin(distance))
    assert distance.min() < 1e-6  # the log rounds to 6 decimals
    assert np.linalg.norm(start - run.scenario.initial_mrp) > 0.05
    has_target = ~np.isnan(run.sigma_t[:, 0])
    assert not has_target[resumed_at - 3 : resumed_at].any()  # no target while it was down
    first = resumed_at + int(np.argmax(has_target[resumed_at:]))
    # Its first recorded target continues from there at the planner's speed: the rotation
    # from the measured attitude is within what the recorded target rate allows. (It is an
    # angle, not an MRP distance: the target may have switched to the shadow set; and the
    # recorder may discover the new publisher some steps late.)
    speed = float(np.nanmax(np.linalg.norm(run.omega_t, axis=1)))
    rotation = angle_between_single(run.sigma_t[first], start)
    assert rotation <= speed * (run.t[first] - run.t[resumed_at] + 0.1) + 1e-3


def test_torque_link_dropping_10_percent_neither_deadlocks_nor_changes_the_run(tmp_path, ros_env):
    out = tmp_path / "lossy"
    env = ros_env()
    proc = subprocess.run(
        [
            str(Path(sys.prefix) / "bin" / "attitude-run"),
            str(CASE1),
            "--out",
            str(out),
            "--quiet",
            "--param",
            "controller:fault.drop_torque_fraction:=0.1",
            "--param",
            "controller:fault.seed:=7",
            "--param",
            "simulator:lockstep.resend_period_s:=0.02",
        ],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    bag_run = run_from_bag(str(out / "bag"))
    assert_safe_arrival(bag_run)
    # Re-sent states get identical answers: the trajectory is the lossless one.
    offline = run_closed_loop(load_scenario(CASE1))
    n = len(bag_run.run.t)
    np.testing.assert_allclose(bag_run.run.sigma_bn, offline.sigma_bn[:n], atol=1e-6, rtol=0)
    log = (out / "logs" / "simulator.log").read_text()
    resends = int(log.split(" state re-sends")[0].rsplit(" ", 1)[-1])
    assert resends > 0.05 * n  # about one in ten torques was lost and asked for again


def _pid_of(executable: str, domain: int) -> int | None:
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
            environ = (entry / "environ").read_bytes()
        except OSError:
            continue
        if executable.encode() in cmdline and f"ROS_DOMAIN_ID={domain}\0".encode() in environ:
            return int(entry.name)
    return None


def test_simulator_killed_still_leaves_a_readable_bag_and_summary(
    tmp_path, ros_domain, ros_env, step_probe
):
    out = tmp_path / "crashed"
    proc = subprocess.Popen(
        [
            str(Path(sys.prefix) / "bin" / "attitude-run"),
            str(CASE1),
            "--out",
            str(out),
            "--quiet",
            "--mode",
            "realtime",
        ],
        env=ros_env(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # some real-time steps: 20 states seen
        step_probe.wait_steps(20, WAIT_S, alive=lambda: proc.poll() is None)
        pid = _pid_of("rigid_body_sim", ros_domain)
        assert pid is not None
        os.kill(pid, signal.SIGKILL)
        _, stderr = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 1
    summary = json.loads((out / "summary.json").read_text())
    assert summary["failure"] == "simulator exited with code -9"
    from rosbags.highlevel import AnyReader

    with AnyReader([out / "bag"]) as reader:
        attitudes = sum(1 for c, _, _ in reader.messages() if c.topic == "/spacecraft/attitude")
    bag_run = run_from_bag(str(out / "bag"))
    assert attitudes >= len(bag_run.run.t) >= 10
    assert summary["steps_recorded"] == len(bag_run.run.t)
    targets = {_stamp(m.msg) for m in read_bag(str(out / "bag"), [TARGET_MRP])}
    # Real time does not wait for the planner's first answer: the states published
    # while its end of the discovery was still settling go unanswered (zero torque
    # applied). From the first answered state on, every step up to the kill keeps
    # its target: the recording lost nothing when the simulator died.
    stamps = bag_run.stamps_ns[:-1].tolist()
    first = next(k for k, s in enumerate(stamps) if s in targets)
    assert first < 10  # the planner answered within its first second
    assert set(stamps[first:]) <= targets
