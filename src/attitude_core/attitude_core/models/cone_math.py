"""The cone constraints' closed forms on arrays and floats (paper eq. 5).

* :func:`margins_deg_from_dcm`: keep-out margins ``angle(C_BN^T s_i, c_j) - beta_i`` of
  attitudes given by their DCMs, degrees (positive: eq. 5 holds).
* :func:`arc_cos_extremes`: along an eigenaxis rotation a body vector's inertial
  direction turns on a small circle, so its cosine to a fixed direction is
  ``A + B cos(phi) + C sin(phi)``; its extremes over ``[0, angle]`` in closed form.
* :func:`short_rotation_single`: the inertial axis and angle of the short eigenaxis
  rotation between two attitudes.
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    cross3,
    dcm_rows_from_mrp,
    relative_euler_single,
)

__all__ = [
    "TWO_PI",
    "unit_rows",
    "unit_perpendicular",
    "margins_deg_from_dcm",
    "boresight_cosines",
    "arc_cos_extremes",
    "short_rotation_single",
]

_Floats = npt.NDArray[np.float64]
TWO_PI = 2.0 * math.pi


def unit_rows(v: npt.ArrayLike) -> _Floats:
    v = np.atleast_2d(np.asarray(v, dtype=float))
    norms: _Floats = np.linalg.norm(v, axis=1, keepdims=True)
    return v / norms


def unit_perpendicular(v: _Floats) -> _Floats:
    """A unit vector normal to the unit vector ``v``."""
    p: _Floats = cross3(v, [1.0, 0.0, 0.0])
    if np.linalg.norm(p) < 0.5:
        p = cross3(v, [0.0, 1.0, 0.0])
    return p / np.linalg.norm(p)


def margins_deg_from_dcm(
    c_bn: np.ndarray,
    boresights_body: np.ndarray,
    half_angles_deg: np.ndarray,
    directions_inertial: np.ndarray,
) -> np.ndarray:
    """Keep-out margins in degrees, shape ``(..., n_instruments, n_objects)``.

    ``margin_ij = angle(C_BN^T s_i, c_j) - beta_i`` (eq. 5 holds iff margin > 0).
    """
    cosang = boresight_cosines(c_bn, boresights_body, directions_inertial)
    margins: _Floats = np.degrees(np.arccos(cosang)) - np.asarray(half_angles_deg)[:, None]
    return margins


def boresight_cosines(
    c_bn: np.ndarray, boresights_body: np.ndarray, directions_inertial: np.ndarray
) -> _Floats:
    """``cos angle(C_BN^T s_i, c_j)``, shape ``(..., n_i, n_j)``, clipped to [-1, 1]."""
    # Boresights in inertial axes: b_i = C_BN^T s_i  -> (..., n_i, 3)
    b_n = np.einsum("...ki,nk->...ni", c_bn, boresights_body)
    cos: _Floats = np.clip(np.einsum("...ni,mi->...nm", b_n, directions_inertial), -1.0, 1.0)
    return cos


def arc_cos_extremes(
    v0: _Floats, axis: _Floats, angle: _Floats, c: _Floats
) -> tuple[_Floats, _Floats]:
    """Largest and smallest ``c . v(phi)`` over ``phi in [0, angle]``, where ``v(phi)`` is
    the unit vector ``v0`` turned actively by ``phi`` about the unit vector ``axis``.

    Broadcasts over leading axes (``v0``, ``axis``, ``c``: ``(..., 3)``; ``angle``:
    ``(...)``). ``c . v(phi) = A + B cos(phi) + C sin(phi)`` with ``A = (e.v0)(e.c)``,
    ``B = c.v0 - A``, ``C = c.(e x v0)``; its extremes are ``A +- sqrt(B^2 + C^2)`` where
    ``phi = atan2(C, B)`` (``+ pi``) falls inside the interval, else at an end.
    """
    ev = np.einsum("...i,...i->...", axis, v0)
    a = ev * np.einsum("...i,...i->...", axis, c)
    at_start = np.einsum("...i,...i->...", c, v0)
    b = at_start - a
    cc = np.einsum("...i,...i->...", c, cross3(axis, v0))
    at_end = a + b * np.cos(angle) + cc * np.sin(angle)
    r = np.hypot(b, cc)
    phi = np.mod(np.arctan2(cc, b), 2.0 * np.pi)
    phi_min = np.mod(phi + np.pi, 2.0 * np.pi)
    hi = np.maximum(at_start, at_end)
    lo = np.minimum(at_start, at_end)
    hi = np.where(phi <= angle, a + r, hi)
    lo = np.where(phi_min <= angle, a - r, lo)
    return np.clip(hi, -1.0, 1.0), np.clip(lo, -1.0, 1.0)


def short_rotation_single(sigma_a: Vec3Like, sigma_b: Vec3Like) -> tuple[Vec3, float]:
    """Inertial unit axis and angle (rad, ``[0, pi]``) of the short eigenaxis rotation
    from attitude ``sigma_a`` to ``sigma_b`` (both ``sigma_BN``): a body vector's inertial
    direction at ``b`` is the one at ``a`` turned actively by the angle about the axis.
    The axis is ``(0, 0, 0)`` for equal attitudes."""
    w, v1, v2, v3 = relative_euler_single(sigma_b, sigma_a)  # q_B/A, unnormalised
    if w < 0.0:
        w, v1, v2, v3 = -w, -v1, -v2, -v3
    n = math.sqrt(v1 * v1 + v2 * v2 + v3 * v3)
    if n == 0.0:
        return (0.0, 0.0, 0.0), 0.0
    angle = 2.0 * math.atan2(n, w)
    # The eigenaxis has the same components in A and B; in inertial axes e_N = C_AN^T e_A.
    r0, r1, r2 = dcm_rows_from_mrp(sigma_a)
    e1, e2, e3 = v1 / n, v2 / n, v3 / n
    return (
        (
            e1 * r0[0] + e2 * r1[0] + e3 * r2[0],
            e1 * r0[1] + e2 * r1[1] + e3 * r2[1],
            e1 * r0[2] + e2 * r1[2] + e3 * r2[2],
        ),
        angle,
    )
