"""Stamp-paired subscriptions for the planner and the controller (the ROS shell of
:class:`attitude_core.runtime.stamp_pairing.StampPairing`).

:func:`subscribe_paired` subscribes each input topic of a node with the contract's QoS.
A message goes through the run guard (:meth:`attitude_ros.run_guard.RunGuard.admit`:
only this run's publishers), the contract frame, the topic's value check (a
``convert`` function: message -> ``(value, reason)``) and the pairing. Refused
messages are logged (throttled) and counted; a complete stamp calls ``on_complete``;
the last answered stamp, re-sent on the first topic, calls ``on_repeat``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

from attitude_core.runtime.plausibility import implausible_mrp, implausible_rate
from attitude_core.runtime.stamp_pairing import Intake, StampPairing
from attitude_ros.convert import bad_frame, bad_quaternion, mrp_from_quaternion, reject, vector3
from attitude_ros.endpoints import subscription
from attitude_ros.run_guard import RunGuard

__all__ = [
    "Convert",
    "subscribe_paired",
    "attitude_value",
    "rate_value",
    "target_mrp_value",
    "target_rate_value",
]

Convert = Callable[[Any], tuple[Any, str | None]]
"""A message -> ``(value, None)``, or ``(None, reason)`` when its content is unusable."""


def attitude_value(msg: Any) -> tuple[Any, str | None]:
    """``sigma_BN`` from a ``QuaternionStamped`` (a unit, finite quaternion)."""
    reason = bad_quaternion(msg.quaternion)
    return (None, reason) if reason else (mrp_from_quaternion(msg.quaternion), None)


def rate_value(msg: Any) -> tuple[Any, str | None]:
    """``omega_B`` (rad/s) from a ``Vector3Stamped``, within the plausible rate."""
    v = vector3(msg.vector)
    reason = implausible_rate(v)
    return (None, reason) if reason else (v, None)


def target_mrp_value(msg: Any) -> tuple[Any, str | None]:
    """``sigma_RN`` from a ``Vector3Stamped`` (a plausible MRP)."""
    v = vector3(msg.vector)
    reason = implausible_mrp(v, "target MRP")
    return (None, reason) if reason else (v, None)


def target_rate_value(msg: Any) -> tuple[Any, str | None]:
    """``omega_t`` (target axes, rad/s) from a ``Vector3Stamped``."""
    v = vector3(msg.vector)
    reason = implausible_rate(v, "target rate")
    return (None, reason) if reason else (v, None)


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
        sub = subscription(
            node, name, _callback(node, guard, pairing, slot, name, convert, on_complete, on_repeat)
        )
        guard.watch(name, sub)


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
    def on_message(msg: Any) -> None:
        if not node.takes_input or not guard.admit(name):
            return  # inactive (a managed node), or a foreign writer
        value, reason = None, bad_frame(msg, name)
        if reason is None:
            value, reason = convert(msg)
        stamp = msg.header.stamp
        offer = pairing.offer(slot, stamp.sec, stamp.nanosec, time.time_ns(), value, reason)
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
            on_complete(offer.stamp_ns, stamp, offer.values)

    return on_message
