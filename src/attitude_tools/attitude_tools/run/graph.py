"""The node processes of one run, with their logs: each started as ``ros2 run`` would
start it (:func:`attitude_tools.run.environment.node_executables`), without the ``ros2``
process in between."""

from __future__ import annotations

import signal
import subprocess
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from attitude_core.config import node_graph
from attitude_core.config.node_graph import NodeSpec
from attitude_core.runtime.process_identity import OWNER_ENV, ProcessIdentity
from attitude_tools.run.environment import node_executables
from attitude_tools.run.processes import die_with_parent

__all__ = ["NodeGraph"]


class NodeGraph:
    """The four node processes of one run, with their logs."""

    def __init__(
        self,
        env: dict[str, str],
        log_dir: Path,
        cwd: Path,
        executables: dict[str, str] | None = None,
    ) -> None:
        """``executables``: each role's, found before (else found at its start)."""
        self.env, self.log_dir, self.cwd = env, log_dir, cwd
        self.executables = dict(executables or {})
        self.procs: dict[str, subprocess.Popen[bytes]] = {}

    def start(
        self,
        spec: NodeSpec[Any],
        ros_args: list[str],
        name: str | None = None,
        autostart: bool = True,
        piped: bool = False,
    ) -> subprocess.Popen[bytes]:
        """Start ``spec``'s executable; its log and key are ``name`` (default: its role).
        ``autostart``: a managed node configures and activates itself (False: it waits
        for a lifecycle manager). ``piped``: stdin and stdout are pipes (the manager's
        commands and events), stderr the log."""
        name = spec.role if name is None else name
        if spec.role not in self.executables:  # RunError when it is not installed
            self.executables.update(node_executables(self.env, [spec]))
        env = {**self.env, OWNER_ENV: ProcessIdentity.current().encode()}  # parent watchdog
        managed = spec.parameters is not node_graph.MANAGER.parameters
        own = ["-p", "autostart:=true"] if autostart and managed else []
        with open(self.log_dir / f"{name}.log", "wb") as log:  # the child keeps its copy
            self.procs[name] = subprocess.Popen(
                [self.executables[spec.role], "--ros-args", *own, *ros_args],
                env=env,
                cwd=self.cwd,
                stdout=subprocess.PIPE if piped else log,
                stderr=log if piped else subprocess.STDOUT,
                stdin=subprocess.PIPE if piped else subprocess.DEVNULL,
                start_new_session=True,
                preexec_fn=die_with_parent(),  # SIGTERM when we die, even by SIGKILL
            )  # we, not the terminal, decide the shutdown order
        return self.procs[name]

    def exited(self) -> dict[str, int]:
        return {n: p.returncode for n, p in self.procs.items() if p.poll() is not None}

    def wait_exit(self, names: Sequence[str], timeout_s: float) -> None:
        """Wait up to ``timeout_s`` for ``names`` to exit by themselves (shut down by
        their lifecycle manager, they are on their way out)."""
        deadline = time.monotonic() + timeout_s
        for p in [self.procs[n] for n in names if n in self.procs]:
            try:
                p.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                return

    def stop(self, names: Sequence[str], grace_s: float) -> dict[str, int]:
        """SIGINT to each, wait up to ``grace_s`` together, then SIGKILL the rest."""
        live = [self.procs[n] for n in names if self.procs[n].poll() is None]
        for p in live:
            p.send_signal(signal.SIGINT)
        deadline = time.monotonic() + grace_s
        for p in live:
            try:
                p.wait(max(0.0, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        return {n: self.procs[n].returncode for n in names}

    def error_line(self, name: str) -> str:
        """The last line of ``name``'s log that reports an error (else its last line)."""
        text = (self.log_dir / f"{name}.log").read_text(errors="replace").splitlines()
        errors = [line for line in text if "error" in line.lower()]
        return (errors or text or ["(empty log)"])[-1].strip()

    def tail(self, name: str, lines: int = 15) -> str:
        text = (self.log_dir / f"{name}.log").read_text(errors="replace").splitlines()
        return "\n".join(f"    {line}" for line in text[-lines:])
