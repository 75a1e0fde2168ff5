"""The declared sensors: a star tracker and a rate gyro, their noise, rate and schedule.

What both sides of the loop read: the sensor models in the world
(:mod:`attitude_core.world.sensors`) sample the true body with it; the estimator and the
guidance's knowledge bounds (:mod:`attitude_core.fsw.estimation`) size their filter and
their buffers from it. SI units, body axes.

The tracker runs on its own clock: a sample is taken at the first step of each
``1 / star_tracker_rate_hz`` period (:func:`star_tracker_due`), unless that step falls in
an outage window, the body turns faster than the tracker's limit, or a bright object is
inside the tracker's own exclusion; such a period has no sample.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "SensorSpec",
    "Measurement",
    "DEFAULT_BIAS_PRIOR_RAD_S",
    "star_tracker_due",
    "star_tracker_sample_steps",
]

_Floats = npt.NDArray[np.float64]

DEFAULT_BIAS_PRIOR_RAD_S = 1e-3
"""The estimator's default 1-sigma on the initial gyro bias, rad/s."""

_TICK_EPS = 1e-9
"""Slack in ``floor(t * rate + eps)``: ``t = k * dt`` lands on a period boundary despite
rounding (``0.30000000000000004 * 10``)."""


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
    star_tracker_max_rate_rad_s: float | None = None
    """No star tracker solution while the body turns faster than this, rad/s (None: any
    rate)."""
    star_tracker_instrument: str | None = None
    """No star tracker solution while a bright object is inside this instrument's
    exclusion (the tracker's own keep-out; None: the tracker is never blinded)."""

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
        limit = self.star_tracker_max_rate_rad_s
        if limit is not None and (not _is_real(limit) or not limit > 0.0):
            return f"star_tracker_max_rate_rad_s: must be > 0, got {limit!r}"
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
