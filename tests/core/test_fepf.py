"""FEPF planner (eqs. 6-10): rotation, safety, convergence and stuck reporting."""

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude_core.assembly.guidance import planner_from_scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.fsw.guidance.fepf import FepfPlanner, PlannerStatus, rotation_matrix
from attitude_core.models.constraints import ConeGeometry


def test_rotation_matrix_is_eq9_rodrigues():
    rng = np.random.default_rng(0)
    for _ in range(20):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        gamma = rng.uniform(-np.pi, np.pi)
        np.testing.assert_allclose(
            rotation_matrix(gamma, axis), Rotation.from_rotvec(gamma * axis).as_matrix(), atol=1e-12
        )


def _run(planner, steps):
    path, statuses = [planner.sigma_t], []
    for _ in range(steps):
        out = planner.step()
        statuses.append(out.status)
        path.append(planner.sigma_t)
    return np.array(path), statuses


def _segment_min_margin(geometry, path, sub=10):
    """Smallest margin along the planner's straight MRP steps, between samples too. A
    step that crossed |sigma| = 1 was taken to the point beyond, then switched to its
    shadow set (the same attitude): interpolate to that point."""
    ends = path[1:].copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        shadows = -ends / np.sum(ends * ends, axis=1, keepdims=True)
    switched = np.linalg.norm(ends - path[:-1], axis=1) > np.linalg.norm(
        shadows - path[:-1], axis=1
    )
    ends[switched] = shadows[switched]
    s = np.linspace(0, 1, sub + 1)[None, :, None]
    pts = path[:-1, None] + s * (ends[:, None] - path[:-1, None])
    return geometry.min_margin_deg(pts.reshape(-1, 3)).min()


def _frame_rates(sc, outputs):
    """The rates the law bounds, in its planning frame: ``omega_t / 4`` in the target
    frame (eq. 12 at rho = 0), ``sigma_t_dot`` in the inertial one."""
    if sc.planner.planning_frame == "target":
        return np.array([0.25 * o.omega_t for o in outputs])
    return np.array([o.sigma_t_dot for o in outputs])


@pytest.mark.parametrize("name", ["case1", "case2", "case1_paper", "case2_paper"])
def test_paper_cases_plan_to_goal_outside_inflated_cones(name):
    sc = load_scenario(f"scenarios/{name}.yaml")
    planner = planner_from_scenario(sc)
    path, outputs = [planner.sigma_t], []
    for _ in range(sc.n_steps):
        outputs.append(planner.step())
        path.append(planner.sigma_t)
    path = np.array(path)
    assert PlannerStatus.ARRIVED in [o.status for o in outputs]
    np.testing.assert_allclose(path[-1], sc.desired_mrp, atol=1e-12)
    # Target path, including between steps, keeps at least half the safety buffer.
    assert _segment_min_margin(sc.cone_geometry(), path) >= 0.5 * planner.geometry.inflation_deg
    # Target rate is bounded by the configured magnitudes (in the planning frame).
    speeds = np.linalg.norm(_frame_rates(sc, outputs), axis=1)
    cfg = sc.planner
    assert speeds.max() <= cfg.max_attractive_rate_mrp_s + cfg.max_repulsive_rate_mrp_s + 1e-9


def test_improved_variant_ends_with_zero_target_rate_and_bounded_acceleration():
    sc = load_scenario("scenarios/case1.yaml")
    planner = planner_from_scenario(sc)
    outputs = [planner.step() for _ in range(sc.n_steps)]
    rates = _frame_rates(sc, outputs)
    accel = np.linalg.norm(np.diff(rates, axis=0), axis=1) / sc.dt_s
    assert accel.max() <= sc.planner.max_accel_mrp_s2 * (1 + 1e-9)
    # Terminal slow-down: the last moving steps are tiny, then exactly zero.
    moving = np.flatnonzero(np.linalg.norm(rates, axis=1) > 0)
    assert np.linalg.norm(rates[moving[-1]]) < 1e-3
    np.testing.assert_array_equal(rates[-1], 0.0)


def _head_on_setup(gamma_deg, axis):
    # Boresight +x, object at +x: the region is a tube around the b1 rotation axis through
    # sigma = 0; start and goal are +-60 deg about b3, so the straight line is blocked head-on.
    geometry = ConeGeometry([[1.0, 0.0, 0.0]], [20.0], [[1.0, 0.0, 0.0]], inflation_deg=2.0)
    sc = load_scenario("scenarios/case1.yaml")
    cfg = dataclasses.replace(
        sc.planner, gamma_deg=gamma_deg, direction_axis=axis, stuck_timeout_s=5.0
    )
    t = np.tan(np.radians(60.0) / 4)
    return geometry, FepfPlanner(geometry, [0.0, 0.0, -t], [0.0, 0.0, t], 0.1, cfg)


def test_head_on_local_minimum_reports_stuck_instead_of_wandering():
    geometry, planner = _head_on_setup(0.0, "goal_plane")  # plain potential field
    path, statuses = _run(planner, 1500)
    assert statuses[-1] == PlannerStatus.STUCK
    assert PlannerStatus.ARRIVED not in statuses
    first_stuck = statuses.index(PlannerStatus.STUCK)
    # Once stuck, the target holds still.
    assert np.ptp(path[first_stuck + 1 :], axis=0).max() == 0.0
    assert _segment_min_margin(geometry, path) >= 1.0


def test_goal_plane_rotation_escapes_head_on_minimum():
    geometry, planner = _head_on_setup(60.0, "goal_plane")
    path, statuses = _run(planner, 1500)
    assert statuses[-1] == PlannerStatus.ARRIVED
    assert _segment_min_margin(geometry, path) >= 1.0


def test_reset_resumes_from_given_attitude():
    sc = load_scenario("scenarios/case2.yaml")
    planner = planner_from_scenario(sc)
    for _ in range(50):
        planner.step()
    here = np.array([0.25, 0.1, 0.0])
    planner.reset(here)
    out = planner.step()
    np.testing.assert_allclose(out.sigma_t, here)
    assert out.status == PlannerStatus.TRACKING


def test_restart_inside_safety_buffer_backs_out_and_arrives():
    sc = load_scenario("scenarios/case1.yaml")
    planner = planner_from_scenario(sc)
    exact = sc.cone_geometry()
    # A measured attitude 1 deg outside a cone: inside the planner's 2 deg buffer.
    rng = np.random.default_rng(7)
    while True:
        s = rng.uniform(-0.6, 0.6, 3)
        if 0.8 < exact.min_margin_deg(s) < 1.2:
            break
    planner.reset(s)
    assert planner.geometry.closest_obstacle(s).distance < 0.0
    path, statuses = _run(planner, 3000)
    assert statuses[-1] == PlannerStatus.ARRIVED
    # The margin never drops below where it started, and the buffer is regained.
    assert _segment_min_margin(exact, path) >= exact.min_margin_deg(s) - 1e-9
    assert exact.min_margin_deg(path[len(path) // 2 :]).min() >= 1.0
