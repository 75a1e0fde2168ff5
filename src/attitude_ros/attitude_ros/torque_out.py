"""The controller's outputs: ``/controller/torque`` (body axes, N m) and, with a
reaction wheel array, ``/controller/wheel_torque`` (the motor torques the plant takes,
:class:`attitude_ros.wheel_msgs.WheelTorqueOut`); one message per answer, stamped with
the state (or the tick) it answers.

``drop_fraction`` (the controller's ``fault.drop_torque_fraction``, a test mode) drops
that share of the answers, seeded, to test that a lossy link neither deadlocks a
lockstep run nor breaks a constraint.
"""

from __future__ import annotations

import random
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.contract.topics import TORQUE
from attitude_core.fsw.control.wheel_control import WheelControl
from attitude_ros import convert as cv
from attitude_ros.endpoints import message, publisher
from attitude_ros.wheel_msgs import WheelTorqueOut

__all__ = ["TorqueOut"]


class TorqueOut:
    """The torque publishers of ``node``; ``wheels``: the wheel stage (None: a torque
    box, the body torque is the command)."""

    def __init__(
        self, node: Any, wheels: WheelControl | None, drop_fraction: float, seed: int
    ) -> None:
        self.pub = publisher(node, TORQUE)
        self.out = message(TORQUE)  # refilled for each state answered
        self.out_tick = message(TORQUE)  # refilled for each tick answered
        self.wheels = None if wheels is None else WheelTorqueOut(node, wheels)
        self.drop_fraction, self.rng, self.dropped = drop_fraction, random.Random(seed), 0
        self.last: Any = None  # the last answer sent (a lockstep re-send)

    def answer(
        self, stamp_msg: Any, torque_b: npt.ArrayLike, wheel_state: Any = None, tick: bool = False
    ) -> npt.NDArray[np.float64]:
        """Send the answer ``torque_b`` (with wheels: its motor torques at the stamp's
        ``wheel_state``, or on a ``tick`` at the last speeds); the body torque sent."""
        u = np.asarray(torque_b, dtype=float)
        if self.wheels is not None:
            u = self.wheels.answer(stamp_msg, u, wheel_state)
        out = self.out_tick if tick else self.out
        out.header.stamp = stamp_msg
        cv.set_vector3(out.wrench.torque, u)
        self._publish(out, resend=False)
        if not tick:
            self.last = out
        return u

    def resend(self) -> None:
        """The last answer to a state, again (a lockstep re-send gets the same)."""
        if self.last is not None:
            self._publish(self.last, resend=True)

    def _publish(self, out: Any, resend: bool) -> None:
        if self.drop_fraction and self.rng.random() < self.drop_fraction:
            self.dropped += 1
            return
        self.pub.publish(out)
        if self.wheels is not None:
            self.wheels.publish(resend)
