"""The sky over time: where each bright object and keep-in direction is, how big it looks,
and the keep-out geometry of any instant or time window.

Inputs: the instruments' body boresights and their per-object exclusion angles
(degrees from the object's *limb*; NaN where an instrument need not avoid an object),
each object's motion (:class:`Motion`: a fixed inertial direction, a direction turning
at a constant inertial rate, or an ephemeris body seen from the spacecraft), the keep-in
cones, the epoch (UTC) and the orbit (:mod:`attitude_core.models.ephemeris`).

Outputs, at time ``t`` (s after the epoch, the run's ``t = 0``):

* the objects' unit directions ``c_j(t)`` (inertial axes) and angular radii
  ``rho_j(t)``; the margin of pair ``(i, j)`` is
  ``angle(C_BN^T s_i, c_j(t)) - exclusion_ij - rho_j(t)`` (eq. 5 with the limb);
* :meth:`Sky.geometry` over a window ``[t, t + w]``: a :class:`ConeGeometry` whose cones
  hold every position of the true cones in that window. Centred on ``c_j(t + w/2)``,
  each pair's angle grows by ``r_j w / 2``, ``r_j`` the object's rate bound
  (:attr:`Sky.rate_bounds_deg_s`: its direction's angular rate plus the rate of its
  radius), since ``angle(c_j(t'), c_j(t + w/2)) <= r_j |t' - t - w/2|``. Keep-in cones
  shrink by their direction's bound likewise. ``w = 0`` is the sky of the instant;
* the exact margins of attitudes at their own times (:meth:`Sky.constraint_margins_deg`),
  which every reported margin uses.

A sky whose objects are all fixed points (no rate, no ephemeris) is *static*: its
geometry is the paper's (eq. 5), the same at every time.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import cast

import numpy as np
import numpy.typing as npt

from attitude_core.models.constraints import EXACT_SAMPLES, ConeGeometry, KeepInCones
from attitude_core.models.ephemeris import (
    EARTH_RADIUS_KM,
    MOON_RADIUS_KM,
    SUN_RADIUS_KM,
    Orbit,
    body_directions,
    sun_moon_geocentric_km,
)
from attitude_core.models.mrp import Vec3Like, cross3, dcm_from_mrp

__all__ = ["Motion", "Sky", "RATE_SAMPLE_S", "RATE_BOUND_FACTOR"]

_Floats = npt.NDArray[np.float64]

RATE_SAMPLE_S = 5.0
"""Spacing of the times at which an ephemeris body's rate is sampled for its bound, s."""
TABLE_STEP_S = 60.0
"""Spacing of the Sun's and the Moon's tabulated geocentric positions, s."""
BODY_RADIUS_KM = {"sun": SUN_RADIUS_KM, "moon": MOON_RADIUS_KM, "earth": EARTH_RADIUS_KM}
RATE_BOUND_FACTOR = 1.25
"""Factor on the largest sampled rate of an ephemeris body (its rate between samples)."""


@dataclass(frozen=True)
class Motion:
    """How one direction moves: ``ephemeris`` (``sun``, ``moon``, ``earth``: seen from the
    spacecraft, with its angular radius) or ``direction_inertial`` turned by the constant
    inertial rate vector ``rate_inertial_rad_s`` from ``t = 0`` (None: fixed)."""

    direction_inertial: tuple[float, float, float] | None = None
    rate_inertial_rad_s: tuple[float, float, float] | None = None
    ephemeris: str | None = None

    @property
    def moves(self) -> bool:
        return self.ephemeris is not None or (
            self.rate_inertial_rad_s is not None and any(self.rate_inertial_rad_s)
        )


def _rotated(c0: _Floats, rate: _Floats, t: _Floats) -> _Floats:
    """``c0`` turned actively by ``|rate| t`` about ``rate`` (Rodrigues), ``(..., 3)``."""
    size = float(np.linalg.norm(rate))
    axis = rate / size
    angle = size * t[..., None]
    cos, sin = np.cos(angle), np.sin(angle)
    out: _Floats = c0 * cos + cross3(axis, c0) * sin + axis * float(axis @ c0) * (1.0 - cos)
    return out


