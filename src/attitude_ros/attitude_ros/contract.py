"""The topic contract as rclpy needs it: the names of :mod:`attitude_core.topics`, plus QoS
and message classes."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from attitude_core.topics import *  # noqa: F403 - the contract's names, re-exported
from attitude_core.topics import CLOCK, HISTORY_DEPTH, TOPICS, Topic  # noqa: F401

if TYPE_CHECKING:
    from rclpy.qos import QoSProfile


def qos(topic: Topic | None = None, *, subscriber: bool = False) -> QoSProfile:
    """QoS of a contract topic.

    Publishers: reliable, volatile, keep-all: a sample leaves the writer only when every
    reader has it, so a recorder that falls behind a lockstep run delays it but loses
    nothing. Latched topics (the planner status): reliable, transient-local, depth 1.
    Subscribers of the nodes: reliable, volatile, keep-last ``HISTORY_DEPTH`` (a
    restarted node must not be fed old history); the recorder keeps all. A reliable
    ``/clock`` publisher also serves rclpy's best-effort ``/clock`` listeners.
    """
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    latched = topic is not None and topic.latched
    # rclpy leaves QoSProfile.__init__(**kwargs) unannotated: hence the ignores.
    if latched:
        return QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1,  # type: ignore[no-untyped-call]
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.TRANSIENT_LOCAL,
        )
    return QoSProfile(  # type: ignore[no-untyped-call]
        history=HistoryPolicy.KEEP_LAST if subscriber else HistoryPolicy.KEEP_ALL,
        depth=HISTORY_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )


def recorder_qos(topic: Topic) -> QoSProfile:
    """QoS of the recorder's subscription: keep-all, and transient-local on latched topics."""
    from rclpy.qos import HistoryPolicy

    profile = qos(topic)
    if not topic.latched:
        profile.history = HistoryPolicy.KEEP_ALL
    return profile


def message_class(type_name: str) -> type[Any]:
    """The Python class of ``pkg/msg/Type``."""
    import importlib

    pkg, _, name = type_name.split("/")
    cls: type[Any] = getattr(importlib.import_module(f"{pkg}.msg"), name)
    return cls


def topic(name: str) -> Topic:
    """The contract entry of a topic name."""
    for t in TOPICS:
        if t.name == name:
            return t
    raise KeyError(name)
