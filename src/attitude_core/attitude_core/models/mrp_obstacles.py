"""The keep-out regions as obstacles in MRP space: their rim circles and the closest one.

All attitudes that point boresight ``s`` along one inertial direction ``b`` form a great
circle on the unit-quaternion sphere (rotations about ``s``); stereographic projection
(the MRP map, eq. 1) sends it to a circle in R^3 that contains both MRP sets (eq. 2) of
each of those attitudes. The keep-out region of one (instrument, object) pair is the
union of such circles over the spherical cap ``angle(b, c) < beta``, and its boundary is
the union over the cap's rim. The distance from ``sigma`` to the region is therefore the
minimum over the rim of the closed-form point-to-circle distance. Rim circles are
precomputed once per geometry at ``samples`` rim angles (:func:`fiber_circles`); a
parabolic refinement of the squared distance between neighbouring rim samples makes the
query exact to second order. Because the circles live in all of R^3, an obstacle on the
far side of ``|sigma| = 1`` (seen through the shadow set) is found like any other.

:class:`MrpObstacles` is a part of
:class:`~attitude_core.models.constraints.ConeGeometry`, which holds the constraints it
reads; :class:`ObstacleQuery` is a query's answer (the paper's ``sigma_c_hat`` and
distance, eqs. 7-9).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.models.cone_math import unit_perpendicular
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    cross3,
    quat_mul_sf,
)

__all__ = ["ObstacleQuery", "MrpObstacles", "fiber_circles"]

_Floats = npt.NDArray[np.float64]


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


class MrpObstacles:
    """The MRP-space obstacles of a ``ConeGeometry`` (its constraints, inflated by
    ``inflation_deg``)."""

    samples: int
    inflation_deg: float
    boresights_body: _Floats
    directions_inertial: _Floats
    pair_instrument: npt.NDArray[np.int64]
    pair_object: npt.NDArray[np.int64]
    pair_angles_deg: _Floats
    keep_in_axes_body: _Floats
    keep_in_directions_inertial: _Floats
    keep_in_max_angles_deg: _Floats
    _rims_built: bool
    _kernel: Any

    def _make_kernel(self, rims: bool) -> Any:
        raise NotImplementedError  # the geometry's (ConeGeometry._make_kernel)

    def min_margin_deg_single(self, sigma_bn: Vec3Like) -> float:
        raise NotImplementedError  # the geometry's (AttitudeMargins)

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
        through :func:`fiber_circles` in one call: row by row the same operations, so
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
            e1 = unit_perpendicular(c)
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
            fiber_circles(s, np.concatenate(rims), np.concatenate(dots))
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


def fiber_circles(
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
        q_base[anti] = np.concatenate([[0.0], unit_perpendicular(s_body)])
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
