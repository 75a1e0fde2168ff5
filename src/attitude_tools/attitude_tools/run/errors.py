"""``attitude-run``'s errors: a failed run (exit 1) and a node that refused its input
(exit 2)."""

from __future__ import annotations

__all__ = ["NodeInputError", "RunError"]


class RunError(RuntimeError):
    pass


class NodeInputError(RunError):
    """A node exited with code 2 (bad input it detected); attitude-run exits 2 too."""
