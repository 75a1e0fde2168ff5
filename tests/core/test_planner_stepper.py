"""The planner node's logic without ROS (:mod:`attitude_core.runtime.planner_stepper`).

Tested: the first stamp starts the guidance's clock (on a moving sky, whose margin
depends on it); the guidance is built from the first measured attitude, not the
scenario's start; an infeasible slew is logged as an error at the first state; an
inactive stepper holds the last target at rest without stepping; a status change is
reported once; derating changes are reported; the report's margin and counts; the
route thread is its own only when none is given. Each target is compared with an
independent guidance (:func:`guidance_from_scenario`) fed the same states.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from attitude_core.assembly.guidance import guidance_from_scenario, prepare_guidance
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.guidance_base import ImmediateExecutor
from attitude_core.runtime.planner_stepper import PlannerStepper

ROOT = Path(__file__).resolve().parents[2]
DT_NS = 100_000_000
ZERO = np.zeros(3)


@pytest.fixture(scope="module")
def case1():
    return load_scenario(ROOT / "scenarios" / "case1.yaml")


@pytest.fixture(scope="module")
def prepared(case1):
    return prepare_guidance(case1)


def make(scenario, prepared=None) -> PlannerStepper:
    return PlannerStepper(scenario, prepared, ImmediateExecutor())


def reference_targets(scenario, sigma_0, times_s, states):
    """The targets of an independent guidance from ``sigma_0`` at ``times_s``."""
    guidance = guidance_from_scenario(scenario, sigma_0=sigma_0)
    return [guidance.update(t, s, w).target for t, (s, w) in zip(times_s, states, strict=True)]


def test_the_first_stamp_starts_the_clock(case1, prepared):
    s = make(case1, prepared)
    t0_ns = 7_300_000_000  # the run's stamps need not start at zero
    sigma = case1.initial_mrp
    first = s.step(t0_ns, sigma, ZERO)
    second = s.step(t0_ns + DT_NS, sigma, ZERO)
    assert first.t_s == 0.0
    assert second.t_s == pytest.approx(0.1, abs=1e-12)
    assert s.first_stamp_ns == t0_ns
    assert s.last_stamp_ns == t0_ns + DT_NS
    ref = reference_targets(case1, sigma, [0.0, 0.1], [(sigma, ZERO)] * 2)
    np.testing.assert_array_equal(second.sigma_t, ref[1].sigma_t)
    np.testing.assert_array_equal(second.omega_t, ref[1].omega_t)


def test_the_margin_is_taken_at_the_guidance_time_on_a_moving_sky():
    moving = load_scenario(ROOT / "scenarios" / "moving_object.yaml")
    assert not moving.sky.static
    s = make(moving)
    t0_ns = 40_000_000_000
    sigma = np.array([-0.5, -0.4, -0.3])  # the mover is the closest object here
    report = s.report(s.step(t0_ns, sigma, ZERO), rejected=0)
    at_start = moving.sky.min_margin_deg_single(0.0, sigma)
    assert report.margin_deg == at_start
    assert at_start != moving.sky.min_margin_deg_single(t0_ns / 1e9, sigma)  # not vacuous


def test_the_guidance_is_built_from_the_first_measured_attitude(case1, prepared):
    s = make(case1, prepared)
    assert s.guidance is None
    measured = case1.initial_mrp + np.array([0.02, -0.01, 0.0])
    step = s.step(0, measured, ZERO)
    assert s.guidance is not None
    assert ("info", f"planning from sigma_BN = {measured.round(6).tolist()}") in step.logs
    assert any(level == "info" and text.startswith("global route: ") for level, text in step.logs)
    from_measured = reference_targets(case1, measured, [0.0], [(measured, ZERO)])[0]
    from_start = reference_targets(case1, None, [0.0], [(measured, ZERO)])[0]
    np.testing.assert_array_equal(step.sigma_t, from_measured.sigma_t)
    assert np.linalg.norm(step.sigma_t - from_start.sigma_t) > 1e-3
    again = s.step(DT_NS, measured, ZERO)
    assert again.logs == []  # built once


def test_an_infeasible_slew_is_an_error_at_the_first_state():
    enclosed = load_scenario(ROOT / "scenarios" / "enclosed_goal.yaml")
    s = make(enclosed)
    step = s.step(0, enclosed.initial_mrp, ZERO)
    errors = [text for level, text in step.logs if level == "error"]
    assert len(errors) == 1 and errors[0].startswith("infeasible: ")
    report = s.report(step, rejected=0)
    assert report.status is PlannerStatus.INFEASIBLE
    assert report.diagnostics.reason and report.diagnostics.reason in errors[0]
    np.testing.assert_allclose(step.sigma_t, enclosed.initial_mrp, atol=1e-12)  # holds


def test_an_inactive_stepper_holds_the_last_target_at_rest(case1, prepared):
    s = make(case1, prepared)
    sigma = case1.initial_mrp
    assert not s.takes_input(active=False)  # nothing to hold before the first target
    assert s.takes_input(active=True)
    s.step(0, sigma, ZERO)
    moving = s.step(DT_NS, sigma, ZERO)
    assert np.linalg.norm(moving.omega_t) > 0.0  # the target was moving
    assert s.takes_input(active=False)
    held = s.step(2 * DT_NS, sigma + 0.01, np.array([0.01, 0.0, 0.0]), active=False)
    assert held.held and held.result is None and held.logs == []
    np.testing.assert_array_equal(held.sigma_t, moving.sigma_t)
    np.testing.assert_array_equal(held.omega_t, ZERO)
    assert s.last_stamp_ns == DT_NS  # not stepped
    with pytest.raises(ValueError):
        s.report(held, rejected=0)
    resumed = s.step(3 * DT_NS, sigma, ZERO)
    ref = reference_targets(case1, sigma, [0.0, 0.1, 0.3], [(sigma, ZERO)] * 3)
    np.testing.assert_array_equal(resumed.sigma_t, ref[2].sigma_t)


def _patched(stepper: PlannerStepper, edit) -> None:
    """Pass every guidance output through ``edit(k, output)`` (k: 0, 1, ...)."""
    update = stepper.guidance.update
    calls = iter(range(10**6))

    def patched(*args):
        out = update(*args)
        edit(next(calls), out)
        return out

    stepper.guidance.update = patched


def test_a_status_change_is_reported_once(case1, prepared):
    s = make(case1, prepared)
    sigma = case1.initial_mrp
    reports = [s.report(s.step(0, sigma, ZERO), rejected=0)]

    def arrive(k, out):
        if k >= 2:
            out.target.status = PlannerStatus.ARRIVED

    _patched(s, arrive)
    reports += [s.report(s.step(k * DT_NS, sigma, ZERO), rejected=0) for k in range(1, 6)]
    statuses = [r.status for r in reports]
    assert statuses == [PlannerStatus.TRACKING, None, None, PlannerStatus.ARRIVED, None, None]
    assert reports[0].logs == [("info", "status tracking at stamp 0.000 s")]
    assert reports[3].logs == [("info", "status arrived at stamp 0.300 s")]
    assert all(r.logs == [] for i, r in enumerate(reports) if i not in (0, 3))
    assert reports[4].diagnostics.status is PlannerStatus.ARRIVED  # reported every step


def test_derating_changes_are_reported(case1, prepared):
    s = make(case1, prepared)
    sigma = case1.initial_mrp
    s.step(0, sigma, ZERO)
    deratings = [0.5, 0.5, 0.25, 0.25]

    def derate(k, out):
        out.derating = deratings[k]

    _patched(s, derate)
    reports = [s.report(s.step(k * DT_NS, sigma, ZERO), rejected=0) for k in range(1, 5)]
    warnings = [[t for lvl, t in r.logs if lvl == "warning"] for r in reports]
    assert [len(w) for w in warnings] == [1, 0, 1, 0]
    assert warnings[0][0].startswith("the body fell behind a profile")
    assert warnings[0][0].endswith("profile acceleration now 0.5 of the declared at stamp 0.100 s")
    assert warnings[2][0].endswith("now 0.25 of the declared at stamp 0.300 s")
    assert s.derating == 0.25
    assert [r.diagnostics.accel_derating for r in reports] == deratings


def test_the_report_carries_the_margin_step_time_and_rejected_count(case1, prepared):
    s = make(case1, prepared)
    sigma = case1.initial_mrp + np.array([0.0, 0.01, 0.0])
    step = s.step(0, sigma, ZERO)
    report = s.report(step, rejected=3)
    assert report.margin_deg == case1.sky.min_margin_deg_single(0.0, sigma)
    assert report.diagnostics.keep_out_margin_deg == report.margin_deg
    assert report.diagnostics.rejected_messages == 3
    assert report.diagnostics.step_time_s == step.step_s > 0.0
    assert report.diagnostics.route_waypoints > 0


def test_the_route_thread_is_its_own_only_when_none_is_given(case1, prepared):
    own = PlannerStepper(case1, prepared)
    assert own.own_thread is not None and own.executor is own.own_thread
    own.close()
    with pytest.raises(RuntimeError):  # shut down: takes no more routes
        own.own_thread.submit(print)
    given = make(case1, prepared)
    assert given.own_thread is None
    given.close()  # nothing of its own to stop
