"""MRP kinematics (paper eqs. 1-3, 12) against SciPy and identities."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from scipy.spatial.transform import Rotation

from attitude_core.models import mrp

finite = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)
vec3 = arrays(np.float64, 3, elements=finite)
small_vec3 = arrays(np.float64, 3, elements=st.floats(-0.9, 0.9))
nonzero_vec3 = vec3.filter(lambda v: np.linalg.norm(v) > 1e-3)


@given(vec3)
def test_dcm_matches_scipy_c_bn(sigma):
    expected = Rotation.from_mrp(sigma).as_matrix().T  # C_BN
    np.testing.assert_allclose(mrp.dcm_from_mrp(sigma), expected, atol=1e-12)
    np.testing.assert_allclose(mrp.dcm_from_mrp_single(sigma), expected, atol=1e-12)


@given(vec3)
def test_dcm_is_proper_rotation(sigma):
    c = mrp.dcm_from_mrp(sigma)
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=1e-12)
    assert abs(np.linalg.det(c) - 1.0) < 1e-12


@given(nonzero_vec3)
def test_shadow_set_same_attitude(sigma):
    s = mrp.shadow(sigma)
    np.testing.assert_allclose(mrp.dcm_from_mrp(s), mrp.dcm_from_mrp(sigma), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(s) * np.linalg.norm(sigma), 1.0, rtol=1e-12)
    assert np.linalg.norm(mrp.to_principal(sigma)) <= 1.0 + 1e-12


@given(vec3)
def test_b_transpose_b_identity(sigma):
    b = mrp.b_matrix(sigma)
    s2 = sigma @ sigma
    np.testing.assert_allclose(b.T @ b, (1.0 + s2) ** 2 * np.eye(3), rtol=1e-12, atol=1e-9)


@given(vec3, vec3)
def test_rate_round_trip(sigma, omega):
    sd = mrp.mrp_rate(sigma, omega)
    np.testing.assert_allclose(sd, 0.25 * mrp.b_matrix(sigma) @ omega, atol=1e-12)
    np.testing.assert_allclose(mrp.mrp_rate_single(tuple(sigma), tuple(omega)), sd, atol=1e-12)
    np.testing.assert_allclose(mrp.omega_from_mrp_rate(sigma, sd), omega, atol=1e-9)
    np.testing.assert_allclose(mrp.omega_from_mrp_rate_single(sigma, sd), omega, atol=1e-9)


@given(small_vec3, vec3)
def test_mrp_rate_matches_dcm_kinematics(sigma, omega):
    # C_dot = -[omega x] C for C_BN with body rates.
    h = 1e-6
    c_plus = mrp.dcm_from_mrp(sigma + h * mrp.mrp_rate(sigma, omega))
    c_minus = mrp.dcm_from_mrp(sigma - h * mrp.mrp_rate(sigma, omega))
    c_dot = (c_plus - c_minus) / (2 * h)
    np.testing.assert_allclose(c_dot, -mrp.skew(omega) @ mrp.dcm_from_mrp(sigma), atol=1e-6)


@given(vec3, vec3)
def test_compose_and_relative(sigma_a, sigma_b):
    composed = mrp.compose(sigma_a, sigma_b)
    np.testing.assert_allclose(
        mrp.dcm_from_mrp(composed), mrp.dcm_from_mrp(sigma_a) @ mrp.dcm_from_mrp(sigma_b), atol=1e-9
    )
    rel = mrp.relative(sigma_a, sigma_b)  # C(rel) = C(a) C(b)^T
    np.testing.assert_allclose(
        mrp.dcm_from_mrp(rel), mrp.dcm_from_mrp(sigma_a) @ mrp.dcm_from_mrp(sigma_b).T, atol=1e-9
    )
    assert np.linalg.norm(rel) <= 1.0 + 1e-12
    expected = (Rotation.from_mrp(sigma_b).inv() * Rotation.from_mrp(sigma_a)).magnitude()
    assert abs(mrp.principal_angle(rel) - expected) < 1e-9


@given(vec3)
def test_quaternion_is_ros_orientation(sigma):
    q = mrp.quat_from_mrp(sigma)
    expected = Rotation.from_mrp(sigma).as_quat()  # (x, y, z, w), body in inertial
    assert abs(abs(q @ expected) - 1.0) < 1e-12
    assert q[3] >= 0.0
    np.testing.assert_allclose(
        mrp.dcm_from_mrp(mrp.mrp_from_quat(q)), mrp.dcm_from_mrp(sigma), atol=1e-9
    )


quat4 = arrays(np.float64, 4, elements=finite).filter(lambda q: np.linalg.norm(q) > 1e-3)


@given(vec3)
def test_single_quaternion_from_mrp_matches_array_form(sigma):
    # the nodes' per-message form: the same quaternion as the array form, w >= 0
    q = mrp.quat_from_mrp_single(sigma)
    np.testing.assert_allclose(q, mrp.quat_from_mrp(sigma), rtol=0.0, atol=4e-16)
    assert q[3] >= 0.0


@given(quat4)
def test_single_mrp_from_quaternion_matches_array_form(q):
    # normalised first, |sigma| <= 1: the same MRP as the array form
    sigma = mrp.mrp_from_quat_single(*q)
    np.testing.assert_allclose(sigma, mrp.mrp_from_quat(q), rtol=0.0, atol=1e-15)
    assert np.linalg.norm(sigma) <= 1.0 + 1e-15
    expected = Rotation.from_quat(q).as_matrix().T  # C_BN of the body orientation q
    np.testing.assert_allclose(mrp.dcm_from_mrp_single(sigma), expected, atol=1e-12)


def test_principal_angle_definition():
    # sigma = e tan(Phi / 4)  (eq. 1)
    e = np.array([0.0, 0.6, 0.8])
    for phi in (0.1, 1.0, 3.0):
        assert abs(mrp.principal_angle(e * np.tan(phi / 4)) - phi) < 1e-12


@settings(max_examples=50)
@given(arrays(np.float64, (4, 3), elements=finite))
def test_vectorised_forms_match_single(stack):
    np.testing.assert_allclose(
        mrp.dcm_from_mrp(stack), np.array([mrp.dcm_from_mrp_single(s) for s in stack]), atol=1e-12
    )


def test_angle_between_single_is_the_principal_angle_of_the_relative_mrp():
    rng = np.random.default_rng(17)
    a = Rotation.random(500, random_state=rng).as_mrp()
    b = Rotation.random(500, random_state=rng).as_mrp()
    b[:50] = a[:50] + 1e-9 * rng.normal(size=(50, 3))  # tiny angles
    b[50:60] = mrp.shadow(a[50:60])  # the same attitude in the shadow set
    expected = mrp.principal_angle(mrp.relative(a, b))
    got = np.array([mrp.angle_between_single(x, y) for x, y in zip(a, b, strict=True)])
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12)
    np.testing.assert_allclose(got[50:60], 0.0, atol=1e-12)
    # Against SciPy: the magnitude of the relative rotation.
    ref = (Rotation.from_mrp(a) * Rotation.from_mrp(b).inv()).magnitude()
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-9)
