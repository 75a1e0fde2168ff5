"""A wheel run's figures (``wheels.*``): the peaks against each wheel's limits, the
system momentum, its error against the external torque, and the momentum-limited time
bound.

* ``peak_wheel_speed_frac``: the largest ``|Omega_i| / max_speed_i`` on record;
  ``peak_wheel_torque_frac``: the largest ``|u_i| / max_torque_i`` applied.
* ``momentum_error_nms``: the largest change of the inertial system momentum
  ``C_BN^T H_B`` (:meth:`WheelArray.system_momentum_b`) not explained by the integrated
  external torque (trapezoid over the record, torque held over each step).
* :func:`wheel_time_bound_s`: ``theta / omega_h + omega_h / alpha`` with ``omega_h`` the
  rate the wheels' whole free momentum allows about the slew's eigenaxis (``h / J``,
  the stored momentum turning over the slew) and ``alpha`` the torque polytope's
  acceleration about it (:func:`attitude_core.fsw.guidance.profile_limits.time_bound_s`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from attitude_core.assembly.guidance_limits import slew_axis, slew_envelope
from attitude_core.fsw.guidance.profile_limits import time_bound_s
from attitude_core.fsw.guidance.wheel_envelope import momentum_rate_limit
from attitude_core.models.mrp import dcm_from_mrp
from attitude_core.record.trajectory import RunResult

__all__ = ["WHEEL_FIGURES", "inertial_momentum", "wheel_figures", "wheel_time_bound_s"]

WHEEL_FIGURES = ("peak_wheel_speed_frac", "peak_wheel_torque_frac", "momentum_error_nms")


def inertial_momentum(run: RunResult) -> np.ndarray:
    """``(N + 1, 3)``: the system momentum in inertial axes at each row (N m s)."""
    sc, wheels = run.scenario, run.wheels
    if sc.wheels is None or wheels is None:
        raise ValueError("inertial_momentum: a run without wheels")
    h_b = sc.wheels.system_momentum_b(sc.inertia_kgm2, run.omega_b, wheels.speed_rad_s)
    dcm = dcm_from_mrp(run.sigma_bn)  # (N + 1, 3, 3) C_BN
    h_n: np.ndarray = np.einsum("kji,kj->ki", dcm, h_b)
    return h_n


def wheel_figures(run: RunResult) -> dict[str, Any]:
    """The :data:`WHEEL_FIGURES` of ``run`` (each None without wheels)."""
    sc, wheels = run.scenario, run.wheels
    if sc.wheels is None or wheels is None:
        return dict.fromkeys(WHEEL_FIGURES)
    array = sc.wheels
    h_n = inertial_momentum(run)
    dcm_t = np.transpose(dcm_from_mrp(run.sigma_bn), (0, 2, 1))  # C_NB per row
    ext_n = np.einsum("kij,kj->ki", dcm_t, wheels.external_b)
    # over [t_k, t_k+1] the body-axes torque is held: average its inertial image
    ext_held = np.einsum("kij,kj->ki", dcm_t[1:], wheels.external_b[:-1])
    dt = np.diff(run.t)[:, None]
    steps = 0.5 * dt * (ext_n[:-1] + ext_held)
    explained = np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])
    error = np.linalg.norm(h_n - h_n[0] - explained, axis=1)
    return {
        "peak_wheel_speed_frac": float(np.max(np.abs(wheels.speed_rad_s) / array.max_speed)),
        "peak_wheel_torque_frac": float(
            np.nanmax(np.abs(wheels.applied_nm) / array.max_torque)  # NaN: none on record
        ),
        "momentum_error_nms": float(np.max(error)),
    }


def wheel_time_bound_s(run: RunResult, rotation_rad: float) -> float | None:
    """The momentum-limited rest-to-rest bound of ``rotation_rad`` (None without wheels,
    or when the wheels leave no momentum or torque about the slew's axis)."""
    sc = run.scenario
    if sc.wheels is None:
        return None
    axis, angle = slew_axis(sc, sc.initial_mrp)
    rate = momentum_rate_limit(
        sc.wheels,
        sc.inertia_kgm2,
        axis,
        angle,
        axis,
        sc.wheels.initial_speed,
        np.ones(len(sc.wheels)),
    )
    env = slew_envelope(sc, sc.initial_mrp)
    if float(rate[0]) <= 0.0 or env.accel_rad_s2 <= 0.0:
        return None  # no momentum or torque about the axis: no slew, no bound
    return time_bound_s(rotation_rad, float(rate[0]), env.accel_rad_s2)
