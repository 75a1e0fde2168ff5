"""PD tracking law (eq. 11) with the relative MRP error."""

import numpy as np
from scipy.spatial.transform import Rotation

from attitude_core.fsw.control.pd import PdGains, pd_torque, tracking_errors
from attitude_core.models.mrp import dcm_from_mrp, relative
from attitude_core.world.rigid_body import RigidBody

J = np.diag([10.0, 10.0, 10.0])
GAINS = PdGains.from_inertia(J)


def test_default_gains_are_paper_table_1():
    np.testing.assert_allclose(GAINS.kp, 5.5 * J)
    np.testing.assert_allclose(GAINS.kd, 3.1 * J)


def test_zero_error_gives_zero_torque():
    sigma_r = np.array([0.2, -0.4, 0.1])
    omega_r = np.array([0.01, 0.02, -0.03])
    # Body coincides with the target frame and spins with it: omega_B = omega_R.
    u = pd_torque(GAINS, sigma_r, omega_r, sigma_r, omega_r)
    np.testing.assert_allclose(u, 0.0, atol=1e-15)


def test_error_is_relative_mrp_not_difference():
    sigma_b, sigma_r = np.array([0.0, 0.0, 0.9]), np.array([0.0, 0.0, -0.9])
    sigma_e, _ = tracking_errors(sigma_b, np.zeros(3), sigma_r, np.zeros(3))
    rot = Rotation.from_mrp(sigma_r).inv() * Rotation.from_mrp(sigma_b)
    assert abs(4 * np.arctan(np.linalg.norm(sigma_e)) - rot.magnitude()) < 1e-12
    assert np.linalg.norm(sigma_e) <= 1.0  # short way round, not |sigma_b - sigma_r| = 1.8
    np.testing.assert_allclose(sigma_e, relative(sigma_b, sigma_r))


def test_rate_error_maps_target_rate_into_body_axes():
    sigma_b, sigma_r = np.array([0.1, 0.2, 0.3]), np.array([-0.3, 0.1, 0.0])
    omega_r = np.array([0.05, -0.02, 0.01])
    c_br = dcm_from_mrp(sigma_b) @ dcm_from_mrp(sigma_r).T
    _, omega_e = tracking_errors(sigma_b, c_br @ omega_r, sigma_r, omega_r)
    np.testing.assert_allclose(omega_e, 0.0, atol=1e-15)


def test_regulation_converges_from_large_error():
    body = RigidBody(J, [0.0, 0.0, 0.25], [0.05, -0.05, 0.02])
    target = np.array([0.0, -0.2, -0.7])
    for _ in range(400):  # 40 s; omega_n = sqrt(5.5) rad/s, zeta ~ 0.66
        body.step(pd_torque(GAINS, body.sigma_bn, body.omega_b, target, np.zeros(3)), 0.1)
    assert np.linalg.norm(relative(body.sigma_bn, target)) < 1e-6
    assert np.linalg.norm(body.omega_b) < 1e-6
