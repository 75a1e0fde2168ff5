"""The topic contract as rclpy needs it: the names of :mod:`attitude_core.contract.topics`, plus QoS
and message classes."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any

from attitude_core.contract.topics import *  # noqa: F403 - the contract's names, re-exported
from attitude_core.contract.topics import (  # noqa: F401
    CLOCK,
    COMMAND_TOPICS,
    GOAL_DEPTH,
    HISTORY_DEPTH,
    STATE_TOPICS,
    TOPICS,
    Topic,
    topic,
)

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile
    from rclpy.qos_overriding_options import QoSOverridingOptions


def qos(entry: Topic | None = None, *, subscriber: bool = False) -> QoSProfile:
    """QoS of a contract entry.

    Publishers: reliable, volatile, keep-all: a sample leaves the writer only when every
    reader has it, so a recorder that falls behind a lockstep run delays it but loses
    nothing. Latched topics (the planner status): reliable, transient-local, depth 1.
    Subscribers of the nodes: reliable, volatile, keep-last ``HISTORY_DEPTH`` (a
    restarted node must not be fed old history); the recorder keeps all. A reliable
    ``/clock`` publisher also serves rclpy's best-effort ``/clock`` listeners.
    """
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    latched = entry is not None and entry.latched
    # rclpy leaves QoSProfile.__init__(**kwargs) unannotated: hence the ignores.
    if latched:
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1,  # type: ignore[no-untyped-call]
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
    command = entry is not None and entry in COMMAND_TOPICS
    return QoSProfile(  # type: ignore[no-untyped-call]
        history=HistoryPolicy.KEEP_LAST if subscriber or command else HistoryPolicy.KEEP_ALL,
        depth=GOAL_DEPTH if command else HISTORY_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )


def recorder_qos(entry: Topic) -> QoSProfile:
    """QoS of the recorder's subscription: keep-all, and transient-local on latched topics."""
    from rclpy.qos import HistoryPolicy

    profile = qos(entry)
    if not entry.latched:
        profile.history = HistoryPolicy.KEEP_ALL
    return profile


@functools.cache
def message_class(type_name: str) -> type[Any]:
    """The Python class of ``pkg/msg/Type`` (looked up once per process)."""
    import importlib

    pkg, _, name = type_name.split("/")
    cls: type[Any] = getattr(importlib.import_module(f"{pkg}.msg"), name)
    return cls


def state_qos_overrides(entry: Topic) -> QoSOverridingOptions | None:
    """ROS 2's standard QoS overrides on the state subscriptions (planner, controller,
    recorder), so a best-effort (sensor-data) state publisher can be connected with
    ``-p qos_overrides./spacecraft/attitude.subscription.reliability:=best_effort``
    (and the same for ``/spacecraft/angular_velocity``). The default stays reliable:
    lossless lockstep with the project's simulator. None for every other entry."""
    if entry.name not in STATE_TOPICS:
        return None
    from rclpy.qos_overriding_options import QoSOverridingOptions

    options: QoSOverridingOptions = QoSOverridingOptions.with_default_policies()
    return options