class Sky:
    """The constraints' sky over time (see the module docstring).

    Parameters
    ----------
    boresights_body : (n_i, 3) instrument boresights, body axes.
    exclusion_deg : (n_i, n_j) exclusion angle of each pair from the object's limb, deg;
        NaN where the instrument need not avoid the object.
    objects : n_j object motions.
    keep_in_axes_body, keep_in_max_angles_deg, keep_in : the keep-in cones' body axes,
        largest angles (deg) and direction motions.
    epoch_utc : two-part UTC Julian date of ``t = 0`` (needed by ephemeris bodies).
    orbit : the spacecraft's orbit (``earth`` needs it; the Sun and Moon are seen from
        the Earth's centre without one).
    horizon_s : the span over which the rate bounds hold (the run and some beyond).
    """

    def __init__(
        self,
        boresights_body: npt.ArrayLike,
        exclusion_deg: npt.ArrayLike,
        objects: Sequence[Motion],
        keep_in_axes_body: npt.ArrayLike = (),
        keep_in_max_angles_deg: npt.ArrayLike = (),
        keep_in: Sequence[Motion] = (),
        epoch_utc: tuple[float, float] | None = None,
        orbit: Orbit | None = None,
        horizon_s: float = 0.0,
    ) -> None:
        self.boresights_body = np.asarray(boresights_body, dtype=float).reshape(-1, 3)
        self.exclusion_deg = np.asarray(exclusion_deg, dtype=float).reshape(
            len(self.boresights_body), len(objects)
        )
        self.objects = tuple(objects)
        self.keep_in_axes_body = np.asarray(keep_in_axes_body, dtype=float).reshape(-1, 3)
        self.keep_in_max_angles_deg = np.asarray(keep_in_max_angles_deg, dtype=float).reshape(-1)
        self.keep_in = tuple(keep_in)
        self.epoch_utc = epoch_utc
        self.orbit = orbit
        self.horizon_s = float(horizon_s)
        self.static = not any(m.moves for m in self.objects + self.keep_in)
        avoided = ~np.isnan(self.exclusion_deg)
        self.pair_instrument, self.pair_object = (x.astype(np.int64) for x in np.nonzero(avoided))
        self.pair_exclusion_deg = self.exclusion_deg[avoided]
        self.rate_bounds_deg_s = self._rate_bounds(self.objects, radius=True)
        self.keep_in_rate_bounds_deg_s = self._rate_bounds(self.keep_in, radius=False)

    # --- where things are -------------------------------------------------------------

    def _directions(self, motions: Sequence[Motion], t_s: npt.ArrayLike) -> tuple[_Floats, _Floats]:
        """Unit directions ``(..., n, 3)`` and angular radii (deg) ``(..., n)`` at ``t_s``."""
        t = np.asarray(t_s, dtype=float)
        dirs = np.empty(t.shape + (len(motions), 3))
        radii = np.zeros(t.shape + (len(motions),))
        for j, m in enumerate(motions):
            if m.ephemeris is not None:
                d, r = self._body(m.ephemeris, t.reshape(-1))
                dirs[..., j, :] = d.reshape(t.shape + (3,))
                radii[..., j] = np.degrees(r).reshape(t.shape)
            elif m.rate_inertial_rad_s is not None and any(m.rate_inertial_rad_s):
                c0 = np.asarray(m.direction_inertial, dtype=float)
                dirs[..., j, :] = _rotated(c0, np.asarray(m.rate_inertial_rad_s, dtype=float), t)
            else:
                dirs[..., j, :] = np.asarray(m.direction_inertial, dtype=float)
        return dirs, radii

    def _body(self, body: str, t: _Floats) -> tuple[_Floats, _Floats]:
        """An ephemeris body's direction from the spacecraft and angular radius (rad) at
        the times ``t`` ``(n,)``: the Sun's and the Moon's geocentric positions are
        interpolated linearly in a table every :data:`TABLE_STEP_S` (their curvature
        over a step is below 2 km for the Moon, 1e-3 deg), the orbit is exact."""
        if body == "earth" or self.epoch_utc is None:
            d, r = body_directions(body, self.epoch_utc, self.orbit, t)
            return np.asarray(d, dtype=float), np.asarray(r, dtype=float)
        grid, sun, moon = self._table
        if len(t) and (t.min() < grid[0] or t.max() > grid[-1]):
            d, r = body_directions(body, self.epoch_utc, self.orbit, t)
            return np.asarray(d, dtype=float), np.asarray(r, dtype=float)
        table = sun if body == "sun" else moon
        pos = np.stack([np.interp(t, grid, table[:, k]) for k in range(3)], axis=-1)
        if self.orbit is not None:
            pos = pos - self.orbit.state_km(t)[0]
        dist = np.linalg.norm(pos, axis=-1)
        radius = np.arcsin(np.minimum(BODY_RADIUS_KM[body] / dist, 1.0))
        return pos / dist[:, None], radius

    @functools.cached_property
    def _table(self) -> tuple[_Floats, _Floats, _Floats]:
        """Times, and the Sun's and the Moon's geocentric positions (km) at them."""
        assert self.epoch_utc is not None
        grid = np.arange(-TABLE_STEP_S, self.horizon_s + 2.0 * TABLE_STEP_S, TABLE_STEP_S)
        sun, moon = sun_moon_geocentric_km(self.epoch_utc, grid)
        return grid, sun, moon

    def object_directions(self, t_s: npt.ArrayLike) -> tuple[_Floats, _Floats]:
        """The bright objects' unit directions ``(..., n_j, 3)``, inertial axes, and
        angular radii ``(..., n_j)``, deg, at ``t_s`` (s after the epoch)."""
        return self._directions(self.objects, t_s)

    def keep_in_directions(self, t_s: npt.ArrayLike) -> _Floats:
        """The keep-in directions ``(..., n_k, 3)``, inertial axes, at ``t_s``."""
        return self._directions(self.keep_in, t_s)[0]

    def _rate_bounds(self, motions: Sequence[Motion], radius: bool) -> _Floats:
        """Per motion: a bound on its direction's angular rate (plus its radius' rate),
        deg/s, over ``[0, horizon_s]``."""
        out = np.zeros(len(motions))
        span = max(self.horizon_s, RATE_SAMPLE_S)
        t = np.arange(0.0, span + RATE_SAMPLE_S, RATE_SAMPLE_S)
        for j, m in enumerate(motions):
            if m.ephemeris is not None:
                step = 1.0
                d0, r0 = self._body(m.ephemeris, t)
                d1, r1 = self._body(m.ephemeris, t + step)
                cos = np.clip(np.einsum("ij,ij->i", d0, d1), -1.0, 1.0)
                rate = np.degrees(np.arccos(cos)) / step
                if radius:
                    rate = rate + np.degrees(np.abs(np.asarray(r1) - np.asarray(r0))) / step
                out[j] = RATE_BOUND_FACTOR * float(rate.max())
            elif m.rate_inertial_rad_s is not None:
                out[j] = math.degrees(float(np.linalg.norm(m.rate_inertial_rad_s)))
        return out

    # --- geometry ---------------------------------------------------------------------

    def geometry(
        self,
        t_s: float = 0.0,
        window_s: float = 0.0,
        inflation_deg: float = 0.0,
        samples: int = EXACT_SAMPLES,
    ) -> ConeGeometry:
        """Keep-out and keep-in geometry holding the true cones over
        ``[t_s, t_s + window_s]`` (module docstring), with ``inflation_deg`` of buffer
        for the MRP obstacles."""
        t_mid = t_s + 0.5 * window_s
        dirs, radii = self.object_directions(t_mid)
        sweep = 0.5 * window_s * self.rate_bounds_deg_s
        pair_angles = self.exclusion_deg + (radii + sweep)[None, :]
        n_k = len(self.keep_in)
        keep_in_dirs = self.keep_in_directions(t_mid) if n_k else np.zeros((0, 3))
        gamma = self.keep_in_max_angles_deg - 0.5 * window_s * self.keep_in_rate_bounds_deg_s
        return ConeGeometry(
            self.boresights_body,
            np.nanmin(self.exclusion_deg, axis=1, initial=90.0),
            dirs,
            inflation_deg=inflation_deg,
            samples=samples,
            keep_in=KeepInCones(self.keep_in_axes_body, keep_in_dirs, np.maximum(gamma, 1e-3)),
            pair_angles_deg=pair_angles,
        )

    # --- margins at their own times ---------------------------------------------------

    def constraint_margins_deg(self, t_s: npt.ArrayLike, sigma_bn: npt.ArrayLike) -> _Floats:
        """Exact margins of every constraint ``(..., n_c)``, deg, of attitudes
        ``sigma_bn`` ``(..., 3)`` each at its time ``t_s`` ``(...)``: keep-out pairs
        (from the limb), then keep-in cones."""
        sigma = np.asarray(sigma_bn, dtype=float)
        c_bn = dcm_from_mrp(sigma)
        dirs, radii = self.object_directions(t_s)
        b_n = np.einsum("...ki,nk->...ni", c_bn, self.boresights_body)
        cos = np.clip(np.einsum("...ni,...mi->...nm", b_n, dirs), -1.0, 1.0)
        i, j = self.pair_instrument, self.pair_object
        keep_out = np.degrees(np.arccos(cos[..., i, j])) - self.pair_exclusion_deg - radii[..., j]
        if not len(self.keep_in):
            return cast(_Floats, keep_out)
        a_n = np.einsum("...ki,nk->...ni", c_bn, self.keep_in_axes_body)
        d = self.keep_in_directions(t_s)
        cos_k = np.clip(np.einsum("...ni,...ni->...n", a_n, d), -1.0, 1.0)
        keep_in = self.keep_in_max_angles_deg - np.degrees(np.arccos(cos_k))
        return cast(_Floats, np.concatenate([keep_out, keep_in], axis=-1))

    def min_margin_deg(self, t_s: npt.ArrayLike, sigma_bn: npt.ArrayLike) -> _Floats:
        """Smallest exact margin ``(...)``, deg, of attitudes at their times."""
        if self.static:
            return cast(_Floats, self.exact_geometry.min_margin_deg(np.asarray(sigma_bn, float)))
        return cast(_Floats, self.constraint_margins_deg(t_s, sigma_bn).min(axis=-1))

    def min_margin_deg_single(self, t_s: float, sigma_bn: Vec3Like) -> float:
        """Smallest exact margin of one attitude at ``t_s``, deg."""
        if self.static:
            return self.exact_geometry.min_margin_deg_single(sigma_bn)
        return float(self.constraint_margins_deg(t_s, np.asarray(sigma_bn, float)).min())

    @functools.cached_property
    def exact_geometry(self) -> ConeGeometry:
        """The geometry at ``t = 0`` (of every time, on a static sky), uninflated."""
        return self.geometry()
