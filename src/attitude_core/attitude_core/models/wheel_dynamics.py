"""Hub and reaction wheels integrated together (eqs. 3-4 with the wheels' momentum).

State ``(sigma_BN, omega_B, Omega)``: the MRPs, the body rate (rad/s, body axes) and
the wheels' speeds relative to the body (rad/s). Inputs held over a step: the motor
torques ``u`` (N m, on the wheels) and the external torque ``L_B`` (N m, body axes).
With ``H_B = J omega + G Js Omega`` (:mod:`attitude_core.models.wheel_array`):

* ``J_hub omega_dot = L_B - omega x H_B - G u``, ``J_hub = J - G Js G^T``;
* ``Js_i (g_i . omega_dot + Omega_dot_i) = u_i``: ``Omega_dot = u / Js - G^T omega_dot``;
* ``sigma_dot`` by eq. 3.

:func:`rk4_step` is classical RK4 with the shadow switch (eq. 2), as
:func:`attitude_core.models.body_dynamics.rk4_step` for the body alone (the two agree
when every wheel's spin inertia tends to zero).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import cross3, mrp_rate
from attitude_core.models.wheel_array import WheelArray

__all__ = ["WheelBody", "state_derivative", "rk4_step"]

_Floats = npt.NDArray[np.float64]


class WheelBody:
    """The constant matrices of a spacecraft of inertia ``J`` with ``array``."""

    def __init__(self, inertia_kgm2: npt.ArrayLike, array: WheelArray) -> None:
        self.inertia: _Floats = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        self.array = array
        self.axes = array.axes
        self.spin_inertia = array.spin_inertia
        self.hub_inertia_inv: _Floats = np.asarray(
            np.linalg.inv(array.hub_inertia(self.inertia)), dtype=float
        )


def state_derivative(
    body: WheelBody,
    sigma: _Floats,
    omega: _Floats,
    speeds: _Floats,
    motor_torque: _Floats,
    external_b: _Floats,
) -> tuple[_Floats, _Floats, _Floats]:
    """``(sigma_dot, omega_dot, Omega_dot)`` of the module docstring."""
    g = body.axes
    h = body.inertia @ omega + g @ (body.spin_inertia * speeds)
    omega_dot = body.hub_inertia_inv @ (external_b - cross3(omega, h) - g @ motor_torque)
    speeds_dot = motor_torque / body.spin_inertia - g.T @ omega_dot
    return mrp_rate(sigma, omega), omega_dot, speeds_dot


def rk4_step(
    body: WheelBody,
    sigma: _Floats,
    omega: _Floats,
    speeds: _Floats,
    motor_torque: npt.ArrayLike,
    external_b: npt.ArrayLike,
    dt: float,
) -> tuple[_Floats, _Floats, _Floats]:
    """The state ``dt`` seconds later, ``u`` and ``L_B`` held (RK4; MRPs principal)."""
    u = np.asarray(motor_torque, dtype=float)
    ext = np.asarray(external_b, dtype=float)
    k1 = state_derivative(body, sigma, omega, speeds, u, ext)
    k2 = state_derivative(
        body, sigma + 0.5 * dt * k1[0], omega + 0.5 * dt * k1[1], speeds + 0.5 * dt * k1[2], u, ext
    )
    k3 = state_derivative(
        body, sigma + 0.5 * dt * k2[0], omega + 0.5 * dt * k2[1], speeds + 0.5 * dt * k2[2], u, ext
    )
    k4 = state_derivative(body, sigma + dt * k3[0], omega + dt * k3[1], speeds + dt * k3[2], u, ext)
    f = dt / 6.0
    s = sigma + f * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0])
    w = omega + f * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1])
    r = speeds + f * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2])
    ss = float(s @ s)
    if ss > 1.0:  # shadow switch, eq. 2
        s = -s / ss
    return s, w, r
