"""The wheel plant (world/wheel_plant.py) and the external torques
(world/disturbances.py): per-wheel torque and speed limits, a failed wheel, the
gravity gradient against point masses in an inverse-square field, and the system
momentum's drift against the integrated external torque."""

import math

import numpy as np

from attitude_core.models.ephemeris import EARTH_RADIUS_KM, Orbit
from attitude_core.models.mrp import dcm_from_mrp
from attitude_core.models.wheel_array import RPM, WheelArray, WheelSpec
from attitude_core.world.disturbances import MU_EARTH_M3_S2, Disturbances, gravity_gradient_b
from attitude_core.world.wheel_plant import WheelPlant
from tests.core.test_wheel_array import pyramid

J = np.diag([10.0, 12.0, 8.0])
LEO = Orbit(EARTH_RADIUS_KM + 500.0, 0.001, 97.4, 30.0, 10.0, 0.0)


def test_commands_are_clipped_to_each_wheels_torque():
    plant = WheelPlant(J, pyramid(max_torque=0.01), np.zeros(3), np.zeros(3))
    u = plant.applied([0.05, -0.05, 0.004, -0.2], 0.0)
    np.testing.assert_array_equal(u, [0.01, -0.01, 0.004, -0.01])


def test_a_wheel_at_its_speed_limit_refuses_to_spin_faster():
    top = 6000 * RPM
    plant = WheelPlant(J, pyramid(speeds=(top, -top, 0.0, 0.0)), np.zeros(3), np.zeros(3))
    np.testing.assert_array_equal(
        plant.applied([0.01, 0.01, 0.01, 0.01], 0.0), [0, 0.01, 0.01, 0.01]
    )
    np.testing.assert_array_equal(plant.applied([-0.01] * 4, 0.0), [-0.01, 0, -0.01, -0.01])


def test_a_failed_wheel_applies_nothing_and_keeps_its_momentum():
    base = pyramid(speeds=(200.0, -100.0, 50.0, 0.0))
    wheels = list(base.wheels)
    w = wheels[1]
    wheels[1] = WheelSpec(w.name, w.spin_axis_body, w.max_torque_nm, w.max_speed_rad_s,
                          w.spin_inertia_kgm2, w.initial_speed_rad_s, fails_at_s=2.0)  # fmt: skip
    array = WheelArray(tuple(wheels))
    plant = WheelPlant(J, array, np.zeros(3), np.zeros(3))
    g1 = np.asarray(w.spin_axis_body)
    t, dt = 0.0, 0.1
    rng = np.random.default_rng(0)
    while t < 2.0 - 1e-9:
        assert plant.step(rng.uniform(-0.01, 0.01, 4), t, dt).motor_torque_nm[1] != 0.0
        t += dt
    h1 = w.spin_inertia_kgm2 * (g1 @ plant.omega_b + plant.speeds[1])  # its own momentum
    for _ in range(100):
        step = plant.step(rng.uniform(-0.01, 0.01, 4), t, dt)
        t += dt
        assert step.motor_torque_nm[1] == 0.0
        assert np.all(step.motor_torque_nm[[0, 2, 3]] != 0.0)
    assert np.linalg.norm(plant.omega_b) > 1e-3  # the body moved meanwhile
    h1_after = w.spin_inertia_kgm2 * (g1 @ plant.omega_b + plant.speeds[1])
    assert abs(h1_after - h1) < 1e-12


def test_gravity_gradient_is_the_torque_on_point_masses_in_an_inverse_square_field():
    rng = np.random.default_rng(1)
    masses = rng.uniform(1.0, 5.0, 12)
    points = rng.normal(size=(12, 3))  # m, body axes
    points -= (masses @ points) / masses.sum()  # about the centre of mass
    inertia = sum(
        m * (p @ p * np.eye(3) - np.outer(p, p)) for m, p in zip(masses, points, strict=True)
    )
    for _ in range(5):
        sigma = rng.uniform(-0.5, 0.5, 3)
        r_n = LEO.state_km(rng.uniform(0.0, 6000.0))[0] * 1e3
        r_b = dcm_from_mrp(sigma) @ r_n
        exact = sum(
            np.cross(p, -MU_EARTH_M3_S2 * m * (r_b + p) / np.linalg.norm(r_b + p) ** 3)
            for m, p in zip(masses, points, strict=True)
        )
        model = gravity_gradient_b(r_n, sigma, inertia)
        np.testing.assert_allclose(model, exact, rtol=0, atol=1e-5 * np.linalg.norm(model))
        assert np.linalg.norm(model) > 1e-7


def test_gravity_gradient_size_at_500_km():
    """``3 mu / R^3 * dJ / 2`` at 45 deg between the local vertical and two axes."""
    r = (EARTH_RADIUS_KM + 500.0) * 1e3
    r_n = r * np.array([0.0, math.cos(math.pi / 4), math.sin(math.pi / 4)])
    torque = gravity_gradient_b(r_n, np.zeros(3), np.diag([10.0, 10.0, 11.0]))
    np.testing.assert_allclose(torque, [1.8e-6, 0.0, 0.0], rtol=0.03)  # 1 kg m^2 of difference
    assert not np.any(gravity_gradient_b(r_n, np.zeros(3), np.eye(3) * 7.0))


def test_system_momentum_drifts_by_the_integrated_external_torque():
    array = pyramid(js=2e-3, speeds=(300.0, -200.0, 100.0, 50.0))
    dist = Disturbances(tuple(J.ravel()), LEO, (2e-6, -1e-6, 5e-7))
    plant = WheelPlant(J, array, [0.1, 0.3, -0.2], [0.0, 0.0, 0.0], dist)
    dcm = dcm_from_mrp(plant.sigma_bn)
    h0 = dcm.T @ plant.system_momentum_b()
    integrated = np.zeros(3)
    rng = np.random.default_rng(2)
    dt = 0.1
    for k in range(6000):  # 600 s, random wheel commands
        before = dcm_from_mrp(plant.sigma_bn).T
        step = plant.step(rng.uniform(-2e-3, 2e-3, 4), k * dt, dt)
        after = dcm_from_mrp(plant.sigma_bn).T
        integrated += 0.5 * dt * (before + after) @ step.external_b
    drift = dcm_from_mrp(plant.sigma_bn).T @ plant.system_momentum_b() - h0
    assert np.linalg.norm(integrated) > 1e-4
    np.testing.assert_allclose(drift, integrated, rtol=0, atol=0.01 * np.linalg.norm(integrated))
