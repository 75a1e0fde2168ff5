"""The plant behind the bridge: a generic interface and one SciPy rigid body.

A hardware bridge implements :class:`Plant` around its hardware (apply the torque for
``dt`` seconds, read the attitude and rate back); :class:`ScipyRigidBody` is a stand-in
that integrates the rigid-body equations with ``scipy.integrate.solve_ivp``.

Conventions: ``q_bn_xyzw`` is the body orientation in the inertial frame as a unit
quaternion (x, y, z, w), Hamilton product, rotating body vectors into inertial ones;
``omega_b`` is omega_BN in body axes, rad/s; torques are body axes, N m.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

import numpy as np
from scipy.integrate import solve_ivp


class PlantState(NamedTuple):
    """Attitude ``q_bn_xyzw`` (x, y, z, w; unit norm, either sign) and rate ``omega_b``."""

    q_bn_xyzw: np.ndarray
    omega_b: np.ndarray


class Plant(Protocol):
    """What the bridge needs from a plant."""

    def step(self, torque_b: np.ndarray, dt: float) -> PlantState:
        """Apply ``torque_b`` (held constant) for ``dt`` seconds; return the new state."""
        ...

    def state(self) -> PlantState:
        """The current state."""
        ...


class ScipyRigidBody:
    """Rigid body: Euler's equation ``J w' = -w x J w + u`` and quaternion kinematics
    ``q' = q (x) (w, 0) / 2``, integrated by ``solve_ivp`` (DOP853, rtol 1e-10,
    atol 1e-12) with the torque held over the step; the quaternion is renormalised."""

    def __init__(self, inertia_kgm2, q_bn_xyzw, omega_b) -> None:
        self.inertia = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        self.inertia_inv = np.linalg.inv(self.inertia)
        q = np.asarray(q_bn_xyzw, dtype=float)
        self.x = np.concatenate([q / np.linalg.norm(q), np.asarray(omega_b, dtype=float)])

    def _rhs(self, _t: float, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        qv, qw, w = x[:3], x[3], x[4:]
        q_dot_v = 0.5 * (qw * w + np.cross(qv, w))
        q_dot_w = -0.5 * qv @ w
        w_dot = self.inertia_inv @ (u - np.cross(w, self.inertia @ w))
        return np.concatenate([q_dot_v, [q_dot_w], w_dot])

    def step(self, torque_b: np.ndarray, dt: float) -> PlantState:
        u = np.asarray(torque_b, dtype=float)
        sol = solve_ivp(
            self._rhs, (0.0, dt), self.x, method='DOP853', rtol=1e-10, atol=1e-12, args=(u,)
        )
        if not sol.success:
            raise RuntimeError(f'integration failed: {sol.message}')
        x = sol.y[:, -1]
        x[:4] /= np.linalg.norm(x[:4])
        self.x = x
        return self.state()

    def state(self) -> PlantState:
        return PlantState(self.x[:4].copy(), self.x[4:].copy())
