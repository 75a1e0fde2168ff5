"""Run metrics shared by the offline runner and the ROS run summary.

All functions take sampled trajectories (``t`` in s, ``sigma_bn`` (N, 3), ``omega_b``
(N, 3) rad/s, ``torque_b`` (N, 3) N m) so they work on arrays from any source.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from attitude_core.models.constraints import ConeGeometry
from attitude_core.models.mrp import (
    mrp_from_quat_sf,
    principal_angle,
    quat_sf_from_mrp,
    relative,
    shadow,
)
from attitude_core.models.sky import Sky

__all__ = [
    "DENSE_SLACK_DEG",
    "dense_min_margin_deg",
    "dense_min_margin_deg_reference",
    "path_length_mrp",
    "arrival_time",
]


def _quat_rate_sf(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Euler-parameter kinematics ``q_dot = B(q) omega / 2`` (body rates)."""
    q0, qv = q[..., :1], q[..., 1:]
    d0 = -0.5 * np.einsum("...i,...i->...", qv, omega)[..., None]
    dv = 0.5 * (q0 * omega + np.cross(qv, omega))
    return np.concatenate([d0, dv], -1)


DENSE_SLACK_DEG = 1e-9
"""How far above the compiled screen's smallest margin an interval is still measured by
the NumPy reference in :func:`dense_min_margin_deg` (deg): the screen's margins differ
from the reference's by about 1e-14 deg, so every interval that could hold the
reference's minimum is kept."""


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

    On fixed cones (a :class:`ConeGeometry`, a static sky) with the compiled kernels, a
    compiled screen (:meth:`ConeGeometry.dense_interval_minima`) measures every
    interpolated attitude and keeps the intervals within :data:`DENSE_SLACK_DEG` of its
    smallest margin; :func:`dense_min_margin_deg_reference` then measures only those, so
    the result is the reference's to the bit at a fraction of its cost.
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        return dense_min_margin_deg_reference(geometry, t, sigma_bn, omega_b, substeps)
    q, q_dot = _hermite_nodes(sigma_bn, omega_b)
    cones = geometry if isinstance(geometry, ConeGeometry) else None
    if isinstance(geometry, Sky) and geometry.static:
        cones = geometry.exact_geometry  # the margins Sky.min_margin_deg takes
    screen = None
    if cones is not None:
        basis = np.ascontiguousarray(np.concatenate(_hermite_basis(substeps), axis=0)[..., 0])
        screen = cones.dense_interval_minima(t, q, q_dot, basis, DENSE_SLACK_DEG)
    if screen is None:
        return _dense_min(geometry, t, q, q_dot, substeps, None)
    smallest, per_interval = screen
    kept = np.flatnonzero(per_interval <= smallest + DENSE_SLACK_DEG)
    if 2 * len(kept) > len(per_interval):  # a flat margin: no saving in a selection
        return _dense_min(geometry, t, q, q_dot, substeps, None)
    return _dense_min(geometry, t, q, q_dot, substeps, kept)


def dense_min_margin_deg_reference(
    geometry: ConeGeometry | Sky,
    t: np.ndarray,
    sigma_bn: np.ndarray,
    omega_b: np.ndarray,
    substeps: int = 8,
) -> tuple[float, float]:
    """:func:`dense_min_margin_deg` in NumPy alone: every interval measured."""
    t = np.asarray(t, dtype=float)
    if len(t) < 2:
        sigma = np.asarray(sigma_bn, dtype=float).reshape(-1, 3)[:1]
        single = _margins(geometry, t[:1], sigma)
        return float(single.min()), float(t[0])
    q, q_dot = _hermite_nodes(sigma_bn, omega_b)
    return _dense_min(geometry, t, q, q_dot, substeps, None)


def _margins(geometry: ConeGeometry | Sky, times: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Smallest exact margin of each attitude (against a sky, at its time)."""
    if isinstance(geometry, Sky):
        return geometry.min_margin_deg(times, sigma)
    return geometry.min_margin_deg(sigma)


def _hermite_nodes(sigma_bn: np.ndarray, omega_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The samples' Euler parameters with a continuous sign, and their rates."""
    q = quat_sf_from_mrp(np.asarray(sigma_bn, dtype=float))
    # Make the quaternion sign continuous (shadow switches flip it).
    flips = np.cumsum(np.r_[0, (np.einsum("ij,ij->i", q[1:], q[:-1]) < 0.0)]) % 2
    q = np.where(flips[:, None] == 1, -q, q)
    return q, _quat_rate_sf(q, np.asarray(omega_b, dtype=float))


def _hermite_basis(substeps: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``h00, h10, h01, h11`` at the substeps ``s = j / substeps``, each ``(1, S + 1, 1)``."""
    s = (np.arange(substeps + 1) / substeps)[None, :, None]
    h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
    h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00, h10, h01, h11


def _dense_min(
    geometry: ConeGeometry | Sky,
    t: np.ndarray,
    q: np.ndarray,
    q_dot: np.ndarray,
    substeps: int,
    intervals: np.ndarray | None,
) -> tuple[float, float]:
    """The smallest margin over the interpolated attitudes of ``intervals`` (None:
    every interval) and its time; each interval's attitudes are computed alike whatever
    the others measured with it."""
    if intervals is None:
        q0, q1, qd0, qd1, t0, t1 = q[:-1], q[1:], q_dot[:-1], q_dot[1:], t[:-1], t[1:]
    else:
        q0, q1, qd0, qd1 = q[intervals], q[intervals + 1], q_dot[intervals], q_dot[intervals + 1]
        t0, t1 = t[intervals], t[intervals + 1]
    h00, h10, h01, h11 = _hermite_basis(substeps)
    dt = t1 - t0
    h = dt[:, None, None]
    qi = h00 * q0[:, None] + h10 * h * qd0[:, None] + h01 * q1[:, None] + h11 * h * qd1[:, None]
    qi /= np.linalg.norm(qi, axis=-1, keepdims=True)
    times = t0[:, None] + dt[:, None] * (np.arange(substeps + 1) / substeps)[None, :]
    margins = _margins(geometry, times, mrp_from_quat_sf(qi))
    k = int(np.argmin(margins))
    i, j = divmod(k, substeps + 1)
    if intervals is not None:
        i = int(intervals[i])
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
