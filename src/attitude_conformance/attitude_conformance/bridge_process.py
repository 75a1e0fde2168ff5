"""The bridge process the tool starts itself (``--launch``): start, watch, SIGINT, output.

The command is the user's (split like a shell would), plus ``--ros-args --params-file
SCENARIO -p time_mode:=MODE -p lockstep.expected_subscribers:=1``. It runs in a session of
its own, so SIGINT goes to its process group and to nothing else; its output goes to a
temporary file that is removed on :meth:`close`.
"""

from __future__ import annotations

import contextlib
import os
import shlex
import signal
import subprocess
import tempfile
import time

from .checks_process import SIGINT_GRACE_S


def bridge_command(launch: str, scenario: str, mode: str) -> list[str]:
    """The full command line of a launched bridge (``autostart``: a managed node, such as
    ``rigid_body_sim``, activates itself; other nodes ignore the parameter)."""
    return [
        *shlex.split(launch),
        "--ros-args",
        "-p",
        "autostart:=true",
        "--params-file",
        scenario,
        "-p",
        f"time_mode:={mode}",
        "-p",
        "lockstep.expected_subscribers:=1",
    ]


def start_bridge(launch: str, scenario: str, mode: str) -> BridgeProcess | None:
    """The bridge started with ``launch`` (given the scenario file and the time mode), or
    None when ``launch`` is empty (the bridge is already running); OSError when it cannot
    start."""
    if not launch:
        return None
    return BridgeProcess(bridge_command(launch, os.path.abspath(scenario), mode))


class BridgeProcess:
    """One started bridge."""

    def __init__(self, command: list[str]) -> None:
        fd, self.log_path = tempfile.mkstemp(prefix="bridge-check-", suffix=".log")
        try:
            self.proc = subprocess.Popen(
                command,
                stdout=fd,
                stderr=subprocess.STDOUT,
                stdin=subprocess.DEVNULL,
                start_new_session=True,
            )
        except OSError:
            os.unlink(self.log_path)
            raise
        finally:
            os.close(fd)

    def exited(self) -> int | None:
        """The exit code if it has ended by itself, else None."""
        return self.proc.poll()

    def interrupt(self) -> tuple[int | None, float]:
        """SIGINT to its process group; (exit code or None when it had to be killed, wall s)."""
        t0 = time.monotonic()
        self._signal(signal.SIGINT)
        try:
            code: int | None = self.proc.wait(SIGINT_GRACE_S)
        except subprocess.TimeoutExpired:
            self._signal(signal.SIGKILL)
            self.proc.wait()
            code = None
        return code, time.monotonic() - t0

    def _signal(self, sig: int) -> None:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.proc.pid, sig)

    def output(self) -> str:
        with open(self.log_path, errors="replace") as f:
            return f.read()

    def tail(self, lines: int = 20) -> str:
        return "\n".join(self.output().splitlines()[-lines:])

    def close(self) -> None:
        """Stop it if it still runs, remove the log."""
        if self.proc.poll() is None:
            self.interrupt()
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.log_path)
