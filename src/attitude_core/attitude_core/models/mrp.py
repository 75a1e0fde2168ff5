"""Modified Rodrigues Parameters (MRPs): attitude, shadow set and kinematics.

Conventions (paper eqs. 1-3 and 12):

* ``sigma_bn`` is the MRP of the body frame B relative to the inertial frame N,
  ``sigma = e_hat * tan(Phi / 4)``.
* ``dcm_from_mrp(sigma_bn)`` is ``C_BN``: it maps inertial components to body
  components (``v_B = C_BN v_N``).
* Quaternions are scalar-last ``(x, y, z, w)`` as in ROS and SciPy, and describe the
  body orientation in the inertial frame (``Rotation.from_mrp(sigma_bn).as_quat()``).
* Angular rates ``omega`` are body rates relative to N in body components, rad/s.

Every function accepts a single 3-vector or a stack ``(..., 3)``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from attitude_core.kernels import compiled as _K

__all__ = [
    "skew",
    "dcm_from_mrp",
    "dcm_from_mrp_single",
    "dcm_rows_from_mrp",
    "mrp_rate_single",
    "shadow",
    "to_principal",
    "b_matrix",
    "mrp_rate",
    "omega_from_mrp_rate",
    "omega_from_mrp_rate_single",
    "compose",
    "relative",
    "angle_between_single",
    "relative_single",
    "relative_euler_single",
    "quat_from_mrp",
    "quat_from_mrp_single",
    "mrp_from_quat",
    "mrp_from_quat_single",
    "principal_angle",
    "quat_mul_sf",
    "quat_sf_from_mrp",
    "mrp_from_quat_sf",
    "Vec3",
    "Vec3Like",
]

_Floats = npt.NDArray[np.float64]

Vec3 = tuple[float, float, float]
"""A 3-vector in plain floats (the per-step hot paths)."""
Vec3Like = Sequence[float] | npt.NDArray[np.float64]
"""One 3-vector as plain floats or an array (what the ``*_single`` functions index)."""


def cross3(a: npt.ArrayLike, b: npt.ArrayLike) -> _Floats:
    """``a x b`` over the last axis of two (broadcast) arrays of 3-vectors: the
    products and differences ``numpy.cross`` computes, so the same bits, without its
    axis handling (a third of its time on the geometry's hot paths)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)


def skew(v: npt.ArrayLike) -> _Floats:
    """Skew-symmetric cross-product matrix ``[v x]`` (``skew(a) @ b == cross(a, b)``)."""
    v = np.asarray(v, dtype=float)
    z = np.zeros(v.shape[:-1])
    x, y, w = v[..., 0], v[..., 1], v[..., 2]
    return np.stack(
        [np.stack([z, -w, y], -1), np.stack([w, z, -x], -1), np.stack([-y, x, z], -1)], -2
    )


def dcm_from_mrp(sigma: npt.ArrayLike) -> _Floats:
    """Direction cosine matrix ``C_BN(sigma_bn)``.

    ``C = I + (8 [s x]^2 - 4 (1 - s.s) [s x]) / (1 + s.s)^2``.
    """
    sigma = np.asarray(sigma, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None, None]
    sx = skew(sigma)
    eye = np.eye(3)
    return eye + (8.0 * sx @ sx - 4.0 * (1.0 - s2) * sx) / (1.0 + s2) ** 2


def dcm_rows_from_mrp(sigma: Vec3Like) -> tuple[Vec3, Vec3, Vec3]:
    """Rows of ``C_BN`` for one MRP set as plain float tuples (per-step hot paths).

    Same formula as :func:`dcm_from_mrp`:
    ``C = I + (8 (s s^T - s.s I) - 4 (1 - s.s) [s x]) / (1 + s.s)^2``.
    """
    s1, s2, s3 = float(sigma[0]), float(sigma[1]), float(sigma[2])
    ss = s1 * s1 + s2 * s2 + s3 * s3
    k8 = 8.0 / (1.0 + ss) ** 2
    k4 = 4.0 * (1.0 - ss) / (1.0 + ss) ** 2
    return (
        (1.0 + k8 * (s1 * s1 - ss), k8 * s1 * s2 + k4 * s3, k8 * s1 * s3 - k4 * s2),
        (k8 * s2 * s1 - k4 * s3, 1.0 + k8 * (s2 * s2 - ss), k8 * s2 * s3 + k4 * s1),
        (k8 * s3 * s1 + k4 * s2, k8 * s3 * s2 - k4 * s1, 1.0 + k8 * (s3 * s3 - ss)),
    )


def dcm_from_mrp_single(sigma: Vec3Like) -> _Floats:
    """``C_BN`` for one MRP set as a (3, 3) array (see :func:`dcm_rows_from_mrp`)."""
    return np.array(dcm_rows_from_mrp(sigma))


def shadow(sigma: npt.ArrayLike) -> _Floats:
    """Shadow MRP set ``sigma^S = -sigma / (sigma^T sigma)`` (eq. 2); same attitude."""
    sigma = np.asarray(sigma, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None]
    return -sigma / s2


def to_principal(sigma: npt.ArrayLike) -> _Floats:
    """Return the MRP set with ``|sigma| <= 1`` (switch to the shadow set when longer)."""
    sigma = np.asarray(sigma, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None]
    return np.where(s2 > 1.0, -sigma / np.where(s2 > 0.0, s2, 1.0), sigma)


def b_matrix(sigma: npt.ArrayLike) -> _Floats:
    """Kinematic matrix ``B(sigma) = (1 - s.s) I + 2 [s x] + 2 s s^T`` (eq. 3)."""
    sigma = np.asarray(sigma, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None, None]
    b: _Floats = (
        (1.0 - s2) * np.eye(3) + 2.0 * skew(sigma) + 2.0 * sigma[..., :, None] * sigma[..., None, :]
    )
    return b


def mrp_rate(sigma: npt.ArrayLike, omega: npt.ArrayLike) -> _Floats:
    """MRP rate ``sigma_dot = B(sigma) omega / 4`` (eq. 3), omega in body axes, rad/s."""
    sigma = np.asarray(sigma, dtype=float)
    omega = np.asarray(omega, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None]
    sw: _Floats = np.einsum("...i,...i->...", sigma, omega)[..., None]
    rate: _Floats = 0.25 * ((1.0 - s2) * omega + 2.0 * cross3(sigma, omega) + 2.0 * sigma * sw)
    return rate


def omega_from_mrp_rate(sigma: npt.ArrayLike, sigma_dot: npt.ArrayLike) -> _Floats:
    """Body rate from the MRP rate, ``omega = 4 B^T sigma_dot / (1 + s.s)^2`` (eq. 12).

    Uses ``B^T B = (1 + s.s)^2 I``, so this is the exact inverse of :func:`mrp_rate`.
    """
    sigma = np.asarray(sigma, dtype=float)
    sd = np.asarray(sigma_dot, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None]
    ssd: _Floats = np.einsum("...i,...i->...", sigma, sd)[..., None]
    bt_sd: _Floats = (1.0 - s2) * sd - 2.0 * cross3(sigma, sd) + 2.0 * sigma * ssd
    return 4.0 * bt_sd / (1.0 + s2) ** 2


def mrp_rate_single(sigma: Vec3, omega: Vec3) -> Vec3:
    """Eq. 3 for one MRP set in plain floats: ``sigma_dot = B(sigma) omega / 4`` (tuple)."""
    s1, s2, s3 = sigma
    w1, w2, w3 = omega
    ss = s1 * s1 + s2 * s2 + s3 * s3
    sw = s1 * w1 + s2 * w2 + s3 * w3
    a = 1.0 - ss
    return (
        0.25 * (a * w1 + 2.0 * (s2 * w3 - s3 * w2) + 2.0 * s1 * sw),
        0.25 * (a * w2 + 2.0 * (s3 * w1 - s1 * w3) + 2.0 * s2 * sw),
        0.25 * (a * w3 + 2.0 * (s1 * w2 - s2 * w1) + 2.0 * s3 * sw),
    )


def omega_from_mrp_rate_single(sigma: Vec3Like, sigma_dot: Vec3Like) -> _Floats:
    """Eq. 12 for one MRP set, in plain floats (hot path of the planner)."""
    s1, s2, s3 = float(sigma[0]), float(sigma[1]), float(sigma[2])
    d1, d2, d3 = float(sigma_dot[0]), float(sigma_dot[1]), float(sigma_dot[2])
    ss = s1 * s1 + s2 * s2 + s3 * s3
    sd = s1 * d1 + s2 * d2 + s3 * d3
    k = 4.0 / (1.0 + ss) ** 2
    a = 1.0 - ss
    return np.array(
        [
            k * (a * d1 - 2.0 * (s2 * d3 - s3 * d2) + 2.0 * s1 * sd),
            k * (a * d2 - 2.0 * (s3 * d1 - s1 * d3) + 2.0 * s2 * sd),
            k * (a * d3 - 2.0 * (s1 * d2 - s2 * d1) + 2.0 * s3 * sd),
        ]
    )


def relative_euler_single(sigma_bn: Vec3Like, sigma_rn: Vec3Like) -> tuple[float, ...]:
    """Euler parameters ``(w, v1, v2, v3)`` of ``q_B/R = q_B (x) q_R^*`` (passive),
    unnormalised: computed from ``(1 - s.s, 2 s)`` of each MRP, so their norm is
    ``(1 + |sigma_bn|^2)(1 + |sigma_rn|^2)`` (plain floats, the hot paths' common core)."""
    r1, r2, r3 = float(sigma_rn[0]), float(sigma_rn[1]), float(sigma_rn[2])
    b1, b2, b3 = float(sigma_bn[0]), float(sigma_bn[1]), float(sigma_bn[2])
    r0 = 1.0 - (r1 * r1 + r2 * r2 + r3 * r3)
    b0 = 1.0 - (b1 * b1 + b2 * b2 + b3 * b3)
    r1, r2, r3 = 2.0 * r1, 2.0 * r2, 2.0 * r3
    b1, b2, b3 = 2.0 * b1, 2.0 * b2, 2.0 * b3
    return (
        r0 * b0 + r1 * b1 + r2 * b2 + r3 * b3,
        r0 * b1 - b0 * r1 - (r2 * b3 - r3 * b2),
        r0 * b2 - b0 * r2 - (r3 * b1 - r1 * b3),
        r0 * b3 - b0 * r3 - (r1 * b2 - r2 * b1),
    )


def angle_between_single_reference(sigma_a: Vec3Like, sigma_b: Vec3Like) -> float:
    """Principal angle (rad, ``[0, pi]``) of the rotation between two attitudes, in plain
    floats (hot path; equals ``principal_angle(relative(sigma_a, sigma_b))``).

    With unit quaternions ``a``, ``b`` of the two MRPs, the relative rotation has
    ``w = a . b`` and vector part ``v = b0 a_v - a0 b_v - a_v x b_v``:
    ``theta = 2 atan2(|v|, |w|)``, accurate at small angles too.
    """
    a1, a2, a3 = float(sigma_a[0]), float(sigma_a[1]), float(sigma_a[2])
    b1, b2, b3 = float(sigma_b[0]), float(sigma_b[1]), float(sigma_b[2])
    sa = a1 * a1 + a2 * a2 + a3 * a3
    sb = b1 * b1 + b2 * b2 + b3 * b3
    # Unscaled quaternions (1 - s.s, 2 s); the common positive scale cancels in atan2.
    a0, b0 = 1.0 - sa, 1.0 - sb
    a1, a2, a3 = 2.0 * a1, 2.0 * a2, 2.0 * a3
    b1, b2, b3 = 2.0 * b1, 2.0 * b2, 2.0 * b3
    w = a0 * b0 + a1 * b1 + a2 * b2 + a3 * b3
    v1 = b0 * a1 - a0 * b1 - (a2 * b3 - a3 * b2)
    v2 = b0 * a2 - a0 * b2 - (a3 * b1 - a1 * b3)
    v3 = b0 * a3 - a0 * b3 - (a1 * b2 - a2 * b1)
    return 2.0 * math.atan2(math.sqrt(v1 * v1 + v2 * v2 + v3 * v3), abs(w))


def relative_single_reference(sigma_bn: Vec3Like, sigma_rn: Vec3Like) -> Vec3:
    """``sigma_B/R`` (short way, ``|sigma| <= 1``) in plain floats: the hot-path form of
    :func:`relative`, through :func:`relative_euler_single`."""
    w, v1, v2, v3 = relative_euler_single(sigma_bn, sigma_rn)
    b1, b2, b3 = float(sigma_bn[0]), float(sigma_bn[1]), float(sigma_bn[2])
    r1, r2, r3 = float(sigma_rn[0]), float(sigma_rn[1]), float(sigma_rn[2])
    sb = b1 * b1 + b2 * b2 + b3 * b3
    sr = r1 * r1 + r2 * r2 + r3 * r3
    norm = (1.0 + sb) * (1.0 + sr)
    k = 1.0 / (norm + w) if w >= 0.0 else -1.0 / (norm - w)
    return (v1 * k, v2 * k, v3 * k)


# The hot-path forms: the compiled kernels when built (attitude_core.kernels), else the references.
angle_between_single: Callable[[Vec3Like, Vec3Like], float] = (
    angle_between_single_reference if _K is None else _K.angle_between
)
relative_single: Callable[[Vec3Like, Vec3Like], Vec3] = (
    relative_single_reference if _K is None else _K.relative
)


def compose(sigma_outer: npt.ArrayLike, sigma_inner: npt.ArrayLike) -> _Floats:
    """MRP of ``C(sigma_outer) C(sigma_inner)``, e.g. ``sigma_BN = compose(sigma_BR, sigma_RN)``.

    Computed through quaternions so that it is defined for every pair (the closed MRP
    formula divides by zero for a 360 deg composite); the result has ``|sigma| <= 1``.
    """
    q = quat_mul_sf(quat_sf_from_mrp(sigma_outer), quat_sf_from_mrp(sigma_inner))
    return mrp_from_quat_sf(q)


def relative(sigma_bn: npt.ArrayLike, sigma_rn: npt.ArrayLike) -> _Floats:
    """Relative MRP ``sigma_B/R`` of frame B with respect to frame R, ``|sigma| <= 1``.

    ``C(sigma_B/R) = C_BN C_RN^T``; this is the paper's attitude error ``sigma_e``.
    """
    q_rn = quat_sf_from_mrp(sigma_rn)
    q_rn_conj = q_rn * np.array([1.0, -1.0, -1.0, -1.0])
    q = quat_mul_sf(quat_sf_from_mrp(sigma_bn), q_rn_conj)
    return mrp_from_quat_sf(q)


def quat_from_mrp(sigma_bn: npt.ArrayLike) -> _Floats:
    """Body orientation in the inertial frame as a unit quaternion ``(x, y, z, w)``, ``w >= 0``."""
    q = quat_sf_from_mrp(to_principal(sigma_bn))
    return np.concatenate([q[..., 1:], q[..., :1]], -1)


def mrp_from_quat(quat_xyzw: npt.ArrayLike) -> _Floats:
    """MRP ``sigma_bn`` (``|sigma| <= 1``) from a quaternion ``(x, y, z, w)``; normalises it."""
    q = np.asarray(quat_xyzw, dtype=float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    return mrp_from_quat_sf(np.concatenate([q[..., 3:], q[..., :3]], -1))


def quat_from_mrp_single(sigma_bn: Vec3Like) -> tuple[float, float, float, float]:
    """:func:`quat_from_mrp` of one MRP in plain floats (the nodes' per-message path):
    ``(x, y, z, w)``, ``w >= 0``."""
    s1, s2, s3 = float(sigma_bn[0]), float(sigma_bn[1]), float(sigma_bn[2])
    n2 = s1 * s1 + s2 * s2 + s3 * s3
    if n2 > 1.0:  # the shadow set, |sigma| <= 1
        s1, s2, s3 = -s1 / n2, -s2 / n2, -s3 / n2
        n2 = s1 * s1 + s2 * s2 + s3 * s3
    d = 1.0 + n2
    return (2.0 * s1 / d, 2.0 * s2 / d, 2.0 * s3 / d, (1.0 - n2) / d)


def mrp_from_quat_single(x: float, y: float, z: float, w: float) -> Vec3:
    """:func:`mrp_from_quat` of one quaternion ``(x, y, z, w)`` in plain floats (the
    nodes' per-message path); normalises it, ``|sigma| <= 1``."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    d = 1.0 + w
    return (x / d, y / d, z / d)


def principal_angle(sigma: npt.ArrayLike) -> _Floats:
    """Principal rotation angle in radians, in ``[0, pi]`` (short way)."""
    s: _Floats = np.linalg.norm(to_principal(sigma), axis=-1)
    return 4.0 * np.arctan(s)


# --- scalar-first quaternion helpers (q = [q0, q1, q2, q3]) ---------------------------


def quat_sf_from_mrp(sigma: npt.ArrayLike) -> _Floats:
    """Scalar-first Euler parameters ``[q0, q1, q2, q3]`` of ``C(sigma)`` (sign not normalised)."""
    sigma = np.asarray(sigma, dtype=float)
    s2: _Floats = np.einsum("...i,...i->...", sigma, sigma)[..., None]
    return np.concatenate([(1.0 - s2), 2.0 * sigma], -1) / (1.0 + s2)


def mrp_from_quat_sf(q: _Floats) -> _Floats:
    """MRP with ``|sigma| <= 1`` from scalar-first Euler parameters."""
    # Choose the sign with q0 >= 0 so that |sigma| <= 1.
    q = np.where(q[..., :1] < 0.0, -q, q)
    return q[..., 1:] / (1.0 + q[..., :1])


def quat_mul_sf(p: _Floats, q: _Floats) -> _Floats:
    """Scalar-first quaternion product for DCM composition: ``C(p (x) q) = C(p) C(q)``.

    With ``C`` the passive DCM of a scalar-first quaternion this is the Schaub & Junkins
    convention ``[p0 q0 - p.q, p0 q + q0 p - p x q]``.
    """
    p0, pv = p[..., :1], p[..., 1:]
    q0, qv = q[..., :1], q[..., 1:]
    w = p0 * q0 - np.einsum("...i,...i->...", pv, qv)[..., None]
    v = p0 * qv + q0 * pv - cross3(pv, qv)
    return np.concatenate([w, v], -1)
