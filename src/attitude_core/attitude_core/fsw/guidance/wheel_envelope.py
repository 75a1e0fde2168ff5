"""What a reaction wheel array lets a slew about a body axis do: the guidance's rate cap
and acceleration bound from the array, not a box.

Inputs: the array (:class:`attitude_core.models.wheel_array.WheelArray`), the inertia
``J`` (kg m^2, the whole spacecraft's), the unit slew axis ``e_B``, the rotation of the
slew (rad), the measured wheel speeds (rad/s) and which wheels are usable.

* **Rate, from momentum.** Without external torque the system momentum is constant
  inertially, so in body axes the momentum stored at the start turns by ``-phi`` about
  ``e_B`` as the body turns by ``phi``; a rate ``omega`` about ``e_B`` is body momentum
  ``omega J e_B`` taken from the wheels. With the controller's minimum-norm allocation
  (:mod:`attitude_core.fsw.control.wheel_allocation`) a momentum change ``dh`` of the
  usable wheels is ``Js dOmega = G^+ dh``, so every wheel's speed is linear in
  ``omega`` at each ``phi``: the largest ``omega`` keeping every usable wheel within its
  speed limit at every ``phi`` of the slew (sampled), times :data:`MOMENTUM_USE`, is
  ``rate_rad_s``. For a momentum-bound slew this is the issue's
  ``(h_max - h_stored) / J`` along the slew.
* **Acceleration, from torque.** ``accel_rad_s2 = u(n) / |J e_B|``, ``u`` the torque
  polytope's reach along ``n = J e_B / |J e_B|`` (:meth:`WheelArray.torque_along`).

With these, :func:`attitude_core.fsw.guidance.profile_limits.time_bound_s` is
``theta J / h + h / u`` once momentum binds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.models.wheel_array import WheelArray

__all__ = ["MOMENTUM_USE", "WheelEnvelope", "wheel_envelope"]

MOMENTUM_USE = 0.8
"""Share of the rate the wheels' speed limits allow that the profile may take (the rest
is the controller's, for its corrections and a path that is not an eigenaxis turn)."""

PHI_SAMPLES_PER_RAD = 12.0
"""Samples of the stored momentum's turn per radian of slew (at least two)."""


@dataclass(frozen=True)
class WheelEnvelope:
    """About one body axis: the rate cap (rad/s) from momentum, the acceleration bound
    (rad/s^2) from torque, and the body momentum (N m s) and torque (N m) behind them."""

    rate_rad_s: float
    accel_rad_s2: float
    momentum_free_nms: float
    torque_nm: float


def _turned(
    h_b: npt.NDArray[np.float64], e: npt.NDArray[np.float64], phi: float
) -> npt.NDArray[np.float64]:
    """``h_b`` seen from a body turned by ``phi`` about the unit ``e`` (frame rotation)."""
    c, s = math.cos(phi), math.sin(phi)
    turned: npt.NDArray[np.float64] = c * h_b + (1.0 - c) * (e @ h_b) * e - s * np.cross(e, h_b)
    return turned


def wheel_envelope(
    array: WheelArray,
    inertia_kgm2: npt.ArrayLike,
    axis_b: npt.ArrayLike,
    rotation_rad: float,
    speeds_rad_s: npt.ArrayLike,
    usable: npt.ArrayLike,
) -> WheelEnvelope:
    """The envelope of a rest-to-rest slew of ``rotation_rad`` about the unit ``axis_b``
    from the wheels' ``speeds_rad_s``, the body at rest."""
    j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
    e = np.asarray(axis_b, dtype=float)
    je = j @ e
    size = float(np.linalg.norm(je))
    speeds = np.asarray(speeds_rad_s, dtype=float)
    use = np.asarray(usable, dtype=bool)
    lower = np.where(use, -array.max_torque, 0.0)
    upper = np.where(use, array.max_torque, 0.0)
    torque = array.torque_along(je / size, lower, upper)

    g_use = array.axes[:, use]
    js, top, now = array.spin_inertia[use], array.max_speed[use], speeds[use]
    pinv = np.linalg.pinv(g_use)
    stored = array.wheel_momentum_b(speeds)
    per_rate = (pinv @ je) / js  # dOmega per unit of body rate
    rate = math.inf
    n_phi = max(2, math.ceil(PHI_SAMPLES_PER_RAD * abs(rotation_rad)) + 1)
    for phi in np.linspace(0.0, rotation_rad, n_phi):
        base = now + (pinv @ (_turned(stored, e, float(phi)) - stored)) / js
        if np.any(np.abs(base) > top):
            rate = 0.0  # the stored momentum alone passes a limit on the way
            break
        # Omega_i = base_i - per_rate_i omega within [-top_i, top_i]
        for b, k, t in zip(base, per_rate, top, strict=True):
            if k > 0.0:
                rate = min(rate, (b + t) / k)
            elif k < 0.0:
                rate = min(rate, (t - b) / -k)
    rate = MOMENTUM_USE * rate
    return WheelEnvelope(rate, torque / size, rate * size, torque)
