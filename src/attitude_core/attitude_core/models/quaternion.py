"""Scalar-last Hamilton quaternions ``(x, y, z, w)`` in plain floats (the per-step paths).

Conventions (those of :mod:`attitude_core.models.mrp`): ``Rotation.from_quat(q) ==
Rotation.from_mrp(sigma_bn)``, i.e. the SciPy rotation of a quaternion is ``C_NB`` (body
to inertial). :func:`quat_mul` is the Hamilton product, the one of SciPy's composition:
``Rotation.from_quat(quat_mul(p, q)) == Rotation.from_quat(p) * Rotation.from_quat(q)``.
Shared by the sensor models (the world) and the MEKF (the flight software).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import Vec3Like

__all__ = ["Quat", "quat_mul", "quat_conj", "quat_from_rotvec", "rotvec_from_quat"]

_Floats = npt.NDArray[np.float64]

Quat = tuple[float, float, float, float]
"""A scalar-last quaternion ``(x, y, z, w)`` in plain floats (the per-step hot paths)."""


def quat_mul(p: Sequence[float] | _Floats, q: Sequence[float] | _Floats) -> Quat:
    """Hamilton product ``p (x) q`` of scalar-last quaternions (SciPy's ``P * Q``)."""
    px, py, pz, pw = float(p[0]), float(p[1]), float(p[2]), float(p[3])
    qx, qy, qz, qw = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    return (
        pw * qx + qw * px + py * qz - pz * qy,
        pw * qy + qw * py + pz * qx - px * qz,
        pw * qz + qw * pz + px * qy - py * qx,
        pw * qw - px * qx - py * qy - pz * qz,
    )


def quat_conj(q: Sequence[float] | _Floats) -> Quat:
    """Conjugate (the inverse of a unit quaternion)."""
    return (-float(q[0]), -float(q[1]), -float(q[2]), float(q[3]))


def quat_from_rotvec(v: Vec3Like) -> Quat:
    """Unit quaternion of the rotation vector ``v`` (rad), ``w >= 0`` for ``|v| <= pi``."""
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    angle = math.sqrt(x * x + y * y + z * z)
    half = 0.5 * angle
    if angle < 1e-6:
        k = 0.5 - angle * angle / 48.0  # sin(a/2)/a to O(a^4)
    else:
        k = math.sin(half) / angle
    return (k * x, k * y, k * z, math.cos(half))


def rotvec_from_quat(q: Sequence[float] | _Floats) -> tuple[float, float, float]:
    """Rotation vector (rad, ``|v| <= pi``) of a quaternion (any norm, either sign)."""
    x, y, z, w = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    if s == 0.0:
        return (0.0, 0.0, 0.0)
    k = 2.0 * math.atan2(s, w) / s  # atan2 is accurate at small angles too
    return (k * x, k * y, k * z)
