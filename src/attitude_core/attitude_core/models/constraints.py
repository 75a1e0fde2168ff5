"""Cone constraint geometry (paper eq. 5) and its obstacles in MRP space.

An instrument ``i`` (body boresight ``s_i``, half-angle ``beta_i``) violates the
keep-out cone of bright object ``j`` (inertial direction ``c_j``) when
``s_i^T C_BN(sigma) c_j >= cos(beta_i)``. The *margin* is the angle between the
boresight (in inertial axes) and the object minus ``beta_i``; positive is safe.

Each (instrument, object) pair may have its own angle (``pair_angles_deg``: the
exclusion angle plus the object's angular radius on a real sky, see
:mod:`attitude_core.models.sky`), and a pair an instrument need not avoid has no
constraint. The keep-out constraints are the avoided pairs, instrument-major.

A keep-in cone ``k`` (body axis ``a_k``, inertial direction ``d_k``, largest angle
``gamma_k``: a sun sensor keeping the Sun in view, a solar array within an incidence
angle) is the mirror image: its margin is ``gamma_k`` minus the angle between the axis
(in inertial axes) and ``d_k``. Its forbidden region is the outside of the cone, whose
boundary is the same kind of rim as a keep-out cone's, so both share the MRP-space
obstacles below. The constraints are numbered keep-out pairs first (``p``, in
:attr:`ConeGeometry.pairs` order; ``i n_j + j`` when every pair is avoided), then
keep-in cones (``n_p + k``).

Along an eigenaxis rotation (the short way between two attitudes, inertial axis ``e``,
angle ``theta``) a body vector's inertial direction turns on a small circle about
``e``, so its cosine to a fixed direction is ``A + B cos(phi) + C sin(phi)``,
``phi in [0, theta]``: :func:`arc_cos_extremes` gives the extremes in closed form and
:meth:`ConeGeometry.arc_min_margin_deg_single` the exact smallest margin along the
whole rotation, not only at its ends.

MRP-space obstacles. All attitudes that point boresight ``s`` along one inertial
direction ``b`` form a great circle on the unit-quaternion sphere (rotations about
``s``); stereographic projection (the MRP map, eq. 1) sends it to a circle in R^3
that contains both MRP sets (eq. 2) of each of those attitudes. The keep-out region
of one (instrument, object) pair is the union of such circles over the spherical cap
``angle(b, c) < beta``, and its boundary is the union over the cap's rim. The distance
from ``sigma`` to the region is therefore the minimum over the rim of the closed-form
point-to-circle distance. Rim circles are precomputed once per scenario at
``samples`` rim angles; a parabolic refinement of the squared distance between
neighbouring rim samples makes the query exact to second order. Because the circles
live in all of R^3, an obstacle on the far side of ``|sigma| = 1`` (seen through the
shadow set) is found like any other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    cross3,
    dcm_from_mrp,
    dcm_rows_from_mrp,
    quat_mul_sf,
    relative_euler_single,
)

__all__ = [
    "EXACT_SAMPLES",
    "RIM_FLOOR",
    "ConeGeometry",
    "KeepInCones",
    "ObstacleQuery",
    "margins_deg_from_dcm",
    "arc_cos_extremes",
    "short_rotation_single",
]

_Floats = npt.NDArray[np.float64]
_TWO_PI = 2.0 * math.pi

EXACT_SAMPLES = 16
"""Rim samples of a geometry used only for its exact margins (which do not depend on
the sampling; 16 is the fewest a scenario allows)."""
RIM_FLOOR = 0.75
"""Share of the buffer a rotation may keep when it leaves an attitude already at (or
inside) the buffer's rim: a stalled target planned from again, or a restart. The local
(FEPF) and the global (route) planner both keep it."""


def _unit_rows(v: npt.ArrayLike) -> _Floats:
    v = np.atleast_2d(np.asarray(v, dtype=float))
    norms: _Floats = np.linalg.norm(v, axis=1, keepdims=True)
    return v / norms


def _unit_perpendicular(v: _Floats) -> _Floats:
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
    cosang = _boresight_cosines(c_bn, boresights_body, directions_inertial)
    margins: _Floats = np.degrees(np.arccos(cosang)) - np.asarray(half_angles_deg)[:, None]
    return margins


def _boresight_cosines(
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


@dataclass(frozen=True, eq=False)
class KeepInCones:
    """Keep-in cones: body axis ``a_k`` within ``max_angles_deg[k]`` of inertial ``d_k``.

    ``axes_body`` and ``directions_inertial`` are ``(n_k, 3)`` (normalised by the
    geometry), ``max_angles_deg`` is ``(n_k,)``.
    """

    axes_body: _Floats
    directions_inertial: _Floats
    max_angles_deg: _Floats

    @classmethod
    def none(cls) -> KeepInCones:
        return cls(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0))


@dataclass(slots=True)
class ObstacleQuery:
    """Result of :meth:`ConeGeometry.closest_obstacle`.

    ``distance`` is the Euclidean MRP-space distance from ``sigma`` to the closest
    keep-out region boundary (negative inside a region); ``direction`` is the unit
    vector pointing from ``sigma`` into that region (the paper's ``sigma_c_hat``:
    towards the closest boundary point outside, away from it inside);
    ``constraint`` numbers the constraint that owns that region (keep-out pairs
    ``i n_j + j``, then keep-in cones ``n_i n_j + k``).
    """

    distance: float
    direction: np.ndarray
    closest_point: np.ndarray
    constraint: int


class ConeGeometry:
    """Keep-out cones for any number of instruments and bright objects, and keep-in cones.

    Parameters
    ----------
    boresights_body : (n_i, 3) instrument boresights ``s_i`` in body axes.
    half_angles_deg : (n_i,) cone half-angles ``beta_i`` in degrees.
    directions_inertial : (n_j, 3) bright-object directions ``c_j`` in inertial axes.
    inflation_deg : extra angle added to every ``beta_i`` (and taken from every
        ``gamma_k``) for the MRP obstacles (a planner safety buffer); the exact margins
        are not inflated.
    samples : rim samples per constraint for the MRP obstacles.
    keep_in : keep-in cones (none by default).
    pair_angles_deg : (n_i, n_j) per-pair keep-out angles in degrees replacing
        ``half_angles_deg[i]``; NaN for a pair that is not a constraint (the instrument
        need not avoid that object). Default: every pair, at its instrument's angle.
    """

    def __init__(
        self,
        boresights_body: np.ndarray,
        half_angles_deg: np.ndarray,
        directions_inertial: np.ndarray,
        inflation_deg: float = 0.0,
        samples: int = 180,
        keep_in: KeepInCones | None = None,
        pair_angles_deg: npt.ArrayLike | None = None,
    ) -> None:
        self.boresights_body = _unit_rows(boresights_body)
        self.half_angles_deg = np.atleast_1d(np.asarray(half_angles_deg, dtype=float))
        self.directions_inertial = _unit_rows(directions_inertial)
        self.inflation_deg = float(inflation_deg)
        self.samples = int(samples)
        n_i, n_j = len(self.boresights_body), len(self.directions_inertial)
        if self.half_angles_deg.shape != (n_i,):
            raise ValueError("half_angles_deg must have one entry per boresight")
        keep_in = KeepInCones.none() if keep_in is None else keep_in
        n_k = len(np.atleast_1d(keep_in.max_angles_deg))
        self.keep_in_axes_body = _unit_rows(keep_in.axes_body) if n_k else np.zeros((0, 3))
        self.keep_in_directions_inertial = (
            _unit_rows(keep_in.directions_inertial) if n_k else np.zeros((0, 3))
        )
        self.keep_in_max_angles_deg = np.atleast_1d(np.asarray(keep_in.max_angles_deg, dtype=float))
        if self.keep_in_axes_body.shape != (n_k, 3) or self.keep_in_directions_inertial.shape != (
            n_k,
            3,
        ):
            raise ValueError("keep-in cones need one body axis and one direction each")
        self.n_instruments, self.n_objects, self.n_keep_in = n_i, n_j, n_k
        if pair_angles_deg is None:
            angles = np.repeat(self.half_angles_deg[:, None], n_j, axis=1)
        else:
            angles = np.asarray(pair_angles_deg, dtype=float).reshape(n_i, n_j)
        avoided = ~np.isnan(angles)
        self.pair_instrument, self.pair_object = (x.astype(np.int64) for x in np.nonzero(avoided))
        self.pair_angles_deg = angles[avoided]
        self.n_keep_out = len(self.pair_angles_deg)
        self.n_constraints = self.n_keep_out + n_k
        objects_py = [cast(Vec3, tuple(v)) for v in self.directions_inertial.tolist()]
        # Per instrument: its boresight and its pairs grouped by angle (one group, all the
        # objects, when every pair has the instrument's angle: the paper's sky).
        self._instruments_py: list[tuple[Vec3, list[tuple[float, list[Vec3]]]]] = []
        for i, s in enumerate(self.boresights_body.tolist()):
            groups: dict[float, list[Vec3]] = {}
            for j in range(n_j):
                if avoided[i, j]:
                    groups.setdefault(float(angles[i, j]), []).append(objects_py[j])
            if groups:
                self._instruments_py.append((cast(Vec3, tuple(s)), list(groups.items())))
        self._keep_in_py = list(
            zip(
                map(tuple, self.keep_in_axes_body.tolist()),
                map(tuple, self.keep_in_directions_inertial.tolist()),
                self.keep_in_max_angles_deg.tolist(),
                strict=True,
            )
        )
        # The rim circles (and the kernel's rim search) are built at the first query that
        # needs them: a geometry used for its exact margins only never builds them. The
        # kernels are those selected when the geometry is made, for its whole life.
        self._rims_built = False
        self._kernels = kernels.compiled
        self._kernel = self._make_kernel(rims=False)

    def _make_kernel(self, rims: bool) -> Any:
        """The compiled form of the exact margins and the rim search (None: the Python
        reference runs), fed this geometry's constraints and, with ``rims``, its rim
        circles as rows (without, the kernel has the exact margins only)."""
        if self._kernels is None:
            return None
        keep_out = np.column_stack(
            [
                self.boresights_body[self.pair_instrument],
                self.directions_inertial[self.pair_object],
                self.pair_angles_deg,
            ]
        ).reshape(-1, 7)
        keep_in = np.column_stack(
            [self.keep_in_axes_body, self.keep_in_directions_inertial, self.keep_in_max_angles_deg]
        ).reshape(-1, 7)
        circles = (
            np.column_stack(
                [
                    self._centres,
                    self._normals,
                    self._c_dot_c,
                    self._c_dot_n,
                    self._r2,
                    self._two_radii,
                ]
            ).reshape(-1, 10)
            if rims
            else np.zeros((0, 10))
        )
        return self._kernels.ConeKernel(
            np.ascontiguousarray(keep_out, dtype=float),
            np.ascontiguousarray(keep_in, dtype=float),
            np.ascontiguousarray(circles, dtype=float),
            self.samples,
            np.ascontiguousarray(self._rim_rows if rims else np.zeros((0, 7)), dtype=float),
            np.ascontiguousarray(self._rim_dirs if rims else np.zeros((0, 3)), dtype=float),
        )

    def compiled_kernel(self, rims: bool = False) -> Any:
        """This geometry's compiled kernel (``_kernels.ConeKernel``: the exact margins,
        and with ``rims`` the rim search, its circles built now if not yet), or None
        when the Python references run: what the compiled FEPF step is handed
        (``FepfCore.set_geometry``)."""
        if rims:
            self._ensure_rims()
        return self._kernel

    # --- exact margins --------------------------------------------------------

    @property
    def pairs(self) -> list[tuple[int, int]]:
        """The keep-out constraints' (instrument, object) index pairs, in order."""
        return list(zip(self.pair_instrument.tolist(), self.pair_object.tolist(), strict=True))

    def margins_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """Exact margins ``(..., n_i, n_j)`` in degrees at attitude(s) ``sigma_bn`` of
        every pair at its instrument's ``half_angles_deg`` (:meth:`pair_margins_deg`
        gives the constraints')."""
        return margins_deg_from_dcm(
            dcm_from_mrp(sigma_bn),
            self.boresights_body,
            self.half_angles_deg,
            self.directions_inertial,
        )

    def pair_margins_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """Exact margins of the keep-out constraints ``(..., n_p)``, degrees:
        ``angle(C_BN^T s_i, c_j) - pair angle``."""
        cos = _boresight_cosines(
            dcm_from_mrp(sigma_bn), self.boresights_body, self.directions_inertial
        )
        angles = np.degrees(np.arccos(cos[..., self.pair_instrument, self.pair_object]))
        margins: _Floats = angles - self.pair_angles_deg
        return margins

    def keep_in_margins_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """Exact keep-in margins ``(..., n_k)`` in degrees: ``gamma_k`` minus the angle
        between ``C_BN^T a_k`` and ``d_k`` (positive inside the cone)."""
        c_bn = dcm_from_mrp(sigma_bn)
        a_n = np.einsum("...ki,nk->...ni", c_bn, self.keep_in_axes_body)
        cosang = np.clip(
            np.einsum("...ni,ni->...n", a_n, self.keep_in_directions_inertial), -1.0, 1.0
        )
        margins: _Floats = self.keep_in_max_angles_deg - np.degrees(np.arccos(cosang))
        return margins

    def constraint_margins_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """Exact margins of every constraint ``(..., n_constraints)``, degrees: keep-out
        pairs ``i n_j + j`` first, then keep-in cones."""
        keep_out = self.pair_margins_deg(sigma_bn)
        if self.n_keep_in == 0:
            return keep_out
        return np.concatenate([keep_out, self.keep_in_margins_deg(sigma_bn)], axis=-1)

    def min_margin_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """Smallest exact margin over all constraints, degrees (``> 0``: all hold)."""
        smallest: _Floats = self.constraint_margins_deg(sigma_bn).min(axis=-1)
        return smallest

    def dense_interval_minima(
        self,
        t: _Floats,
        q: _Floats,
        q_dot: _Floats,
        basis: _Floats,
        slack_deg: float,
    ) -> tuple[float, _Floats] | None:
        """The compiled screen of a sampled run's dense margin: each interval's smallest
        exact margin over its cubic Hermite attitudes (scalar-first Euler parameters
        ``q`` ``(N, 4)`` with a continuous sign, their rates ``q_dot``, the basis
        ``(4, S + 1)`` at the substeps), exact for the intervals within ``slack_deg`` of
        the run's smallest and larger for the others: ``(smallest, per interval (N - 1,))``.
        None without the compiled kernels, or when an input is not finite; the margins
        differ from :meth:`min_margin_deg`'s in the last bits
        (:func:`attitude_core.record.metrics.dense_min_margin_deg` uses it)."""
        if self._kernel is None:
            return None
        assert self._kernels is not None  # a kernel is built only with them
        out = np.empty(len(t) - 1)
        smallest = float(
            self._kernels.dense_interval_minima(
                self._kernel, t, q, q_dot, basis, out, float(slack_deg)
            )
        )
        return None if not math.isfinite(smallest) else (smallest, out)

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
            phi = math.atan2(cc, b) % _TWO_PI
            hi = a + r if phi <= angle else max(start, end)
            lo = a - r if (phi + math.pi) % _TWO_PI <= angle else min(start, end)
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
            return phi % _TWO_PI

        keep_out, keep_in = self._inertial_vectors(sigma_bn)
        for (vx, vy, vz), beta, (x, y, z) in keep_out:
            best = min(best, entry(vx, vy, vz, x, y, z, math.radians(beta) + rim, False))
        for (vx, vy, vz), (x, y, z), gamma in keep_in:
            best = min(best, entry(vx, vy, vz, x, y, z, math.radians(gamma) - rim, True))
        return math.degrees(best)

    # --- MRP-space obstacles --------------------------------------------------

    @property
    def rim_circles(self) -> tuple[_Floats, _Floats, _Floats]:
        """The rim circles of the (inflated) regions: centres ``(P*k, 3)``, unit normals
        ``(P*k, 3)`` and radii ``(P*k,)``, ``k = samples`` consecutive circles per
        constraint, in constraint order (built at the first call)."""
        self._ensure_rims()
        return self._centres, self._normals, self._radii

    def _ensure_rims(self) -> None:
        """Build the rim circles and the kernel's rim search, once."""
        if not self._rims_built:
            self._build_rim_circles()
            self._rims_built = True
            self._kernel = self._make_kernel(rims=True)

    def _build_rim_circles(self) -> None:
        """Precompute the rim circles (centre, unit normal, radius) of every constraint.

        The consecutive rims of one body vector (an instrument's keep-out pairs) go
        through :func:`_fiber_circles` in one call: row by row the same operations, so
        the same bits as one call per rim, at a fraction of the calls."""
        k = self.samples
        phi = 2.0 * np.pi * np.arange(k) / k
        # (body vector's key, s, c, beta): keep-out pairs keyed by instrument, each
        # keep-in cone on its own.
        cones: list[tuple[int, _Floats, _Floats, float]] = [
            (
                int(i),
                self.boresights_body[i],
                self.directions_inertial[j],
                np.radians(beta + self.inflation_deg),
            )
            for i, j, beta in zip(
                self.pair_instrument, self.pair_object, self.pair_angles_deg, strict=True
            )
        ]
        cones += [
            (-1 - n, a, d, np.radians(max(gamma - self.inflation_deg, 1e-3)))
            for n, (a, d, gamma) in enumerate(
                zip(
                    self.keep_in_axes_body,
                    self.keep_in_directions_inertial,
                    self.keep_in_max_angles_deg,
                    strict=True,
                )
            )
        ]
        # Each rim's body vector, inertial direction and angle (rad), in the circles'
        # order: the compiled rim search bounds a rim's distance with them.
        self._rim_rows = np.array(
            [[*(s / np.linalg.norm(s)), *(c / np.linalg.norm(c)), beta] for _, s, c, beta in cones]
        ).reshape(-1, 7)
        groups: list[tuple[int, _Floats, list[_Floats], list[_Floats]]] = []
        for key, s, c, beta in cones:
            e1 = _unit_perpendicular(c)
            e2 = cross3(c, e1)
            # Body-vector directions on the cone rim, inertial axes: (k, 3). A rim sample
            # on the body vector itself has the identity on its fibre, which the MRP map
            # sends to a line (a circle of infinite radius): sample half a step over.
            b = self._rim(c, e1, e2, beta, phi)
            b_dot_s = b @ s
            if np.max(b_dot_s) > 1.0 - 1e-9:
                b = self._rim(c, e1, e2, beta, phi + np.pi / k)
                b_dot_s = b @ s
            if groups and groups[-1][0] == key:
                groups[-1][2].append(b)
                groups[-1][3].append(b_dot_s)
            else:
                groups.append((key, s, [b], [b_dot_s]))
        circles = [
            _fiber_circles(s, np.concatenate(rims), np.concatenate(dots))
            for _, s, rims, dots in groups
        ]
        # Each circle's rim direction (inertial), unit: where its attitudes point the body
        # vector (the compiled rim search bounds a circle's distance with it).
        dirs = np.concatenate([np.concatenate(rims) for _, _, rims, _ in groups])
        self._rim_dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
        self._centres = np.concatenate([cc for cc, _, _ in circles])  # (P*k, 3)
        self._normals = np.concatenate([nn for _, nn, _ in circles])
        self._radii = np.concatenate([rr for _, _, rr in circles])
        # Per query, column by column (rim_distances_sq): the centres' and the normals'.
        self._stack_cols = [
            np.ascontiguousarray(a[:, i]) for a in (self._centres, self._normals) for i in range(3)
        ]
        self._c_dot_c = np.einsum("ij,ij->i", self._centres, self._centres)
        self._c_dot_n = np.einsum("ij,ij->i", self._centres, self._normals)
        self._r2 = self._radii**2
        self._two_radii = 2.0 * self._radii
        self._circles_list: list[tuple[list[float], list[float], float]] | None = None

    @staticmethod
    def _rim(c: _Floats, e1: _Floats, e2: _Floats, beta: float, phi: _Floats) -> _Floats:
        rim: _Floats = np.cos(beta) * c[None, :] + np.sin(beta) * (
            np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2
        )
        return rim

    def rim_distances_sq(self, sigma: Vec3Like) -> _Floats:
        """Squared distance from ``sigma`` to every precomputed rim circle, ``(P*k,)``:
        element by element the compiled rim search's operations in its order (no matrix
        product, whose sums may round otherwise), so the same bits."""
        self._ensure_rims()
        sx, sy, sz = float(sigma[0]), float(sigma[1]), float(sigma[2])
        cx, cy, cz, nx, ny, nz = self._stack_cols
        dd = cx * sx
        dd += cy * sy
        dd += cz * sz  # centre . sigma
        dd *= -2.0
        dd += self._c_dot_c
        dd += sx * sx + sy * sy + sz * sz  # |sigma - centre|^2
        h = nx * sx
        h += ny * sy
        h += nz * sz  # normal . sigma
        h -= self._c_dot_n  # axial offset
        h *= h
        np.subtract(dd, h, out=h)
        np.copyto(h, 0.0, where=h < 0.0)
        np.sqrt(h, out=h)  # radial offset rho
        h *= self._two_radii
        dd += self._r2
        dd -= h  # rho^2 + h^2 - 2 r rho + r^2
        np.copyto(dd, 0.0, where=~(dd > 0.0))  # as the kernel's: +0.0 for -0.0 and NaN
        return dd

    def closest_obstacle(self, sigma: Vec3Like) -> ObstacleQuery:
        """Distance and direction from ``sigma`` to the closest (inflated) keep-out region.

        Accurate to second order in the rim spacing; the sign is negative when
        ``sigma`` is inside an inflated region.
        """
        dist, direction, point, pair = self.closest_obstacle_single(sigma)
        return ObstacleQuery(dist, np.array(direction), np.array(point), pair)

    def closest_obstacle_single(self, sigma: Vec3Like) -> tuple[float, Vec3, Vec3, int]:
        """:meth:`closest_obstacle` as ``(distance, direction, closest point,
        constraint)`` in plain floats (every planner step: compiled when the kernels are,
        :meth:`closest_obstacle_single_reference` otherwise)."""
        if not self._rims_built:  # tested here: this is every planner step
            self._ensure_rims()
        if self._kernel is not None:
            out: tuple[float, Vec3, Vec3, int] = self._kernel.closest_obstacle(
                sigma, self.inflation_deg
            )
            return out
        return self.closest_obstacle_single_reference(sigma)

    def closest_obstacle_single_reference(self, sigma: Vec3Like) -> tuple[float, Vec3, Vec3, int]:
        """:meth:`closest_obstacle_single` in Python (the compiled query's reference)."""
        self._ensure_rims()
        idx, f0, fm, fp, jm, jp = self.closest_rim_reference(sigma)
        pair = idx // self.samples
        # Parabola through (-1, fm), (0, f0), (1, fp): vertex offset t in [-1/2, 1/2].
        curv = fm - 2.0 * f0 + fp
        t = 0.0
        best = f0
        if curv > 0.0:
            t = min(max(0.5 * (fm - fp) / curv, -0.5), 0.5)
            best = max(f0 - 0.25 * (fm - fp) * t, 0.0)
        sx, sy, sz = float(sigma[0]), float(sigma[1]), float(sigma[2])
        p0 = self._closest_on_circle(idx, sx, sy, sz)
        pn = self._closest_on_circle(jp if t >= 0.0 else jm, sx, sy, sz)
        a = abs(t)
        px = p0[0] + a * (pn[0] - p0[0])
        py = p0[1] + a * (pn[1] - p0[1])
        pz = p0[2] + a * (pn[2] - p0[2])
        vx, vy, vz = px - sx, py - sy, pz - sz
        norm = math.sqrt(vx * vx + vy * vy + vz * vz)
        dist = math.sqrt(best)
        if self.min_margin_deg_single(sigma) < self.inflation_deg:
            dist, norm = -dist, -norm
        direction = (vx / norm, vy / norm, vz / norm) if norm != 0.0 else (0.0, 0.0, 0.0)
        return dist, direction, (px, py, pz), pair

    def closest_rim_reference(self, sigma: Vec3Like) -> tuple[int, float, float, float, int, int]:
        """The rim circle nearest ``sigma`` and its neighbours on the same rim,
        ``(index, d2, d2_before, d2_after, index_before, index_after)`` (``d2``: squared
        MRP distances): the reference of the compiled search."""
        d2 = self.rim_distances_sq(sigma)
        idx = int(np.argmin(d2))
        k = self.samples
        base = (idx // k) * k
        j = idx - base
        jm, jp = base + (j - 1) % k, base + (j + 1) % k
        return idx, float(d2[idx]), float(d2[jm]), float(d2[jp]), jm, jp

    def _circles_py(self) -> list[tuple[list[float], list[float], float]]:
        """The rim circles as ``(centre, normal, radius)`` in plain floats, for the
        Python reference of the closest point (made at its first use: the compiled query
        reads the circles' array)."""
        if self._circles_list is None:
            self._circles_list = list(
                zip(
                    self._centres.tolist(),
                    self._normals.tolist(),
                    self._radii.tolist(),
                    strict=True,
                )
            )
        return self._circles_list

    def _closest_on_circle(self, idx: int, sx: float, sy: float, sz: float) -> Vec3:
        """Closest point to ``(sx, sy, sz)`` on precomputed rim circle ``idx``."""
        (cx, cy, cz), (nx, ny, nz), r = self._circles_py()[idx]
        dx, dy, dz = sx - cx, sy - cy, sz - cz
        h = dx * nx + dy * ny + dz * nz
        rx, ry, rz = dx - h * nx, dy - h * ny, dz - h * nz
        rn = math.sqrt(rx * rx + ry * ry + rz * rz)
        if rn < 1e-15:  # on the circle's axis: every point is equally close
            rx, ry, rz = ny, -nx, 0.0
            if abs(nz) > 0.9:
                rx, ry, rz = 0.0, nz, -ny
            rn = math.sqrt(rx * rx + ry * ry + rz * rz)
        f = r / rn
        return (cx + f * rx, cy + f * ry, cz + f * rz)


def _fiber_circles(
    s_body: _Floats, b_inertial: _Floats, b_dot_s: _Floats | None = None
) -> tuple[_Floats, _Floats, _Floats]:
    """MRP-space circles of the attitudes with ``C_BN^T s = b`` for each row ``b``
    (``b_dot_s``: the rows' ``b . s`` when already known).

    Returns centres ``(k, 3)``, unit normals ``(k, 3)`` and radii ``(k,)``.
    """
    k = len(b_inertial)
    # Passive rotation taking inertial b to body s: q0 = normalise(1 + b.s, s x b).
    w = 1.0 + (b_inertial @ s_body if b_dot_s is None else b_dot_s)
    v = cross3(np.broadcast_to(s_body, b_inertial.shape), b_inertial)
    q_base = np.concatenate([w[:, None], v], axis=1)
    anti = w < 1e-9  # b = -s: rotate by pi about any axis normal to s
    if np.any(anti):
        q_base[anti] = np.concatenate([[0.0], _unit_perpendicular(s_body)])
    q_base /= np.linalg.norm(q_base, axis=1, keepdims=True)
    # Three points on each fibre great circle, q(psi) = q_rot(s, psi) (x) q_base,
    # psi spread over [0, 4 pi); pick the offset keeping them far from q0 = -1
    # (the MRP point at infinity).
    best_pts, best_score = None, None
    for offset in (0.0, 0.7, 1.9, 2.9):
        psis = offset + 4.0 * np.pi * np.arange(3) / 3.0
        pts = []
        score = np.full(k, np.inf)
        for psi in psis:
            rot = np.concatenate([[np.cos(psi / 2.0)], np.sin(psi / 2.0) * s_body])
            q = quat_mul_sf(rot, q_base)
            score = np.minimum(score, 1.0 + q[:, 0])
            pts.append(q[:, 1:] / (1.0 + q[:, :1]))
        if best_score is None:
            best_pts, best_score = pts, score
        else:
            assert best_pts is not None  # set together with best_score
            better = score > best_score
            best_pts = [
                np.where(better[:, None], p, bp) for p, bp in zip(pts, best_pts, strict=True)
            ]
            best_score = np.maximum(score, best_score)
    assert best_pts is not None  # the loop above runs
    a_pt, b_pt, c_pt = best_pts
    u = a_pt - c_pt
    v = b_pt - c_pt
    uxv = cross3(u, v)
    nrm2 = np.einsum("ij,ij->i", uxv, uxv)
    uu = np.einsum("ij,ij->i", u, u)[:, None]
    vv = np.einsum("ij,ij->i", v, v)[:, None]
    centre = c_pt + cross3(uu * v - vv * u, uxv) / (2.0 * nrm2[:, None])
    radius = np.linalg.norm(centre - c_pt, axis=1)
    normal = uxv / np.sqrt(nrm2)[:, None]
    return centre, normal, radius
