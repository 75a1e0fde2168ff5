"""One clearance rule for a static and a moving sky (attitude_core.assembly.guidance.buffer_deg,
attitude_core.fsw.guidance.goal_watch): a goal just outside a keep-out that the sky never
covers is flown, on the moving sky as on the sky frozen at t = 0; a goal the sky covers is
blocked, and the reason names the body and when it reaches the goal; a commanded goal
near a keep-out is accepted. Judged on the simulated body against the sky of each
instant."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, Slerp
from sky_oracle import independent_margins_deg
from test_goal_sequence import _Loop

from attitude_core.assembly.guidance import buffer_deg, guidance_from_scenario
from attitude_core.config.scenario_flatten import flatten_parameters
from attitude_core.config.scenario_loader import load_scenario, loads_scenario, parse_scenario
from attitude_core.contract.status import GoalOutcome, PlannerStatus
from attitude_core.fsw.guidance.goal_watch import goal_blockages, goal_margin_bounds_deg
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import angle_between_single
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_core.yamlio import load_strict
from attitude_tools.campaign.near_keep_out import goal_at_margin

ROOT = Path(__file__).resolve().parents[2]
NEAR_SUN = ROOT / "scenarios" / "leo_goal_near_sun.yaml"
BLOCKED = ROOT / "scenarios" / "leo_goal_blocked.yaml"


def _flat(path: Path) -> dict:
    doc = load_strict(path.read_text())["/**"]["ros__parameters"]
    return flatten_parameters(doc, str(path))


def _near_sun(margin_deg: float | None, frozen: bool = False):
    """leo_goal_near_sun with its goal turned to ``margin_deg`` outside the Sun's
    keep-out at t = 0 (None: as shipped); ``frozen``: the Sun a fixed direction, its
    t = 0 one, the exclusion counted from its limb as the ephemeris Sun's."""
    flat = _flat(NEAR_SUN)
    sc = parse_scenario(flat, str(NEAR_SUN))
    if margin_deg is not None:
        flat["desired_mrp"] = [
            float(x) for x in goal_at_margin(sc.sky, sc.desired_mrp, 0, margin_deg)
        ]
    if frozen:
        dirs, radii = sc.sky.object_directions(0.0)
        del flat["bright_objects.sun.ephemeris"]
        flat["bright_objects.sun.direction_inertial"] = [float(x) for x in dirs[0]]
        flat["instruments.star_tracker.exclusion_deg.sun"] += float(radii[0])
    return parse_scenario(flat, str(NEAR_SUN))


def _goal_history_deg(sc, t: np.ndarray) -> np.ndarray:
    """The goal attitude's least margin at ``t``, from the boresight and the Sun's
    direction and radius (not through the guidance's code)."""
    boresight = Rotation.from_mrp(np.array(sc.desired_mrp)).apply([1.0, 0.0, 0.0])  # C_NB s
    dirs, radii = sc.sky.object_directions(t)
    angle = np.degrees(np.arccos(np.clip(dirs[:, 0] @ boresight, -1.0, 1.0)))
    exclusion = sc.sky.pair_exclusion_deg[0]
    return angle - exclusion - radii[:, 0]


@pytest.mark.parametrize("margin_deg", [None, 0.9, 1.6, 0.3])
def test_a_goal_just_outside_a_keep_out_the_sky_never_covers_is_flown(margin_deg):
    sc = _near_sun(margin_deg)
    history = _goal_history_deg(sc, np.arange(0.0, sc.sim_time_s + 0.05, 0.1))
    assert history.min() > 0.0 and np.ptp(history) < 0.02  # the Sun barely moves
    run = run_closed_loop(sc)
    s = summarize(run)
    assert s.reached and not s.planner_blocked and s.blocked_reason is None
    assert s.final_attitude_error_deg < 0.5
    dense, _ = dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)
    assert dense > 0.0 and dense == s.min_margin_deg
    assert s.goal_min_margin_deg == pytest.approx(history.min(), abs=1e-6)
    assert s.t_goal_covered_s is None
    # On an independent sky (astropy's Sun, a two-body orbit): the slew and its settling
    # between the samples too (Slerp midpoints), then every second while held.
    k = int(np.searchsorted(run.t, s.t_reach_s + 30.0))
    fine = np.concatenate([np.linspace(run.t[0], run.t[k], 2 * k + 1), run.t[k + 10 :: 10]])
    body = Slerp(run.t, Rotation.from_mrp(run.sigma_bn))(fine).as_mrp()
    oracle = independent_margins_deg(sc, fine, body)
    assert oracle.min() > 0.0 and oracle.min() == pytest.approx(dense, abs=0.02)
    goal = independent_margins_deg(sc, fine, np.tile(sc.desired_mrp, (len(fine), 1)))
    assert goal.min() > 0.0
    # The same slew on the sky frozen at t = 0: the same buffer and the same flight.
    frozen = _near_sun(margin_deg, frozen=True)
    fs = summarize(run_closed_loop(frozen))
    assert fs.reached and fs.t_reach_s == pytest.approx(s.t_reach_s, abs=1.0)
    assert buffer_deg(sc, sc.initial_mrp) == pytest.approx(
        buffer_deg(frozen, frozen.initial_mrp), abs=0.01
    )


