"""The plant behind the bridge with a reaction wheel array: an interface and an RK4 model.

A hardware bridge implements :class:`WheelPlant` around its bench (send the motor torques
for ``dt`` seconds, then read back the attitude, the body rate, the wheel tachometers and
the motor torques the wheels applied); :class:`RK4WheelBody` is a stand-in that
integrates the hub and its wheels together, written from the contract
(docs/hil_bridge.md, "Reaction wheels") and docs/scenarios.md (``wheels.*``).

Conventions (body axes, SI): ``inertia_kgm2`` is the whole spacecraft's with the wheels
as if locked, so the hub the motors turn is ``J_hub = J - sum_i Js_i g_i g_i^T``. Wheel
``i`` spins about the unit axis ``g_i`` at ``Omega_i`` relative to the body; its motor
torque ``u_i`` acts on the wheel, ``-u_i g_i`` on the body. With
``H = J omega + sum_i g_i Js_i Omega_i`` (the system momentum in body axes):

* ``J_hub omega_dot = -omega x H - G u`` (no external torque);
* ``Omega_dot_i = u_i / Js_i - g_i . omega_dot``;
* ``q_dot = q (x) (omega, 0) / 2``, ``q = (x, y, z, w)`` the body in the inertial frame.

The commanded motor torque of a wheel becomes the applied one by the wheel's own limits
(:meth:`RK4WheelBody.applied`): clipped to ``max_torque_nm``; zero when the wheel is at or
above ``max_speed_rpm`` and the command would spin it faster; zero from ``fails_at_s`` on.
It is held over the step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple, Protocol

import numpy as np

RPM = 2.0 * math.pi / 60.0  # rad/s per rpm


class Wheel(NamedTuple):
    """One wheel as the scenario declares it (``wheels.<name>.*``), in SI units."""

    name: str
    spin_axis_body: tuple[float, float, float]  # unit
    max_torque_nm: float
    max_speed_rad_s: float
    spin_inertia_kgm2: float
    initial_speed_rad_s: float = 0.0
    fails_at_s: float = math.inf  # never


class WheelPlantState(NamedTuple):
    """Attitude ``q_bn_xyzw`` (x, y, z, w), body rate ``omega_b`` (rad/s), the wheels'
    speeds relative to the body (rad/s) and the motor torques they applied over the step
    that ended here (N m; zero at the first state), both in the wheels' order."""

    q_bn_xyzw: np.ndarray
    omega_b: np.ndarray
    speeds_rad_s: np.ndarray
    motor_torque_nm: np.ndarray


class WheelPlant(Protocol):
    """What the bridge needs from a plant with reaction wheels."""

    wheels: tuple[Wheel, ...]

    def applied(self, commanded_nm: np.ndarray, t_s: float) -> np.ndarray:
        """The motor torques the wheels apply, from now, for ``commanded_nm`` at ``t_s``
        (the scenario's time: since the first state)."""
        ...

    def body_torque(self, motor_torque_nm: np.ndarray) -> np.ndarray:
        """The torque on the body of the motor torques, ``-G u`` (N m, body axes)."""
        ...

    def step(self, commanded_nm: np.ndarray, t_s: float, dt: float) -> WheelPlantState:
        """Apply ``commanded_nm`` (as :meth:`applied`) from ``t_s`` for ``dt`` seconds; the
        new state."""
        ...

    def state(self) -> WheelPlantState:
        """The current state."""
        ...


def wheel_problem(inertia_kgm2: Sequence[float], wheels: Sequence[Wheel]) -> str | None:
    """Why these wheels cannot fly a spacecraft of ``inertia_kgm2`` (None: they can)."""
    names = [w.name for w in wheels]
    if not wheels or len(set(names)) != len(names):
        return f'wheels.names: at least one wheel, names unique; got {names}'
    for w in wheels:
        key = f'wheels.{w.name}'
        if abs(float(np.linalg.norm(w.spin_axis_body)) - 1.0) > 1e-12:
            return f'{key}.spin_axis_body: not a unit vector'
        for field in ('max_torque_nm', 'max_speed_rad_s', 'spin_inertia_kgm2'):
            value = getattr(w, field)
            if not (math.isfinite(value) and value > 0.0):
                return f'{key}.{field.replace("_rad_s", "_rpm")}: must be > 0, got {value}'
        if not abs(w.initial_speed_rad_s) <= w.max_speed_rad_s:
            return f'{key}.initial_speed_rpm: must be finite and within max_speed_rpm'
        if math.isnan(w.fails_at_s) or w.fails_at_s < 0.0:
            return f'{key}.fails_at_s: must be >= 0, got {w.fails_at_s}'
    axes = np.array([w.spin_axis_body for w in wheels], dtype=float).T
    if np.linalg.matrix_rank(axes, tol=1e-6) < 3:
        return 'wheels: the spin axes must span the three body axes'
    hub = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
    hub = hub - (axes * [w.spin_inertia_kgm2 for w in wheels]) @ axes.T
    if np.linalg.eigvalsh(0.5 * (hub + hub.T))[0] <= 0.0:
        return 'wheels: the spin inertia is not smaller than inertia_kgm2 (wheels locked)'
    return None


