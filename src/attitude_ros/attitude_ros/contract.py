"""The topic contract as rclpy needs it: the names of :mod:`attitude_core.topics`, plus QoS
and message classes."""

from __future__ import annotations

from attitude_core.topics import *  # noqa: F401,F403 - the contract's names, re-exported
from attitude_core.topics import CLOCK, HISTORY_DEPTH, TOPICS, Topic  # noqa: F401


def qos(topic: Topic | None = None, *, subscriber: bool = False):
    """QoS of a contract topic.

    Publishers: reliable, transient-local, keep-last ``HISTORY_DEPTH`` (depth 1 for
    latched topics). Subscribers of the nodes: reliable, volatile (a restarted node
    must not be fed old history); the recorder asks for transient-local itself.
    A reliable ``/clock`` publisher also serves rclpy's best-effort ``/clock`` listeners.
    """
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    latched = topic is not None and topic.latched
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=1 if latched else HISTORY_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=(DurabilityPolicy.VOLATILE if subscriber and not latched
                    else DurabilityPolicy.TRANSIENT_LOCAL),
    )


def message_class(type_name: str):
    """The Python class of ``pkg/msg/Type``."""
    import importlib
    pkg, _, name = type_name.split("/")
    return getattr(importlib.import_module(f"{pkg}.msg"), name)


def topic(name: str) -> Topic:
    """The contract entry of a topic name."""
    for t in TOPICS:
        if t.name == name:
            return t
    raise KeyError(name)
