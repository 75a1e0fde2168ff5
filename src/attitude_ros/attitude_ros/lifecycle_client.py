"""A managed node seen from its manager: the standard ``lifecycle_msgs`` services
(``<node>/change_state``, ``<node>/get_state``), its ``<node>/transition_event`` and
its parameters (``rcl_interfaces``), driven from one rclpy node by spinning it."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import rclpy
from lifecycle_msgs.msg import Transition, TransitionEvent
from lifecycle_msgs.srv import ChangeState, GetState
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient

__all__ = ["LifecycleClient", "GONE_POLL_S", "STATE_RETRY_S"]

GONE_POLL_S = 0.02
"""How often a wait that may end with the node's process asks whether it has, s."""
STATE_RETRY_S = 0.1
"""How long a ``get_state`` request waits for its answer before it is sent again, s.
The first answer of a service the client has not called before can be lost (the
server's response writer still matching the client's reader: the request side being
ready says nothing of it); ``get_state`` changes nothing, so asking again is safe."""


def _on_transition(event: Any, name: str, on_event: Callable[[str, str, str], None]) -> None:
    on_event(name, event.start_state.label, event.goal_state.label)


class LifecycleClient:
    """The lifecycle interface of the node ``name`` (fully qualified)."""

    def __init__(
        self,
        node: Node,
        name: str,
        on_event: Callable[[str, str, str], None],
        executor: Any = None,
    ) -> None:
        """``on_event(name, start_label, goal_label)`` for each transition event;
        ``executor``: the one spinning ``node`` (default: rclpy's global one)."""
        self.node, self.name, self.executor = node, name, executor
        self.change = node.create_client(ChangeState, f"{name}/change_state")
        self.get = node.create_client(GetState, f"{name}/get_state")
        self.params = AsyncParameterClient(node, name)
        self.events = node.create_subscription(
            TransitionEvent,
            f"{name}/transition_event",
            lambda e: _on_transition(e, name, on_event),
            10,
        )

    def ready(self) -> bool:
        """Whether both lifecycle services are discovered and the transition events
        matched (none is missed from then on)."""
        services = self.change.service_is_ready() and self.get.service_is_ready()
        return bool(services and self.events.get_publisher_count() > 0)

    def _call(
        self, client: Any, request: Any, timeout_s: float, gone: Callable[[], bool] | None
    ) -> Any:
        future = client.call_async(request)
        if gone is None:
            self._spin(future, timeout_s)
        else:  # waited for in short slices: a node whose process has ended answers never
            deadline = time.monotonic() + timeout_s
            while not future.done() and time.monotonic() < deadline and not gone():
                self._spin(future, GONE_POLL_S)
        if not future.done():
            client.remove_pending_request(future)
            return None
        return future.result()

    def _spin(self, future: Any, timeout_s: float) -> None:
        """Spin the node (on ``executor`` when given) until ``future`` is done or
        ``timeout_s`` has passed."""
        if self.executor is not None:
            self.executor.spin_until_future_complete(future, timeout_sec=timeout_s)
        else:
            rclpy.spin_until_future_complete(self.node, future, timeout_sec=timeout_s)

    def state(self, timeout_s: float, gone: Callable[[], bool] | None = None) -> str | None:
        """The node's current state label; None when it does not answer in time (or
        ``gone()`` turns true meanwhile: its process has ended). The request is sent
        again every :data:`STATE_RETRY_S` while no answer has come; the first answer to
        any of them counts (a slow node's late answers are not thrown away)."""
        deadline = time.monotonic() + timeout_s
        sent: list[Any] = []
        next_send = 0.0
        try:
            while (now := time.monotonic()) < deadline and not (gone and gone()):
                if now >= next_send:
                    sent.append(self.get.call_async(GetState.Request()))
                    next_send = now + STATE_RETRY_S
                self._spin(sent[-1], min(GONE_POLL_S, deadline - now))
                for future in sent:
                    if future.done():
                        return str(future.result().current_state.label)
            return None
        finally:
            for future in sent:
                if not future.done():
                    self.get.remove_pending_request(future)

    def transition(
        self, label: str, timeout_s: float, gone: Callable[[], bool] | None = None
    ) -> bool | None:
        """Request the transition ``label`` (configure, activate, ...): whether it
        succeeded; None when the node did not answer within ``timeout_s`` (or ``gone()``
        turned true meanwhile)."""
        request = ChangeState.Request(transition=Transition(label=label))
        response = self._call(self.change, request, timeout_s, gone)
        return None if response is None else bool(response.success)

    def transition_async(self, label: str) -> Any:
        """Request the transition ``label`` without waiting: the future of the
        ``ChangeState`` response (the caller spins the node)."""
        return self.change.call_async(ChangeState.Request(transition=Transition(label=label)))

    def set_strings_async(self, key: str, values: Sequence[str]) -> Any:
        """Set a string-array parameter without waiting: the future of the
        ``SetParameters`` response (the caller spins the node; the service must be ready,
        see :meth:`params_ready`)."""
        value = list(values) or [""]
        param = Parameter(key, Parameter.Type.STRING_ARRAY, value)  # type: ignore[no-untyped-call]
        return self.params.set_parameters([param])

    def params_ready(self) -> bool:
        """Whether the node's parameter services are discovered."""
        return bool(self.params.services_are_ready())
