"""Which wheels the controller may use: a wheel that applied no torque when commanded
one, while not at its speed limit, is taken out for good (latched).

Inputs each step: the motor torques commanded, the torques the wheels report applied
(``/spacecraft/wheel_states`` ``effort``), their speeds and speed limits. Output:
:attr:`WheelHealth.usable`, and :attr:`WheelHealth.changed` when a wheel was just taken
out (the guidance then re-budgets the slew on the wheels left).
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["DEAD_FRACTION", "WheelHealth"]

DEAD_FRACTION = 1e-6
"""A wheel applying less than this share of a command of at least
:data:`MIN_COMMAND_NM` is reported failed."""

MIN_COMMAND_NM = 1e-7


class WheelHealth:
    """The usable wheels of an array of ``n`` (all at first)."""

    def __init__(self, n: int) -> None:
        self.usable = np.ones(n, dtype=bool)
        self.changed = False

    def observe(
        self,
        commanded_nm: npt.ArrayLike,
        applied_nm: npt.ArrayLike,
        speeds_rad_s: npt.ArrayLike,
        max_speed_rad_s: npt.ArrayLike,
    ) -> npt.NDArray[np.bool_]:
        """Take out the wheels that ignored their command; the wheels still usable."""
        cmd = np.asarray(commanded_nm, dtype=float)
        got = np.asarray(applied_nm, dtype=float)
        speeds = np.asarray(speeds_rad_s, dtype=float)
        at_limit = (np.abs(speeds) >= np.asarray(max_speed_rad_s)) & (cmd * speeds > 0.0)
        dead = (np.abs(cmd) >= MIN_COMMAND_NM) & (np.abs(got) < DEAD_FRACTION * np.abs(cmd))
        lost = self.usable & dead & ~at_limit
        self.changed = bool(np.any(lost))
        self.usable = self.usable & ~lost
        return self.usable