class RK4WheelBody:
    """Hub and wheels integrated together by classical RK4 over each step (the state
    ``(q, omega, Omega)``; the quaternion renormalised after the step)."""

    def __init__(self, inertia_kgm2, wheels: Sequence[Wheel], q_bn_xyzw, omega_b) -> None:
        self.wheels = tuple(wheels)
        self.inertia = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        self.axes = np.array([w.spin_axis_body for w in self.wheels], dtype=float).T  # G, 3 x N
        self.spin = np.array([w.spin_inertia_kgm2 for w in self.wheels])
        self.max_torque = np.array([w.max_torque_nm for w in self.wheels])
        self.max_speed = np.array([w.max_speed_rad_s for w in self.wheels])
        self.fails_at = np.array([w.fails_at_s for w in self.wheels])
        self.hub_inv = np.linalg.inv(self.inertia - (self.axes * self.spin) @ self.axes.T)
        q = np.asarray(q_bn_xyzw, dtype=float)
        self.q = q / np.linalg.norm(q)
        self.omega = np.asarray(omega_b, dtype=float).copy()
        self.speeds = np.array([w.initial_speed_rad_s for w in self.wheels])
        self.motor = np.zeros(len(self.wheels))

    def applied(self, commanded_nm: np.ndarray, t_s: float) -> np.ndarray:
        u = np.clip(np.asarray(commanded_nm, dtype=float), -self.max_torque, self.max_torque)
        faster = (np.abs(self.speeds) >= self.max_speed) & (u * self.speeds > 0.0)
        return np.where(faster | (t_s >= self.fails_at), 0.0, u)

    def body_torque(self, motor_torque_nm: np.ndarray) -> np.ndarray:
        return -(self.axes @ np.asarray(motor_torque_nm, dtype=float))

    def _rhs(
        self, q: np.ndarray, w: np.ndarray, speeds: np.ndarray, u: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        h = self.inertia @ w + self.axes @ (self.spin * speeds)
        w_dot = self.hub_inv @ (-np.cross(w, h) - self.axes @ u)
        speeds_dot = u / self.spin - self.axes.T @ w_dot
        qv, qw = q[:3], q[3]
        q_dot = np.append(0.5 * (qw * w + np.cross(qv, w)), -0.5 * (qv @ w))
        return q_dot, w_dot, speeds_dot

    def step(self, commanded_nm: np.ndarray, t_s: float, dt: float) -> WheelPlantState:
        u = self.applied(commanded_nm, t_s)
        q0, w0, s0 = self.q, self.omega, self.speeds
        q1, w1, s1 = self._rhs(q0, w0, s0, u)
        q2, w2, s2 = self._rhs(q0 + 0.5 * dt * q1, w0 + 0.5 * dt * w1, s0 + 0.5 * dt * s1, u)
        q3, w3, s3 = self._rhs(q0 + 0.5 * dt * q2, w0 + 0.5 * dt * w2, s0 + 0.5 * dt * s2, u)
        q4, w4, s4 = self._rhs(q0 + dt * q3, w0 + dt * w3, s0 + dt * s3, u)
        f = dt / 6.0
        q = q0 + f * (q1 + 2.0 * q2 + 2.0 * q3 + q4)
        self.omega = w0 + f * (w1 + 2.0 * w2 + 2.0 * w3 + w4)
        self.speeds = s0 + f * (s1 + 2.0 * s2 + 2.0 * s3 + s4)
        self.q, self.motor = q / np.linalg.norm(q), u
        return self.state()

    def state(self) -> WheelPlantState:
        return WheelPlantState(
            self.q.copy(), self.omega.copy(), self.speeds.copy(), self.motor.copy()
        )
