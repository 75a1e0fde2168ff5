"""Sensor models: a star tracker and a rate gyro on the true body.

The world's side of the sensors: what the declared sensors
(:class:`attitude_core.models.sensor_spec.SensorSpec`) measure on the true body.
Quaternions are those of :mod:`attitude_core.models.quaternion` (scalar-last, Hamilton).

* Gyro (Markley & Crassidis 2014, the gyro model of the MEKF): sample ``k`` is
  ``omega_b + b_k + gyro_noise_rad_s * n_k``, ``n_k ~ N(0, I3)``; then the bias walks,
  ``b_{k+1} = b_k + gyro_bias_walk_rad_s2 * sqrt(dt) * u_k``, ``u_k ~ N(0, I3)``.
* Star tracker: ``q_meas = q_true (x) dq(delta)``, that is
  ``Rotation.from_quat(q_meas) == Rotation.from_quat(q_true) * Rotation.from_rotvec(delta)``:
  ``C_NB_meas = C_NB_true exp([delta x])``, ``C_BN_meas = exp(-[delta x]) C_BN_true``.
  ``delta`` is a small rotation vector in BODY axes with independent components
  ``delta_i ~ N(0, star_tracker_noise_rad[i]^2)``: the MEKF's attitude-error convention.
  The tracker runs on its own clock: a sample is taken at the first step of each
  ``1 / star_tracker_rate_hz`` period (:func:`star_tracker_due`), unless that step falls
  in an outage window; a period whose first step is in an outage has no sample.

Random numbers come from one ``np.random.default_rng(spec.seed)``, drawn in a fixed order
at every step: gyro noise (3), bias walk (3), then star-tracker noise (3) only at a step
with a sample. A run is reproducible from the seed.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import Vec3Like
from attitude_core.models.quaternion import Quat, quat_from_rotvec, quat_mul
from attitude_core.models.sensor_spec import Measurement, SensorSpec, star_tracker_due

__all__ = ["SensorSuite"]

_Floats = npt.NDArray[np.float64]


def _quat_from_mrp(sigma: Vec3Like) -> Quat:
    """``(x, y, z, w)`` of an MRP set (``Rotation.from_mrp(sigma).as_quat()`` up to sign)."""
    s1, s2, s3 = float(sigma[0]), float(sigma[1]), float(sigma[2])
    ss = s1 * s1 + s2 * s2 + s3 * s3
    k = 1.0 / (1.0 + ss)
    return (2.0 * s1 * k, 2.0 * s2 * k, 2.0 * s3 * k, (1.0 - ss) * k)


class SensorSuite:
    """Star tracker and gyro on the true body; reproducible from ``spec.seed``."""

    def __init__(self, spec: SensorSpec, dt_s: float) -> None:
        problem = spec.problem()
        if problem is not None:
            raise ValueError(f"sensors: {problem}")
        if not dt_s > 0.0:
            raise ValueError(f"dt_s must be > 0, got {dt_s!r}")
        self.spec = spec
        self.dt_s = float(dt_s)
        self._rng = np.random.default_rng(spec.seed)
        self._bias: _Floats = np.array(spec.gyro_bias_rad_s, dtype=float)
        self._walk_scale = spec.gyro_bias_walk_rad_s2 * math.sqrt(self.dt_s)
        self._st_noise: _Floats = np.array(spec.star_tracker_noise_rad, dtype=float)
        self._rate = float(spec.star_tracker_rate_hz)
        self._last_t: float | None = None

    @property
    def bias_rad_s(self) -> _Floats:
        """The current true bias: the one the next gyro sample will carry (read it before
        :meth:`measure` for the bias of that sample; the initial bias before the first)."""
        return self._bias.copy()

    def measure(
        self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like, blinded: bool = False
    ) -> Measurement:
        """This step's gyro sample and, at a new tracker period, star tracker sample, from
        the TRUE ``sigma_bn`` and ``omega_b``. ``t_s`` must increase from call to call.
        No tracker sample in an outage, above the tracker's rate limit, or ``blinded`` (a
        bright object inside the tracker's exclusion, judged by the caller on the sky)."""
        t = float(t_s)
        if self._last_t is not None and not t > self._last_t:
            raise ValueError(f"measure: t_s must increase, got {t!r} after {self._last_t!r}")
        rng = self._rng
        gyro = (
            np.asarray(omega_b, dtype=float)
            + self._bias
            + self.spec.gyro_noise_rad_s * rng.standard_normal(3)
        )
        self._bias = self._bias + self._walk_scale * rng.standard_normal(3)  # the next sample's
        self._last_t = t
        quat: _Floats | None = None
        outage = blinded or any(a <= t < b for a, b in self.spec.star_tracker_outages_s)
        limit = self.spec.star_tracker_max_rate_rad_s
        if limit is not None:
            w = np.asarray(omega_b, dtype=float)
            outage = outage or float(np.sqrt(w @ w)) > limit
        if star_tracker_due(t, self._rate, self.dt_s) and not outage:
            delta = self._st_noise * rng.standard_normal(3)
            q = quat_mul(_quat_from_mrp(sigma_bn), quat_from_rotvec(delta))
            quat = np.array(q) if q[3] >= 0.0 else -np.array(q)
            quat /= np.linalg.norm(quat)
        return Measurement(t_s=t, gyro_rad_s=gyro, star_tracker_quat=quat)
