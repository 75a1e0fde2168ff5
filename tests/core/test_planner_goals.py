"""The planner node's logic (PlannerStepper, no ROS) with goals: a plan fed the offline
run's states gives the offline run's targets and goal reports; a goal message is checked
(frame, finite, unit norm) and a malformed one refused at once, the goal in force kept;
a received goal is judged at the next state."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.goals import SOURCE_PLAN, SOURCE_TOPIC
from attitude_core.contract.status import GoalOutcome, PlannerStatus
from attitude_core.contract.topics import NS_PER_S
from attitude_core.fsw.guidance.guidance_base import ImmediateExecutor
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import quat_from_mrp
from attitude_core.runtime.planner_stepper import PlannerStepper

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
PLAN = ROOT / "scenarios" / "case1_plan.yaml"


def _xyzw(sigma) -> tuple[float, float, float, float]:
    q = quat_from_mrp(np.asarray(sigma, dtype=float))  # (x, y, z, w)
    return (float(q[0]), float(q[1]), float(q[2]), float(q[3]))


def test_a_plan_through_the_stepper_is_the_offline_run():
    sc = load_scenario(PLAN)
    run = run_closed_loop(sc)
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    dt_ns = round(sc.dt_s * NS_PER_S)
    reports = []
    for k in range(len(run.t)):
        step = stepper.step(k * dt_ns, run.sigma_bn[k], run.omega_b[k])
        np.testing.assert_array_equal(step.sigma_t, run.sigma_t[k])
        np.testing.assert_array_equal(step.omega_t, run.omega_t[k])
        assert step.result is not None and step.result.target.status.code == run.planner_status[k]
        reports += step.goals
    stepper.close()
    finals = [r for r in reports if r.final]
    assert [(r.source, r.name, r.outcome) for r in finals] == [
        (SOURCE_PLAN, g.name, g.outcome) for g in run.goals
    ]
    assert [r.t_reach_s for r in finals] == [g.t_reach_s for g in run.goals]


@pytest.mark.parametrize(
    "frame, xyzw, words",
    [
        ("body", (0.0, 0.0, 0.0, 1.0), "frame_id 'body', not 'inertial'"),
        ("inertial", (0.0, math.nan, 0.0, 1.0), "quaternion not finite"),
        ("inertial", (0.0, 0.0, 0.0, 1.00001), "quaternion norm 1.00001, not 1 within 1e-06"),
        ("inertial", (0.0, 0.0, 0.0, 0.0), "quaternion norm 0, not 1"),
    ],
)
def test_a_malformed_goal_is_refused_at_once_and_the_goal_in_force_kept(frame, xyzw, words):
    sc = load_scenario(CASE1)
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    dt_ns = round(sc.dt_s * NS_PER_S)
    first = stepper.step(0, sc.initial_mrp, np.zeros(3))
    guidance = stepper.guidance
    (report,) = stepper.command(5 * NS_PER_S + 7, frame, xyzw)
    assert report.outcome is GoalOutcome.REFUSED and words in report.reason
    assert report.source == SOURCE_TOPIC and report.name == "goal@5.000000007"
    step = stepper.step(dt_ns, first.sigma_t, np.zeros(3))
    assert stepper.guidance is guidance and step.goals == [report]
    assert step.result is not None and step.result.target.status is PlannerStatus.REFUSED
    assert stepper.sequence.reported == [report]
    stepper.close()


def test_a_goal_message_is_judged_at_the_next_state_and_preempts():
    sc = load_scenario(CASE1)
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    dt_ns = round(sc.dt_s * NS_PER_S)
    stepper.step(0, sc.initial_mrp, np.zeros(3))
    goal = np.array([0.3, 0.4, 0.1])
    assert stepper.command(42, "inertial", _xyzw(goal)) == []
    step = stepper.step(dt_ns, sc.initial_mrp, np.zeros(3))
    (taken,) = step.goals
    assert taken.outcome is GoalOutcome.ACCEPTED and taken.goal_id == 42
    np.testing.assert_allclose(taken.sigma_goal, goal, atol=1e-12)
    np.testing.assert_allclose(stepper.guidance.goal, goal, atol=1e-12)
    assert taken.t_start_s == pytest.approx(0.1) and taken.t_commanded_s == 0.0
    stepper.close()


def test_a_goal_received_before_the_first_state_is_flown_instead_of_the_scenarios():
    sc = load_scenario(CASE1)
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    goal = np.array([0.3, 0.4, 0.1])
    assert stepper.command(9, "inertial", _xyzw(goal)) == []
    step = stepper.step(0, sc.initial_mrp, np.zeros(3))
    np.testing.assert_allclose(stepper.guidance.goal, goal, atol=1e-12)
    assert [g.goal_id for g in step.goals] == [9]
    own = stepper.sequence.records[0]
    assert own.source == "scenario" and own.outcome is GoalOutcome.PREEMPTED
    assert not stepper.sequence.queue  # the scenario's goal will not follow it
    stepper.close()
