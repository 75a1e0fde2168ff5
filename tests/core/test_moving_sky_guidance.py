"""Guidance on a moving sky, judged on the body against the sky of each instant
(attitude_core.fsw.guidance.moving_sky, goal_watch): a fast object across the path, a goal the
Earth covers, a goal covered for a while (before arrival, and while the body holds it)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude_core.config.scenario_loader import load_scenario, parse_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import dcm_from_mrp, principal_angle, relative
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_core.yamlio import load_strict

ROOT = Path(__file__).resolve().parents[2]


def _doc(name: str) -> dict:
    return load_strict((ROOT / "scenarios" / name).read_text())["/**"]["ros__parameters"]


def _statuses(run) -> list[tuple[str, float]]:
    """The status changes of a run: (status, time)."""
    st = run.planner_status.astype(int)
    at = [0, *(np.flatnonzero(np.diff(st)) + 1).tolist()]
    return [(PlannerStatus.from_code(int(st[k])).value, float(run.t[k])) for k in at]


def _crossing_goal(t_cross_s: float, sim_time_s: float) -> dict:
    """Case 1 plus an object turning at 0.4 deg/s whose centre crosses the goal's
    boresight at ``t_cross_s``."""
    doc = _doc("case1.yaml")
    doc["sim_time_s"] = sim_time_s
    b = dcm_from_mrp(np.array(doc["desired_mrp"])).T @ np.array([1.0, 0.0, 0.0])
    p = np.cross(b, [0.0, 0.0, 1.0])
    p /= np.linalg.norm(p)
    axis = np.cross(b, p)
    rate = np.radians(0.4)
    c0 = Rotation.from_rotvec(-axis * rate * t_cross_s).apply(b)
    doc["bright_objects"]["names"].append("mover")
    doc["bright_objects"]["mover"] = {
        "direction_inertial": [float(x) for x in c0],
        "rate_inertial_rad_s": [float(x) for x in axis * rate],
    }
    return doc


def test_fast_object_across_the_path_is_avoided_where_a_frozen_sky_fails():
    moving = load_scenario(ROOT / "scenarios" / "moving_object.yaml")
    run = run_closed_loop(moving)
    summary = summarize(run)
    margin, _ = dense_min_margin_deg(moving.sky, run.t, run.sigma_bn, run.omega_b)
    assert summary.reached and margin > 0.0
    assert summary.min_margin_deg == margin
    # The same slew planned on the sky frozen at t = 0 flies into the mover's cone.
    doc = _doc("moving_object.yaml")
    del doc["bright_objects"]["mover"]["rate_inertial_rad_s"]
    frozen = run_closed_loop(parse_scenario(doc, str(ROOT / "scenarios" / "frozen.yaml")))
    frozen_margin, _ = dense_min_margin_deg(moving.sky, frozen.t, frozen.sigma_bn, frozen.omega_b)
    assert frozen_margin < 0.0


def test_a_goal_the_earth_covers_is_reported_blocked_and_never_entered():
    sc = load_scenario(ROOT / "scenarios" / "leo_goal_blocked.yaml")
    run = run_closed_loop(sc)
    summary = summarize(run)
    # Reported from the first step, before the Earth gets there (about 62 s).
    assert _statuses(run) == [("blocked", 0.0)]
    assert summary.planner_blocked and summary.blocked_by == "star_tracker/earth"
    start, end = summary.blocked_window_s
    assert 55.0 <= start <= 70.0 and end is None
    assert "star_tracker/earth" in summary.blocked_reason
    assert not summary.reached
    margin, _ = dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)
    assert margin > 0.0
    # The goal's own margin over the run: below zero by the end, so entering it would fail.
    goal = np.broadcast_to(sc.desired_mrp, run.sigma_bn.shape)
    assert sc.sky.constraint_margins_deg(run.t, goal).min() < 0.0


@pytest.mark.parametrize(
    ("t_cross", "sim_time", "expected"),
    [
        (30.0, 250.0, ["blocked", "tracking", "arrived"]),  # covered at the start
        (250.0, 400.0, ["tracking", "arrived", "blocked", "tracking", "arrived"]),  # held
    ],
)
def test_a_goal_covered_for_a_while_is_waited_for_then_reached(t_cross, sim_time, expected):
    sc = parse_scenario(_crossing_goal(t_cross, sim_time), str(ROOT / "scenarios" / "x.yaml"))
    run = run_closed_loop(sc)
    summary = summarize(run)
    changes = _statuses(run)
    assert [s for s, _ in changes] == expected
    start, end = summary.blocked_window_s
    assert summary.blocked_by == "star_tracker/mover"
    blocked_at = [t for s, t in changes if s == "blocked"][0]
    assert blocked_at < start or blocked_at == 0.0  # reported before it happens
    cleared_at = [t for s, t in changes if s == "tracking"][-1]
    assert cleared_at >= end  # the goal taken again once clear
    assert summary.reached and summary.t_reach_s > end
    margin, _ = dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)
    assert margin > 0.0
    # While blocked the body stays out of the goal's arrival tolerance.
    blocked = run.planner_status == PlannerStatus.BLOCKED.code
    err = np.degrees(principal_angle(relative(run.sigma_bn[blocked], sc.desired_mrp)))
    in_window = (run.t[blocked] >= start) & (run.t[blocked] < end)
    assert np.all(err[in_window] > sc.arrival.attitude_tol_deg)
