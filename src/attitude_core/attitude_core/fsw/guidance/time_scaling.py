"""The guidance's time scaling to the actuator limits (step 3 of
:mod:`~attitude_core.fsw.guidance.guidance`): the rate cap, the bounded rate change, the
braking curves to the goal and to the closest buffered rim, and the derating of a
plant weaker than declared (step 4)."""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.guidance.fepf import PlannerOutput
from attitude_core.fsw.guidance.guidance_base import (
    DERATE_EVERY_S,
    MIN_DERATING,
    GuidanceBase,
)
from attitude_core.fsw.guidance.profile_limits import (
    RATE_USE,
)
from attitude_core.fsw.guidance.route_following import braking_speed, corner_speed
from attitude_core.models.mrp import (
    Vec3Like,
    dcm_rows_from_mrp,
)

__all__ = ["BRAKE_USE", "TimeScaling"]

BRAKE_USE = 1.0
"""Fraction of the angle to the closest buffered rim that the braking curve may use."""


class TimeScaling(GuidanceBase):
    """The time-scaling part of a :class:`~attitude_core.fsw.guidance.guidance.Guidance`."""

    def _to_rim(self, sigma_t: Vec3Like, omega_t: npt.NDArray[np.float64], rim_deg: float) -> float:
        """Rotation (rad) about the rate ``omega_t`` (target axes) until a constraint's
        margin falls to ``rim_deg`` (:meth:`ConeGeometry.rotation_to_rim_deg`)."""
        size = math.hypot(float(omega_t[0]), float(omega_t[1]), float(omega_t[2]))
        if size == 0.0:
            return math.inf
        r0, r1, r2 = dcm_rows_from_mrp(sigma_t)  # C_TN: inertial axis = C_TN^T omega_hat
        w = [float(x) / size for x in omega_t]
        axis = tuple(w[0] * r0[i] + w[1] * r1[i] + w[2] * r2[i] for i in range(3))
        return math.radians(self.planner.geometry.rotation_to_rim_deg(sigma_t, axis, rim_deg))

    def _time_scaled(self, out: PlannerOutput, dt: float) -> npt.NDArray[np.float64]:
        """Step 3 of the module docstring: the FEPF rate within the limits."""
        lim = self.limits
        omega = np.array(out.omega_t, dtype=float)
        if lim.max_rate_rad_s is None and lim.accel_rad_s2 is None:
            return omega
        speed = math.hypot(*omega)
        cap = math.inf if lim.max_rate_rad_s is None else RATE_USE * lim.max_rate_rad_s
        alpha = None if lim.accel_rad_s2 is None else lim.accel_rad_s2 * self.derating
        if alpha is not None:
            sigma_t = out.sigma_t
            theta = self.remaining_rad(sigma_t)
            # Rotation to the buffered rim: a rotation by theta moves a boresight by at
            # most theta, so the exact margin less the buffer bounds it from below.
            geometry = self.planner.geometry
            margin = self.planner.margin_deg()  # at sigma_t, the target just proposed
            theta_obs = math.radians(max(margin - geometry.inflation_deg, 0.0))
            if self.follower is not None:
                # On a route, the rotation to the rim along the way the target turns (its
                # rate now and the rate asked for): alongside a cone, no braking. The rim
                # is the buffer's, or RIM_FLOOR of it for a target already at the rim.
                rim = self.planner.sight_margin_deg()
                ahead = min(
                    self._to_rim(sigma_t, self.omega_prev, rim), self._to_rim(sigma_t, omega, rim)
                )
                theta_obs = max(math.radians(max(margin - rim, 0.0)), ahead)
            theta = min(theta, BRAKE_USE * theta_obs)
            cap = min(cap, braking_speed(alpha, theta, dt))
            if self.follower is not None:
                cap = min(cap, self.follower.corner_cap(sigma_t, alpha, dt))
        wanted = cap
        follower = self.follower
        if alpha is not None and speed > 0.0 and follower is not None:
            # Turn before speeding up (on a route): the speed aimed at while the rate vector
            # turns to the new direction keeps the swing of the turn within the route's
            # slack (a soft cap, reached at alpha).
            prev = math.hypot(*self.omega_prev)
            want = self.planner.wanted_omega
            size = math.hypot(*want)
            if prev > 0.0 and size > 0.0:
                cos_turn = float(np.dot(want, self.omega_prev)) / (size * prev)
                turn = math.acos(min(max(cos_turn, -1.0), 1.0))
                wanted = min(cap, corner_speed(alpha, turn, math.radians(follower.swing_deg)))
        if speed > wanted:
            omega *= wanted / speed
        if alpha is not None:
            change = omega - self.omega_prev
            size = math.hypot(*change)
            if size > alpha * dt:
                omega = self.omega_prev + change * (alpha * dt / size)
            # The braking caps are hard: when turning used up the acceleration bound,
            # braking takes what it needs (from the controller's reserve).
            speed = math.hypot(*omega)
            if speed > cap:
                omega *= cap / speed
        return omega

    @property
    def stuck_timeout_s(self) -> float:
        """``planner.stuck_timeout_s`` plus, with limits, the time to stop from the rate
        cap at the profile's derated acceleration (slow actuators turn round slowly),
        counting the derating down to a quarter only, so that a dead plant is still
        reported."""
        lim = self.limits
        timeout = self.planner.cfg.stuck_timeout_s
        if lim.accel_rad_s2 is not None and lim.max_rate_rad_s is not None:
            timeout += lim.max_rate_rad_s / (lim.accel_rad_s2 * max(self.derating, 0.25))
        return timeout

    def _derate(self, factor: float, t_s: float) -> None:
        """A plant that falls behind a profile within its declared limits is weaker than
        declared: halve the profile's acceleration (at most once per settling time),
        down to :data:`MIN_DERATING`. On estimates the governor must have held for the
        knowledge's decision window first (noise alone must not derate)."""
        if factor >= 1.0 or self.limits.accel_rad_s2 is None:
            self._behind_since = None
            return
        if self._behind_since is None:
            self._behind_since = t_s
        if t_s - self._behind_since < self.knowledge.decision_window_s:
            return
        if t_s - self._derated_at < DERATE_EVERY_S:
            return
        self.derating = max(0.5 * self.derating, MIN_DERATING)
        self._derated_at = t_s
