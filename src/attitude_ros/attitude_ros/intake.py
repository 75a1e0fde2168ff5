"""Stamp-paired subscriptions for the planner and the controller (the ROS shell of
:class:`attitude_core.runtime.stamp_pairing.StampPairing`).

:func:`subscribe_paired` subscribes each input topic of a node with the contract's QoS,
raw: a message is read from its serialized form (:func:`attitude_ros.cdr.stamped`, its
stamp, frame and floats), not built into rclpy's message objects. It goes through the
run guard (:meth:`attitude_ros.run_guard.RunGuard.admit`: only this run's publishers),
the contract frame, the topic's value check (a ``convert`` function: the message's
floats -> ``(value, reason)``) and the pairing. Refused messages (malformed ones too)
are logged (throttled) and counted; a complete stamp calls ``on_complete``; the last
answered stamp, re-sent on the first topic, calls ``on_repeat``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time

from attitude_core.runtime.plausibility import implausible_mrp, implausible_rate
from attitude_core.runtime.stamp_pairing import Intake, StampPairing
from attitude_ros import contract as c
from attitude_ros.cdr import FLOATS, CdrError, joint_state, stamped
from attitude_ros.convert import bad_frame_id, bad_quaternion_xyzw, mrp_from_xyzw, reject
from attitude_ros.endpoints import subscription
from attitude_ros.run_guard import RunGuard
from attitude_ros.wheel_msgs import WheelOrder

__all__ = [
    "Convert",
    "subscribe_paired",
    "attitude_value",
    "rate_value",
    "target_mrp_value",
    "target_rate_value",
    "subscribe_wheel_torque",
]

Convert = Callable[[Any], tuple[Any, str | None]]
"""A message's floats (a ``JointState``'s :class:`attitude_ros.cdr.JointValues`) ->
``(value, None)``, or ``(None, reason)`` when unusable."""


def attitude_value(q: tuple[float, ...]) -> tuple[Any, str | None]:
    """``sigma_BN`` from a ``QuaternionStamped``'s ``(x, y, z, w)`` (unit, finite)."""
    reason = bad_quaternion_xyzw(*q)
    return (None, reason) if reason else (mrp_from_xyzw(*q), None)


def rate_value(v: tuple[float, ...]) -> tuple[Any, str | None]:
    """``omega_B`` (rad/s) from a ``Vector3Stamped``, within the plausible rate."""
    reason = implausible_rate(v)
    return (None, reason) if reason else (np.array(v), None)


def target_mrp_value(v: tuple[float, ...]) -> tuple[Any, str | None]:
    """``sigma_RN`` from a ``Vector3Stamped`` (a plausible MRP)."""
    reason = implausible_mrp(v, "target MRP")
    return (None, reason) if reason else (np.array(v), None)


def target_rate_value(v: tuple[float, ...]) -> tuple[Any, str | None]:
    """``omega_t`` (target axes, rad/s) from a ``Vector3Stamped``."""
    reason = implausible_rate(v, "target rate")
    return (None, reason) if reason else (np.array(v), None)


def subscribe_paired(
    node: Any,
    guard: RunGuard,
    pairing: StampPairing,
    inputs: Sequence[tuple[str, Convert]],
    on_complete: Callable[[int, Any, tuple[Any, ...]], None],
    on_repeat: Callable[[], None],
) -> None:
    """Subscribe ``inputs`` (topic, convert), one per pairing slot, as the contract says.

    ``on_complete(stamp_ns, stamp_msg, values)`` answers a stamp whose inputs are all
    in (``values`` in ``inputs`` order); ``on_repeat()`` answers the last stamp again.
    """
    if len(inputs) != pairing.slots:
        raise ValueError(f"{len(inputs)} input topics for {pairing.slots} pairing slots")
    for slot, (name, convert) in enumerate(inputs):
        on_message = _callback(node, guard, pairing, slot, name, convert, on_complete, on_repeat)
        guard.watch(name, subscription(node, name, on_message, raw=True))


def _callback(
    node: Any,
    guard: RunGuard,
    pairing: StampPairing,
    slot: int,
    name: str,
    convert: Convert,
    on_complete: Callable[[int, Any, tuple[Any, ...]], None],
    on_repeat: Callable[[], None],
) -> Callable[[Any], None]:
    entry = c.topic(name)
    n_floats, frame = FLOATS.get(entry.type_name, 0), entry.frame
    joints = entry.type_name == "sensor_msgs/msg/JointState"  # convert gets JointValues

    def on_message(data: bytes) -> None:
        if not node.takes_input or not guard.admit(name):
            return  # inactive (a managed node), or a foreign writer
        floats: Any
        try:
            if joints:
                sec, nanosec, frame_id, floats = joint_state(data)
            else:
                sec, nanosec, frame_id, floats = stamped(data, n_floats)
        except CdrError as err:  # no stamp to pair it with: refused as a bad value
            pairing.bad_values += 1
            reject(node, name, f"malformed message: {err}", count=pairing.rejected)
            return
        value, reason = None, bad_frame_id(frame_id, frame)
        if reason is None:
            value, reason = convert(floats)
        offer = pairing.offer(slot, sec, nanosec, time.time_ns(), value, reason)
        if offer.intake is Intake.REPEAT:
            if slot == 0:  # a lockstep re-send: the same answer again
                on_repeat()
            return
        if offer.intake is Intake.REJECTED:
            reject(node, name, offer.reason, count=offer.rejected)
            return
        if offer.reason:  # accepted, with a note (the gate re-anchored)
            node.get_logger().warning(f"{name}: {offer.reason}")
        if offer.intake is Intake.COMPLETE:
            on_complete(offer.stamp_ns, Time(sec=sec, nanosec=nanosec), offer.values)

    return on_message


def subscribe_wheel_torque(
    node: Any,
    guard: RunGuard,
    pairing: StampPairing,
    names: Sequence[str],
    on_command: Callable[[int, Any], None],
) -> None:
    """Subscribe ``/controller/wheel_torque`` (not paired): ``on_command(stamp_ns,
    motor torques in the order of ``names``)``; refused messages counted in ``pairing``."""
    order = WheelOrder(names)

    def on_message(data: bytes) -> None:
        if not node.takes_input or not guard.admit(c.WHEEL_TORQUE):
            return
        stamp, _, u, reason = order.command(data)
        if u is None:
            pairing.bad_values += 1
            reject(node, c.WHEEL_TORQUE, reason or "", count=pairing.rejected)
        else:
            on_command(stamp, u)

    guard.watch(c.WHEEL_TORQUE, subscription(node, c.WHEEL_TORQUE, on_message, raw=True))
