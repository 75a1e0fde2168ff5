"""Sensor models: a star tracker and a rate gyro on the true body.

Conventions (those of :mod:`attitude_core.gnc.mrp`): quaternions are scalar-last
``(x, y, z, w)`` with ``Rotation.from_quat(q) == Rotation.from_mrp(sigma_bn)``, i.e. the
SciPy rotation of a quaternion is ``C_NB`` (body to inertial). The quaternion product
:func:`quat_mul` is the Hamilton product, the one of SciPy's composition:
``Rotation.from_quat(quat_mul(p, q)) == Rotation.from_quat(p) * Rotation.from_quat(q)``.

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
import numbers
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.gnc.mrp import Vec3Like

__all__ = [
    "SensorSpec",
    "Measurement",
    "SensorSuite",
    "DEFAULT_BIAS_PRIOR_RAD_S",
    "star_tracker_due",
    "star_tracker_sample_steps",
    "quat_mul",
    "quat_conj",
    "quat_from_rotvec",
    "rotvec_from_quat",
    "Quat",
]

_Floats = npt.NDArray[np.float64]

Quat = tuple[float, float, float, float]
"""A scalar-last quaternion ``(x, y, z, w)`` in plain floats (the per-step hot paths)."""

DEFAULT_BIAS_PRIOR_RAD_S = 1e-3
"""The estimator's default 1-sigma on the initial gyro bias, rad/s."""

_TICK_EPS = 1e-9
"""Slack in ``floor(t * rate + eps)``: ``t = k * dt`` lands on a period boundary despite
rounding (``0.30000000000000004 * 10``)."""


# --- scalar-last Hamilton quaternions in plain floats ---------------------------------


def quat_mul(p: Sequence[float] | _Floats, q: Sequence[float] | _Floats) -> Quat:
    """Hamilton product ``p (x) q`` of scalar-last quaternions (SciPy's ``P * Q``)."""
    px, py, pz, pw = float(p[0]), float(p[1]), float(p[2]), float(p[3])
    qx, qy, qz, qw = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    return (
        pw * qx + qw * px + py * qz - pz * qy,
        pw * qy + qw * py + pz * qx - px * qz,
        pw * qz + qw * pz + px * qy - py * qx,
        pw * qw - px * qx - py * qy - pz * qz,
    )


def quat_conj(q: Sequence[float] | _Floats) -> Quat:
    """Conjugate (the inverse of a unit quaternion)."""
    return (-float(q[0]), -float(q[1]), -float(q[2]), float(q[3]))


def quat_from_rotvec(v: Vec3Like) -> Quat:
    """Unit quaternion of the rotation vector ``v`` (rad), ``w >= 0`` for ``|v| <= pi``."""
    x, y, z = float(v[0]), float(v[1]), float(v[2])
    angle = math.sqrt(x * x + y * y + z * z)
    half = 0.5 * angle
    if angle < 1e-6:
        k = 0.5 - angle * angle / 48.0  # sin(a/2)/a to O(a^4)
    else:
        k = math.sin(half) / angle
    return (k * x, k * y, k * z, math.cos(half))


def rotvec_from_quat(q: Sequence[float] | _Floats) -> tuple[float, float, float]:
    """Rotation vector (rad, ``|v| <= pi``) of a quaternion (any norm, either sign)."""
    x, y, z, w = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    if w < 0.0:
        x, y, z, w = -x, -y, -z, -w
    s = math.sqrt(x * x + y * y + z * z)
    if s == 0.0:
        return (0.0, 0.0, 0.0)
    k = 2.0 * math.atan2(s, w) / s  # atan2 is accurate at small angles too
    return (k * x, k * y, k * z)


def _quat_from_mrp(sigma: Vec3Like) -> Quat:
    """``(x, y, z, w)`` of an MRP set (``Rotation.from_mrp(sigma).as_quat()`` up to sign)."""
    s1, s2, s3 = float(sigma[0]), float(sigma[1]), float(sigma[2])
    ss = s1 * s1 + s2 * s2 + s3 * s3
    k = 1.0 / (1.0 + ss)
    return (2.0 * s1 * k, 2.0 * s2 * k, 2.0 * s3 * k, (1.0 - ss) * k)


# --- spec and measurements ------------------------------------------------------------


def _is_real(x: object) -> bool:
    """A finite real number (NumPy scalars too), not a bool."""
    return isinstance(x, numbers.Real) and not isinstance(x, bool) and math.isfinite(x)


def _vec3_problem(name: str, value: object, positive: bool) -> str | None:
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if not isinstance(value, tuple | list) or len(value) != 3:
        return f"{name}: must be three numbers (body x, y, z), got {value!r}"
    if not all(_is_real(v) for v in value):
        return f"{name}: every element must be a finite number, got {value!r}"
    if positive and not all(v > 0.0 for v in value):
        return f"{name}: every element must be > 0, got {value!r}"
    return None


def _scalar_problem(name: str, value: object, minimum: float, strict: bool) -> str | None:
    if not _is_real(value):
        return f"{name}: must be a finite number, got {value!r}"
    assert isinstance(value, numbers.Real)
    if (value <= minimum) if strict else (value < minimum):
        return f"{name}: must be {'>' if strict else '>='} {minimum:g}, got {value!r}"
    return None


