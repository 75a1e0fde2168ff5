"""Guidance closed on the measured state: real-time stepping, time scaling to the
actuator limits, the tracking governor, and a status judged on the body."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from attitude_core.assembly.guidance import guidance_from_scenario, planner_from_scenario
from attitude_core.config.scenario import ActuatorLimits
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.fsw.guidance.profile_limits import (
    GYRO_SHARE,
    RATE_USE,
    GuidanceLimits,
    time_bound_s,
)
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import principal_angle, relative
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_core.world.actuator import clip_to_bound
from attitude_core.world.rigid_body import RigidBody

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"
WHEELS = sorted(p.name for p in SCENARIOS.glob("*_wheels.yaml"))


def fly(scenario, period_s, plant_bound_nm="declared", sim_time_s=None):
    """A test plant: the rigid body stepped every ``period_s`` with the PD torque held,
    the guidance and the controller answering each state. ``plant_bound_nm`` is the
    plant's own per-axis clip (default: the scenario's)."""
    sim_time_s = scenario.sim_time_s if sim_time_s is None else sim_time_s
    bound = scenario.actuators.max_torque_nm if plant_bound_nm == "declared" else plant_bound_nm
    guidance = guidance_from_scenario(scenario)
    gains = PdGains(scenario.kp, scenario.kd)
    body = RigidBody(scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s)
    rows = []
    for k in range(int(round(sim_time_s / period_s)) + 1):
        out = guidance.update(k * period_s, body.sigma_bn, body.omega_b)
        u = commanded_torque(
            gains,
            body.sigma_bn,
            body.omega_b,
            out.target.sigma_t,
            out.target.omega_t,
            scenario.actuators.max_torque_nm,
        )
        applied, _ = clip_to_bound(u, bound)
        rows.append((k * period_s, body.sigma_bn.copy(), body.omega_b.copy(), out, u, applied))
        body.step(applied, period_s)
    t = np.array([r[0] for r in rows])
    return {
        "t": t,
        "sigma": np.array([r[1] for r in rows]),
        "omega": np.array([r[2] for r in rows]),
        "out": [r[3] for r in rows],
        "status": [r[3].target.status for r in rows],
        "sigma_t": np.array([r[3].target.sigma_t for r in rows]),
        "torque": np.array([r[4] for r in rows]),
        "applied": np.array([r[5] for r in rows]),
    }


def first_arrival(run):
    for t, status in zip(run["t"], run["status"], strict=True):
        if status == PlannerStatus.ARRIVED:
            return float(t)
    return None


def goal_error_deg(scenario, sigma):
    return np.degrees(principal_angle(relative(sigma, scenario.desired_mrp)))


# --- the limits and the bound ----------------------------------------------------------


def test_time_bound_is_the_bang_coast_bang_time():
    """T* against a numerically integrated rest-to-rest profile at the bounds."""
    w, a = 0.035, 0.003
    for theta in (0.1, w * w / a, 1.0, 4.0):
        dt, t, angle, rate = 1e-4, 0.0, 0.0, 0.0
        while angle < theta - 1e-9:
            stop = rate * rate / (2 * a)
            rate = max(rate - a * dt, 0.0) if angle + stop >= theta else min(rate + a * dt, w)
            angle += rate * dt
            t += dt
            if rate == 0.0 and angle < theta - 1e-9 and t > 1.0:
                rate = a * dt  # restart a stall caused by the discrete stop test
        assert time_bound_s(theta, w, a) == pytest.approx(t, rel=2e-3)
    assert time_bound_s(4.0, w, a) == pytest.approx(4.0 / w + w / a)
    assert time_bound_s(1.0, None, a) == pytest.approx(2.0 * math.sqrt(1.0 / a))
    assert time_bound_s(1.0, w, None) == pytest.approx(1.0 / w)
    assert time_bound_s(1.0, None, None) is None


def test_profile_acceleration_leaves_room_for_gyroscopic_torque():
    inertia = np.diag([8.0, 10.0, 12.0])
    lim = GuidanceLimits.from_actuators(inertia, (0.03, 0.02, 0.05), 0.035)
    assert lim.alpha_max_rad_s2 == pytest.approx(0.02 / 12.0)
    # Inertia torque plus the worst gyroscopic torque at the rate cap fit the bound.
    gyro = 0.5 * (12.0 - 8.0) * lim.max_rate_rad_s**2
    assert 12.0 * lim.accel_rad_s2 + gyro < 0.02
    # ... with the worst case found by sampling: |w x J w| <= (J_max - J_min) |w|^2 / 2.
    rng = np.random.default_rng(5)
    w = rng.normal(size=(20000, 3))
    w /= np.linalg.norm(w, axis=1, keepdims=True)
    worst = np.linalg.norm(np.cross(w, w @ inertia), axis=1).max()
    assert 0.99 * 0.5 * (12.0 - 8.0) < worst <= 0.5 * (12.0 - 8.0) + 1e-12
    # A rate bound whose gyroscopic torque would eat the torque is lowered.
    fast = GuidanceLimits.from_actuators(inertia, (0.03, 0.02, 0.05), 1.0)
    assert fast.max_rate_rad_s < 1.0
    assert 0.5 * (12.0 - 8.0) * fast.max_rate_rad_s**2 == pytest.approx(GYRO_SHARE * 0.02)
    spherical = GuidanceLimits.from_actuators(10.0 * np.eye(3), (0.03,) * 3, None)
    assert spherical.max_rate_rad_s is None and spherical.accel_rad_s2 < 0.003
    unlimited = GuidanceLimits.from_actuators(inertia, None, None)
    assert unlimited == GuidanceLimits()


# --- unlimited: the paper's planner ----------------------------------------------------


@pytest.mark.parametrize("name", ["case1.yaml", "case2_paper.yaml"])
def test_unlimited_lockstep_target_is_the_fepf_target(name):
    """No limits, no route to follow and a body on the target: the guidance gives the
    FEPF's own targets."""
    sc = load_scenario(SCENARIOS / name)
    sc = dataclasses.replace(sc, planner=dataclasses.replace(sc.planner, global_route=False))
    plain = planner_from_scenario(sc)
    guidance = guidance_from_scenario(sc)
    for k in range(600):
        expected = plain.step()
        got = guidance.update(k * sc.dt_s, expected.sigma_t, expected.omega_t).target
        np.testing.assert_allclose(got.sigma_t, expected.sigma_t, rtol=0, atol=1e-9)
        np.testing.assert_allclose(got.omega_t, expected.omega_t, rtol=0, atol=1e-9)


