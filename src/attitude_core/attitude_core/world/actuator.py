"""The plant's torque saturation for a per-body-axis bound.

``actuators.max_torque_nm`` bounds each body-axis component of the torque (reaction
wheels about the body axes). :func:`clip_to_bound` clips each component to its bound on
its own, as independent wheels saturate. A command already within the box is unchanged,
so with the project's controller (:mod:`attitude_core.fsw.control.saturation` scales the
command into the box) the plant never clips; a foreign controller's command is clipped
the way real hardware would. ``None`` as the bound means unlimited (the paper's case).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["clip_to_bound"]

Vector = npt.NDArray[np.float64]


def clip_to_bound(torque_b: Vector, max_torque_nm: Sequence[float] | None) -> tuple[Vector, bool]:
    """``(u', saturated)``: every component clipped to ``[-bound_i, bound_i]``."""
    u = np.asarray(torque_b, dtype=float)
    if max_torque_nm is None:
        return u, False
    if u.shape == (3,) and len(max_torque_nm) == 3:  # one torque (every step): in floats
        x, y, z = u.tolist()
        bx, by, bz = (float(b) for b in max_torque_nm)
        cx, cy, cz = min(max(x, -bx), bx), min(max(y, -by), by), min(max(z, -bz), bz)
        return np.array((cx, cy, cz)), not (cx == x and cy == y and cz == z)
    bound = np.asarray(max_torque_nm, dtype=float)
    clipped: Vector = np.clip(u, -bound, bound)
    return clipped, bool(np.any(clipped != u))
