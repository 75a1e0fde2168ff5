"""The controller's torque saturation for a per-body-axis bound.

``actuators.max_torque_nm`` bounds each body-axis component of the torque. The whole
command is scaled by one factor so that every component is within its bound
(:func:`scale_to_bound`): the direction of the eq. 11 torque is kept, so the correction
keeps its axis; only its size is lost. (The plant clips each axis on its own:
:mod:`attitude_core.world.actuator`.) ``None`` as the bound means unlimited (the paper's
case): the torque is returned as is.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["scale_to_bound"]

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
