"""Publishers, subscriptions and outgoing messages driven by the topic contract
(:mod:`attitude_core.contract.topics`): a node names the topic, the contract gives the
message class, the QoS and the header's frame."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from attitude_ros import contract as c

__all__ = ["publisher", "subscription", "raw_subscription", "message"]


def publisher(node: Any, name: str, **kwargs: Any) -> Any:
    """A publisher of ``name`` with the contract's message class and QoS."""
    entry = c.topic(name)
    cls = c.message_class(entry.type_name)
    return node.create_publisher(cls, entry.node_name, c.qos(entry), **kwargs)


def subscription(node: Any, name: str, callback: Callable[[Any], None], **kwargs: Any) -> Any:
    """A subscription of ``name`` with the contract's message class and subscriber QoS
    (and ROS 2's QoS overrides on the state topics); ``raw=True``: the callback takes
    the serialized message (bytes, see :mod:`attitude_ros.cdr`)."""
    entry = c.topic(name)
    return node.create_subscription(
        c.message_class(entry.type_name),
        entry.node_name,
        callback,
        c.qos(entry, subscriber=True),
        qos_overriding_options=c.state_qos_overrides(entry),
        **kwargs,
    )


def raw_subscription(node: Any, name: str, callback: Callable[[bytes], None]) -> Any:
    """A recorder's subscription of ``name``: serialized messages, the recorder QoS
    (keep-all; transient-local on latched topics)."""
    entry = c.topic(name)
    return node.create_subscription(
        c.message_class(entry.type_name),
        entry.node_name,
        callback,
        c.recorder_qos(entry),
        raw=True,
        qos_overriding_options=c.state_qos_overrides(entry),
    )


def message(name: str) -> Any:
    """A new message of ``name``'s class, its header's frame set as the contract says."""
    entry = c.topic(name)
    msg = c.message_class(entry.type_name)()
    if entry.frame is not None:
        msg.header.frame_id = entry.frame
    return msg
