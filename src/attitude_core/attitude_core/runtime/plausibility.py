"""Physical plausibility of the values the nodes exchange: finite is not enough.

A receiver refuses, logs and counts a value outside these bounds instead of acting on it
(a torque of 1e300 N m integrated once makes the state non-finite for the rest of the
run). The bounds are generous on purpose: they catch faults and hostile input, never a
real slew.

* Torque (body axes, per axis): the scenario's ``actuators.max_torque_nm`` when it is
  set (the controller saturates to it, so a legitimate command never exceeds it), else
  :data:`DEFAULT_MAX_TORQUE_NM`.
* Body and target rates: :data:`MAX_RATE_RAD_S`.
* MRPs on the wire (the target ``sigma_RN``): ``|sigma| <= 1 +`` :data:`MRP_NORM_TOLERANCE`
  (the planner switches to the shadow set at 1).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np
import numpy.typing as npt

from attitude_core.config.scenario import Scenario

Values = Sequence[float] | npt.NDArray[np.float64]

__all__ = [
    "DEFAULT_MAX_TORQUE_NM",
    "MAX_RATE_RAD_S",
    "MRP_NORM_TOLERANCE",
    "TORQUE_BOUND_TOLERANCE",
    "torque_bound_nm",
    "implausible_torque",
    "implausible_rate",
    "implausible_mrp",
]

DEFAULT_MAX_TORQUE_NM = 100.0
"""Per-axis torque bound without ``actuators.max_torque_nm``, N m: above the reaction
wheels and small control-moment gyros of the spacecraft this stack is for, and some
250 times the paper's peak command (0.41 N m)."""

MAX_RATE_RAD_S = 10.0
"""Body or target rate bound, rad/s (573 deg/s; a slewing spacecraft stays below
a few deg/s)."""

MRP_NORM_TOLERANCE = 1e-6
"""How far above 1 the norm of a transmitted MRP may be (rounding at the shadow switch)."""

TORQUE_BOUND_TOLERANCE = 1e-9
"""Relative slack on ``actuators.max_torque_nm`` (the controller's clip is exact)."""


def torque_bound_nm(scenario: Scenario) -> tuple[float, float, float]:
    """The per-axis torque a plausible command stays within, N m."""
    limit = scenario.actuators.max_torque_nm
    if limit is None:
        return (DEFAULT_MAX_TORQUE_NM,) * 3
    x, y, z = (float(v) * (1.0 + TORQUE_BOUND_TOLERANCE) for v in limit)
    return (x, y, z)


def _finite(values: Values, name: str) -> str | None:
    if not all(math.isfinite(v) for v in values):
        return f"{name} has a non-finite element {[float(v) for v in values]}"
    return None


def implausible_torque(u: Values, bound: Sequence[float], wheels: bool = False) -> str | None:
    """Why a commanded torque (body axes, N m; ``wheels``: motor torques, one per wheel
    in the scenario's order) is not plausible, else None."""
    reason = _finite(u, "torque")
    if reason:
        return reason
    for axis, (value, limit) in enumerate(zip(u, bound, strict=True)):
        if abs(value) > limit:
            about = f"of wheel {axis}" if wheels else f"about body axis {'xyz'[axis]}"
            return (
                f"torque {float(value):.6g} N m {about} exceeds the plausible bound {limit:.6g} N m"
            )
    return None


def implausible_rate(omega: Values, name: str = "angular velocity") -> str | None:
    """Why a rate (rad/s) is not plausible, else None."""
    return _beyond_norm(
        omega,
        name,
        MAX_RATE_RAD_S,
        lambda norm: (
            f"{name} {norm:.6g} rad/s exceeds the plausible bound {MAX_RATE_RAD_S:g} rad/s"
        ),
    )


def implausible_mrp(sigma: Values, name: str = "MRP") -> str | None:
    """Why a transmitted MRP is not plausible (non-finite, or beyond the unit ball)."""
    return _beyond_norm(
        sigma,
        name,
        1.0 + MRP_NORM_TOLERANCE,
        lambda norm: f"{name} has norm {norm:.6g} > 1 (MRPs on the wire are the short set)",
    )


def _beyond_norm(
    values: Values, name: str, bound: float, why: Callable[[float], str]
) -> str | None:
    """Why ``values`` are non-finite or of Euclidean norm above ``bound``, else None."""
    reason = _finite(values, name)
    if reason:
        return reason
    norm = math.sqrt(sum(float(v) * float(v) for v in values))
    return why(norm) if norm > bound else None
