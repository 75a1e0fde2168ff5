"""Managed (lifecycle) nodes over real DDS, in real processes: a node started by hand
walks every transition through the standard ``lifecycle_msgs`` services; a bad
scenario fails ``configure`` with the key named (exit 2); a ``deactivate`` mid-run is a
safe stop measured on the recorded run (zero torque applied, target held); an error
in a callback goes through ``errorprocessing``. Each test has its own ROS domain."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from support import needs_workspace
from test_faults import Graph

from attitude_core.config import node_graph
from attitude_tools.bag.run_record import run_from_bag

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
BAD = ROOT / "tests" / "bad_scenarios"
WAIT_S = 60.0
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


class Lifecycle:
    """The probe's lifecycle clients, and every transition event it saw."""

    def __init__(self, graph: Graph) -> None:
        from attitude_ros.lifecycle_client import LifecycleClient

        self.graph, self.events = graph, []
        self.clients = {}
        self._client = lambda name: LifecycleClient(
            graph.probe, name, lambda *e: self.events.append(e), executor=graph.executor
        )

    def client(self, name: str):
        if name not in self.clients:
            self.clients[name] = self._client(name)
            self.spin_until(self.clients[name].ready, f"{name}'s lifecycle services")
        return self.clients[name]

    def spin_until(self, condition, what) -> None:
        deadline = time.monotonic() + WAIT_S
        while not condition():
            assert time.monotonic() < deadline, f"timed out waiting for {what}: {self.events}"
            self.graph.executor.spin_once(timeout_sec=0.05)

    def state(self, name: str) -> str:
        return self.client(name).state(WAIT_S)

    def set(self, name: str, label: str) -> bool:
        return self.client(name).transition(label, WAIT_S)


@pytest.fixture
def graph(tmp_path, ros_domain):
    g = Graph(tmp_path, ros_domain)
    yield g
    g.close()


def test_a_node_started_by_hand_walks_every_transition(graph):
    lc = Lifecycle(graph)
    graph.graph.start(node_graph.CONTROLLER, graph.params, autostart=False)
    name = "/" + node_graph.CONTROLLER.node_name
    assert lc.state(name) == "unconfigured"
    assert lc.set(name, "activate") is False  # not from unconfigured
    assert lc.set(name, "configure") and lc.state(name) == "inactive"
    log = graph.graph.log_dir / "controller.log"
    assert "Kp = 5.5 J" in log.read_text()  # the scenario was read by configure
    assert lc.set(name, "activate") and lc.state(name) == "active"
    assert lc.set(name, "deactivate") and lc.state(name) == "inactive"
    assert lc.set(name, "cleanup") and lc.state(name) == "unconfigured"
    assert lc.set(name, "configure") and lc.state(name) == "inactive"  # endpoints anew

    # Each transition the node made, as its ~/transition_event reported it (waited for
    # before the shutdown: a process that exits may take its last samples with it).
    def goals():
        primary = ("unconfigured", "inactive", "active", "finalized")
        return [goal for _, _, goal in lc.events if goal in primary]

    lc.spin_until(lambda: len(goals()) >= 5, "the transition events")
    assert goals() == ["inactive", "active", "inactive", "unconfigured", "inactive"]
    assert lc.set(name, "shutdown")
    assert graph.graph.procs["controller"].wait(WAIT_S) == 0


def test_a_bad_scenario_fails_configure_with_the_key_named_and_exit_2(graph):
    lc = Lifecycle(graph)
    bad = BAD / "half_angle_95.yaml"
    assert bad.exists()
    graph.graph.start(node_graph.PLANNER, ["--params-file", str(bad)], autostart=False)
    name = "/" + node_graph.PLANNER.node_name
    assert lc.state(name) == "unconfigured"  # nothing read before configure
    assert lc.set(name, "configure") is False
    proc = graph.graph.procs["planner"]
    assert proc.wait(WAIT_S) == 2
    text = (graph.graph.log_dir / "planner.log").read_text()
    assert "error: scenario:" in text and "half_angle_deg" in text
    assert "Traceback" not in text


