"""Body torque to wheel motor torques: minimum-norm allocation with saturation and
redistribution (the redistributed pseudo-inverse).

Inputs: the array (:class:`attitude_core.models.wheel_array.WheelArray`), the body torque
wanted ``tau_B`` (N m), and each wheel's bounds ``[lower, upper]`` (:func:`wheel_bounds`:
``+-max_torque``; no torque that would spin a wheel at its speed limit faster; ``[0, 0]``
for a wheel taken out). Output: :class:`Allocation`, motor torques ``u`` with
``-G u = tau_B`` when the array can apply it.

1. ``u = -G_free^+ (tau_B + G_fixed u_fixed)`` over the free wheels; each wheel beyond
   a bound is fixed at it and the rest re-allocated, until none is beyond.
2. When ``tau_B`` is outside the torque polytope, the largest torque along it that is
   inside (:meth:`WheelArray.torque_along`) is allocated instead: the direction of the
   eq. 11 torque is kept, as :mod:`attitude_core.fsw.control.saturation` keeps it in a
   box. Should the redistribution miss a torque that is inside, bounded least squares
   (SciPy's ``lsq_linear``) finds it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from attitude_core.models.wheel_array import WheelArray

__all__ = ["Allocation", "wheel_bounds", "allocate"]

_Floats = npt.NDArray[np.float64]

_RTOL = 1e-9


@dataclass(frozen=True)
class Allocation:
    """``motor_torque_nm`` per wheel, the body torque it makes (``achieved_b``), and
    ``saturated``: the wanted torque was outside the envelope and was scaled down."""

    motor_torque_nm: _Floats
    achieved_b: _Floats
    saturated: bool


def wheel_bounds(
    array: WheelArray,
    speeds_rad_s: npt.ArrayLike,
    usable: npt.ArrayLike,
    dt_s: float | None = None,
) -> tuple[_Floats, _Floats]:
    """``(lower, upper)`` motor torques (N m): ``+-max_torque``, zero on the side that
    would spin a wheel at its speed limit faster, ``[0, 0]`` for a wheel not ``usable``.
    With the step ``dt_s``: no more than brings a wheel to its speed limit over the step
    (``(max_speed -+ Omega) Js / dt``, to first order: the body's own acceleration
    about the spin axis aside), so a wheel is never commanded past its limit."""
    speeds = np.asarray(speeds_rad_s, dtype=float)
    use = np.asarray(usable, dtype=bool)
    top, bottom = array.max_torque, array.max_torque
    if dt_s is not None:
        js_dt = array.spin_inertia / dt_s
        top = np.minimum(top, np.maximum(array.max_speed - speeds, 0.0) * js_dt)
        bottom = np.minimum(bottom, np.maximum(array.max_speed + speeds, 0.0) * js_dt)
    upper = np.where(use & (speeds < array.max_speed), top, 0.0)
    lower = np.where(use & (speeds > -array.max_speed), -bottom, 0.0)
    return lower, upper


def _redistributed(axes: _Floats, b: _Floats, lower: _Floats, upper: _Floats) -> _Floats:
    """Step 1: ``G u = b`` by the pseudo-inverse over the free wheels, fixing each wheel
    that passes a bound at it."""
    n = axes.shape[1]
    u = np.zeros(n)
    free = lower < upper
    while np.any(free):
        rest = b - axes[:, ~free] @ u[~free]
        u_free = np.linalg.pinv(axes[:, free]) @ rest
        idx = np.flatnonzero(free)
        lo, hi = lower[idx], upper[idx]
        beyond = (u_free < lo) | (u_free > hi)
        u[idx] = np.clip(u_free, lo, hi)
        if not np.any(beyond):
            break
        free[idx[beyond]] = False
    return u


def allocate(
    array: WheelArray, torque_b: npt.ArrayLike, lower: npt.ArrayLike, upper: npt.ArrayLike
) -> Allocation:
    """The motor torques for the body torque ``torque_b`` within ``[lower, upper]``."""
    g = array.axes
    lo = np.asarray(lower, dtype=float)
    hi = np.asarray(upper, dtype=float)
    tau = np.asarray(torque_b, dtype=float)
    size = float(np.linalg.norm(tau))
    if size == 0.0:
        u = np.zeros(len(array))
        return Allocation(u, array.body_torque_b(u), False)
    b = -tau
    u = _redistributed(g, b, lo, hi)
    tol = _RTOL * max(size, float(np.max(array.max_torque)))
    if float(np.linalg.norm(g @ u - b)) <= tol:
        return Allocation(u, array.body_torque_b(u), False)
    # Outside the envelope (or missed): the largest torque along tau inside it.
    reach = array.torque_along(tau / size, lo, hi)
    saturated = reach < size * (1.0 - 1e-9)
    b = -tau * (min(reach, size) / size)
    u = _redistributed(g, b, lo, hi)
    if float(np.linalg.norm(g @ u - b)) > tol:
        free = lo < hi
        u = lo.copy()  # a wheel with no room: at its single bound
        if np.any(free):
            rest = b - g[:, ~free] @ u[~free]
            from scipy.optimize import lsq_linear  # rare: not imported on every start

            fit = lsq_linear(g[:, free], rest, bounds=(lo[free], hi[free]), method="bvls")
            u[free] = np.clip(fit.x, lo[free], hi[free])
    return Allocation(u, array.body_torque_b(u), saturated)
