"""Actuator limits: the scenario keys, the controller's and the plant's saturation, and
their use in the offline loop and the simulator's stepper."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario, loads_scenario
from attitude_core.fsw.control.pd import PdGains, commanded_torque, pd_torque
from attitude_core.fsw.control.saturation import scale_to_bound
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.runtime.sim_stepper import Action, SimStepper, StepperConfig
from attitude_core.world.actuator import clip_to_bound
from attitude_core.world.rigid_body import RigidBody

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
BOUND = (0.03, 0.02, 0.05)


def with_actuators(lines: str, path: Path = CASE1) -> str:
    """Case 1's text with an ``actuators:`` block (``lines`` indented under it)."""
    block = "    actuators:\n" + "".join(f"      {line}\n" for line in lines.splitlines())
    text = path.read_text()
    assert "    controller:\n" in text
    return text.replace("    controller:\n", block + "    controller:\n")


# --- saturation rules -------------------------------------------------------------------


def test_scale_keeps_the_direction_and_meets_the_bound():
    rng = np.random.default_rng(3)
    for _ in range(500):
        u = rng.normal(scale=0.1, size=3)
        v, saturated = scale_to_bound(u, BOUND)
        assert np.all(np.abs(v) <= np.array(BOUND) * (1 + 1e-12))
        inside = bool(np.all(np.abs(u) <= BOUND))
        assert saturated is not inside
        if inside:
            np.testing.assert_array_equal(v, u)
        else:  # one component on its bound, the same direction, a smaller size
            assert np.isclose(np.max(np.abs(v) / BOUND), 1.0, rtol=0, atol=1e-12)
            np.testing.assert_allclose(np.cross(u, v), 0.0, atol=1e-15)
            assert float(u @ v) > 0.0 and np.linalg.norm(v) < np.linalg.norm(u)


def test_clip_saturates_each_axis_on_its_own():
    u = np.array([0.1, -0.01, -0.2])
    v, saturated = clip_to_bound(u, BOUND)
    np.testing.assert_array_equal(v, [0.03, -0.01, -0.05])
    assert saturated
    inside = np.array([0.01, -0.02, 0.0])
    v, saturated = clip_to_bound(inside, BOUND)
    np.testing.assert_array_equal(v, inside)
    assert not saturated


def test_clip_of_one_torque_is_numpys_clip_to_the_bit():
    rng = np.random.default_rng(4)
    torques = list(rng.normal(scale=0.05, size=(2000, 3)))
    torques += [np.array([0.03, -0.02, 0.05]), np.array([-0.0, 0.0, -0.05]), np.array(BOUND)]
    torques += [np.array([np.nan, 0.1, -0.1]), np.array([np.inf, -np.inf, 0.01])]
    bound = np.array(BOUND)
    for u in torques:
        v, saturated = clip_to_bound(u, BOUND)
        expected = np.clip(u, -bound, bound)
        np.testing.assert_array_equal(v, expected)
        assert np.array_equal(np.signbit(v), np.signbit(expected))
        assert saturated == bool(np.any(expected != u))
        assert v is not u  # a new array, as np.clip's


def test_no_bound_is_unlimited():
    u = np.array([10.0, -20.0, 30.0])
    for rule in (scale_to_bound, clip_to_bound):
        v, saturated = rule(u, None)
        np.testing.assert_array_equal(v, u)
        assert not saturated


# --- scenario keys ----------------------------------------------------------------------


def test_limits_load_and_absent_means_unlimited():
    sc = loads_scenario(with_actuators("max_torque_nm: [0.03, 0.02, 0.05]\nmax_rate_rad_s: 0.035"))
    assert sc.actuators.max_torque_nm == BOUND and sc.actuators.max_rate_rad_s == 0.035
    assert sc.actuators.limited
    plain = load_scenario(CASE1).actuators
    assert plain.max_torque_nm is None and plain.max_rate_rad_s is None and not plain.limited


@pytest.mark.parametrize(
    "lines, key, reason",
    [
        (
            "max_torque_nm: [0.03, -0.02, 0.05]",
            "actuators.max_torque_nm",
            "every element must be > 0",
        ),
        (
            "max_torque_nm: [0.03, 0.0, 0.05]",
            "actuators.max_torque_nm",
            "every element must be > 0",
        ),
        ("max_torque_nm: [0.03, 0.02]", "actuators.max_torque_nm", "expected a list of 3 floats"),
        ("max_torque_nm: 0.03", "actuators.max_torque_nm", "expected a list of 3 floats"),
        ("max_torque_nm: [1, 1, 1]", "actuators.max_torque_nm", "expected float, got integer"),
        ("max_torque_nm: [.nan, 0.1, 0.1]", "actuators.max_torque_nm", "must be finite"),
        ("max_rate_rad_s: 0.0", "actuators.max_rate_rad_s", "must be > 0"),
        ("max_rate_rad_s: -0.1", "actuators.max_rate_rad_s", "must be > 0"),
        ("max_rate: 0.1", "actuators.max_rate", "did you mean 'actuators.max_rate_rad_s'?"),
    ],
)
def test_bad_limits_are_refused_naming_the_key(lines, key, reason):
    with pytest.raises(ScenarioError) as info:
        loads_scenario(with_actuators(lines))
    assert info.value.key == key
    assert reason in info.value.reason


