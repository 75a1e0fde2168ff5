"""``attitude-run``'s end of the run's lifecycle manager process
(``attitude_bringup lifecycle_manager``): its events, read from its stdout on a thread
(:func:`attitude_core.runtime.bringup.parse_event`), and its commands on its stdin
(``activate`` after a hold, ``stop`` with the nodes that have exited already, ``gone``
with those that exit during the bring-down)."""

from __future__ import annotations

import queue
import subprocess
import threading
import time
from collections.abc import Callable
from typing import Any

from attitude_core.runtime.bringup import parse_event

__all__ = ["ManagerLink", "POLL_S"]

POLL_S = 0.02
"""How often :meth:`ManagerLink.wait` calls its ``on_poll``, s."""


class ManagerLink:
    """The manager process ``proc`` (stdin and stdout pipes) of the nodes ``names``
    (role -> fully qualified node name)."""

    def __init__(self, proc: subprocess.Popen[bytes], names: dict[str, str]) -> None:
        self.proc, self.names = proc, names
        self.queue: queue.Queue[dict[str, Any]] = queue.Queue()
        self.seen: list[dict[str, Any]] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        for raw in self.proc.stdout:
            event = parse_event(raw.decode(errors="replace").rstrip("\n"))
            if event is not None:
                self.queue.put(event)

    def events(self) -> list[dict[str, Any]]:
        """The events that arrived since the last call (all are kept in ``seen``)."""
        new = []
        while True:
            try:
                new.append(self.queue.get_nowait())
            except queue.Empty:
                break
        self.seen.extend(new)
        return new

    def send(self, command: str) -> bool:
        """Write one command line; False when the manager is gone."""
        if self.proc.poll() is not None or self.proc.stdin is None:
            return False
        try:
            self.proc.stdin.write((command + "\n").encode())
            self.proc.stdin.flush()
        except (BrokenPipeError, OSError):
            return False
        return True

    def wait(self, timeout_s: float, on_poll: Callable[[], None] | None = None) -> bool:
        """Wait for the manager to exit; whether it did. ``on_poll`` is called every
        :data:`POLL_S` meanwhile (attitude-run tells the manager of nodes that end)."""
        deadline = time.monotonic() + timeout_s
        while True:
            if on_poll is not None:
                on_poll()
            try:
                self.proc.wait(min(POLL_S, max(0.0, deadline - time.monotonic())))
            except subprocess.TimeoutExpired:
                if time.monotonic() >= deadline:
                    return False
                continue
            return True
