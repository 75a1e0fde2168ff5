"""The reference physics of one step: :class:`attitude_core.world.rigid_body.RigidBody` over ``dt``
with the torque held, started from the bridge's own state, and the errors against the
bridge's next state."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import mrp_from_quat, quat_from_mrp
from attitude_core.world.rigid_body import RigidBody

ATTITUDE_TOL_RAD = 1e-6
RATE_TOL_RAD_S = 1e-8


def rotation_angle(q_a: npt.ArrayLike, q_b: npt.ArrayLike) -> float:
    """Angle (rad) of the rotation between two quaternions, either sign, well conditioned
    for small angles."""
    a, b = np.asarray(q_a, dtype=float), np.asarray(q_b, dtype=float)
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    if float(a @ b) < 0.0:
        b = -b
    return 4.0 * math.atan2(float(np.linalg.norm(a - b)), float(np.linalg.norm(a + b)))


def propagate(
    inertia: np.ndarray,
    quat_xyzw: npt.ArrayLike,
    omega: npt.ArrayLike,
    torque: npt.ArrayLike,
    dt_s: float,
) -> tuple[np.ndarray, np.ndarray]:
    """The state (quaternion ``(x, y, z, w)``, rate) after ``dt_s`` with ``torque`` held."""
    body = RigidBody(inertia, mrp_from_quat(quat_xyzw), omega)
    body.step(np.asarray(torque, dtype=float), dt_s)
    return quat_from_mrp(body.sigma_bn), body.omega_b


def step_errors(
    inertia: np.ndarray, before: tuple, after: tuple, torque: npt.ArrayLike, dt_s: float
) -> tuple[float, float]:
    """(attitude error rad, rate error rad/s) of ``after`` against ``before`` propagated
    with ``torque``; states are ``(quaternion, rate)`` pairs."""
    q, w = propagate(inertia, before[0], before[1], torque, dt_s)
    return rotation_angle(q, after[0]), float(np.linalg.norm(w - np.asarray(after[1])))


def matches(errors: tuple[float, float]) -> bool:
    return errors[0] <= ATTITUDE_TOL_RAD and errors[1] <= RATE_TOL_RAD_S
