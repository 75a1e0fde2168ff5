"""External torques on the spacecraft (``disturbances.*``), body axes, N m.

* Gravity gradient (``disturbances.gravity_gradient: true``, needs ``orbit.*``):
  ``L_B = 3 mu / R^5 (r_B x J r_B)``, ``r_B = C_BN r_N`` the spacecraft's geocentric
  position in body axes (m), ``mu`` the Earth's (two-body orbit of
  :class:`attitude_core.models.ephemeris.Orbit`). At 500 km it is about 1.8e-6 N m per
  kg m^2 of inertia difference at 45 deg.
* A constant torque (``disturbances.constant_torque_nm``), body axes.

:meth:`Disturbances.torque_b` is evaluated at the start of a step and held over it, as
the motor torques are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.models.ephemeris import MU_EARTH_KM3_S2, Orbit
from attitude_core.models.mrp import dcm_from_mrp

__all__ = ["MU_EARTH_M3_S2", "gravity_gradient_b", "Disturbances"]

MU_EARTH_M3_S2 = MU_EARTH_KM3_S2 * 1.0e9

_Floats = npt.NDArray[np.float64]


def gravity_gradient_b(
    position_n_m: npt.ArrayLike, sigma_bn: npt.ArrayLike, inertia_kgm2: npt.ArrayLike
) -> _Floats:
    """The gravity-gradient torque (N m, body axes) on a body of inertia ``J`` at the
    geocentric position ``r_N`` (m, inertial) with attitude ``sigma_BN``."""
    r_b = dcm_from_mrp(sigma_bn) @ np.asarray(position_n_m, dtype=float)
    j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
    radius = float(np.linalg.norm(r_b))
    torque: _Floats = 3.0 * MU_EARTH_M3_S2 / radius**5 * np.cross(r_b, j @ r_b)
    return torque


@dataclass(frozen=True)
class Disturbances:
    """The declared external torques of a spacecraft of inertia ``inertia_kgm2``:
    gravity gradient on ``orbit`` (None: off) and ``constant_b`` (N m)."""

    inertia_kgm2: tuple[float, ...]
    orbit: Orbit | None = None
    constant_b: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def torque_b(self, t_s: float, sigma_bn: npt.ArrayLike) -> _Floats:
        """The external torque at ``t_s`` (s after the epoch) and attitude ``sigma_BN``."""
        torque = np.array(self.constant_b, dtype=float)
        if self.orbit is not None:
            position_km, _ = self.orbit.state_km(t_s)
            torque += gravity_gradient_b(1.0e3 * position_km, sigma_bn, self.inertia_kgm2)
        return torque
