"""A short-lived rclpy node for one ``ros2`` verb, and the graph queries the verbs share.

Like ros2cli's daemon-less ``DirectNode``: ``rclpy.init`` on the environment's domain
(``ROS_DOMAIN_ID``, ``ROS_AUTOMATIC_DISCOVERY_RANGE``), a hidden node ``_ros2cli_<pid>``
without rosout, spun for ``spin_time`` and then until the graph has not changed for a
second and holds another node (3 s more at most), so a verb sees what discovery found.
rclpy installs no signal handlers: Ctrl-C raises KeyboardInterrupt, which the verbs turn
into an exit.
"""

from __future__ import annotations

import importlib
import os
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

import rclpy
from rclpy.node import HIDDEN_NODE_PREFIX, Node
from rclpy.signals import SignalHandlerOptions

SETTLE_S = 1.0
"""After ``spin_time``, the graph must stay unchanged this long before a verb reads it."""
SETTLE_MAX_S = 3.0
"""At most this much longer; a graph of this node alone is not settled before then."""


@contextmanager
def graph_node(spin_time: float) -> Iterator[Node]:
    """A hidden node on the default context, discovery given ``spin_time`` s to settle."""
    rclpy.init(args=[], signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = rclpy.create_node(
            f"{HIDDEN_NODE_PREFIX}ros2cli_{os.getpid()}",
            enable_rosout=False,
            start_parameter_services=False,
        )
        try:
            _settle(node, spin_time)
            yield node
        finally:
            node.destroy_node()  # type: ignore[no-untyped-call]  # unannotated in rclpy
    finally:
        rclpy.try_shutdown()


def _snapshot(node: Node) -> tuple[Any, ...]:
    return (
        sorted(node.get_node_names_and_namespaces()),
        sorted((n, sorted(t)) for n, t in node.get_topic_names_and_types()),
        sorted((n, sorted(t)) for n, t in node.get_service_names_and_types()),
    )


def _settle(node: Node, spin_time: float) -> None:
    spin_for(node, spin_time)
    deadline = time.monotonic() + SETTLE_MAX_S
    last, since = _snapshot(node), time.monotonic()
    while time.monotonic() < deadline and (
        time.monotonic() - since < SETTLE_S or len(last[0]) <= 1  # only this node so far
    ):
        spin_for(node, 0.1)
        now = _snapshot(node)
        if now != last:
            last, since = now, time.monotonic()


def spin_for(node: Node, seconds: float) -> None:
    """Spin ``node`` for ``seconds`` of wall time."""
    end = time.monotonic() + seconds
    while (left := end - time.monotonic()) > 0:
        rclpy.spin_once(node, timeout_sec=min(left, 0.1))


def wait_for(node: Node, condition: Callable[[], bool], timeout_s: float) -> bool:
    """Spin until ``condition()`` holds (True) or ``timeout_s`` passed (False)."""
    end = time.monotonic() + timeout_s
    while not condition():
        if time.monotonic() >= end:
            return False
        rclpy.spin_once(node, timeout_sec=0.1)
    return True


def node_names(node: Node, include_hidden: bool = False) -> list[str]:
    """Fully qualified names of the nodes in the graph (hidden ones with ``include_hidden``)."""
    return [
        ns + ("" if ns.endswith("/") else "/") + name
        for name, ns in node.get_node_names_and_namespaces()
        if include_hidden or (name and not name.startswith(HIDDEN_NODE_PREFIX))
    ]


def absolute_name(name: str) -> str:
    """``talker`` -> ``/talker``, as ros2cli takes node names."""
    return name if name.startswith("/") else "/" + name


def load_interface(type_name: str, kind: str = "msg") -> Any:
    """The class of ``pkg/msg/Type`` (or ``pkg/Type``) imported from ``pkg.<kind>``.

    ValueError if the name is malformed or names no such interface.
    """
    parts = type_name.split("/")
    if len(parts) == 2:
        parts.insert(1, kind)
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"'{type_name}' is not a full interface name like 'pkg/{kind}/Type'")
    pkg, sub, name = parts
    try:
        cls = getattr(importlib.import_module(f"{pkg}.{sub}"), name)
    except (ImportError, AttributeError):
        raise ValueError(f"The interface type '{type_name}' is invalid") from None
    return cls


def call(node: Node, srv_type: Any, service: str, request: Any, timeout_s: float) -> Any:
    """Call ``service`` once and return its response; RuntimeError on no server or no answer."""
    client = node.create_client(srv_type, service)
    try:
        if not client.wait_for_service(timeout_sec=timeout_s):
            raise RuntimeError(f"Service '{service}' not available after {timeout_s:g} s")
        future: Any = client.call_async(request)  # rclpy's Future is unannotated
        rclpy.spin_until_future_complete(node, future, timeout_sec=timeout_s)
        if not future.done():
            raise RuntimeError(f"No answer from service '{service}' within {timeout_s:g} s")
        if future.exception() is not None:
            raise RuntimeError(f"Service '{service}' failed: {future.exception()}")
        return future.result()
    finally:
        node.destroy_client(client)
