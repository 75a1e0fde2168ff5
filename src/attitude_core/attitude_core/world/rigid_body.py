"""Rigid-body attitude dynamics: Euler's equation (eq. 4) and MRP kinematics (eq. 3).

State ``x = (sigma_bn, omega_b)``; torque ``u`` in body axes, N m, held constant over a
step (zero-order hold). Integration is classical RK4; after each step the MRP set is
switched to its shadow when ``|sigma| > 1`` (eq. 2), so ``|sigma_bn| <= 1`` always.
:meth:`RigidBody.step` runs the compiled kernel (:mod:`attitude_core.kernels`,
``kernels/rigid_body.pxi``); :meth:`RigidBody.step_reference` is its reference, the
same operations in Python.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.models.mrp import Vec3, Vec3Like, mrp_rate_single, to_principal

__all__ = ["RigidBody"]

_Floats = npt.NDArray[np.float64]


class RigidBody:
    """Torque-driven rigid body with inertia ``J`` (kg m^2, body axes)."""

    def __init__(
        self, inertia_kgm2: npt.ArrayLike, sigma_bn: npt.ArrayLike, omega_b: npt.ArrayLike
    ) -> None:
        self.inertia: _Floats = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        self.inertia_inv = np.linalg.inv(self.inertia)
        self.sigma_bn: _Floats = to_principal(np.asarray(sigma_bn, dtype=float))
        self.omega_b: _Floats = np.asarray(omega_b, dtype=float).copy()
        self._j_rows = tuple(map(tuple, self.inertia.tolist()))
        self._ji_rows = tuple(map(tuple, self.inertia_inv.tolist()))
        self.inertia_flat = tuple(self.inertia.ravel().tolist())
        self.inertia_inv_flat = tuple(self.inertia_inv.ravel().tolist())
        self._kernels = kernels.compiled  # those selected when the body is made

    def step(self, torque_b: Vec3Like, dt: float) -> None:
        """Advance by ``dt`` seconds with torque ``torque_b`` held constant (RK4)."""
        k = self._kernels
        if k is None:
            self.step_reference(torque_b, dt)
            return
        sigma, omega = k.rk4_step(
            self.inertia_flat, self.inertia_inv_flat, self.sigma_bn, self.omega_b, torque_b, dt
        )
        self.sigma_bn = np.array(sigma)
        self.omega_b = np.array(omega)

    def step_reference(self, torque_b: Vec3Like, dt: float) -> None:
        """:meth:`step` in Python: advance by ``dt`` seconds with ``torque_b`` held (RK4).

        Written in plain floats (one body per call is the hot path of every run);
        :func:`attitude_core.models.body_dynamics.rk4_step` is the array form of the same equations.
        """
        j = self._j_rows
        ji = self._ji_rows
        u = (float(torque_b[0]), float(torque_b[1]), float(torque_b[2]))

        def deriv(s: Vec3, w: Vec3) -> tuple[Vec3, Vec3]:
            w1, w2, w3 = w
            h1 = j[0][0] * w1 + j[0][1] * w2 + j[0][2] * w3
            h2 = j[1][0] * w1 + j[1][1] * w2 + j[1][2] * w3
            h3 = j[2][0] * w1 + j[2][1] * w2 + j[2][2] * w3
            r1 = u[0] - (w2 * h3 - w3 * h2)
            r2 = u[1] - (w3 * h1 - w1 * h3)
            r3 = u[2] - (w1 * h2 - w2 * h1)
            wd = (
                ji[0][0] * r1 + ji[0][1] * r2 + ji[0][2] * r3,
                ji[1][0] * r1 + ji[1][1] * r2 + ji[1][2] * r3,
                ji[2][0] * r1 + ji[2][1] * r2 + ji[2][2] * r3,
            )
            return mrp_rate_single(s, w), wd

        def add(x: Vec3, k: Vec3, f: float) -> Vec3:
            return (x[0] + f * k[0], x[1] + f * k[1], x[2] + f * k[2])

        s0 = tuple(self.sigma_bn.tolist())
        w0 = tuple(self.omega_b.tolist())
        k1s, k1w = deriv(s0, w0)
        k2s, k2w = deriv(add(s0, k1s, 0.5 * dt), add(w0, k1w, 0.5 * dt))
        k3s, k3w = deriv(add(s0, k2s, 0.5 * dt), add(w0, k2w, 0.5 * dt))
        k4s, k4w = deriv(add(s0, k3s, dt), add(w0, k3w, dt))
        f = dt / 6.0
        sigma = [s0[i] + f * (k1s[i] + 2.0 * k2s[i] + 2.0 * k3s[i] + k4s[i]) for i in range(3)]
        omega = [w0[i] + f * (k1w[i] + 2.0 * k2w[i] + 2.0 * k3w[i] + k4w[i]) for i in range(3)]
        ss = sigma[0] ** 2 + sigma[1] ** 2 + sigma[2] ** 2
        if ss > 1.0:  # shadow switch, eq. 2
            sigma = [-x / ss for x in sigma]
        self.sigma_bn = np.array(sigma)
        self.omega_b = np.array(omega)

    def kinetic_energy(self) -> float:
        """Rotational kinetic energy ``omega^T J omega / 2``, J."""
        return 0.5 * float(self.omega_b @ self.inertia @ self.omega_b)
