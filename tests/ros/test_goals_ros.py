"""Commanded slews through ``attitude-run`` over real DDS: an observation plan in
lockstep, and an operator commanding a real-time ``--until-stopped`` run on
``<run namespace>/planner/goal`` (a feasible constrained goal, a goal that points the
star tracker into a keep-out, a third goal), ended with SIGINT. Judged from the bag on
the recorded body, with the goals' outcomes from ``summary.json``."""

from __future__ import annotations

import json
import math
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from support import needs_workspace

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.diagnostics import STATUS_NAME
from attitude_core.contract.goals import GOAL_DIAGNOSTIC_NAME
from attitude_core.contract.topics import DIAGNOSTICS, GOAL
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import angle_between_single, quat_from_mrp
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
PLAN = ROOT / "scenarios" / "case1_plan.yaml"
OPERATOR = ROOT / "scenarios" / "case1_operator.yaml"
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


def _deg(a, b) -> float:
    return math.degrees(angle_between_single(a, b))


def test_a_plan_through_attitude_run_is_flown_in_order_and_held(tmp_path, ros_env):
    out = tmp_path / "plan"
    run = subprocess.run(
        [str(BIN / "attitude-run"), str(PLAN), "--out", str(out), "--quiet"],
        env=ros_env(ros_environment()), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    sc = load_scenario(PLAN)
    assert [(g["name"], g["outcome"]) for g in summary["goals"]] == [
        (t.name, "reached") for t in sc.plan
    ]
    assert summary["end_reason"] == "planner finished"
    bag = run_from_bag(str(out / "bag")).run
    margin, _ = dense_min_margin_deg(sc.sky, bag.t, bag.sigma_bn, bag.omega_b)
    assert margin > 0.0
    tol = sc.arrival.attitude_tol_deg
    for goal, target in zip(summary["goals"], sc.plan, strict=True):
        held = (bag.t >= goal["t_end_s"] - target.dwell_s - 1e-9) & (bag.t <= goal["t_end_s"])
        assert held.sum() >= round(target.dwell_s / sc.dt_s)
        assert max(_deg(s, target.desired_mrp) for s in bag.sigma_bn[held]) < tol
    starts = [g["t_start_s"] for g in summary["goals"]]
    assert starts == sorted(starts)
    # Lockstep: the offline run's goals, to the step.
    offline = run_closed_loop(sc)
    assert [g["t_reach_s"] for g in summary["goals"]] == [g.t_reach_s for g in offline.goals]
    names = {m.topic for m in read_bag(str(out / "bag"), [GOAL, DIAGNOSTICS])}
    assert DIAGNOSTICS in names  # the goal reports; no goal message in a plan's run


class Operator:
    """An operator's node on the run's domain: publishes goals on the run's
    ``<namespace>/planner/goal`` (a default rclpy publisher) and follows the planner's
    goal reports on ``/diagnostics``."""

    def __init__(self, domain: int, namespace: str) -> None:
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from geometry_msgs.msg import QuaternionStamped
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        self.ctx = rclpy.Context()
        rclpy.init(context=self.ctx, domain_id=domain)
        self.node = rclpy.create_node("operator", namespace=namespace, context=self.ctx)
        self.msg_type = QuaternionStamped
        self.pub = self.node.create_publisher(QuaternionStamped, GOAL.lstrip("/"), 10)
        self.reports: list[dict[str, str]] = []
        self.steps = 0  # the planner's per-step reports heard: the run is active
        self.node.create_subscription(
            DiagnosticArray,
            DIAGNOSTICS,
            self._on_diag,
            QoSProfile(depth=200, reliability=ReliabilityPolicy.RELIABLE),
        )
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.executor.add_node(self.node)

    def _on_diag(self, msg) -> None:
        for st in msg.status:
            self.steps += st.name == STATUS_NAME
            if st.name == GOAL_DIAGNOSTIC_NAME:
                self.reports.append({kv.key: kv.value for kv in st.values})

    def wait(self, condition, what: str, timeout_s: float, alive) -> None:
        deadline = time.monotonic() + timeout_s
        while not condition():
            assert alive(), f"attitude-run exited waiting for {what}"
            assert time.monotonic() < deadline, f"no {what} in {timeout_s} s: {self.reports}"
            self.executor.spin_once(timeout_sec=0.05)

    def send(self, stamp_s: int, sigma) -> None:
        q = quat_from_mrp(np.asarray(sigma, dtype=float))
        msg = self.msg_type()
        msg.header.stamp.sec = stamp_s
        msg.header.frame_id = "inertial"
        msg.quaternion.x, msg.quaternion.y, msg.quaternion.z, msg.quaternion.w = map(float, q)
        self.pub.publish(msg)

    def report(self, stamp_s: int, outcome: str, arrived: bool = False):
        goal_id = str(stamp_s * 10**9)
        for r in self.reports:
            reached = not math.isnan(float(r["t_reach_s"]))
            if r["goal_id"] == goal_id and r["outcome"] == outcome and (reached or not arrived):
                return r
        return None

    def close(self) -> None:
        self.executor.shutdown()
        self.node.destroy_node()
        self.ctx.try_shutdown()


def test_an_operator_commands_a_running_stack_then_stops_it(tmp_path, ros_domain, ros_env):
    sc = load_scenario(OPERATOR)
    ns = f"/ops_{ros_domain}"
    out = tmp_path / "ops"
    proc = subprocess.Popen(
        [str(BIN / "attitude-run"), str(OPERATOR), "--out", str(out), "--quiet",
         "--mode", "realtime", "--until-stopped", "--run-namespace", ns],
        env=ros_env(ros_environment()), stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        text=True,
    )  # fmt: skip
    alive = lambda: proc.poll() is None
    op = Operator(ros_domain, ns)
    constrained = np.array([0.0, -0.2, -0.7])  # Case 1's goal: a detour around object_2
    blind = np.zeros(3)  # the star tracker 17 deg from object_3, inside its 20 deg
    third = np.array([-0.2271, -0.102, -0.6239])  # 40 deg on from the first, in the clear
    try:
        # The planner and the recorder subscribe the goal once they are configured.
        op.wait(lambda: op.pub.get_subscription_count() >= 2, "goal subscribers", 120.0, alive)
        # ... and the run is active (the recorder records while active only: a goal sent
        # before would be flown but not in the bag).
        op.wait(lambda: op.steps > 0, "a planner step", 120.0, alive)
        op.send(1, constrained)
        op.wait(lambda: op.report(1, "accepted", arrived=True), "arrival", 240.0, alive)
        op.send(2, blind)
        op.wait(lambda: op.report(2, "refused"), "refusal", 60.0, alive)
        looked = time.monotonic() + 5.0  # the body keeps the constrained goal meanwhile
        op.wait(lambda: time.monotonic() > looked, "a while", 10.0, alive)
        op.send(3, third)
        op.wait(lambda: op.report(3, "accepted", arrived=True), "arrival", 240.0, alive)
        settled = time.monotonic() + 3.0  # the operator looks on a while, then stops the run
        op.wait(lambda: time.monotonic() > settled, "a while", 10.0, alive)
    finally:
        op.close()
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 0, stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["end_reason"] == "stopped by the operator" and summary["failure"] is None
    goals = summary["goals"]
    assert [(g["name"], g["outcome"]) for g in goals] == [
        ("goal@1.000000000", "reached"),
        ("goal@2.000000000", "refused"),
        ("goal@3.000000000", "reached"),
    ]
    assert "inside the keep-out of star_tracker/object_3" in goals[1]["reason"]
    bag = run_from_bag(str(out / "bag")).run
    margin, _ = dense_min_margin_deg(sc.sky, bag.t, bag.sigma_bn, bag.omega_b)
    assert margin > 0.0 and summary["min_margin_deg"] > 0.0
    tol = sc.arrival.attitude_tol_deg
    # Each reached goal: the body within the arrival band at its arrival; the refused
    # one moved nothing: from the first arrival to the third goal's start the body
    # stayed on the constrained goal.
    for goal, sigma in ((goals[0], constrained), (goals[2], third)):
        k = int(np.searchsorted(bag.t, goal["t_reach_s"] - 1e-6))
        assert _deg(bag.sigma_bn[k], sigma) < tol
    held = (bag.t >= goals[0]["t_reach_s"]) & (bag.t < goals[2]["t_start_s"])
    assert held.sum() > 30
    assert max(_deg(s, constrained) for s in bag.sigma_bn[held]) < tol
    # The goals are on record as sent.
    sent = [m for m in read_bag(str(out / "bag"), [GOAL])]
    assert [m.msg.header.stamp.sec for m in sent] == [1, 2, 3]
