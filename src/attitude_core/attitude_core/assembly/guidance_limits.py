"""The guidance's profile bounds of a scenario: from ``actuators.*`` (a torque box and a
rate bound), or from ``wheels.*`` (the array's envelope about the slew's axis,
:mod:`attitude_core.fsw.guidance.wheel_envelope`).

Inputs: a :class:`~attitude_core.config.scenario.Scenario`, the attitude ``sigma_BN``
the slew starts from and, with wheels, their speeds (rad/s; default the declared
initial speeds) and which are usable (default all). Outputs: :func:`scenario_limits`
(:class:`GuidanceLimits`) and :func:`slew_envelope`; :class:`WheelBudget` gives them
again as wheels stop answering.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from attitude_core.config.scenario import Scenario
from attitude_core.fsw.control.wheel_control import WheelWatch
from attitude_core.fsw.guidance.profile_limits import GuidanceLimits
from attitude_core.fsw.guidance.wheel_envelope import WheelEnvelope, wheel_envelope
from attitude_core.models.mrp import Vec3Like, relative

__all__ = ["DETOUR_FACTOR", "slew_axis", "slew_envelope", "scenario_limits", "WheelBudget"]

DETOUR_FACTOR = 1.5
"""The rotation a slew is budgeted for: its principal angle times this (the detours
around the cones), at most half a turn."""


def slew_axis(scenario: Scenario, sigma_bn: Vec3Like) -> tuple[np.ndarray, float]:
    """The slew's eigenaxis from ``sigma_bn`` to the goal (body axes, unit) and its
    principal angle (rad)."""
    error = relative(scenario.desired_mrp, sigma_bn)  # sigma_D/B: the eigenaxis, tan(phi/4)
    size = float(np.linalg.norm(error))
    axis = error / size if size > 0.0 else np.array([1.0, 0.0, 0.0])
    return axis, 4.0 * math.atan(size)


def slew_envelope(
    scenario: Scenario,
    sigma_bn: Vec3Like,
    speeds_rad_s: npt.ArrayLike | None = None,
    usable: npt.ArrayLike | None = None,
) -> WheelEnvelope:
    """The wheel envelope of the slew from ``sigma_bn`` to the goal, about the slew's
    eigenaxis (body axes), for :data:`DETOUR_FACTOR` of its angle."""
    array = scenario.wheels
    if array is None:
        raise ValueError(f"{scenario.name}: no wheels.* declared")
    axis, angle = slew_axis(scenario, sigma_bn)
    rotation = min(math.pi, DETOUR_FACTOR * angle)
    speeds = array.initial_speed if speeds_rad_s is None else speeds_rad_s
    use = np.ones(len(array), dtype=bool) if usable is None else usable
    return wheel_envelope(array, scenario.inertia_kgm2, axis, rotation, speeds, use)


def scenario_limits(scenario: Scenario, sigma_bn: Vec3Like) -> GuidanceLimits:
    """The profile bounds of ``scenario``'s slew from ``sigma_bn``."""
    if scenario.wheels is None:
        return GuidanceLimits.from_actuators(
            scenario.inertia_kgm2,
            scenario.actuators.max_torque_nm,
            scenario.guidance_max_rate_rad_s,
        )
    return GuidanceLimits.from_wheels(scenario.inertia_kgm2, slew_envelope(scenario, sigma_bn))


class WheelBudget:
    """The planner's side of a wheel array: the profile bounds again whenever a wheel
    stops answering its commands (:class:`~attitude_core.fsw.control.wheel_control.WheelWatch`),
    on the wheels left and from their measured speeds; and at the first state, when the
    measured speeds are not the declared ``initial_speed_rpm`` (a bench's own wheels)."""

    def __init__(self, scenario: Scenario) -> None:
        if scenario.wheels is None:
            raise ValueError(f"{scenario.name}: no wheels.* declared")
        self.scenario = scenario
        self.array = scenario.wheels
        self.watch = WheelWatch(scenario.wheels)
        self.started = False

    def measured(
        self, sigma_bn: Vec3Like, speeds: npt.ArrayLike, applied_nm: npt.ArrayLike
    ) -> GuidanceLimits | None:
        """A measured state with its wheel state: new bounds for the rest of the slew,
        or None (unchanged)."""
        first, self.started = not self.started, True
        taken_out = self.watch.measured(speeds, applied_nm)
        same_speeds = np.array_equal(np.asarray(speeds, dtype=float), self.array.initial_speed)
        if not taken_out and not (first and not same_speeds):
            return None
        env = slew_envelope(self.scenario, sigma_bn, speeds, self.watch.usable)
        return GuidanceLimits.from_wheels(self.scenario.inertia_kgm2, env)

    def commanded(self, motor_torque_nm: npt.ArrayLike, speeds: npt.ArrayLike) -> None:
        """The motor torques the controller sent for the state with wheel ``speeds``."""
        self.watch.commanded(motor_torque_nm, speeds)