def test_paper_cases_unlimited_keep_their_times():
    for name, bound in (("case1.yaml", 71.5), ("case2.yaml", 52.2)):
        summary = summarize(run_closed_loop(load_scenario(SCENARIOS / name))).to_json()
        assert summary["reached"] and summary["t_reach_s"] <= bound + 1e-9
        assert summary["min_margin_deg"] > 0.0
        # 0.41 N m before the FEPF was formed in the target frame, which flies the same
        # MRP rate scale faster where |sigma_BN| is large (sigma_dot = B(sigma) rho_dot).
        assert summary["peak_torque_nm"] <= 0.45


# --- limited: the wheels scenarios -----------------------------------------------------


def test_there_are_wheel_scenarios():
    assert {"case1_wheels.yaml", "case2_wheels.yaml", "case1_small_wheels.yaml"} <= set(WHEELS)


@pytest.mark.parametrize("name", WHEELS)
def test_wheels_scenario_is_flown_within_the_limits(name):
    sc = load_scenario(SCENARIOS / name)
    act = sc.actuators
    assert act.max_torque_nm is not None and act.max_rate_rad_s is not None
    run = run_closed_loop(sc)
    summary = summarize(run).to_json()
    assert summary["reached"] and not summary["planner_stuck"]
    # Body-based arrival: the planner says arrived only with the body on the goal.
    arrived = run.planner_status == PlannerStatus.ARRIVED.code
    assert arrived.any()
    err = goal_error_deg(sc, run.sigma_bn[arrived])
    assert err.max() <= 2.0 * sc.arrival.attitude_tol_deg
    assert summary["t_plan_arrival_s"] >= summary["t_reach_s"] - 1e-9
    # The body, densely, outside every cone; torque within the bound; rate within 5 %.
    margin, _ = dense_min_margin_deg(sc.cone_geometry(), run.t, run.sigma_bn, run.omega_b)
    assert margin > 0.0
    assert np.all(np.abs(run.torque_b) <= np.asarray(act.max_torque_nm) * (1 + 1e-12))
    assert np.linalg.norm(run.omega_b, axis=1).max() <= 1.05 * act.max_rate_rad_s
    assert np.linalg.norm(run.omega_t, axis=1).max() <= RATE_USE * act.max_rate_rad_s + 1e-12
    # Zero terminal rate, and a slew near the rest-to-rest bound.
    assert summary["final_rate_rad_s"] <= sc.arrival.rate_tol_rad_s
    assert 1.0 <= summary["time_ratio_to_bound"] <= 1.3


