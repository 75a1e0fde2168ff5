"""The plant with a reaction wheel array: the hub and its wheels
(:mod:`attitude_core.models.wheel_dynamics`), the wheels' own limits and failures, and
the external torques (:mod:`attitude_core.world.disturbances`).

Each step the commanded motor torques become the applied ones (:meth:`WheelPlant.applied`):

* clipped to each wheel's ``max_torque_nm``;
* zero for a wheel at or above its speed limit when the command would spin it faster
  (the convention of Basilisk's ``reactionWheelStateEffector``);
* zero from a wheel's ``fails_at_s`` on (no friction is modelled: a failed wheel keeps
  its speed relative to an inertially still body).

They are held over the step with the external torque of its start (zero-order hold).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import to_principal
from attitude_core.models.wheel_array import WheelArray
from attitude_core.models.wheel_dynamics import WheelBody, rk4_step
from attitude_core.world.disturbances import Disturbances

__all__ = ["WheelStep", "WheelPlant"]

_Floats = npt.NDArray[np.float64]


@dataclass(frozen=True)
class WheelStep:
    """What one step applied: the motor torques (N m, per wheel), the body torque they
    made (``-G u``, body axes) and the external torque (body axes)."""

    motor_torque_nm: _Floats
    body_torque_b: _Floats
    external_b: _Floats


class WheelPlant:
    """A rigid hub with ``array`` (``inertia_kgm2`` the whole spacecraft's, wheels
    locked), state ``(sigma_bn, omega_b, speeds_rad_s)``."""

    def __init__(
        self,
        inertia_kgm2: npt.ArrayLike,
        array: WheelArray,
        sigma_bn: npt.ArrayLike,
        omega_b: npt.ArrayLike,
        disturbances: Disturbances | None = None,
    ) -> None:
        self.body = WheelBody(inertia_kgm2, array)
        self.array = array
        self.sigma_bn: _Floats = to_principal(np.asarray(sigma_bn, dtype=float))
        self.omega_b: _Floats = np.asarray(omega_b, dtype=float).copy()
        self.speeds: _Floats = array.initial_speed.copy()
        self.disturbances = disturbances
        self._fails_at = np.array(
            [np.inf if w.fails_at_s is None else w.fails_at_s for w in array.wheels]
        )

    def failed(self, t_s: float) -> npt.NDArray[np.bool_]:
        """The wheels failed at ``t_s``."""
        return t_s >= self._fails_at

    def applied(self, commanded_nm: npt.ArrayLike, t_s: float) -> _Floats:
        """The motor torques the wheels apply for ``commanded_nm`` at ``t_s``."""
        a = self.array
        u = np.clip(np.asarray(commanded_nm, dtype=float), -a.max_torque, a.max_torque)
        at_limit = (np.abs(self.speeds) >= a.max_speed) & (u * self.speeds > 0.0)
        u = np.where(at_limit | self.failed(t_s), 0.0, u)
        return u

    def system_momentum_b(self) -> _Floats:
        """``H_B`` (N m s, body axes) of the present state."""
        return self.array.system_momentum_b(self.body.inertia, self.omega_b, self.speeds)

    def step(self, commanded_nm: npt.ArrayLike, t_s: float, dt: float) -> WheelStep:
        """Advance from ``t_s`` by ``dt`` seconds with ``commanded_nm`` (RK4)."""
        u = self.applied(commanded_nm, t_s)
        if self.disturbances is None:
            external = np.zeros(3)
        else:
            external = self.disturbances.torque_b(t_s, self.sigma_bn)
        self.sigma_bn, self.omega_b, self.speeds = rk4_step(
            self.body, self.sigma_bn, self.omega_b, self.speeds, u, external, dt
        )
        return WheelStep(u, self.array.body_torque_b(u), external)
