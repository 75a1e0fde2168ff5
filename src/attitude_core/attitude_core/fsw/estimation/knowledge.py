"""How well the loop knows the body's state: the bounds the guidance plans with.

With declared sensors (:mod:`attitude_core.world.sensors`) the planner and the controller
see the MEKF's estimate (:mod:`attitude_core.fsw.estimation.mekf`), not the body. The guidance
then needs, from the sensor declaration alone (the same in every node, before the
first state):

* ``attitude_3sigma_deg``: :data:`SETTLED_RATIO` times ``3 sqrt(trace P_att)`` of the
  filter's steady covariance at its worst phase (just before a star tracker sample):
  the filter's 3-sigma from the moment the slew starts (``settle_s``) on. A rotation
  error of ``phi`` moves any boresight by at most ``phi``, so this bounds every
  instrument's pointing knowledge error (3-sigma). It is added to the planner's
  keep-out buffer and is the least attitude arrival tolerance.
* ``rate_3sigma_rad_s``: ``3 sqrt(3 sigma_g^2 + trace P_bias)``: the bias-corrected
  rate's error (the gyro's white noise and the bias estimate's error), the least rate
  arrival tolerance.
* ``decision_window_s``: the state time a decision on noisy states must hold before
  the guidance takes it (arrival, its withdrawal, the acceleration derating); 0 with
  perfect knowledge, where one sample is the truth.
* ``settle_s``: the state time the filter takes, from its first fix (the tracker's
  noise, the bias prior), until its attitude 3-sigma is within ``attitude_3sigma_deg``,
  at most :data:`MAX_SETTLE_S` (a filter without process noise has no steady state to
  settle to: then the bound is its 3-sigma at that time). The guidance holds the start
  until then, as flight software waits for attitude determination to converge before a
  slew: the buffer holds the settled 3-sigma, not the first fix's.
* ``outage_3sigma_deg``: the attitude 3-sigma at the end of the longest declared star
  tracker outage (``sensors.star_tracker.outages``), the filter propagating on the gyro
  alone from its steady covariance; at least ``attitude_3sigma_deg``. The keep-out
  buffer holds it (:attr:`Knowledge.buffer_3sigma_deg`): the body keeps its margin
  through a scheduled outage.
* ``first_fix_3sigma_deg``: ``3 sqrt(sum noise^2)`` of the star tracker, the 3-sigma of the
  filter's first estimate: a start estimated within it is the scenario's start (the
  route planned before the first state is flown from it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from attitude_core.fsw.estimation.mekf import MekfConfig, process_noise, steady_state_covariance
from attitude_core.models.sensor_spec import SensorSpec, star_tracker_due

__all__ = [
    "Knowledge",
    "PERFECT",
    "DECISION_WINDOW_S",
    "SETTLED_RATIO",
    "MAX_SETTLE_S",
    "knowledge_of",
]

DECISION_WINDOW_S = 1.0
"""State time a decision taken on estimates must hold, s (several star tracker samples
at a few Hz, short against a slew's settling)."""

SETTLED_RATIO = 2.0
"""The filter has settled once its attitude 3-sigma is within this factor of the steady
(a few seconds with a good tracker, about 20 s with a coarse one and a poor gyro)."""

MAX_SETTLE_S = 30.0
"""The longest wait for the filter at the start, s."""


@dataclass(frozen=True)
class Knowledge:
    """The state knowledge bounds (module docstring); all zero: perfect knowledge."""

    attitude_3sigma_deg: float = 0.0
    rate_3sigma_rad_s: float = 0.0
    decision_window_s: float = 0.0
    settle_s: float = 0.0
    first_fix_3sigma_deg: float = 0.0
    outage_3sigma_deg: float = 0.0

    @property
    def buffer_3sigma_deg(self) -> float:
        """The 3-sigma the keep-out buffer holds: the settled one, or the one at the end
        of the longest declared tracker outage."""
        return max(self.attitude_3sigma_deg, self.outage_3sigma_deg)

    @property
    def perfect(self) -> bool:
        return self.attitude_3sigma_deg == 0.0 and self.rate_3sigma_rad_s == 0.0


PERFECT = Knowledge()


def knowledge_of(spec: SensorSpec, dt_s: float) -> Knowledge:
    """The bounds of the MEKF fed by ``spec``'s sensors at one gyro sample per ``dt_s``."""
    cfg = MekfConfig.from_spec(spec, dt_s)
    p = steady_state_covariance(cfg, spec.star_tracker_rate_hz)
    steady = float(np.trace(p[:3, :3]))
    settle, trace = _settle(cfg, spec.star_tracker_rate_hz, SETTLED_RATIO**2 * steady)
    attitude = 3.0 * math.degrees(math.sqrt(max(trace, SETTLED_RATIO**2 * steady)))
    rate = 3.0 * math.sqrt(3.0 * spec.gyro_noise_rad_s**2 + float(np.trace(p[3:, 3:])))
    first = 3.0 * math.degrees(math.sqrt(sum(float(r) ** 2 for r in spec.star_tracker_noise_rad)))
    outage = _after_outage(
        cfg, p, max((b - a for a, b in spec.star_tracker_outages_s), default=0.0)
    )
    return Knowledge(attitude, rate, DECISION_WINDOW_S, settle, first, max(attitude, outage))


def _after_outage(cfg: MekfConfig, p: np.ndarray, duration_s: float) -> float:
    """``3 sqrt(trace P_att)`` (deg) after ``duration_s`` of gyro-only propagation from the
    covariance ``p``."""
    if duration_s <= 0.0:
        return 0.0
    dt = cfg.dt_s
    phi = np.eye(6)
    phi[:3, 3:] = -dt * np.eye(3)
    qd = process_noise(cfg, dt)
    for _ in range(math.ceil(duration_s / dt)):
        p = phi @ p @ phi.T + qd
    return 3.0 * math.degrees(math.sqrt(float(np.trace(p[:3, :3]))))


def _settle(cfg: MekfConfig, rate_hz: float, limit: float) -> tuple[float, float]:
    """The filter's covariance recursion from its first fix at rest (``Phi = [[I, -dt I],
    [0, I]]``): the time its attitude trace before a star tracker sample first falls
    to ``limit`` (rad^2), at most :data:`MAX_SETTLE_S`, and that trace
    (:attr:`Knowledge.settle_s`)."""
    dt = cfg.dt_s
    r = np.diag(np.array(cfg.star_tracker_noise_rad, dtype=float) ** 2)
    p = np.zeros((6, 6))
    p[:3, :3] = r
    p[3:, 3:] = cfg.gyro_bias_prior_rad_s**2 * np.eye(3)
    phi = np.eye(6)
    phi[:3, 3:] = -dt * np.eye(3)
    qd = process_noise(cfg, dt)
    worst = float(np.trace(p[:3, :3]))  # the largest pre-update trace of the last period
    last = round(MAX_SETTLE_S / dt)
    for k in range(1, last + 1):
        p = phi @ p @ phi.T + qd
        if star_tracker_due(k * dt, rate_hz, dt):
            worst = float(np.trace(p[:3, :3]))
            if worst <= limit:
                return k * dt, worst
            gain = p[:, :3] @ np.linalg.inv(p[:3, :3] + r)
            p = p - gain @ p[:3, :]
    return last * dt, max(worst, float(np.trace(p[:3, :3])))