# --- real time between states ------------------------------------------------------------


@pytest.mark.parametrize("name", ["case1_wheels.yaml", "case2.yaml"])
def test_state_rate_does_not_change_the_slew(name):
    """States at 5, 10 and 20 Hz: the same target in time, the same safety and arrival."""
    sc = load_scenario(SCENARIOS / name)
    runs = {p: fly(sc, p) for p in (0.05, 0.1, 0.2)}
    arrivals = {p: first_arrival(r) for p, r in runs.items()}
    assert all(a is not None for a in arrivals.values()), arrivals
    for p, run in runs.items():
        margin, _ = dense_min_margin_deg(sc.cone_geometry(), run["t"], run["sigma"], run["omega"])
        assert margin > 0.0, p
        assert all(o.derating == 1.0 for o in run["out"])  # a plant as declared
        assert arrivals[p] == pytest.approx(arrivals[0.1], rel=0.03), arrivals
    # The target at common instants (every 2 s) agrees across the rates.
    ref = runs[0.1]
    for p in (0.05, 0.2):
        run = runs[p]
        stride, ref_stride = round(2.0 / p), 20
        a = run["sigma_t"][::stride]
        b = ref["sigma_t"][::ref_stride]
        n = min(len(a), len(b))
        apart = np.degrees(principal_angle(relative(a[:n], b[:n])))
        assert apart.max() < 2.0, (p, apart.max())


# --- a plant weaker than declared ------------------------------------------------------------


@pytest.mark.parametrize("plant_nm", [(0.004, 0.004, 0.004), (0.0, 0.0, 0.0)])
def test_weaker_plant_never_gets_arrived_off_the_goal(plant_nm):
    """Declared 0.03 N m, the plant gives far less (or nothing): the target does not run
    away, ``arrived`` never comes with the body off the goal, and a dead plant is
    reported ``stuck``."""
    sc = load_scenario(SCENARIOS / "case1_wheels.yaml")
    run = fly(sc, sc.dt_s, plant_bound_nm=plant_nm, sim_time_s=400.0)
    err = goal_error_deg(sc, run["sigma"])
    for status, e, w in zip(run["status"], err, run["omega"], strict=True):
        if status == PlannerStatus.ARRIVED:
            assert e <= 2 * sc.arrival.attitude_tol_deg
            assert np.linalg.norm(w) <= 2 * sc.arrival.rate_tol_rad_s
    # The target never runs away from the body: each step moves it by at most the
    # governor's factor times the rate bound, and the factor falls to zero at twice the
    # governor's bound (a body that overshoots its target is its own doing).
    hold = guidance_from_scenario(sc).hold_deg
    factors = np.array([o.speed_factor for o in run["out"]])
    errors = np.array([o.tracking_error_deg for o in run["out"]])
    assert errors.max() > hold and factors.min() < 1.0  # the plant did fall behind
    np.testing.assert_array_less(factors[errors >= 2 * hold], 1e-12)
    moved = np.degrees(principal_angle(relative(run["sigma_t"][1:], run["sigma_t"][:-1])))
    per_step = np.degrees(sc.actuators.max_rate_rad_s * sc.dt_s)
    np.testing.assert_array_less(moved, factors[:-1] * per_step + 1e-9)
    if plant_nm == (0.0, 0.0, 0.0):
        assert errors.max() <= 2 * hold + 1e-9
    final = run["status"][-1]
    if plant_nm == (0.0, 0.0, 0.0):
        assert final == PlannerStatus.STUCK
        assert err[-1] == pytest.approx(err[0])
    else:
        assert final in (PlannerStatus.STUCK, PlannerStatus.TRACKING, PlannerStatus.ARRIVED)
        if final == PlannerStatus.ARRIVED:
            assert err[-1] <= 2 * sc.arrival.attitude_tol_deg


