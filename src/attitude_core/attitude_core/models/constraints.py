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

The parts: the closed forms on arrays (:mod:`attitude_core.models.cone_math`), the
margins of one attitude and along one rotation in floats
(:mod:`attitude_core.models.attitude_margins`) and the regions as obstacles in MRP
space, rim circles and the closest one (:mod:`attitude_core.models.mrp_obstacles`).
:class:`ConeGeometry` holds the constraints and gives all three.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, cast

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.models.attitude_margins import AttitudeMargins
from attitude_core.models.cone_math import boresight_cosines, margins_deg_from_dcm, unit_rows
from attitude_core.models.mrp import (
    Vec3,
    dcm_from_mrp,
)
from attitude_core.models.mrp_obstacles import MrpObstacles

__all__ = ["EXACT_SAMPLES", "RIM_FLOOR", "ConeGeometry", "KeepInCones"]

_Floats = npt.NDArray[np.float64]

EXACT_SAMPLES = 16
"""Rim samples of a geometry used only for its exact margins (which do not depend on
the sampling; 16 is the fewest a scenario allows)."""
RIM_FLOOR = 0.75
"""Share of the buffer a rotation may keep when it leaves an attitude already at (or
inside) the buffer's rim: a stalled target planned from again, or a restart. The local
(FEPF) and the global (route) planner both keep it."""


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


class ConeGeometry(AttitudeMargins, MrpObstacles):
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
        self.boresights_body = unit_rows(boresights_body)
        self.half_angles_deg = np.atleast_1d(np.asarray(half_angles_deg, dtype=float))
        self.directions_inertial = unit_rows(directions_inertial)
        self.inflation_deg = float(inflation_deg)
        self.samples = int(samples)
        n_i, n_j = len(self.boresights_body), len(self.directions_inertial)
        if self.half_angles_deg.shape != (n_i,):
            raise ValueError("half_angles_deg must have one entry per boresight")
        keep_in = KeepInCones.none() if keep_in is None else keep_in
        n_k = len(np.atleast_1d(keep_in.max_angles_deg))
        self.keep_in_axes_body = unit_rows(keep_in.axes_body) if n_k else np.zeros((0, 3))
        self.keep_in_directions_inertial = (
            unit_rows(keep_in.directions_inertial) if n_k else np.zeros((0, 3))
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
        cos = boresight_cosines(
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