def test_the_buffer_is_capped_by_the_goals_least_margin_over_the_time_it_is_held():
    sc = _near_sun(1.0)
    least, greatest = goal_margin_bounds_deg(sc.sky, sc.desired_mrp, 0.0, sc.sim_time_s)
    history = _goal_history_deg(sc, np.arange(0.0, sc.sim_time_s + 0.005, 0.01))
    assert least <= history.min() <= least + 0.01  # a lower bound, and a tight one
    assert greatest >= least and greatest <= history.max()
    start = float(np.min(sc.sky.constraint_margins_deg(0.0, sc.initial_mrp)))
    assert start > 2.0 * sc.planner.safety_margin_deg  # the goal's margin is what caps
    assert buffer_deg(sc, sc.initial_mrp) == pytest.approx(0.5 * least, abs=1e-12)
    assert goal_blockages(sc.sky, sc.desired_mrp, 0.0, sc.sim_time_s, 0.5 * least, ["s"]) == []
    # Held for a shorter span (a plan's dwell), the cap uses that span only.
    short = buffer_deg(sc, sc.initial_mrp, 0.0, 60.0)
    assert short == pytest.approx(
        0.5 * goal_margin_bounds_deg(sc.sky, sc.desired_mrp, 0.0, 60.0)[0]
    )


def test_a_goal_the_sky_covers_keeps_the_full_buffer_and_is_blocked_naming_the_body_and_time():
    sc = load_scenario(BLOCKED)
    least, greatest = goal_margin_bounds_deg(sc.sky, sc.desired_mrp, 0.0, sc.sim_time_s)
    assert least < 0.0 < greatest  # covered during the run
    assert buffer_deg(sc, sc.initial_mrp) == pytest.approx(sc.planner.safety_margin_deg)
    run = run_closed_loop(sc)
    s = summarize(run)
    assert s.planner_blocked and not s.reached and s.min_margin_deg > 0.0
    assert s.t_goal_covered_s is not None and s.goal_min_margin_deg < 0.0
    assert s.blocked_by == "star_tracker/earth"
    assert s.blocked_reason.startswith("goal blocked by star_tracker/earth: the keep-out reaches")
    (block,) = goal_blockages(
        sc.sky, sc.desired_mrp, 0.0, sc.sim_time_s, buffer_deg(sc, sc.initial_mrp),
        sc.constraint_names,
    )  # fmt: skip
    assert block.t_covered_s is not None and abs(block.t_covered_s - s.t_goal_covered_s) <= 1.0
    assert f"reaches the goal at {block.t_covered_s:.1f} s" in s.blocked_reason
    assert block.start_s < block.t_covered_s and block.least_margin_deg < 0.0


def test_a_commanded_goal_near_a_keep_out_is_accepted_and_reached():
    loop = _Loop(NEAR_SUN)
    loop.run_until(5.0)
    goal = goal_at_margin(loop.sc.sky, loop.sc.desired_mrp, 0, 0.6)
    loop.seq.command(5 * 10**9, "goal@5", goal, 5.0)
    loop.run_until(200.0)
    received = loop.seq.records[-1]
    assert received.outcome is GoalOutcome.ACCEPTED and not math.isnan(received.t_reach_s)
    assert loop.status[-1] is PlannerStatus.ARRIVED
    assert math.degrees(angle_between_single(loop.body.sigma_bn, goal)) < 0.5
    assert loop.margin() > 0.0
    # One just inside the keep-out is refused, naming the constraint.
    inside = goal_at_margin(loop.sc.sky, loop.sc.desired_mrp, 0, -0.2)
    loop.seq.command(201 * 10**9, "goal@201", inside, 200.0)
    loop.run_until(200.2)
    assert loop.seq.records[-1].outcome is GoalOutcome.REFUSED
    assert "inside the keep-out of star_tracker/sun" in loop.seq.records[-1].reason


def test_a_static_sky_keeps_its_buffer_rule():
    sc = load_scenario(ROOT / "scenarios" / "case1.yaml")
    exact = sc.exact_geometry()
    ends = min(
        float(exact.min_margin_deg(sc.initial_mrp)), float(exact.min_margin_deg(sc.desired_mrp))
    )
    assert buffer_deg(sc, sc.initial_mrp) == min(sc.planner.safety_margin_deg, 0.5 * ends)
    assert guidance_from_scenario(sc).planner.geometry.inflation_deg == buffer_deg(
        sc, sc.initial_mrp
    )


def test_a_plan_target_the_sky_covers_for_a_while_is_waited_for_not_refused():
    """A plan target the mover covers from 28 s to 132 s, with a 50 s dwell in a 400 s
    run: flyable (held after the mover has passed), so flown, not refused; the next
    target follows. The body never enters a cone."""
    sc = load_scenario(ROOT / "scenarios" / "moving_object.yaml")
    mover = sc.bright_object_names.index("mover")
    ahead = sc.sky.object_directions(80.0)[0][mover]
    rot, _ = Rotation.align_vectors([ahead], [[1.0, 0.0, 0.0]])  # C_NB: +x at the mover
    sigma = [float(x) for x in rot.as_mrp()]
    text = (ROOT / "scenarios" / "moving_object.yaml").read_text()
    text = text.replace("    sim_time_s: 200.0", "    sim_time_s: 400.0")
    plan = (
        f"    plan:\n      names: [covered, after]\n      covered:\n"
        f"        desired_mrp: {sigma}\n        dwell_s: 50.0\n      after:\n"
        "        desired_mrp: [0.0, -0.2, -0.7]\n        dwell_s: 10.0\n"
    )
    text = text.replace("    desired_mrp: [0.0, -0.2, -0.7]\n", plan)
    planned = loads_scenario(text, str(ROOT / "scenarios" / "moving_object.yaml"))
    run = run_closed_loop(planned)
    covered, after = run.goals
    assert covered.outcome is GoalOutcome.REACHED and covered.t_reach_s > 132.0
    assert after.outcome is GoalOutcome.REACHED
    assert PlannerStatus.BLOCKED.code in set(run.planner_status.tolist())  # waited it out
    assert dense_min_margin_deg(planned.sky, run.t, run.sigma_bn, run.omega_b)[0] > 0.0