def test_arrival_waits_for_the_body():
    """The target reaches the goal long before a slow body: status stays tracking until
    the body is within both tolerances."""
    sc = load_scenario(SCENARIOS / "case2.yaml")
    guidance = guidance_from_scenario(sc)
    goal = sc.desired_mrp
    t = 0.0
    # Drive the target to the goal with a body that follows it exactly.
    for _ in range(2000):
        out = guidance.update(t, guidance.planner.sigma_t, np.zeros(3))
        t += sc.dt_s
        if guidance.planner.status == PlannerStatus.ARRIVED:
            break
    assert guidance.planner.status == PlannerStatus.ARRIVED  # the target is on the goal
    off = dataclasses.replace(sc).initial_mrp  # the body far from the goal
    out = guidance.update(t, off, np.zeros(3))
    assert out.target.status == PlannerStatus.TRACKING and out.goal_error_deg > 10.0
    t += sc.dt_s
    out = guidance.update(t, goal, np.array([0.0, 0.0, 10 * sc.arrival.rate_tol_rad_s]))
    assert out.target.status == PlannerStatus.TRACKING  # on the goal, still turning
    t += sc.dt_s
    out = guidance.update(t, goal, np.zeros(3))
    assert out.target.status == PlannerStatus.ARRIVED


def test_a_repeated_or_older_state_time_is_refused():
    guidance = guidance_from_scenario(load_scenario(SCENARIOS / "case1.yaml"))
    sigma = guidance.planner.sigma_t
    guidance.update(0.0, sigma, np.zeros(3))
    guidance.update(0.1, sigma, np.zeros(3))
    with pytest.raises(ValueError, match="repeats"):
        guidance.update(0.1, sigma, np.zeros(3))
    with pytest.raises(ValueError, match="before"):
        guidance.update(0.05, sigma, np.zeros(3))


def test_limits_only_on_rate_keep_the_body_within_five_percent():
    sc = load_scenario(SCENARIOS / "case1.yaml")
    sc = dataclasses.replace(sc, actuators=ActuatorLimits(None, 0.035), sim_time_s=250.0)
    run = run_closed_loop(sc)
    summary = summarize(run).to_json()
    assert summary["reached"] and summary["min_margin_deg"] > 0.0
    assert summary["peak_rate_to_bound"] <= 1.05


def test_a_plant_at_a_tenth_of_its_declared_torque_is_derated_and_stays_safe():
    """Once the body falls behind, the profile's acceleration is derated: the tracking
    error then stays within the governor's hold point and the body out of every cone."""
    sc = load_scenario(SCENARIOS / "case1_wheels.yaml")
    run = fly(sc, sc.dt_s, plant_bound_nm=(0.003, 0.003, 0.003), sim_time_s=300.0)
    derating = np.array([o.derating for o in run["out"]])
    assert derating[0] == 1.0 and derating[-1] < 0.2
    assert np.all(np.diff(derating) <= 0.0)  # only ever lowered
    errors = np.array([o.tracking_error_deg for o in run["out"]])
    assert errors.max() <= 2.0 * guidance_from_scenario(sc).hold_deg
    margin, _ = dense_min_margin_deg(sc.cone_geometry(), run["t"], run["sigma"], run["omega"])
    assert margin > 0.0
    err = goal_error_deg(sc, run["sigma"])
    assert err[-1] < err[0] - 90.0  # still flying the slew, not stuck
    assert run["status"][-1] in (PlannerStatus.TRACKING, PlannerStatus.ARRIVED)