# --- the offline loop and the stepper -----------------------------------------------------


def test_offline_loop_never_applies_more_than_the_bound():
    # A tumbling start saturates the controller (the guidance's profile alone does not).
    text = with_actuators("max_torque_nm: [0.03, 0.02, 0.05]")
    still = "initial_rate_rad_s: [0.0, 0.0, 0.0]"
    assert still in text
    sc = loads_scenario(text.replace(still, "initial_rate_rad_s: [0.02, -0.02, 0.02]"))
    run = run_closed_loop(sc)
    assert np.all(np.abs(run.torque_b) <= np.array(BOUND) * (1 + 1e-12))
    assert np.any(np.isclose(np.abs(run.torque_b), BOUND, rtol=0, atol=1e-12))  # it saturated
    # Each step is the PD torque scaled into the bound, direction kept.
    gains = PdGains(sc.kp, sc.kd)
    for k in range(0, len(run.t), 97):
        args = (gains, run.sigma_bn[k], run.omega_b[k], run.sigma_t[k], run.omega_t[k])
        np.testing.assert_allclose(run.torque_b[k], commanded_torque(*args, BOUND), atol=1e-15)
        np.testing.assert_allclose(np.cross(run.torque_b[k], pd_torque(*args)), 0.0, atol=1e-12)


def test_unlimited_offline_loop_is_the_paper_loop():
    """No bound: the torque is the plain eq. 11 torque (the paper's behaviour): the
    loop's command to the bit, and the reference law to rounding (the compiled law sums
    in another order)."""
    sc = load_scenario(CASE1)
    run = run_closed_loop(sc)
    gains = PdGains(sc.kp, sc.kd)
    for k in range(0, len(run.t), 131):
        args = (gains, run.sigma_bn[k], run.omega_b[k], run.sigma_t[k], run.omega_t[k])
        np.testing.assert_array_equal(run.torque_b[k], commanded_torque(*args))
        np.testing.assert_allclose(run.torque_b[k], pd_torque(*args), rtol=0, atol=1e-13)


@pytest.mark.parametrize("mode", ["lockstep", "realtime"])
def test_stepper_clips_what_the_body_gets_and_reports_it_applied(mode):
    sc = load_scenario(CASE1)
    body = RigidBody(sc.inertia_kgm2, sc.initial_mrp, sc.initial_rate_rad_s)
    ref = RigidBody(sc.inertia_kgm2, sc.initial_mrp, sc.initial_rate_rad_s)
    cfg = StepperConfig(dt_s=sc.dt_s, n_steps=10, time_mode=mode, max_torque_nm=BOUND)
    s = SimStepper(cfg, body, created=0.0)
    s.poll_graph(0.0, True)
    start = s.poll_graph(1.0, True)
    assert start.action is Action.START
    command = np.array([0.1, -0.01, -0.2])
    clipped = np.array([0.03, -0.01, -0.05])
    if mode == "lockstep":
        d = s.on_torque(1.0, 0, command)
    else:
        s.on_timer(1.0, 10)  # state 0
        s.on_torque(1.0, 10, command)
        d = s.on_timer(1.1, 20)  # state 1, after the torque was applied over step 0
    np.testing.assert_array_equal(d.applied, clipped)
    ref.step(clipped, sc.dt_s)
    np.testing.assert_allclose(d.state.sigma_bn, ref.sigma_bn, rtol=0, atol=1e-15)
    np.testing.assert_allclose(d.state.omega_b, ref.omega_b, rtol=0, atol=1e-15)
    assert s.saturated_steps == 1


def test_stepper_from_scenario_takes_the_scenario_bound():
    from attitude_core.config.node_parameters import SIMULATOR
    from attitude_core.config.parameters import values_from

    sc = loads_scenario(with_actuators("max_torque_nm: [0.03, 0.02, 0.05]"))
    params = SIMULATOR.typed(values_from(SIMULATOR.own, {}, "test"))
    s = SimStepper.from_scenario(sc, params, created=0.0)
    assert s.cfg.max_torque_nm == BOUND
