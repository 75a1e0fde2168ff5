"""The check's messages: what it hears as recorded samples (:class:`.record.Sample`,
:class:`.record.JointSample` for the wheel states), and with ``wheels.*`` the motor
torques it sends on ``/controller/wheel_torque``, by wheel name in a changing order (a
bridge that reads by position is caught)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.endpoints import message

from .record import JointSample, Sample

__all__ = ["values", "sample_of", "joint_sample", "wheel_command"]


def values(name: str, msg: Any) -> tuple[float, ...]:
    """The numbers of a state or applied-torque message, as recorded."""
    if name == c.ATTITUDE:
        q = msg.quaternion
        return (q.x, q.y, q.z, q.w)
    return tuple(cv.vector3(msg.wrench.torque if name == c.APPLIED_TORQUE else msg.vector))


def sample_of(name: str, msg: Any, now: float) -> Sample | JointSample:
    """A message heard on ``name`` at ``now`` (s), as recorded."""
    if name == c.CLOCK:
        return Sample(cv.stamp_ns(msg.clock), "", (), now)
    if name == c.WHEEL_STATES:
        return joint_sample(msg, now)
    return Sample(cv.stamp_ns(msg.header.stamp), msg.header.frame_id, values(name, msg), now)


def joint_sample(msg: Any, now: float) -> JointSample:
    """A ``/spacecraft/wheel_states`` message as recorded, heard at ``now`` (s)."""
    return JointSample(
        cv.stamp_ns(msg.header.stamp),
        msg.header.frame_id,
        tuple(msg.name),
        tuple(float(x) for x in msg.velocity),
        tuple(float(x) for x in msg.effort),
        now,
    )


def wheel_command(
    names: Sequence[str], motor_torque_nm: Any, order: Sequence[int], stamp_ns: int
) -> Any:
    """A ``/controller/wheel_torque`` of ``motor_torque_nm`` (the scenario's order),
    its entries in ``order``, stamped ``stamp_ns``."""
    msg = message(c.WHEEL_TORQUE)
    cv.set_stamp(msg.header.stamp, stamp_ns)
    msg.name = [names[j] for j in order]
    msg.effort = [float(motor_torque_nm[j]) for j in order]
    return msg
