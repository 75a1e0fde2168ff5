"""Run metrics shared by the offline runner and the ROS run summary.

All functions take sampled trajectories (``t`` in s, ``sigma_bn`` (N, 3), ``omega_b``
(N, 3) rad/s, ``torque_b`` (N, 3) N m) so they work on arrays from any source.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from attitude_core.gnc.constraints import ConeGeometry
from attitude_core.gnc.mrp import (
    mrp_from_quat_sf,
    principal_angle,
    quat_sf_from_mrp,
    relative,
    shadow,
)
from attitude_core.gnc.sky import Sky

__all__ = [
    "dense_min_margin_deg",
    "path_length_mrp",
    "arrival_time",
]


def _quat_rate_sf(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Euler-parameter kinematics ``q_dot = B(q) omega / 2`` (body rates)."""
    q0, qv = q[..., :1], q[..., 1:]
    d0 = -0.5 * np.einsum("...i,...i->...", qv, omega)[..., None]
    dv = 0.5 * (q0 * omega + np.cross(qv, omega))
    return np.concatenate([d0, dv], -1)


def dense_min_margin_deg(
    geometry: ConeGeometry | Sky,
    t: np.ndarray,
    sigma_bn: np.ndarray,
    omega_b: np.ndarray,
    substeps: int = 8,
) -> tuple[float, float]:
    """Smallest exact keep-out margin over the whole run, between samples too; against
    a :class:`Sky`, each attitude's against the sky of its own time.

    Between samples the attitude is a cubic Hermite interpolant of the quaternion and
    its rate (``q_dot`` from ``omega``, so it is exact to O(dt^4)), renormalised.
    Returns ``(min_margin_deg, time_of_min_s)``; a run of one sample has no interval, and
    its margin is that sample's.
    """
    t = np.asarray(t, dtype=float)
    if isinstance(geometry, Sky):
        sky = geometry

        def smallest(times: np.ndarray, sigma: np.ndarray) -> np.ndarray:
            return sky.min_margin_deg(times, sigma)
    else:
        cones = geometry

        def smallest(times: np.ndarray, sigma: np.ndarray) -> np.ndarray:
            return cones.min_margin_deg(sigma)

    if len(t) < 2:
        single = smallest(t[:1], np.asarray(sigma_bn, dtype=float).reshape(-1, 3)[:1])
        return float(single.min()), float(t[0])
    q = quat_sf_from_mrp(np.asarray(sigma_bn, dtype=float))
    # Make the quaternion sign continuous (shadow switches flip it).
    flips = np.cumsum(np.r_[0, (np.einsum("ij,ij->i", q[1:], q[:-1]) < 0.0)]) % 2
    q = np.where(flips[:, None] == 1, -q, q)
    qd = _quat_rate_sf(q, np.asarray(omega_b, dtype=float))
    h = np.diff(t)[:, None, None]
    s = (np.arange(substeps + 1) / substeps)[None, :, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    qi = h00 * q[:-1, None] + h10 * h * qd[:-1, None] + h01 * q[1:, None] + h11 * h * qd[1:, None]
    qi /= np.linalg.norm(qi, axis=-1, keepdims=True)
    times = t[:-1, None] + np.diff(t)[:, None] * s[..., 0]  # (N-1, substeps+1)
    margins = smallest(times, mrp_from_quat_sf(qi))
    k = int(np.argmin(margins))
    i, j = divmod(k, substeps + 1)
    t_min = float(t[i] + (t[i + 1] - t[i]) * j / substeps)
    return float(margins.flat[k]), t_min


def path_length_mrp(sigma: np.ndarray) -> float:
    """Length of a sampled MRP path, not counting the jumps of shadow switches."""
    sigma = np.asarray(sigma, dtype=float)
    a, b = sigma[:-1], sigma[1:]
    direct = np.linalg.norm(b - a, axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        via_shadow = np.linalg.norm(shadow(b) - a, axis=1)
    return float(np.sum(np.fmin(direct, np.nan_to_num(via_shadow, nan=np.inf))))


def arrival_time(
    t: np.ndarray,
    sigma_bn: np.ndarray,
    omega_b: np.ndarray,
    sigma_goal: np.ndarray,
    attitude_tol_deg: float,
    rate_tol_rad_s: float,
) -> tuple[bool, float | None, npt.NDArray[np.float64]]:
    """First time after which the body stays within the arrival tolerances.

    Attitude error is the principal angle of ``sigma_B/D``. Returns
    ``(reached, t_reach_s or None, attitude_error_deg (N,))``.
    """
    err_deg = np.degrees(principal_angle(relative(sigma_bn, np.asarray(sigma_goal))))
    ok = (err_deg <= attitude_tol_deg) & (np.linalg.norm(omega_b, axis=1) <= rate_tol_rad_s)
    if not ok[-1]:
        return False, None, err_deg
    bad = np.flatnonzero(~ok)
    first = 0 if len(bad) == 0 else bad[-1] + 1
    return True, float(t[first]), err_deg
