"""Exact margins of one attitude and along one rotation, in plain floats (eq. 5).

The hot-path forms of a :class:`~attitude_core.models.constraints.ConeGeometry`'s
margins: the smallest exact margin at one attitude, the smallest along the whole short
eigenaxis rotation between two attitudes (closed form, :func:`arc_cos_extremes`), and
the rotation about an axis until a constraint's margin falls to a rim. Each calls the
compiled kernel when the geometry has one, else its ``*_reference`` in Python floats.
:class:`AttitudeMargins` is a part of ``ConeGeometry``, which holds the state it reads.
"""

from __future__ import annotations

import math
from typing import Any

from attitude_core.models.cone_math import TWO_PI, short_rotation_single
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    dcm_rows_from_mrp,
)

__all__ = ["AttitudeMargins"]


class AttitudeMargins:
    """The single-attitude and along-rotation margins of a ``ConeGeometry``."""

    _kernel: Any  # the geometry's compiled kernel, or None
    _instruments_py: list[tuple[Vec3, list[tuple[float, list[Vec3]]]]]
    _keep_in_py: list[tuple[Vec3, Vec3, float]]

    def min_margin_deg_single(self, sigma_bn: Vec3Like) -> float:
        """Smallest exact margin for one attitude, degrees: the hot-path form of
        :meth:`min_margin_deg` (compiled; :meth:`min_margin_deg_single_reference`)."""
        if self._kernel is not None:
            return float(self._kernel.min_margin_deg(sigma_bn))
        return self.min_margin_deg_single_reference(sigma_bn)

    def min_margin_deg_single_reference(self, sigma_bn: Vec3Like) -> float:
        """:meth:`min_margin_deg_single` in plain Python floats (no array overhead)."""
        r0, r1, r2 = dcm_rows_from_mrp(sigma_bn)  # b = C^T s = sum_r s_r C[r, :]
        best = math.inf
        for (a, b, c), groups in self._instruments_py:
            bx = a * r0[0] + b * r1[0] + c * r2[0]
            by = a * r0[1] + b * r1[1] + c * r2[1]
            bz = a * r0[2] + b * r1[2] + c * r2[2]
            for beta, objects in groups:
                cmax = max(bx * x + by * y + bz * z for x, y, z in objects)
                m = math.degrees(math.acos(min(max(cmax, -1.0), 1.0))) - beta
                if m < best:
                    best = m
        for (a, b, c), (x, y, z), gamma in self._keep_in_py:
            ax = a * r0[0] + b * r1[0] + c * r2[0]
            ay = a * r0[1] + b * r1[1] + c * r2[1]
            az = a * r0[2] + b * r1[2] + c * r2[2]
            cosang = min(max(ax * x + ay * y + az * z, -1.0), 1.0)
            m = gamma - math.degrees(math.acos(cosang))
            if m < best:
                best = m
        return best

    def _inertial_vectors(
        self, sigma_bn: Vec3Like
    ) -> tuple[list[tuple[Vec3, float, Vec3]], list[tuple[Vec3, Vec3, float]]]:
        """At ``sigma_bn``: each keep-out constraint as (boresight in inertial axes, its
        angle in deg, the object's direction), and each keep-in axis in inertial axes
        with its direction and angle (deg)."""
        r0, r1, r2 = dcm_rows_from_mrp(sigma_bn)

        def inertial(a: float, b: float, c: float) -> Vec3:
            return (
                a * r0[0] + b * r1[0] + c * r2[0],
                a * r0[1] + b * r1[1] + c * r2[1],
                a * r0[2] + b * r1[2] + c * r2[2],
            )

        keep_out = []
        for s, groups in self._instruments_py:
            v = inertial(*s)
            keep_out += [(v, beta, c) for beta, objects in groups for c in objects]
        return keep_out, [(inertial(*a), d, gamma) for a, d, gamma in self._keep_in_py]

    def arc_min_margin_deg_single(self, sigma_a: Vec3Like, sigma_b: Vec3Like) -> float:
        """Smallest exact margin over every constraint along the short eigenaxis rotation
        from ``sigma_a`` to ``sigma_b`` (all of it, closed form), degrees (compiled;
        :meth:`arc_min_margin_deg_single_reference`)."""
        if self._kernel is not None:
            return float(self._kernel.arc_min_margin_deg(sigma_a, sigma_b))
        return self.arc_min_margin_deg_single_reference(sigma_a, sigma_b)

    def arc_min_margin_deg_single_reference(self, sigma_a: Vec3Like, sigma_b: Vec3Like) -> float:
        """:meth:`arc_min_margin_deg_single` in plain Python floats."""
        (e1, e2, e3), angle = short_rotation_single(sigma_a, sigma_b)
        if angle == 0.0:
            return self.min_margin_deg_single_reference(sigma_a)
        cos_t, sin_t = math.cos(angle), math.sin(angle)
        best = math.inf

        def extremes(vx: float, vy: float, vz: float, x: float, y: float, z: float) -> Vec3:
            # (at the start, largest, smallest) of c . v(phi), phi in [0, angle]
            a = (e1 * vx + e2 * vy + e3 * vz) * (e1 * x + e2 * y + e3 * z)
            start = x * vx + y * vy + z * vz
            b = start - a
            cc = x * (e2 * vz - e3 * vy) + y * (e3 * vx - e1 * vz) + z * (e1 * vy - e2 * vx)
            end = a + b * cos_t + cc * sin_t
            r = math.sqrt(b * b + cc * cc)  # b, cc = O(1): no hypot needed, and C's sqrt
            # rounds as the compiled kernel's does (CPython's hypot has its own algorithm)
            phi = math.atan2(cc, b) % TWO_PI
            hi = a + r if phi <= angle else max(start, end)
            lo = a - r if (phi + math.pi) % TWO_PI <= angle else min(start, end)
            return start, hi, lo

        keep_out, keep_in = self._inertial_vectors(sigma_a)
        for (vx, vy, vz), beta, (x, y, z) in keep_out:
            hi = extremes(vx, vy, vz, x, y, z)[1]
            best = min(best, math.degrees(math.acos(min(max(hi, -1.0), 1.0))) - beta)
        for (vx, vy, vz), (x, y, z), gamma in keep_in:
            lo = extremes(vx, vy, vz, x, y, z)[2]
            best = min(best, gamma - math.degrees(math.acos(min(max(lo, -1.0), 1.0))))
        return best

    def rotation_to_rim_deg(
        self, sigma_bn: Vec3Like, axis_inertial: Vec3Like, rim_deg: float
    ) -> float:
        """Rotation (deg) about the inertial unit ``axis_inertial`` (positive sense, as
        the body turns with its rate along that axis) until the first constraint's exact
        margin falls to ``rim_deg``: 0 when one is already there, ``inf`` when none gets
        there in a whole turn. Closed form: each margin's cosine along the turn is
        ``A + R cos(phi - phi*)`` (see :func:`arc_cos_extremes`)."""
        e1, e2, e3 = float(axis_inertial[0]), float(axis_inertial[1]), float(axis_inertial[2])
        rim = math.radians(rim_deg)
        best = math.inf

        def entry(vx: float, vy: float, vz: float, x: float, y: float, z: float,
                  bound: float, keep_in: bool) -> float:  # fmt: skip
            a = (e1 * vx + e2 * vy + e3 * vz) * (e1 * x + e2 * y + e3 * z)
            b = x * vx + y * vy + z * vz - a
            c = x * (e2 * vz - e3 * vy) + y * (e3 * vx - e1 * vz) + z * (e1 * vy - e2 * vx)
            r = math.hypot(b, c)
            k = math.cos(bound)
            start = a + b
            if (start <= k) if keep_in else (start >= k):
                return 0.0  # at or past the rim already
            if r == 0.0:
                return math.inf
            level = (k - a) / r
            if abs(level) > 1.0:
                return math.inf  # the turn never reaches the rim
            phi_star = math.atan2(c, b)
            half = math.acos(level)
            phi = phi_star + half if keep_in else phi_star - half
            return phi % TWO_PI

        keep_out, keep_in = self._inertial_vectors(sigma_bn)
        for (vx, vy, vz), beta, (x, y, z) in keep_out:
            best = min(best, entry(vx, vy, vz, x, y, z, math.radians(beta) + rim, False))
        for (vx, vy, vz), (x, y, z), gamma in keep_in:
            best = min(best, entry(vx, vy, vz, x, y, z, math.radians(gamma) - rim, True))
        return math.degrees(best)
