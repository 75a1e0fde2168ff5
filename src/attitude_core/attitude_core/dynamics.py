"""Rigid-body attitude dynamics: Euler's equation (eq. 4) and MRP kinematics (eq. 3).

State ``x = (sigma_bn, omega_b)``; torque ``u`` in body axes, N m, held constant over a
step (zero-order hold). Integration is classical RK4; after each step the MRP set is
switched to its shadow when ``|sigma| > 1`` (eq. 2), so ``|sigma_bn| <= 1`` always.
"""

from __future__ import annotations

import numpy as np

from .mrp import mrp_rate, to_principal

__all__ = ["RigidBody", "state_derivative"]


def state_derivative(inertia, inertia_inv, sigma, omega, torque):
    """``(sigma_dot, omega_dot)`` with ``J omega_dot = -omega x J omega + u`` (eq. 4)."""
    omega_dot = inertia_inv @ (torque - np.cross(omega, inertia @ omega))
    return mrp_rate(sigma, omega), omega_dot


class RigidBody:
    """Torque-driven rigid body with inertia ``J`` (kg m^2, body axes)."""

    def __init__(self, inertia_kgm2, sigma_bn, omega_b) -> None:
        self.inertia = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        self.inertia_inv = np.linalg.inv(self.inertia)
        self.sigma_bn = to_principal(np.asarray(sigma_bn, dtype=float))
        self.omega_b = np.asarray(omega_b, dtype=float).copy()

    def step(self, torque_b, dt: float) -> None:
        """Advance by ``dt`` seconds with torque ``torque_b`` held constant (RK4)."""
        u = np.asarray(torque_b, dtype=float)
        j, ji = self.inertia, self.inertia_inv
        s0, w0 = self.sigma_bn, self.omega_b
        k1s, k1w = state_derivative(j, ji, s0, w0, u)
        k2s, k2w = state_derivative(j, ji, s0 + 0.5 * dt * k1s, w0 + 0.5 * dt * k1w, u)
        k3s, k3w = state_derivative(j, ji, s0 + 0.5 * dt * k2s, w0 + 0.5 * dt * k2w, u)
        k4s, k4w = state_derivative(j, ji, s0 + dt * k3s, w0 + dt * k3w, u)
        sigma = s0 + dt / 6.0 * (k1s + 2.0 * k2s + 2.0 * k3s + k4s)
        self.omega_b = w0 + dt / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w)
        self.sigma_bn = to_principal(sigma)

    def kinetic_energy(self) -> float:
        """Rotational kinetic energy ``omega^T J omega / 2``, J."""
        return 0.5 * float(self.omega_b @ self.inertia @ self.omega_b)