@dataclass(frozen=True)
class SensorSpec:
    """The declared sensors (scenario keys ``sensors.*``). SI units, body axes."""

    seed: int
    star_tracker_noise_rad: tuple[float, float, float]
    """1-sigma error about body x, y, z, rad (about the boresight, often z, several times
    worse)."""
    star_tracker_rate_hz: float
    gyro_noise_rad_s: float
    """1-sigma white noise of one sample, per axis, rad/s."""
    gyro_bias_rad_s: tuple[float, float, float]
    """The true initial bias, rad/s."""
    gyro_bias_walk_rad_s2: float = 0.0
    """Bias random walk ``sigma_u``, rad/s^(3/2): ``b_{k+1} = b_k + sigma_u sqrt(dt) n_k``."""
    gyro_bias_prior_rad_s: float = DEFAULT_BIAS_PRIOR_RAD_S
    """The estimator's 1-sigma on the initial bias (it does not know the true one)."""
    star_tracker_outages_s: tuple[tuple[float, float], ...] = ()
    """``[start, end)`` windows of simulated time, s, with no star tracker sample."""

    def problem(self) -> str | None:
        """None for a usable spec, else a message naming the field and the reason."""
        seed = self.seed
        if not isinstance(seed, numbers.Integral) or isinstance(seed, bool) or seed < 0:
            return f"seed: must be a non-negative integer, got {self.seed!r}"
        checks = (
            _vec3_problem("star_tracker_noise_rad", self.star_tracker_noise_rad, True),
            _scalar_problem("star_tracker_rate_hz", self.star_tracker_rate_hz, 0.0, True),
            _scalar_problem("gyro_noise_rad_s", self.gyro_noise_rad_s, 0.0, False),
            _vec3_problem("gyro_bias_rad_s", self.gyro_bias_rad_s, False),
            _scalar_problem("gyro_bias_walk_rad_s2", self.gyro_bias_walk_rad_s2, 0.0, False),
            _scalar_problem("gyro_bias_prior_rad_s", self.gyro_bias_prior_rad_s, 0.0, True),
        )
        for message in checks:
            if message is not None:
                return message
        outages = self.star_tracker_outages_s
        if not isinstance(outages, tuple | list):
            return f"star_tracker_outages_s: must be a list of [start, end] pairs, got {outages!r}"
        for i, window in enumerate(outages):
            name = f"star_tracker_outages_s[{i}]"
            if not isinstance(window, tuple | list) or len(window) != 2:
                return f"{name}: must be a [start, end] pair, got {window!r}"
            if not all(_is_real(v) for v in window):
                return f"{name}: start and end must be finite numbers, got {window!r}"
            if not window[0] < window[1]:
                return f"{name}: start must be < end, got {window!r}"
        return None


@dataclass(frozen=True)
class Measurement:
    """One step's sensor output."""

    t_s: float
    gyro_rad_s: _Floats
    """(3,) measured body rate, body axes, rad/s."""
    star_tracker_quat: _Floats | None
    """(4,) measured scalar-last ``q_BN`` with ``w >= 0``, or None (no sample this step)."""


def star_tracker_due(t_s: float, rate_hz: float, dt_s: float) -> bool:
    """Whether the step at ``t_s`` (steps ``t = k dt_s``) starts a new ``1 / rate_hz``
    tracker period, outages aside: ``floor(t rate + 1e-9)`` is larger than at ``t - dt_s``.
    True at ``t = 0`` and at every step when ``rate_hz >= 1 / dt_s``; with 0.1 s steps at
    4 Hz, at 0, 0.3, 0.5, 0.8, 1.0 s ..."""
    return math.floor(t_s * rate_hz + _TICK_EPS) > math.floor((t_s - dt_s) * rate_hz + _TICK_EPS)


def star_tracker_sample_steps(rate_hz: float, dt_s: float, n_steps: int) -> npt.NDArray[np.int64]:
    """The steps ``k < n_steps`` at which :func:`star_tracker_due` holds (same formula,
    vectorised)."""
    t = np.arange(n_steps) * dt_s
    due = np.floor(t * rate_hz + _TICK_EPS) > np.floor((t - dt_s) * rate_hz + _TICK_EPS)
    steps: npt.NDArray[np.int64] = np.flatnonzero(due).astype(np.int64)
    return steps


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

    def measure(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> Measurement:
        """This step's gyro sample and, at a new tracker period, star tracker sample, from
        the TRUE ``sigma_bn`` and ``omega_b``. ``t_s`` must increase from call to call."""
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
        outage = any(a <= t < b for a, b in self.spec.star_tracker_outages_s)
        if star_tracker_due(t, self._rate, self.dt_s) and not outage:
            delta = self._st_noise * rng.standard_normal(3)
            q = quat_mul(_quat_from_mrp(sigma_bn), quat_from_rotvec(delta))
            quat = np.array(q) if q[3] >= 0.0 else -np.array(q)
            quat /= np.linalg.norm(quat)
        return Measurement(t_s=t, gyro_rad_s=gyro, star_tracker_quat=quat)
