"""Torque saturation: the controller's and the plant's, for a per-body-axis bound.

``actuators.max_torque_nm`` bounds each body-axis component of the torque (reaction
wheels about the body axes). Two rules:

* :func:`scale_to_bound`, the controller's: the whole command is scaled by one factor so
  that every component is within its bound. The direction of the eq. 11 torque is kept,
  so the correction keeps its axis; only its size is lost.
* :func:`clip_to_bound`, the plant's: each component is clipped to its bound on its own,
  as independent wheels saturate. A command already within the box is unchanged, so
  with the project's controller the plant never clips; a foreign controller's command
  is clipped the way real hardware would.

``None`` as the bound means unlimited (the paper's case): the torque is returned as is.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["scale_to_bound", "clip_to_bound"]

Vector = npt.NDArray[np.float64]


def scale_to_bound(torque_b: Vector, max_torque_nm: Sequence[float] | None) -> tuple[Vector, bool]:
    """``(u', saturated)``: ``u' = s u`` with the largest ``s <= 1`` that puts every
    component within its bound."""
    u = np.asarray(torque_b, dtype=float)
    if max_torque_nm is None:
        return u, False
    bound = np.asarray(max_torque_nm, dtype=float)
    ratio = float(np.max(np.abs(u) / bound))
    if ratio <= 1.0:
        return u, False
    scaled: Vector = u / ratio
    return scaled, True


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
