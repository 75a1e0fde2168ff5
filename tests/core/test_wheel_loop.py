"""Slews flown by reaction wheels offline (loop/wheel_loop.py through run_closed_loop),
judged on the true body and wheels: no wheel past a limit, no cone entered, arrival,
the inertial system momentum constant (or drifting by the integrated gravity gradient),
a wheel failed mid-slew, and the scenario keys' errors."""

from pathlib import Path

import numpy as np
import pytest

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import angle_between_single, dcm_from_mrp
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_core.record.wheel_figures import inertial_momentum
from attitude_core.world.disturbances import gravity_gradient_b

ROOT = Path(__file__).resolve().parents[2]
PYRAMID = (ROOT / "scenarios" / "case1_rw_pyramid.yaml").read_text()
LEO = (ROOT / "scenarios" / "leo_rw_gravity_gradient.yaml").read_text()


def judged(text: str):
    sc = loads_scenario(text)
    run = run_closed_loop(sc)
    w, array = run.wheels, sc.wheels
    assert w is not None and array is not None
    # every wheel within its limits, at every step
    assert np.all(np.abs(w.speed_rad_s) <= array.max_speed)
    assert np.all(np.abs(w.applied_nm) <= array.max_torque * (1 + 1e-12))
    # the body outside every cone, densely, and at the goal in the end
    assert dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)[0] > 0.0
    assert np.degrees(angle_between_single(run.sigma_bn[-1], sc.desired_mrp)) < 0.5
    assert summarize(run).reached
    return sc, run


def test_a_pyramid_flies_case1_with_the_system_momentum_constant():
    sc, run = judged(PYRAMID)
    h = inertial_momentum(run)
    peak_wheel_h = float(np.max(np.abs(run.wheels.speed_rad_s) * sc.wheels.spin_inertia))
    assert np.max(np.linalg.norm(h - h[0], axis=1)) < 0.01 * peak_wheel_h
    # the wheels did the slew: their momentum moved by much more than the tolerance
    assert np.ptp(run.wheels.speed_rad_s, axis=0).max() * sc.wheels.spin_inertia[0] > 0.05
    s = summarize(run)
    assert s.peak_wheel_speed_frac < 1.0 and s.momentum_error_nms < 1e-9
    assert s.time_ratio_to_bound is not None and s.time_ratio_to_bound > 1.0


def test_the_gravity_gradient_drifts_the_momentum_by_its_integral():
    sc, run = judged(LEO)
    h = inertial_momentum(run)
    # the gravity gradient computed here, on the recorded attitude (trapezoid)
    r_n = sc.orbit.state_km(run.t)[0] * 1e3
    torque_n = np.array(
        [dcm_from_mrp(s).T @ gravity_gradient_b(r, s, sc.inertia_kgm2)
         for s, r in zip(run.sigma_bn, r_n, strict=True)]
    )  # fmt: skip
    integral = np.sum(0.5 * np.diff(run.t)[:, None] * (torque_n[1:] + torque_n[:-1]), axis=0)
    drift = h[-1] - h[0]
    assert np.linalg.norm(integral) > 1e-3  # the gradient did load the wheels
    assert np.linalg.norm(drift - integral) < 0.05 * np.linalg.norm(integral)


def test_a_wheel_failed_mid_slew_applies_nothing_and_the_others_finish_the_slew():
    text = PYRAMID + "    wheels.rw2.fails_at_s: 30.0\n"
    sc, run = judged(text)
    after = run.t >= 30.0
    assert np.all(run.wheels.applied_nm[after, 1] == 0.0)
    assert np.any(run.wheels.applied_nm[~after, 1] != 0.0)
    assert np.any(run.wheels.commanded_nm[after, 1] != 0.0)  # commanded once, then dropped
    assert np.all(run.wheels.commanded_nm[np.flatnonzero(after)[5:], 1] == 0.0)


@pytest.mark.parametrize(
    "extra, key, words",
    [
        ("    actuators.max_rate_rad_s: 0.03\n", "actuators.max_rate_rad_s", "exclusive"),
        ("    disturbances.gravity_gradient: true\n", "disturbances.gravity_gradient", "orbit"),
        ("    wheels.rw1.spin_inertia_kgm2: 20.0\n", "wheels", "spin inertia"),
        ("    wheels.rw3.initial_speed_rpm: 7000.0\n", "wheels.rw3.initial_speed_rpm", "above"),
        ("    wheels.rw4.max_torque_nm: 0.0\n", "wheels.rw4.max_torque_nm", "> 0"),
    ],
)
def test_bad_wheel_keys_name_the_key(extra, key, words):
    text = PYRAMID
    leaf = extra.strip().split(":")[0]
    if leaf.startswith("wheels."):  # replace the wheel's own line
        wheel, field = leaf.split(".")[1:]
        block = text.index(f"      {wheel}:")
        line = text.index(f"        {field}:", block) if f"        {field}:" in text[block:] else -1
        if line >= 0:
            end = text.index("\n", line)
            text = text[:line] + text[end + 1 :]
        text += extra
    else:
        text += extra
    with pytest.raises(ScenarioError) as info:
        loads_scenario(text, "src.yaml")
    assert info.value.key == key and words in info.value.reason, str(info.value)


def test_external_torques_need_wheels():
    case1 = (ROOT / "scenarios" / "case1.yaml").read_text()
    with pytest.raises(ScenarioError) as info:
        loads_scenario(case1 + "    disturbances.constant_torque_nm: [1.0e-5, 0.0, 0.0]\n")
    assert info.value.key == "disturbances.constant_torque_nm"
    assert "wheels" in info.value.reason


def test_wheels_with_no_momentum_free_make_the_slew_infeasible_and_hold_the_body():
    import re

    saturated = re.sub(r"initial_speed_rpm: [-0-9.]+", "initial_speed_rpm: 5995.0", PYRAMID)
    run = run_closed_loop(
        loads_scenario(saturated.replace("sim_time_s: 400.0", "sim_time_s: 60.0"))
    )
    summary = summarize(run).to_json()
    assert summary["planner_infeasible"] and not summary["reached"]
    assert "no momentum" in summary["infeasible_reason"]
    assert summary["peak_wheel_speed_frac"] < 1.0  # held: no wheel pushed past its limit
    assert np.abs(run.omega_b).max() < 1e-9  # the body never left its start


def test_wheels_left_spanning_two_axes_end_the_slew_as_infeasible():
    import re

    two_fail = re.sub(r"(\n(\s+)rw([34]):\n)", r"\1\2  fails_at_s: 20.0\n", PYRAMID)
    run = run_closed_loop(loads_scenario(two_fail.replace("sim_time_s: 400.0", "sim_time_s: 60.0")))
    summary = summarize(run).to_json()
    assert (
        summary["planner_infeasible"]
        and "span 2 of the 3 body axes" in summary["infeasible_reason"]
    )
    assert summary["min_margin_deg"] > 0.0
    assert np.all(run.wheels.applied_nm[run.t >= 20.0][:, 2:] == 0.0)
