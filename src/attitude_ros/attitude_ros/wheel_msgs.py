"""The wheel topics' ``sensor_msgs/JointState`` (``/spacecraft/wheel_states``,
``/controller/wheel_torque``; conventions in :mod:`attitude_core.contract.topics`) as
arrays in the scenario's wheel order, and back.

A message is read by wheel name, in any order: every declared wheel present once, no
other name, and each array used (``velocity``, ``effort``) as long as ``name``; the
values finite. Anything else is refused with the reason, never guessed.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_ros.cdr import JointValues

__all__ = ["WheelOrder", "fill_joint_state"]

_Floats = npt.NDArray[np.float64]


class WheelOrder:
    """The scenario's wheel names: a JointState's arrays in that order."""

    def __init__(self, names: Sequence[str]) -> None:
        self.names = tuple(names)
        self._index = {name: i for i, name in enumerate(self.names)}

    def _order(self, names: Sequence[str]) -> tuple[list[int] | None, str | None]:
        if len(names) != len(set(names)):
            dup = sorted({n for n in names if list(names).count(n) > 1})
            return None, f"name: wheel(s) {dup} more than once"
        unknown = [n for n in names if n not in self._index]
        if unknown:
            return None, f"name: {unknown} not among the declared wheels {list(self.names)}"
        missing = [n for n in self.names if n not in names]
        if missing:
            return None, f"name: wheel(s) {missing} missing"
        return [self._index[n] for n in names], None

    def array(
        self, values: JointValues, field: str, names: Sequence[str] | None = None
    ) -> tuple[_Floats | None, str | None]:
        """``values.<field>`` in the scenario's order, or ``(None, reason)``."""
        got = tuple(values.name if names is None else names)
        order, reason = self._order(got)
        if order is None:
            return None, reason
        data = getattr(values, field)
        if len(data) != len(got):
            return None, f"{field}: {len(data)} values for {len(got)} names"
        out = np.empty(len(self.names))
        out[order] = data
        if not np.isfinite(out).all():
            return None, f"{field}: not finite ({out.tolist()})"
        return out, None

    def speeds_and_effort(
        self, values: JointValues
    ) -> tuple[tuple[_Floats, _Floats] | None, str | None]:
        """``(velocity, effort)`` of a wheel state, or ``(None, reason)``."""
        speeds, reason = self.array(values, "velocity")
        if speeds is None:
            return None, reason
        effort, reason = self.array(values, "effort")
        if effort is None:
            return None, reason
        return (speeds, effort), None


def fill_joint_state(
    msg: Any, names: Sequence[str], velocity: npt.ArrayLike | None, effort: npt.ArrayLike
) -> None:
    """Write a wheel message: ``name``, ``velocity`` (None: empty), ``effort``."""
    if list(msg.name) != list(names):
        msg.name = list(names)
    msg.velocity = [] if velocity is None else np.asarray(velocity, dtype=float).tolist()
    msg.effort = np.asarray(effort, dtype=float).tolist()
