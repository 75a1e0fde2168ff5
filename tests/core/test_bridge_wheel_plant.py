"""The example bridge's wheel plant (``spacecraft_bridge_example.wheel_plant``, written
from the contract alone: quaternions, its own RK4) against the project's
:class:`attitude_core.world.wheel_plant.WheelPlant` (MRPs, its own RK4): same scenario,
same commanded motor torques, same states. No ROS: the module is imported directly."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from spacecraft_bridge_example.wheel_plant import RK4WheelBody, Wheel, wheel_problem

from attitude_core.config.scenario import Scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.models.mrp import mrp_from_quat, principal_angle, quat_from_mrp, relative
from attitude_core.world.wheel_plant import WheelPlant

ROOT = Path(__file__).resolve().parents[2]
PYRAMID = ROOT / "scenarios" / "case1_rw_pyramid.yaml"


def limited(tmp_path: Path) -> Scenario:
    """The pyramid with rw1 120 rpm short of its speed limit (it reaches it within a few
    steps and must refuse more) and rw3 failing at 2 s."""
    text = PYRAMID.read_text()
    rw1 = "initial_speed_rpm: 1500.0"
    assert text.count(rw1) == 1
    text = text.replace(rw1, "initial_speed_rpm: 5880.0")
    rw3 = "      rw3:\n"
    text = text.replace(rw3, rw3 + "        fails_at_s: 2.0\n")
    path = tmp_path / "limited.yaml"
    path.write_text(text)
    return load_scenario(path)


def bridge_wheels(scenario: Scenario) -> list[Wheel]:
    assert scenario.wheels is not None
    return [
        Wheel(
            w.name,
            w.spin_axis_body,
            w.max_torque_nm,
            w.max_speed_rad_s,
            w.spin_inertia_kgm2,
            w.initial_speed_rad_s,
            math.inf if w.fails_at_s is None else w.fails_at_s,
        )
        for w in scenario.wheels.wheels
    ]


@pytest.mark.parametrize("which", ["pyramid", "limited"])
def test_bridge_wheel_plant_matches_the_project_wheel_plant(which, tmp_path):
    scenario = load_scenario(PYRAMID) if which == "pyramid" else limited(tmp_path)
    assert scenario.wheels is not None
    omega0 = np.array([0.04, -0.03, 0.06])  # tumbling: the gyroscopic terms matter
    core = WheelPlant(scenario.inertia_kgm2, scenario.wheels, scenario.initial_mrp, omega0)
    bridge = RK4WheelBody(
        np.ravel(scenario.inertia_kgm2),
        bridge_wheels(scenario),
        quat_from_mrp(scenario.initial_mrp),
        omega0,
    )
    np.testing.assert_array_equal(bridge.state().speeds_rad_s, core.speeds)
    assert not np.any(bridge.state().motor_torque_nm)  # zero at the first state
    rng = np.random.default_rng(34)
    limit = scenario.wheels.max_torque
    dt, refused, clipped = scenario.dt_s, 0, 0
    worst = np.zeros(3)
    for k in range(300):  # 30 s; commands up to twice the motor limit
        t = k * dt
        u = rng.uniform(-2.0, 2.0, len(limit)) * limit
        if which == "limited":
            u[0] = abs(u[0])  # rw1 pushed past its speed limit
        step = core.step(u, t, dt)
        state = bridge.step(u, t, dt)
        np.testing.assert_array_equal(state.motor_torque_nm, step.motor_torque_nm)
        np.testing.assert_array_equal(bridge.body_torque(state.motor_torque_nm), step.body_torque_b)
        clipped += int(np.sum(np.abs(u) > limit))
        refused += int(step.motor_torque_nm[0] == 0.0)
        angle = principal_angle(relative(core.sigma_bn, mrp_from_quat(state.q_bn_xyzw)))
        errors = (angle, np.abs(core.omega_b - state.omega_b).max())
        worst = np.maximum(worst, (*errors, np.abs(core.speeds - state.speeds_rad_s).max()))
    assert clipped > 100
    assert worst[0] < 1e-9 and worst[1] < 1e-12 and worst[2] < 1e-9, worst
    if which == "limited":
        assert refused > 100  # rw1 at its limit: no torque that spins it faster
        assert abs(core.speeds[0]) <= scenario.wheels.max_speed[0] + 10.0
        assert not np.any(bridge.applied(np.ones(4), 2.0)[2])  # rw3 failed at 2 s
    else:
        assert refused == 0


def test_wheel_problem_names_the_key():
    wheels = bridge_wheels(load_scenario(PYRAMID))
    inertia = np.eye(3).ravel() * 10.0
    assert wheel_problem(inertia, wheels) is None
    assert "unique" in str(wheel_problem(inertia, [wheels[0], wheels[0], *wheels[1:]]))
    planar = [w._replace(spin_axis_body=(1.0, 0.0, 0.0)) for w in wheels]
    assert "span" in str(wheel_problem(inertia, planar))
    heavy = [w._replace(spin_inertia_kgm2=20.0) for w in wheels]
    assert "spin inertia" in str(wheel_problem(inertia, heavy))
    fast = [wheels[0]._replace(initial_speed_rad_s=1e4), *wheels[1:]]
    assert "wheels.rw1.initial_speed_rpm" in str(wheel_problem(inertia, fast))
