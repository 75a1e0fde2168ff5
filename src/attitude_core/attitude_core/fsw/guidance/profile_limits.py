"""The target profile's bounds from the actuator limits, and the rest-to-rest time
bound (no ROS, no guidance state): what :mod:`attitude_core.fsw.guidance.guidance` time-scales
the FEPF to, and what a run's summary compares its slew time with.

Inputs: the inertia (kg m^2, body axes), the per-axis torque bound (N m) and the rate
bound (rad/s), each None when unlimited. Outputs: :class:`GuidanceLimits` (rate cap,
acceleration bound of the profile, rest-to-rest ``alpha_max``) and
:func:`time_bound_s`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.guidance.wheel_envelope import WheelEnvelope

__all__ = ["TORQUE_USE", "GYRO_SHARE", "RATE_USE", "GuidanceLimits", "time_bound_s"]

TORQUE_USE = 0.85
"""Fraction of the available acceleration the target profile uses; the PD law keeps the
rest for its corrections (tracking error, disturbances)."""

GYRO_SHARE = 0.25
"""Largest share of the smallest torque bound the gyroscopic torque may take at the
profile's rate cap (which is lowered below ``max_rate_rad_s`` when needed)."""

RATE_USE = 0.95
"""Fraction of ``max_rate_rad_s`` the target's rate may reach, for the body's overshoot."""


@dataclass(frozen=True)
class GuidanceLimits:
    """The target profile's bounds in body-rate space, from the actuator limits.

    ``max_rate_rad_s`` bounds ``|omega_t|`` and ``accel_rad_s2`` its change; None is
    unlimited. ``alpha_max_rad_s2`` is the rest-to-rest bound's ``alpha_max``: the
    smallest torque bound over the largest principal inertia.
    """

    max_rate_rad_s: float | None = None
    accel_rad_s2: float | None = None
    alpha_max_rad_s2: float | None = None

    @classmethod
    def from_actuators(
        cls,
        inertia_kgm2: npt.ArrayLike,
        max_torque_nm: tuple[float, float, float] | None,
        max_rate_rad_s: float | None,
    ) -> GuidanceLimits:
        if max_torque_nm is None:
            return cls(max_rate_rad_s, None, None)
        j = np.linalg.eigvalsh(np.asarray(inertia_kgm2, dtype=float).reshape(3, 3))
        j_min, j_max = float(j[0]), float(j[-1])
        tau = float(min(max_torque_nm))
        # |omega x J omega| <= (J_max - J_min) |omega|^2 / 2; the rate is capped so that
        # the gyroscopic torque takes at most GYRO_SHARE of the smallest bound.
        half_spread = 0.5 * (j_max - j_min)
        rate = max_rate_rad_s
        if half_spread > 0.0:
            gyro_rate = math.sqrt(GYRO_SHARE * tau / half_spread)
            rate = gyro_rate if rate is None else min(rate, gyro_rate)
        gyro = 0.0 if rate is None else half_spread * rate * rate
        accel = TORQUE_USE * (tau - gyro) / j_max
        return cls(rate, accel, tau / j_max)

    @classmethod
    def from_wheels(cls, inertia_kgm2: npt.ArrayLike, envelope: WheelEnvelope) -> GuidanceLimits:
        """The bounds of a slew with a wheel array (``envelope`` about its axis,
        :func:`attitude_core.fsw.guidance.wheel_envelope.wheel_envelope`): the rate the
        wheels' momentum allows (lowered as in :meth:`from_actuators` so the gyroscopic
        torque takes at most :data:`GYRO_SHARE` of the array's torque), and
        :data:`TORQUE_USE` of the rest of the torque along the slew."""
        j = np.linalg.eigvalsh(np.asarray(inertia_kgm2, dtype=float).reshape(3, 3))
        half_spread = 0.5 * (float(j[-1]) - float(j[0]))
        tau = envelope.torque_nm
        alpha = envelope.accel_rad_s2
        rate = envelope.rate_rad_s
        if half_spread > 0.0:
            rate = min(rate, math.sqrt(GYRO_SHARE * tau / half_spread))
        gyro = half_spread * rate * rate
        return cls(rate, TORQUE_USE * alpha * (tau - gyro) / tau, alpha)


def time_bound_s(
    rotation_rad: float, max_rate_rad_s: float | None, alpha_max_rad_s2: float | None
) -> float | None:
    """Rest-to-rest time bound along a rotation of ``rotation_rad``.

    ``T* = theta / omega_max + omega_max / alpha_max`` when the rate bound is reached
    (``theta >= omega_max^2 / alpha_max``), ``2 sqrt(theta / alpha_max)`` when it is
    not, ``theta / omega_max`` with no torque bound; None with neither bound.
    """
    theta = max(float(rotation_rad), 0.0)
    if alpha_max_rad_s2 is None:
        return None if max_rate_rad_s is None else theta / max_rate_rad_s
    if max_rate_rad_s is None or theta < max_rate_rad_s**2 / alpha_max_rad_s2:
        return 2.0 * math.sqrt(theta / alpha_max_rad_s2)
    return theta / max_rate_rad_s + max_rate_rad_s / alpha_max_rad_s2
