"""Rigid-body simulator (eq. 4 and eq. 3): conservation laws and shadow switching."""

import numpy as np
from scipy.integrate import solve_ivp

from attitude_core.models.body_dynamics import rk4_step, state_derivative
from attitude_core.models.mrp import dcm_from_mrp
from attitude_core.world.rigid_body import RigidBody

J = np.array([[12.0, 0.4, -0.2], [0.4, 9.0, 0.3], [-0.2, 0.3, 7.0]])


def _momentum_inertial(body):
    return dcm_from_mrp(body.sigma_bn).T @ (body.inertia @ body.omega_b)


def test_torque_free_conserves_energy_and_inertial_momentum():
    body = RigidBody(J, [0.1, -0.2, 0.3], [0.1, -0.2, 0.3])
    e0, h0 = body.kinetic_energy(), _momentum_inertial(body)
    switches = 0
    for _ in range(6000):  # 600 s, many tumbles and shadow switches
        before = body.sigma_bn.copy()
        body.step(np.zeros(3), 0.1)
        switches += np.linalg.norm(body.sigma_bn - before) > 0.5
        assert np.linalg.norm(body.sigma_bn) <= 1.0 + 1e-12
    assert switches > 0
    assert abs(body.kinetic_energy() - e0) / e0 < 1e-7
    np.testing.assert_allclose(_momentum_inertial(body), h0, rtol=0, atol=1e-7 * np.linalg.norm(h0))


def test_constant_torque_matches_reference_integrator():
    u = np.array([0.02, -0.01, 0.015])
    body = RigidBody(J, [0.0, 0.0, 0.25], [0.0, 0.0, 0.0])
    ji = np.linalg.inv(J)

    def rhs(_t, x):
        sd, wd = state_derivative(J, ji, x[:3], x[3:], u)
        return np.r_[sd, wd]

    ref = solve_ivp(rhs, (0.0, 10.0), np.r_[body.sigma_bn, body.omega_b], rtol=1e-11, atol=1e-12).y[
        :, -1
    ]
    for _ in range(100):
        body.step(u, 0.1)
    np.testing.assert_allclose(body.sigma_bn, ref[:3], atol=1e-8)
    np.testing.assert_allclose(body.omega_b, ref[3:], atol=1e-8)


def test_spin_about_principal_axis_is_steady():
    jd = np.diag([10.0, 20.0, 30.0])
    body = RigidBody(jd, [0.0, 0.0, 0.0], [0.0, 0.0, 0.1])
    for _ in range(100):
        body.step(np.zeros(3), 0.1)
    np.testing.assert_allclose(body.omega_b, [0.0, 0.0, 0.1], atol=1e-12)
    # 10 s at 0.1 rad/s about b3: sigma = b3 tan(1 rad / 4)
    np.testing.assert_allclose(body.sigma_bn, [0.0, 0.0, np.tan(0.25)], atol=1e-9)


def test_array_rk4_step_is_the_plants_step():
    """The flight software's body model (models.body_dynamics.rk4_step) steps as the
    plant does, shadow switches included, to rounding."""
    ji = np.linalg.inv(J)
    body = RigidBody(J, [0.2, -0.5, 0.7], [0.3, -0.2, 0.25])
    s, w = body.sigma_bn.copy(), body.omega_b.copy()
    u = np.array([0.05, -0.02, 0.01])
    switched = 0
    for _ in range(400):
        body.step_reference(u, 0.1)
        before = s
        s, w = rk4_step(J, ji, s, w, u, 0.1)
        switched += np.linalg.norm(s - before) > 0.5
        np.testing.assert_allclose(s, body.sigma_bn, rtol=0, atol=1e-12)
        np.testing.assert_allclose(w, body.omega_b, rtol=0, atol=1e-12)
    assert switched > 0
