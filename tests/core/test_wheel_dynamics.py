"""Hub and wheels (models/wheel_dynamics.py): the system momentum's conservation, an
independent momentum-form integration with SciPy, and a spin-up with a closed form."""

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from attitude_core.models.mrp import dcm_from_mrp, mrp_rate
from attitude_core.models.wheel_array import RPM, WheelArray, WheelSpec
from attitude_core.models.wheel_dynamics import WheelBody, rk4_step

J = np.array([[12.0, 0.4, -0.2], [0.4, 9.0, 0.3], [-0.2, 0.3, 7.0]])


def random_array(rng: np.random.Generator, n: int = 4, js: float = 0.02) -> WheelArray:
    wheels = []
    for i in range(n):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        wheels.append(
            WheelSpec(
                f"rw{i}",
                tuple(axis),
                max_torque_nm=0.05,
                max_speed_rad_s=6000 * RPM,
                spin_inertia_kgm2=js * rng.uniform(0.5, 1.5),
                initial_speed_rad_s=rng.uniform(-300.0, 300.0),
            )
        )
    array = WheelArray(tuple(wheels))
    assert array.problem(J) is None
    return array


def inertial_momentum(array, sigma, omega, speeds):
    return dcm_from_mrp(sigma).T @ array.system_momentum_b(J, omega, speeds)


@pytest.mark.parametrize("seed", range(5))
def test_system_momentum_is_constant_inertially_without_external_torque(seed):
    rng = np.random.default_rng(seed)
    array = random_array(rng)
    body = WheelBody(J, array)
    sigma, omega, speeds = rng.uniform(-0.4, 0.4, 3), rng.uniform(-0.1, 0.1, 3), array.initial_speed
    h0 = inertial_momentum(array, sigma, omega, speeds)
    spun = 0.0
    for _ in range(3000):  # 300 s, motor torques changing every step
        u = rng.uniform(-0.05, 0.05, len(array))
        before = speeds.copy()
        sigma, omega, speeds = rk4_step(body, sigma, omega, speeds, u, np.zeros(3), 0.1)
        spun += float(np.max(np.abs(speeds - before)))
        assert np.linalg.norm(sigma) <= 1.0 + 1e-12
    assert spun > 10.0  # the wheels did exchange momentum with the hub
    h = inertial_momentum(array, sigma, omega, speeds)
    np.testing.assert_allclose(h, h0, rtol=0, atol=1e-7 * np.linalg.norm(h0))


def test_matches_a_momentum_form_integration_with_external_torque():
    """State ``(sigma, H_N, h_wheel)``: ``H_N' = C_BN^T L``, ``h_i' = u_i``,
    ``omega = J_hub^-1 (H_B - G h)``, ``Omega_i = h_i / Js_i - g_i . omega``."""
    rng = np.random.default_rng(11)
    array = random_array(rng)
    body = WheelBody(J, array)
    g, js = array.axes, array.spin_inertia
    hub_inv = np.linalg.inv(array.hub_inertia(J))
    u = rng.uniform(-0.05, 0.05, len(array))
    ext = np.array([3e-3, -2e-3, 1e-3])
    sigma0, omega0, speeds0 = (
        np.array([0.1, -0.2, 0.3]),
        np.array([0.02, -0.01, 0.03]),
        array.initial_speed,
    )

    def unpack(x):
        sigma, h_n, h_w = x[:3], x[3:6], x[6:]
        h_b = dcm_from_mrp(sigma) @ h_n
        omega = hub_inv @ (h_b - g @ h_w)
        return sigma, h_n, h_w, omega

    def rhs(_t, x):
        sigma, _, _, omega = unpack(x)
        return np.r_[mrp_rate(sigma, omega), dcm_from_mrp(sigma).T @ ext, u]

    h_n0 = inertial_momentum(array, sigma0, omega0, speeds0)
    h_w0 = js * (g.T @ omega0 + speeds0)
    t_end = 20.0
    sol = solve_ivp(rhs, (0.0, t_end), np.r_[sigma0, h_n0, h_w0], rtol=1e-12, atol=1e-13)
    sigma_ref, _, h_w, omega_ref = unpack(sol.y[:, -1])
    speeds_ref = h_w / js - g.T @ omega_ref

    sigma, omega, speeds = sigma0, omega0, speeds0
    for _ in range(int(t_end / 0.01)):
        sigma, omega, speeds = rk4_step(body, sigma, omega, speeds, u, ext, 0.01)
    np.testing.assert_allclose(sigma, sigma_ref, atol=1e-9)
    np.testing.assert_allclose(omega, omega_ref, atol=1e-9)
    np.testing.assert_allclose(speeds, speeds_ref, atol=1e-6)
    assert np.linalg.norm(speeds - speeds0) > 1.0  # the run is not trivial


def test_one_wheel_spins_the_body_up_as_the_closed_form_says():
    """Body at rest, principal inertia, one wheel on x with a constant motor torque:
    ``omega_x = -u t / (J_x - Js)``, ``Omega = u t / Js - omega_x``."""
    j = np.diag([10.0, 12.0, 8.0])
    wheel = WheelSpec("rw", (1.0, 0.0, 0.0), 0.1, 1e4, 0.05)
    array = WheelArray((wheel,))
    body = WheelBody(j, array)
    u, t = 0.02, 5.0
    sigma, omega, speeds = np.zeros(3), np.zeros(3), np.zeros(1)
    for _ in range(50):
        sigma, omega, speeds = rk4_step(body, sigma, omega, speeds, [u], np.zeros(3), 0.1)
    omega_x = -u * t / (10.0 - 0.05)
    np.testing.assert_allclose(omega, [omega_x, 0.0, 0.0], atol=1e-14)
    np.testing.assert_allclose(speeds, [u * t / 0.05 - omega_x], rtol=1e-12)
    # the body turned about x by the integral of omega_x: sigma = tan(phi / 4)
    np.testing.assert_allclose(sigma[0], np.tan(0.5 * omega_x * t / 4.0), rtol=1e-9)
