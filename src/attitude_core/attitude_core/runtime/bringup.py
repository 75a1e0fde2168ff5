"""The bring-up of one run's managed nodes, as a lifecycle manager drives it (no ROS).

The order follows the node table (:mod:`attitude_core.config.node_graph`): every
node is configured, the run is checked (each loop node runs the same scenario, the
plant is there), then the nodes are activated in start order (the recorder first, the
simulator last) and deactivated and shut down in the reverse order.

:class:`TransitionWatch` tells the manager's own transitions from the others: a node
that leaves a state the manager put it in (a deactivation it did not ask for, an
``errorprocessing``) is a named failure of the run.

The manager's events (``attitude-run`` reads them on the manager's stdout) are JSON
lines after :data:`EVENT_PREFIX`: :func:`event_line` and :func:`parse_event`.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

__all__ = [
    "EVENT_PREFIX",
    "PRIMARY",
    "TRANSITION_GOALS",
    "TransitionWatch",
    "bring_down_order",
    "event_line",
    "parse_event",
]

EVENT_PREFIX = "@bringup "
PRIMARY = ("unconfigured", "inactive", "active", "finalized")
"""The primary states of a managed node (``lifecycle_msgs/msg/State``)."""
TRANSITION_GOALS = {
    "configure": "inactive",
    "activate": "active",
    "deactivate": "inactive",
    "cleanup": "unconfigured",
    "shutdown": "finalized",
}
"""The primary state each transition the manager requests ends in when it succeeds."""


def bring_down_order(names: Sequence[str]) -> list[str]:
    """Deactivation and shutdown order: the reverse of activation."""
    return list(reversed(names))


def event_line(event: str, **fields: Any) -> str:
    """One event of the manager, as the line it prints."""
    return EVENT_PREFIX + json.dumps({"event": event, **fields}, sort_keys=True)


def parse_event(line: str) -> dict[str, Any] | None:
    """The event of a line the manager printed; None for any other line."""
    if not line.startswith(EVENT_PREFIX):
        return None
    try:
        value = json.loads(line[len(EVENT_PREFIX) :])
    except json.JSONDecodeError:
        return None
    return value if isinstance(value, dict) and "event" in value else None


@dataclass
class TransitionWatch:
    """The state the manager expects of each node, and the transitions it did not ask for."""

    expected: dict[str, str] = field(default_factory=dict)  # node -> primary state
    requested: dict[str, str] = field(default_factory=dict)  # node -> goal in progress

    def request(self, node: str, transition: str) -> None:
        """The manager asks ``node`` for ``transition``."""
        self.requested[node] = TRANSITION_GOALS[transition]

    def settle(self, node: str, state: str) -> None:
        """The manager's request ended with ``node`` in ``state``."""
        self.requested.pop(node, None)
        self.expected[node] = state

    def judge(self, node: str, start: str, goal: str) -> str | None:
        """A transition event of ``node`` (``start`` -> ``goal`` labels): the failure it
        means, or None when the manager asked for it (or it is an intermediate step)."""
        if goal == "errorprocessing":
            return f"{node} went to errorprocessing (from {start}): see its log"
        if goal not in PRIMARY:
            return None  # configuring, activating, ...: the goal follows
        if self.requested.get(node) == goal:
            return None
        if node in self.requested and goal != self.requested[node]:
            return f"{node}: transition to {goal}, the manager asked for {self.requested[node]}"
        expected = self.expected.get(node)
        if expected is not None and goal != expected:
            return (
                f"{node}: unexpected transition {start} -> {goal} (the manager left it {expected})"
            )
        return None
