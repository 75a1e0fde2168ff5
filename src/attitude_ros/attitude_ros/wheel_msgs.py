"""The wheel topics' ``sensor_msgs/JointState`` (``/spacecraft/wheel_states``,
``/controller/wheel_torque``; conventions in :mod:`attitude_core.contract.topics`) as
arrays in the scenario's wheel order, and back.

A message is read by wheel name, in any order: every declared wheel present once, no
other name, and each array used (``velocity``, ``effort``) as long as ``name``; the
values finite. Anything else is refused with the reason, never guessed.
:class:`WheelTorqueOut` is the controller's wheel output.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.contract.topics import WHEEL_STATES, WHEEL_TORQUE
from attitude_core.fsw.control.wheel_control import WheelControl
from attitude_ros.cdr import CdrError, JointValues, joint_state
from attitude_ros.endpoints import message, publisher

__all__ = ["WheelOrder", "WheelTorqueOut", "fill_joint_state", "wheel_inputs"]

_Floats = npt.NDArray[np.float64]


class WheelOrder:
    """The scenario's wheel names: a JointState's arrays in that order."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names = tuple(names)
        self._index = {name: i for i, name in enumerate(self.names)}

    def _order(self, names: Sequence[str]) -> tuple[list[int] | None, str | None]:
        if len(names) != len(set(names)):
            dup = sorted({n for n in names if list(names).count(n) > 1})
            return None, f"name: wheel(s) {dup} more than once"
        unknown = [n for n in names if n not in self._index]
        if unknown:
            return None, f"name: {unknown} not among the declared wheels {list(self.names)}"
        missing = [n for n in self.names if n not in names]
        if missing:
            return None, f"name: wheel(s) {missing} missing"
        return [self._index[n] for n in names], None

    def array(
        self, values: JointValues, field: str, names: Sequence[str] | None = None
    ) -> tuple[_Floats | None, str | None]:
        """``values.<field>`` in the scenario's order, or ``(None, reason)``."""
        got = tuple(values.name if names is None else names)
        order, reason = self._order(got)
        if order is None:
            return None, reason
        data = getattr(values, field)
        if len(data) != len(got):
            return None, f"{field}: {len(data)} values for {len(got)} names"
        out = np.empty(len(self.names))
        out[order] = data
        if not np.isfinite(out).all():
            return None, f"{field}: not finite ({out.tolist()})"
        return out, None

    def command(self, data: bytes) -> tuple[int, str, _Floats | None, str | None]:
        """A serialized ``/controller/wheel_torque``: ``(stamp_ns, frame_id, effort,
        None)``, or ``(stamp_ns, frame_id, None, reason)`` (stamp 0 when unreadable)."""
        try:
            sec, nanosec, frame_id, values = joint_state(data)
        except CdrError as err:
            return 0, "", None, f"malformed message: {err}"
        effort, reason = self.array(values, "effort")
        return sec * 1_000_000_000 + nanosec, frame_id, effort, reason

    def speeds_and_effort(
        self, values: JointValues
    ) -> tuple[tuple[_Floats, _Floats] | None, str | None]:
        """``(velocity, effort)`` of a wheel state, or ``(None, reason)``."""
        speeds, reason = self.array(values, "velocity")
        if speeds is None:
            return None, reason
        effort, reason = self.array(values, "effort")
        if effort is None:
            return None, reason
        return (speeds, effort), None


def fill_joint_state(
    msg: Any, names: Sequence[str], velocity: npt.ArrayLike | None, effort: npt.ArrayLike
) -> None:
    """Write a wheel message: ``name``, ``velocity`` (None: empty), ``effort``."""
    if list(msg.name) != list(names):
        msg.name = list(names)
    msg.velocity = [] if velocity is None else np.asarray(velocity, dtype=float).tolist()
    msg.effort = np.asarray(effort, dtype=float).tolist()


def wheel_inputs(names: Sequence[str] | None) -> list[tuple[str, Any]]:
    """The paired input of a node reading the wheel state (none without wheels)."""
    if names is None:
        return []
    return [(WHEEL_STATES, WheelOrder(names).speeds_and_effort)]


class WheelTorqueOut:
    """The controller's ``/controller/wheel_torque``: the motor torques of ``control``
    (:class:`attitude_core.fsw.control.wheel_control.WheelControl`) at the last measured
    wheel speeds, filled per answer and sent beside the body torque."""

    def __init__(self, node: Any, control: WheelControl) -> None:
        self.control = control
        self.names = control.array.names
        self.speeds: _Floats = control.array.initial_speed.copy()  # the last measured
        self.pub = publisher(node, WHEEL_TORQUE)
        self.out = message(WHEEL_TORQUE)  # refilled for each answer
        self.sent = message(WHEEL_TORQUE)  # the last sent (a lockstep re-send)

    def answer(self, stamp_msg: Any, tau_b: npt.ArrayLike, wheel_state: Any = None) -> _Floats:
        """Fill the motor torques for ``tau_b`` (``wheel_state``: the stamp's measured
        speeds and applied torques; None: a tick, at the last speeds); the body torque
        they make."""
        if wheel_state is None:
            cmd = self.control.allocate(tau_b, self.speeds)
        else:
            self.speeds, applied = wheel_state
            cmd = self.control.command(tau_b, self.speeds, applied)
        self.out.header.stamp = stamp_msg
        fill_joint_state(self.out, self.names, None, cmd.motor_torque_nm)
        return cmd.body_torque_b

    def publish(self, resend: bool = False) -> None:
        """Send the torques just filled (``resend``: the last sent, again)."""
        if not resend:
            self.sent.header.stamp = self.out.header.stamp
            fill_joint_state(self.sent, self.names, None, self.out.effort)
        self.pub.publish(self.sent)
