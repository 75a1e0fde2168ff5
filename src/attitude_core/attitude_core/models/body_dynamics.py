"""The rigid body's equations, shared by the world's plant and the flight software's model.

Euler's equation (eq. 4) ``J omega_dot = -omega x J omega + u`` and the MRP kinematics
(eq. 3), state ``(sigma_BN, omega_B)``, torque ``u`` in body axes, N m.
:func:`rk4_step` advances the state by one step with ``u`` held (zero-order hold) and
switches to the shadow set when ``|sigma| > 1`` (eq. 2): the array form of the plant's
step (:meth:`attitude_core.world.rigid_body.RigidBody.step_reference`), which the flight
software's state predictor (:mod:`attitude_core.fsw.fdir.state_predictor`) flies on
when no state comes.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import cross3, mrp_rate

__all__ = ["state_derivative", "rk4_step"]

_Floats = npt.NDArray[np.float64]


def state_derivative(
    inertia: _Floats, inertia_inv: _Floats, sigma: _Floats, omega: _Floats, torque: _Floats
) -> tuple[_Floats, _Floats]:
    """``(sigma_dot, omega_dot)`` with ``J omega_dot = -omega x J omega + u`` (eq. 4)."""
    omega_dot = inertia_inv @ (torque - cross3(omega, inertia @ omega))
    return mrp_rate(sigma, omega), omega_dot


def rk4_step(
    inertia: _Floats,
    inertia_inv: _Floats,
    sigma: _Floats,
    omega: _Floats,
    torque: _Floats,
    dt: float,
) -> tuple[_Floats, _Floats]:
    """The state ``dt`` seconds later with ``torque`` held (classical RK4, eqs. 3-4),
    MRPs on the principal set (eq. 2)."""
    u = np.asarray(torque, dtype=float)
    k1s, k1w = state_derivative(inertia, inertia_inv, sigma, omega, u)
    k2s, k2w = state_derivative(
        inertia, inertia_inv, sigma + 0.5 * dt * k1s, omega + 0.5 * dt * k1w, u
    )
    k3s, k3w = state_derivative(
        inertia, inertia_inv, sigma + 0.5 * dt * k2s, omega + 0.5 * dt * k2w, u
    )
    k4s, k4w = state_derivative(inertia, inertia_inv, sigma + dt * k3s, omega + dt * k3w, u)
    s = sigma + dt / 6.0 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s)
    w = omega + dt / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
    ss = float(s @ s)
    if ss > 1.0:
        s = -s / ss
    return s, w
