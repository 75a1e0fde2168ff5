"""A reaction wheel array (``wheels.*``): what the plant integrates and the flight
software allocates, budgets and bounds its profile with.

Conventions (body axes, SI):

* ``inertia_kgm2`` is the whole spacecraft's, the wheels included as if locked; the hub
  seen by the wheels' motors is ``J_hub = J - sum_i Js_i g_i g_i^T``
  (:meth:`WheelArray.hub_inertia`).
* A wheel's speed ``Omega_i`` (rad/s) is relative to the body, about its spin axis
  ``g_i``; its motor torque ``u_i`` (N m) acts on the wheel, ``-u_i g_i`` on the body.
* The system angular momentum in body axes is ``H_B = J omega + sum_i g_i Js_i Omega_i``
  (:meth:`WheelArray.system_momentum_b`); its inertial image ``C_BN^T H_B`` is constant
  without external torque.

The torque envelope is the polytope ``{-G u : lo <= u <= hi}`` of the wheels' torques
(``G`` the 3 x N matrix of spin axes), not a box; :meth:`WheelArray.torque_along` gives
its reach along a direction (a linear programme, SciPy's HiGHS: once per slew, not per
step); :mod:`attitude_core.fsw.guidance.wheel_envelope` budgets the momentum.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = ["RPM", "WheelSpec", "WheelArray"]

RPM = 2.0 * math.pi / 60.0
"""rad/s per revolution per minute."""

_Floats = npt.NDArray[np.float64]


@dataclass(frozen=True)
class WheelSpec:
    """One wheel: ``spin_axis_body`` (unit), ``max_torque_nm`` (motor), ``max_speed_rad_s``,
    ``spin_inertia_kgm2`` (about the spin axis), ``initial_speed_rad_s`` (relative to the
    body) and ``fails_at_s`` (from then on it applies no torque; None: never)."""

    name: str
    spin_axis_body: tuple[float, float, float]
    max_torque_nm: float
    max_speed_rad_s: float
    spin_inertia_kgm2: float
    initial_speed_rad_s: float = 0.0
    fails_at_s: float | None = None

    def problem(self) -> str | None:
        """Why this wheel is not usable (None: it is); names the key."""
        key = f"wheels.{self.name}"
        axis = np.asarray(self.spin_axis_body, dtype=float)
        if axis.shape != (3,) or not np.all(np.isfinite(axis)):
            return f"{key}.spin_axis_body: must be 3 finite numbers, got {self.spin_axis_body!r}"
        if abs(float(np.linalg.norm(axis)) - 1.0) > 1e-9:
            return f"{key}.spin_axis_body: must be a unit vector (normalised on load)"
        for field in ("max_torque_nm", "max_speed_rad_s", "spin_inertia_kgm2"):
            v = getattr(self, field)
            if not (math.isfinite(v) and v > 0.0):
                return f"{key}.{field}: must be > 0, got {v!r}"
        if not math.isfinite(self.initial_speed_rad_s):
            return f"{key}.initial_speed_rpm: must be finite"
        if abs(self.initial_speed_rad_s) > self.max_speed_rad_s:
            return (
                f"{key}.initial_speed_rpm: {self.initial_speed_rad_s / RPM:.6g} rpm is above "
                f"max_speed_rpm {self.max_speed_rad_s / RPM:.6g}"
            )
        if self.fails_at_s is not None and not (
            math.isfinite(self.fails_at_s) and self.fails_at_s >= 0.0
        ):
            return f"{key}.fails_at_s: must be >= 0, got {self.fails_at_s!r}"
        return None


class WheelArray:
    """The wheels of a spacecraft, in declaration order (index ``i`` of every array)."""

    def __init__(self, wheels: tuple[WheelSpec, ...]) -> None:
        if not wheels:
            raise ValueError("wheels.names: at least one wheel")
        self.wheels = wheels
        self.names = tuple(w.name for w in wheels)
        self.axes: _Floats = np.array([w.spin_axis_body for w in wheels], dtype=float).T
        self.spin_inertia: _Floats = np.array([w.spin_inertia_kgm2 for w in wheels])
        self.max_torque: _Floats = np.array([w.max_torque_nm for w in wheels])
        self.max_speed: _Floats = np.array([w.max_speed_rad_s for w in wheels])
        self.initial_speed: _Floats = np.array([w.initial_speed_rad_s for w in wheels])

    def __len__(self) -> int:
        return len(self.wheels)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, WheelArray):
            return NotImplemented
        return self.wheels == other.wheels

    def __hash__(self) -> int:
        return hash(self.wheels)

    def problem(self, inertia_kgm2: npt.ArrayLike) -> str | None:
        """Why this array cannot fly a spacecraft of ``inertia_kgm2`` (None: it can)."""
        if len(set(self.names)) != len(self.names):
            return f"wheels.names: names must be unique, got {list(self.names)}"
        for w in self.wheels:
            why = w.problem()
            if why:
                return why
        if np.linalg.matrix_rank(self.axes, tol=1e-6) < 3:
            return "wheels: the spin axes must span the three body axes (rank 3)"
        hub = np.linalg.eigvalsh(self.hub_inertia(inertia_kgm2))
        if hub[0] <= 0.0:
            return (
                "wheels: the wheels' spin inertia is not smaller than the spacecraft's "
                "inertia_kgm2 (which includes the wheels as if locked)"
            )
        return None

    # -- momentum ------------------------------------------------------------------

    def hub_inertia(self, inertia_kgm2: npt.ArrayLike) -> _Floats:
        """``J - sum_i Js_i g_i g_i^T`` (kg m^2): the inertia the wheel motors turn."""
        j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        hub: _Floats = j - (self.axes * self.spin_inertia) @ self.axes.T
        return hub

    def wheel_momentum_b(self, speeds_rad_s: npt.ArrayLike) -> _Floats:
        """``sum_i g_i Js_i Omega_i`` (N m s, body axes); speeds ``(N,)`` or one row per
        time ``(K, N)`` giving ``(K, 3)``."""
        h: _Floats = (self.spin_inertia * np.asarray(speeds_rad_s, dtype=float)) @ self.axes.T
        return h

    def system_momentum_b(
        self, inertia_kgm2: npt.ArrayLike, omega_b: npt.ArrayLike, speeds_rad_s: npt.ArrayLike
    ) -> _Floats:
        """``H_B = J omega + sum_i g_i Js_i Omega_i`` (N m s, body axes); one state, or
        one row per time (``omega_b`` ``(K, 3)``, speeds ``(K, N)``)."""
        j = np.asarray(inertia_kgm2, dtype=float).reshape(3, 3)
        omega = np.asarray(omega_b, dtype=float)
        h: _Floats = omega @ j.T + self.wheel_momentum_b(speeds_rad_s)
        return h

    def body_torque_b(self, motor_torque_nm: npt.ArrayLike) -> _Floats:
        """The torque on the body of the motor torques ``u``: ``-G u`` (N m)."""
        tau: _Floats = -(self.axes @ np.asarray(motor_torque_nm, dtype=float))
        return tau

    # -- the torque envelope ---------------------------------------------------------

    def torque_along(
        self,
        direction_b: npt.ArrayLike,
        lower_nm: npt.ArrayLike | None = None,
        upper_nm: npt.ArrayLike | None = None,
    ) -> float:
        """The largest body torque ``s >= 0`` along the unit ``direction_b`` the array can
        apply with motor torques in ``[lower, upper]`` (default ``+-max_torque``; a
        failed wheel: ``[0, 0]``)."""
        lo = -self.max_torque if lower_nm is None else np.asarray(lower_nm, dtype=float)
        hi = self.max_torque if upper_nm is None else np.asarray(upper_nm, dtype=float)
        return _support(-self.axes, direction_b, lo, hi)


def _support(a: _Floats, direction: npt.ArrayLike, lo: _Floats, hi: _Floats) -> float:
    """``max s`` subject to ``a x = s d``, ``lo <= x <= hi`` (0 when only ``s = 0``)."""
    from scipy.optimize import linprog  # on use: scipy.optimize costs 0.4 s to import

    d = np.asarray(direction, dtype=float)
    n = a.shape[1]
    # variables (x, s): maximise s
    cost = np.zeros(n + 1)
    cost[-1] = -1.0
    a_eq = np.hstack([a, -d.reshape(3, 1)])
    bounds = [(float(lo[i]), float(hi[i])) for i in range(n)] + [(0.0, None)]
    res = linprog(cost, A_eq=a_eq, b_eq=np.zeros(3), bounds=bounds, method="highs")
    if res.status != 0:
        return 0.0
    return max(float(res.x[-1]), 0.0)