def test_deactivating_the_controller_and_planner_mid_run_is_a_safe_stop(tmp_path, ros_domain):
    """Nodes started with autostart, in real time (so "at 5 s" holds to a step or two: a
    lockstep loop runs 100 s of simulated time while a lifecycle request is answered):
    at 5 s of run time the controller, then the planner, are deactivated by hand. From
    then on every applied torque is exactly zero and the loop keeps stepping; the held
    target does not move. Judged from the bag."""
    graph = Graph(tmp_path, ros_domain, sim_params=["time_mode:=realtime"])
    try:
        lc = Lifecycle(graph)
        graph.start()
        graph.wait_clock(0.0)  # the first state: real-time stamps are the plant's clock
        graph.wait_clock(graph.clock_s + 5.0)
        controller = "/" + node_graph.CONTROLLER.node_name
        planner = "/" + node_graph.PLANNER.node_name
        assert lc.set(controller, "deactivate") and lc.state(controller) == "inactive"
        assert lc.set(planner, "deactivate") and lc.state(planner) == "inactive"
        graph.wait_clock(graph.clock_s + 3.0)  # the loop keeps stepping on zero torque
    finally:
        graph.close()  # the recorder finishes the bag on SIGINT
    run = run_from_bag(str(graph.bag)).run
    k_off = _trailing_start(np.all(run.torque_b == 0.0, axis=1))
    assert k_off > 0 and run.t[k_off] >= 5.0 - 1e-9  # the torque ran until deactivation
    assert np.abs(run.torque_b[run.t < 5.0]).max() > 1e-4  # a real slew before
    assert len(run.t) - k_off >= 20  # and the loop stepped on, every torque zero
    same = np.all(run.sigma_t == run.sigma_t[-1], axis=1) & np.all(run.omega_t == 0.0, axis=1)
    k_held = _trailing_start(same)
    assert k_held >= k_off  # the controller stopped first, then the planner held
    assert len(run.t) - k_held >= 10


def _trailing_start(flags: np.ndarray) -> int:
    """The index where the trailing run of True in ``flags`` starts (len: none)."""
    false = np.flatnonzero(~flags)
    return int(false[-1]) + 1 if len(false) else 0


FAILING_NODE = """
import sys
from attitude_core.config import node_graph
from attitude_ros.node_base import StackNode
from attitude_ros.runner import run


class FailingNode(StackNode):
    spec = node_graph.CONTROLLER  # any table entry: the name and the identity

    def configure(self):
        self.create_timer(0.5, self.tick)

    def tick(self):
        if self.active:
            raise RuntimeError("the callback broke")


sys.exit(run(FailingNode))
"""


def test_an_error_in_a_callback_goes_through_errorprocessing_and_exits_1(graph, tmp_path):
    import subprocess
    import sys

    lc = Lifecycle(graph)
    name = "/" + node_graph.CONTROLLER.node_name
    script = tmp_path / "failing_node.py"
    script.write_text(FAILING_NODE)
    log = tmp_path / "failing.log"
    with open(log, "wb") as out:
        proc = subprocess.Popen(
            [sys.executable, str(script), "--ros-args", "-p", "autostart:=false"],
            env=graph.graph.env, stdout=out, stderr=subprocess.STDOUT,
        )  # fmt: skip
    try:
        assert lc.state(name) == "unconfigured"
        assert lc.set(name, "configure") and lc.set(name, "activate")
        lc.spin_until(lambda: proc.poll() is not None, "the node to exit")
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.wait() == 1
    text = log.read_text()
    assert "RuntimeError: the callback broke" in text and "error processing" in text
    lc.spin_until(lambda: any(goal == "finalized" for *_, goal in lc.events), "finalized")
    goals = [goal for _, _, goal in lc.events]
    assert "errorprocessing" in goals and goals.index("errorprocessing") < goals.index("finalized")
