"""The controller's wheel stage: the body torque it wants (eq. 11) as wheel motor torques,
on the wheels still answering.

Inputs each step: the body torque wanted ``tau_B`` (N m), and the wheel state the plant
reports with the measured state (``/spacecraft/wheel_states``): the speeds (rad/s) and
the motor torques applied over the step that ended there. Output: the motor torques
to command (N m, the array's order) and the body torque they make.

Each step first judges the step just flown (:class:`~.wheel_health.WheelHealth`: its
command, what the wheels applied, their speeds when commanded), then allocates on the
usable wheels within their bounds (:mod:`.wheel_allocation`); with the step ``dt_s``
each wheel's bound also keeps the step from taking it past its speed limit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.control.wheel_allocation import allocate, wheel_bounds
from attitude_core.fsw.control.wheel_health import WheelHealth
from attitude_core.models.wheel_array import WheelArray

__all__ = ["WheelCommand", "WheelControl", "WheelWatch"]

_Floats = npt.NDArray[np.float64]


@dataclass(frozen=True)
class WheelCommand:
    """Motor torques per wheel (N m) and the body torque they make (``-G u``, N m)."""

    motor_torque_nm: _Floats
    body_torque_b: _Floats


class WheelWatch:
    """Which wheels answer their commands: the step last commanded (its motor torques
    and the speeds then), judged against what the next wheel state reports applied."""

    def __init__(self, array: WheelArray) -> None:
        self.array = array
        self.health = WheelHealth(len(array))
        self.last: tuple[_Floats, _Floats] | None = None  # (commanded, speeds then)

    @property
    def usable(self) -> npt.NDArray[np.bool_]:
        return self.health.usable

    def judge(
        self, commanded_nm: npt.ArrayLike, speeds_then: npt.ArrayLike, applied_nm: npt.ArrayLike
    ) -> bool:
        """One step flown: ``commanded_nm`` at ``speeds_then``, ``applied_nm`` reported.
        True when a wheel was just taken out."""
        self.health.observe(commanded_nm, applied_nm, speeds_then, self.array.max_speed)
        return self.health.changed

    def measured(self, speeds: npt.ArrayLike, applied_nm: npt.ArrayLike) -> bool:
        """A wheel state: judges the step last :meth:`commanded` (if any). True when a
        wheel was just taken out."""
        if self.last is None:
            return False
        commanded, speeds_then = self.last
        self.last = None
        return self.judge(commanded, speeds_then, applied_nm)

    def commanded(self, motor_torque_nm: npt.ArrayLike, speeds: npt.ArrayLike) -> None:
        """The motor torques sent for the state with wheel ``speeds``."""
        self.last = (np.asarray(motor_torque_nm, dtype=float), np.asarray(speeds, dtype=float))


class WheelControl:
    """Allocation on the usable wheels of ``array`` (all at first), each wheel's torque
    bounded so the step of ``dt_s`` does not take it past its speed limit."""

    def __init__(self, array: WheelArray, dt_s: float | None = None) -> None:
        self.array = array
        self.dt_s = dt_s
        self.watch = WheelWatch(array)

    def command(
        self, tau_b: npt.ArrayLike, speeds: npt.ArrayLike, applied_nm: npt.ArrayLike
    ) -> WheelCommand:
        """The motor torques for ``tau_b`` at wheel ``speeds``; ``applied_nm``: what the
        wheels applied over the step that ended at this state (judged first)."""
        self.watch.measured(speeds, applied_nm)
        return self.allocate(tau_b, speeds)

    def allocate(self, tau_b: npt.ArrayLike, speeds: npt.ArrayLike) -> WheelCommand:
        """The motor torques for ``tau_b`` at ``speeds``, remembered to be judged."""
        usable = self.watch.usable
        lower, upper = wheel_bounds(self.array, speeds, usable, self.dt_s)
        u = allocate(self.array, tau_b, lower, upper).motor_torque_nm
        self.watch.commanded(u, speeds)
        return WheelCommand(u, self.array.body_torque_b(u))
