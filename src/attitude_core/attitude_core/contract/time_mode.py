"""How a plant's time advances: the simulator's ``time_mode`` and ``attitude-run --mode``."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["TimeMode"]


class TimeMode(StrEnum):
    """``LOCKSTEP``: sim time, the plant waits for the torque of each state (stamps
    ``k dt``). ``REALTIME``: the plant steps every ``dt`` of wall time with the latest
    torque held (stamps are its clock)."""

    LOCKSTEP = "lockstep"
    REALTIME = "realtime"
