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

__all__ = [
    "MOMENTUM_USE",
    "WheelEnvelope",
    "momentum_rate_limit",
    "sphere_directions",
    "wheel_envelope",
]

MOMENTUM_USE = 0.8
"""Share of the rate the wheels' speed limits allow that the profile may take (the rest
is the controller's, for its corrections and a path that is not an eigenaxis turn)."""

PHI_SAMPLES_PER_RAD = 12.0
"""Samples of the stored momentum's turn per radian of slew (at least two)."""

SPHERE_AXES = 256
"""Axes over the sphere the rate cap holds about, besides the slew's eigenaxis."""


@dataclass(frozen=True)
class WheelEnvelope:
    """About one body axis: the rate cap (rad/s) from momentum, the acceleration bound
    (rad/s^2) from torque, and the body momentum (N m s) and torque (N m) behind them."""

    rate_rad_s: float
    accel_rad_s2: float
    momentum_free_nms: float
    torque_nm: float


def _turned(
    h_b: npt.NDArray[np.float64], e: npt.NDArray[np.float64], phi: npt.NDArray[np.float64]
) -> npt.NDArray[np.float64]:
    """``h_b`` seen from a body turned by each ``phi`` (P,) about the unit ``e``
    (frame rotation): (P, 3)."""
    c, s = np.cos(phi)[:, None], np.sin(phi)[:, None]
    turned: npt.NDArray[np.float64] = c * h_b + (1.0 - c) * (e @ h_b) * e - s * np.cross(e, h_b)
    return turned


def sphere_directions(count: int) -> npt.NDArray[np.float64]:
    """``count`` unit vectors spread evenly over the sphere (a Fibonacci lattice)."""
    k = np.arange(count) + 0.5
    z = 1.0 - 2.0 * k / count
    r = np.sqrt(1.0 - z * z)
    phi = math.pi * (3.0 - math.sqrt(5.0)) * k
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def momentum_rate_limit(
    array: WheelArray,
    inertia_kgm2: npt.ArrayLike,
    turn_axis_b: npt.ArrayLike,
    rotation_rad: float,
    rate_axes_b: npt.ArrayLike,
    speeds_rad_s: npt.ArrayLike,
    usable: npt.ArrayLike,
) -> npt.NDArray[np.float64]:
    """Per unit axis of ``rate_axes_b`` (K, 3): the largest rate about it that keeps
    every usable wheel within its speed limit at every turn ``phi`` of the body about
    ``turn_axis_b`` up to ``rotation_rad`` (module docstring), before
    :data:`MOMENTUM_USE`; 0 for every axis when the stored momentum alone passes a limit
    on the way (the slew cannot be flown without one)."""
    j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
    e = np.atleast_2d(np.asarray(rate_axes_b, dtype=float))
    use = np.asarray(usable, dtype=bool)
    speeds = np.asarray(speeds_rad_s, dtype=float)
    js, top, now = array.spin_inertia[use], array.max_speed[use], speeds[use]
    pinv = np.linalg.pinv(array.axes[:, use])
    stored = array.wheel_momentum_b(speeds)
    n_phi = max(2, math.ceil(PHI_SAMPLES_PER_RAD * abs(rotation_rad)) + 1)
    phi = np.linspace(0.0, rotation_rad, n_phi)
    turn = np.asarray(turn_axis_b, dtype=float)
    base = now + ((_turned(stored, turn, phi) - stored) @ pinv.T) / js  # (P, n)
    if np.any(np.abs(base) > top):
        return np.zeros(len(e))
    per_rate = (e @ j.T) @ pinv.T / js  # dOmega per unit rate (K, n)
    # Omega = base - per_rate omega within [-top, top], for omega >= 0: the room left
    room_down = (base + top).min(axis=0)  # for a wheel slowed (per_rate > 0)
    room_up = (top - base).min(axis=0)  # for a wheel sped up (per_rate < 0)
    with np.errstate(divide="ignore"):
        up = np.where(per_rate > 0.0, room_down / per_rate, np.inf)
        down = np.where(per_rate < 0.0, room_up / -per_rate, np.inf)
    limit: npt.NDArray[np.float64] = np.minimum(up, down).min(axis=1)
    return limit


def wheel_envelope(
    array: WheelArray,
    inertia_kgm2: npt.ArrayLike,
    axis_b: npt.ArrayLike,
    rotation_rad: float,
    speeds_rad_s: npt.ArrayLike,
    usable: npt.ArrayLike,
) -> WheelEnvelope:
    """The envelope of a rest-to-rest slew of ``rotation_rad`` about the unit ``axis_b``
    from the wheels' ``speeds_rad_s``, the body at rest. The stored momentum turns
    about ``axis_b``; the rate is the smallest about any axis (a path around the cones
    turns about other axes than the eigenaxis): about ``axis_b``, each wheel's worst
    axis (``J p_i``, ``p_i`` its row of ``G^+``), and :data:`SPHERE_AXES` more."""
    j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
    e = np.asarray(axis_b, dtype=float)
    je = j @ e
    size = float(np.linalg.norm(je))
    use = np.asarray(usable, dtype=bool)
    lower = np.where(use, -array.max_torque, 0.0)
    upper = np.where(use, array.max_torque, 0.0)
    torque = array.torque_along(je / size, lower, upper)
    # Each wheel's speed is linear in the body momentum through a row p_i of G^+: the
    # rate about e is least where J e is along p_i, so those axes are exact worst cases.
    rows = np.linalg.pinv(array.axes[:, use])
    worst = rows @ j
    worst /= np.linalg.norm(worst, axis=1, keepdims=True)
    axes = np.vstack([e, worst, -worst, sphere_directions(SPHERE_AXES)])
    rates = momentum_rate_limit(array, j, e, rotation_rad, axes, speeds_rad_s, use)
    rate = MOMENTUM_USE * float(np.min(rates))
    return WheelEnvelope(rate, torque / size, rate * size, torque)
