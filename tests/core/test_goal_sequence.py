"""Commanded goals and observation plans (attitude_core.assembly.goal_sequence): a plan's
targets flown in order and held for their dwell on the body; a goal received during the
run preempts the one in force, planned from the measured state; a goal that points an
instrument into a keep-out is refused before any torque. Judged on the simulated body."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from attitude_core.assembly.goal_sequence import GoalSequence, goal_clearance
from attitude_core.assembly.guidance import prepare_guidance
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario, loads_scenario
from attitude_core.contract.goals import GoalReport, goal_name
from attitude_core.contract.status import GoalOutcome, PlannerStatus
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import angle_between_single
from attitude_core.record.goal_figures import goal_in_force, in_force_rows
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_core.world.rigid_body import RigidBody

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
PLAN = ROOT / "scenarios" / "case1_plan.yaml"


def _plan_text(targets: str, top: str = "") -> str:
    text = PLAN.read_text()
    start = text.index("    plan:")
    end = text.index("    controller:")
    return text[:start] + targets + top + text[end:]


def test_plan_targets_are_flown_in_order_each_held_for_its_dwell_on_the_body():
    sc = load_scenario(PLAN)
    run = run_closed_loop(sc)
    assert [g.name for g in run.goals] == [t.name for t in sc.plan]
    assert [g.outcome for g in run.goals] == [GoalOutcome.REACHED] * 3
    tol = sc.arrival.attitude_tol_deg
    for goal, target in zip(run.goals, sc.plan, strict=True):
        # The body, not the target: inside the arrival band for the whole dwell.
        hold = (run.t >= goal.t_end_s - target.dwell_s - 1e-9) & (run.t <= goal.t_end_s + 1e-9)
        err = [
            math.degrees(angle_between_single(s, target.desired_mrp)) for s in run.sigma_bn[hold]
        ]
        assert max(err) < tol and goal.t_end_s - goal.t_reach_s >= target.dwell_s - 1e-9
        assert hold.sum() >= round(target.dwell_s / sc.dt_s)
    starts = [g.t_start_s for g in run.goals]
    ends = [g.t_end_s for g in run.goals]
    assert starts == sorted(starts) and all(b > a for a, b in zip(ends, starts[1:], strict=False))
    margin, _ = dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)
    assert margin > 0.0
    summary = summarize(run).to_json()
    assert summary["reached"] and summary["t_reach_s"] == run.goals[-1].t_reach_s
    assert [g["outcome"] for g in summary["goals"]] == ["reached"] * 3
    assert min(g["min_margin_deg"] for g in summary["goals"]) == pytest.approx(margin)
    # The plan is complete after the last dwell: the status says so from then on.
    done = run.t > run.goals[-1].t_end_s + 1e-9
    assert np.all(run.planner_status[done] == PlannerStatus.COMPLETE.code)
    index = goal_in_force(run)
    assert index[0] == 0 and set(index[in_force_rows(run, run.goals[1])]) == {1}


def test_a_plan_target_inside_a_keep_out_is_refused_and_skipped():
    # object_3 is at (0.958, 0, 0.287): the identity puts the star tracker (+x) 17 deg
    # from it, inside its 20 deg.
    targets = (
        "    plan:\n      names: [blind, case1_goal]\n"
        "      blind:\n        desired_mrp: [0.0, 0.0, 0.0]\n        dwell_s: 5.0\n"
        "      case1_goal:\n        desired_mrp: [0.0, -0.2, -0.7]\n        dwell_s: 5.0\n"
    )
    sc = loads_scenario(_plan_text(targets), str(PLAN))
    run = run_closed_loop(sc)
    blind, goal = run.goals
    assert blind.outcome is GoalOutcome.REFUSED and math.isnan(blind.t_start_s)
    assert "inside the keep-out of star_tracker/object_3" in blind.reason
    assert goal.outcome is GoalOutcome.REACHED and goal.t_start_s == 0.0
    assert run.planner_status[0] == PlannerStatus.REFUSED.code
    assert dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)[0] > 0.0


@pytest.mark.parametrize(
    "extra, key, words",
    [
        ("    desired_mrp: [0.0, 0.1, 0.0]\n", "desired_mrp", "has no top-level desired_mrp"),
        ("", "plan.a.dwell_s", ">= 0"),
    ],
)
def test_plan_keys_are_checked(extra, key, words):
    targets = "    plan:\n      names: [a]\n      a:\n        desired_mrp: [0.0, 0.1, 0.0]\n"
    targets += "        dwell_s: -1.0\n" if key.endswith("dwell_s") else ""
    with pytest.raises(ScenarioError) as err:
        loads_scenario(_plan_text(targets, extra), str(PLAN))
    assert err.value.key == key and words in str(err.value)


def test_a_scenario_without_plan_or_goal_names_the_key():
    text = CASE1.read_text().replace("    desired_mrp: [0.0, -0.2, -0.7]", "")
    with pytest.raises(ScenarioError) as err:
        loads_scenario(text, str(CASE1))
    assert err.value.key == "desired_mrp" and "plan" in str(err.value)


class _Loop:
    """Guidance, PD (eq. 11) and the rigid body, a state at a time, with goals commanded
    between states."""

    def __init__(self, path: Path) -> None:
        self.sc = load_scenario(path)
        self.seq = GoalSequence(self.sc, prepare_guidance(self.sc))
        self.body = RigidBody(self.sc.inertia_kgm2, self.sc.initial_mrp, self.sc.initial_rate_rad_s)
        self.gains = PdGains(self.sc.kp, self.sc.kd)
        self.k = 0
        self.t: list[float] = []
        self.sigma: list[np.ndarray] = []
        self.omega: list[np.ndarray] = []
        self.status: list[PlannerStatus] = []

    def run_until(self, t_end: float) -> None:
        dt = self.sc.dt_s
        while self.k * dt <= t_end + 1e-9:
            t = round(self.k * dt, 9)
            s, w = self.body.sigma_bn.copy(), self.body.omega_b.copy()
            out = self.seq.update(t, s, w)
            self.t.append(t)
            self.sigma.append(s)
            self.omega.append(w)
            self.status.append(out.target.status)
            u = commanded_torque(self.gains, s, w, out.target.sigma_t, out.target.omega_t)
            self.body.step(u, dt)
            self.k += 1

    def margin(self) -> float:
        return dense_min_margin_deg(
            self.sc.sky, np.array(self.t), np.array(self.sigma), np.array(self.omega)
        )[0]


def test_a_goal_received_mid_slew_preempts_and_is_flown_from_the_moving_body():
    loop = _Loop(CASE1)
    loop.run_until(20.0)
    rate = np.linalg.norm(loop.body.omega_b)
    assert rate > 0.01  # mid-slew: the new plan starts from a moving body
    goal = np.array([0.3, 0.4, 0.1])
    loop.seq.command(20 * 10**9 + 5, goal_name(20 * 10**9 + 5), goal, 20.05)
    loop.run_until(200.0)
    (received,) = loop.seq.reported
    assert received.name == "goal@20.000000005" and received.goal_id == 20 * 10**9 + 5
    assert received.t_start_s == pytest.approx(20.1) and not math.isnan(received.t_reach_s)
    own = loop.seq.records[0]
    assert own.outcome is GoalOutcome.PREEMPTED and own.t_end_s == pytest.approx(20.1)
    assert math.degrees(angle_between_single(loop.body.sigma_bn, goal)) < 0.5
    assert loop.margin() > 0.0
    loop.seq.finish(200.0)
    assert loop.seq.reported[0].outcome is GoalOutcome.REACHED


def test_a_goal_into_a_keep_out_is_refused_and_the_body_keeps_its_slew():
    loop = _Loop(CASE1)
    loop.run_until(10.0)
    guidance = loop.seq.guidance
    loop.seq.command(7, "goal@blind", np.zeros(3), 10.0)
    loop.run_until(10.1)
    assert loop.status[-1] is PlannerStatus.REFUSED and loop.seq.guidance is guidance
    (refused,) = loop.seq.reports
    assert refused.outcome is GoalOutcome.REFUSED and "star_tracker/object_3" in refused.reason
    loop.run_until(150.0)
    assert loop.status[-1] is PlannerStatus.ARRIVED  # Case 1's own goal, as before
    assert math.degrees(angle_between_single(loop.body.sigma_bn, loop.sc.desired_mrp)) < 0.5
    assert loop.margin() > 0.0


def test_goal_clearance_names_the_constraint_and_passes_a_clear_goal():
    sc = load_scenario(CASE1)
    assert goal_clearance(sc, 0.0, sc.desired_mrp, 10.0) == ""
    why = goal_clearance(sc, 0.0, np.zeros(3), 10.0)
    assert why.startswith("the goal attitude is inside the keep-out of star_tracker/object_3")


def test_goal_report_round_trips_through_its_diagnostic_values():
    report = GoalReport(
        "topic",
        12,
        "goal@0.000000012",
        (0.1, -0.2, 0.3),
        math.inf,
        GoalOutcome.REFUSED,
        1.5,
        reason="the goal attitude is inside the keep-out of a/b (margin -1.00 deg)",
    )
    back = GoalReport.from_values(dict(report.diagnostic_values()))
    assert back.diagnostic_values() == report.diagnostic_values()
    assert back.goal_id == report.goal_id and back.sigma_goal == report.sigma_goal
    assert back.outcome is report.outcome and back.reason == report.reason
    assert math.isinf(back.dwell_s) and math.isnan(back.t_reach_s)
    with pytest.raises(ValueError, match="goal report without 'outcome'"):
        GoalReport.from_values({k: v for k, v in report.diagnostic_values() if k != "outcome"})
    entry = report.to_json(None)
    assert entry["outcome"] == "refused" and entry["t_reach_s"] is None and entry["dwell_s"] is None


def test_a_goal_the_moving_sky_leaves_no_clear_dwell_is_refused_when_judged():
    """On a moving sky a goal with a dwell is refused only when the sky leaves it no
    clear stretch of its dwell between its expected arrival and the run's end: an
    attitude that points the star tracker where the mover will be in 80 s (covered from
    28 s to 132 s of a 200 s run) is clear now, taken with a 50 s dwell (held after the
    mover has passed), refused with a 100 s one, and taken when held until the next goal
    (the guidance then watches the sky, as for a single slew)."""
    from scipy.spatial.transform import Rotation

    sc = load_scenario(ROOT / "scenarios" / "moving_object.yaml")
    mover = sc.bright_object_names.index("mover")
    ahead = sc.sky.object_directions(80.0)[0][mover]
    # The body attitude whose +x boresight points at the mover's direction at 80 s.
    rot, _ = Rotation.align_vectors([ahead], [[1.0, 0.0, 0.0]])  # C_NB: body -> inertial
    sigma = rot.as_mrp()
    assert goal_clearance(sc, 0.0, sigma, 0.0) == ""  # clear now (and no dwell)
    assert goal_clearance(sc, 0.0, sigma, math.inf) == ""  # judged now only
    assert goal_clearance(sc, 0.0, sigma, 50.0) == ""  # clear 133-200 s
    assert goal_clearance(sc, 0.0, sigma, 80.0, eta_s=100.0) != ""  # clear 67 s after 132 s
    why = goal_clearance(sc, 0.0, sigma, 100.0)
    assert "no clear 100.0 s" in why and "star_tracker/mover covers it" in why
    t_hit = float(why.split("at t = ")[1].split(" s")[0])
    assert 0.0 < t_hit <= 80.0
