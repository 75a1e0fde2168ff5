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

__all__ = [
    "DETOUR_FACTOR",
    "MIN_WHEEL_RATE_RAD_S",
    "slew_axis",
    "slew_envelope",
    "scenario_limits",
    "wheel_infeasibility",
    "WheelBudget",
]

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


MIN_WHEEL_RATE_RAD_S = 1.0e-4
"""Below this rate cap (0.0057 deg/s: half a turn in nine hours) the wheels have no
momentum free for the slew: it is infeasible."""


def wheel_infeasibility(
    scenario: Scenario,
    sigma_bn: Vec3Like,
    speeds_rad_s: npt.ArrayLike | None = None,
    usable: npt.ArrayLike | None = None,
) -> str | None:
    """Why the wheels (``usable``, at ``speeds_rad_s``) cannot fly the slew from
    ``sigma_bn`` safely, or None: their spin axes no longer span the body's three axes
    (the body cannot be held about the rest), or no momentum is free for a slew rate."""
    array = scenario.wheels
    if array is None:
        return None
    use = np.ones(len(array), dtype=bool) if usable is None else np.asarray(usable, dtype=bool)
    names = [n for n, u in zip(array.names, use, strict=True) if u]
    rank = int(np.linalg.matrix_rank(array.axes[:, use], tol=1e-6)) if use.any() else 0
    if rank < 3:
        return (
            f"wheels: the usable wheels {names} span {rank} of the 3 body axes: "
            "the body cannot be controlled about the others"
        )
    env = slew_envelope(scenario, sigma_bn, speeds_rad_s, use)
    if env.rate_rad_s < MIN_WHEEL_RATE_RAD_S or env.accel_rad_s2 <= 0.0:
        return (
            f"wheels: {env.momentum_free_nms:.3g} N m s free about the slew axis "
            f"(rate cap {env.rate_rad_s:.3g} rad/s, below {MIN_WHEEL_RATE_RAD_S:g}): "
            "the wheels' speeds leave no momentum for the slew"
        )
    return None


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
        self.infeasible: str | None = None  # why the wheels left cannot fly the slew

    def measured(
        self, sigma_bn: Vec3Like, speeds: npt.ArrayLike, applied_nm: npt.ArrayLike
    ) -> GuidanceLimits | None:
        """A measured state with its wheel state: new bounds for the rest of the slew,
        or None (unchanged; or :attr:`infeasible` says why the wheels left cannot fly
        it)."""
        first, self.started = not self.started, True
        taken_out = self.watch.measured(speeds, applied_nm)
        same_speeds = np.array_equal(np.asarray(speeds, dtype=float), self.array.initial_speed)
        if not taken_out and not (first and not same_speeds):
            return None
        usable = self.watch.usable
        self.infeasible = wheel_infeasibility(self.scenario, sigma_bn, speeds, usable)
        if self.infeasible is not None:
            return None
        env = slew_envelope(self.scenario, sigma_bn, speeds, usable)
        return GuidanceLimits.from_wheels(self.scenario.inertia_kgm2, env)

    def commanded(self, motor_torque_nm: npt.ArrayLike, speeds: npt.ArrayLike) -> None:
        """The motor torques the controller sent for the state with wheel ``speeds``."""
        self.watch.commanded(motor_torque_nm, speeds)
