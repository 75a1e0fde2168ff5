"""A process named so that a reused PID cannot be mistaken for it (Linux ``/proc``).

``pid:start_ticks:boot_id``: the PID, the process's start time in clock ticks since
boot (field 22 of ``/proc/PID/stat``) and the kernel's boot ID. The process is alive
while a process with that PID and start time exists on the same boot. Used for the
owner of an ``attitude-run`` staging directory and by a node's parent watchdog.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

__all__ = ["ProcessIdentity", "OWNER_ENV"]

OWNER_ENV = "ATTITUDE_RUN_OWNER"
"""Environment variable naming the process a node stops with (set by ``attitude-run``)."""


def _start_ticks(pid: int) -> int | None:
    try:
        with open(f"/proc/{pid}/stat", "rb") as f:
            stat = f.read()
    except OSError:
        return None
    fields = stat[stat.rindex(b")") + 2 :].split()  # after "pid (comm) "
    if fields[0] in (b"Z", b"X"):  # exited, not yet reaped: dead
        return None
    return int(fields[19])  # field 22 overall


def _boot_id() -> str:
    try:
        with open("/proc/sys/kernel/random/boot_id") as f:
            return f.read().strip()
    except OSError:
        return ""


@dataclass(frozen=True)
class ProcessIdentity:
    pid: int
    start_ticks: int
    boot_id: str

    @classmethod
    def of(cls, pid: int) -> ProcessIdentity | None:
        """The identity of the live process ``pid``; None when there is none."""
        ticks = _start_ticks(pid)
        return None if ticks is None else cls(pid, ticks, _boot_id())

    @classmethod
    def current(cls) -> ProcessIdentity:
        me = cls.of(os.getpid())
        if me is None:
            raise OSError("cannot read /proc/self/stat (not Linux?)")
        return me

    def alive(self) -> bool:
        """True while this very process runs (not merely one with its PID)."""
        return self.boot_id == _boot_id() and _start_ticks(self.pid) == self.start_ticks

    def encode(self) -> str:
        return f"{self.pid}:{self.start_ticks}:{self.boot_id}"

    @classmethod
    def decode(cls, text: str) -> ProcessIdentity:
        """Inverse of :meth:`encode`; ValueError on anything else."""
        pid, ticks, boot = text.strip().split(":", 2)
        return cls(int(pid), int(ticks), boot)
