"""What every node of the stack offers the main loop (:func:`attitude_ros.runner.run`):
``done`` and ``exit_code`` to end it, ``stop`` (the run guard's verdict), ``rejected``
(input messages refused so far) and ``close`` (on every way out)."""

from __future__ import annotations

from typing import Any, Protocol

from rclpy.node import Node

from attitude_core.contract.node_graph import NodeSpec

__all__ = ["StackNode", "Stoppable"]


class Stoppable(Protocol):
    """The main loop's view of a node."""

    done: bool
    exit_code: int

    def close(self) -> None: ...


class StackNode(Node):
    """A node of the node table (``spec``), named as the table says."""

    def __init__(self, spec: NodeSpec[Any], **kwargs: Any) -> None:
        super().__init__(spec.node_name, **kwargs)
        self.spec = spec
        self.done, self.exit_code = False, 0

    @property
    def rejected(self) -> int:
        """Input messages refused so far, for their stamp or their content."""
        return 0

    def stop(self, code: int, reason: str = "") -> None:
        """The run guard's verdict: stop answering, end the main loop with ``code``."""
        self.done, self.exit_code = True, code

    def close(self) -> None:
        """Release what the node holds (threads, files); runs on every way out."""
