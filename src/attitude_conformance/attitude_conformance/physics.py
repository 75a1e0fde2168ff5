"""The reference physics of one step: :class:`attitude_core.world.rigid_body.RigidBody` over ``dt``
with the torque held, started from the bridge's own state, and the errors against the
bridge's next state. With a wheel array (``wheels.*``) :func:`reference` steps
:class:`attitude_core.world.wheel_plant.WheelPlant` instead, from the bridge's attitude,
rate and wheel speeds, with the commanded motor torques (which it clips, refuses at the
speed limit and zeroes for a failed wheel, as the contract says a wheel does); no external
torque."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import mrp_from_quat, quat_from_mrp
from attitude_core.world.rigid_body import RigidBody
from attitude_core.world.wheel_plant import WheelPlant

from .record import Setup

ATTITUDE_TOL_RAD = 1e-6
RATE_TOL_RAD_S = 1e-8
SPEED_TOL_RAD_S = 1e-6  # the wheel speeds (hundreds of rad/s; one step moves them ~10)


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


def matches(errors: tuple[float, ...]) -> bool:
    """The attitude and the rate within tolerance (the wheel speeds are the wheels point's)."""
    return errors[0] <= ATTITUDE_TOL_RAD and errors[1] <= RATE_TOL_RAD_S


class Reference(NamedTuple):
    """One step of the reference physics against the bridge's next state: the errors
    (attitude rad, rate rad/s, and with wheels the worst wheel speed rad/s, else 0), the
    body torque applied over the step and, with wheels, the motor torques applied."""

    errors: tuple[float, float, float]
    body: np.ndarray
    motor: np.ndarray | None = None
    speeds: np.ndarray | None = None  # with wheels: the wheel speeds at the step's end


StateValues = tuple[Sequence[float], Sequence[float], Sequence[float] | None]
"""A state as the reference takes it: quaternion ``(x, y, z, w)``, rate, wheel speeds
(scenario's wheel order; None without a wheel state)."""


def reference(
    setup: Setup, before: StateValues, after: StateValues, command: npt.ArrayLike, t_s: float
) -> Reference:
    """``before`` propagated over ``dt`` with ``command`` (the body torque, or with wheels
    the commanded motor torques at the scenario time ``t_s``) against ``after``."""
    if setup.wheels is None:
        u = np.asarray(command, dtype=float)
        att, rate = step_errors(setup.inertia, before[:2], after[:2], u, setup.dt_s)
        return Reference((att, rate, 0.0), u)
    if before[2] is None:
        raise ValueError("a wheel step needs the wheel speeds of the state it starts from")
    plant = WheelPlant(setup.inertia, setup.wheels, mrp_from_quat(before[0]), before[1])
    plant.speeds = np.array(before[2], dtype=float)
    step = plant.step(command, t_s, setup.dt_s)
    att = rotation_angle(quat_from_mrp(plant.sigma_bn), after[0])
    rate = float(np.linalg.norm(plant.omega_b - np.asarray(after[1])))
    speeds = math.inf if after[2] is None else float(np.max(np.abs(plant.speeds - after[2])))
    return Reference((att, rate, speeds), step.body_torque_b, step.motor_torque_nm, plant.speeds)
