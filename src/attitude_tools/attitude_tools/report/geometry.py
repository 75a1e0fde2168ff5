"""Numbers behind the figures: sky coordinates, keep-out and keep-in circles, boresight
and keep-in axis paths, and the MRP-space surfaces of both kinds of constraint. Plain
NumPy (and scikit-image for marching cubes).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import cast

import numpy as np
import numpy.typing as npt
from skimage.measure import marching_cubes

from attitude_core.config.scenario import Scenario
from attitude_core.models.constraints import ConeGeometry, KeepInCones
from attitude_core.models.mrp import Vec3, dcm_from_mrp

__all__ = [
    "Pair",
    "pairs_of",
    "pair_index",
    "KeepIn",
    "keep_ins_of",
    "keep_in_margin_on_sky",
    "ra_dec_deg",
    "break_wraps",
    "small_circle",
    "sky_grid",
    "pair_margin_on_sky",
    "boresight_inertial",
    "break_jumps",
    "mrp_surface",
    "clip_to_unit_ball",
    "best_view",
]

_Floats = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Pair:
    """One keep-out cone: instrument (boresight ``s``) and object ``c``, at ``t = 0``.

    ``half_angle_deg`` is the pair's keep-out angle: the instrument's half-angle ``beta``
    on the paper's sky, else its exclusion of this object (from the limb) plus the
    object's angular radius. A ``moving`` object's cone (``direction_inertial``,
    ``radius_deg``) is the one at ``t = 0``; ``exclusion_deg`` is set for an object with
    a radius (an ephemeris body). ``instrument_half_angle_deg`` (the instrument's
    ``beta``, None without one) groups the pairs by instrument (:attr:`instrument_key`).
    """

    instrument: str
    obj: str
    boresight_body: tuple[float, float, float]
    half_angle_deg: float
    direction_inertial: tuple[float, float, float]
    exclusion_deg: float | None = None
    radius_deg: float = 0.0
    moving: bool = False
    instrument_half_angle_deg: float | None = None

    @property
    def key(self) -> str:
        """The constraint's label (``Scenario.constraint_names``)."""
        return f"{self.instrument}/{self.obj}"

    @property
    def exclusion(self) -> float:
        """The keep-out angle without the object's radius, deg."""
        return self.half_angle_deg if self.exclusion_deg is None else self.exclusion_deg

    @property
    def instrument_key(self) -> tuple[str, tuple[float, float, float], float | None]:
        """(name, boresight, half-angle or None): the instrument, one per key."""
        return (self.instrument, self.boresight_body, self.instrument_half_angle_deg)

    def geometry(self) -> ConeGeometry:
        return ConeGeometry(
            np.array([self.boresight_body]),
            np.array([self.half_angle_deg]),
            np.array([self.direction_inertial]),
            samples=8,
        )

    def margins_deg(self, sigma_bn: _Floats) -> _Floats:
        """This cone's exact margin at attitude(s) ``sigma_bn`` (shape ``(...)``)."""
        margins: _Floats = self.geometry().margins_deg(sigma_bn)[..., 0, 0]
        return margins


@dataclass(frozen=True)
class KeepIn:
    """One keep-in cone: body axis ``a`` within ``max_angle_deg`` of inertial ``d``."""

    name: str
    axis_body: tuple[float, float, float]
    direction_inertial: tuple[float, float, float]
    max_angle_deg: float

    @property
    def key(self) -> str:
        """The constraint's label (``Scenario.constraint_names``, the summary's keys)."""
        return f"keep_in/{self.name}"

    def geometry(self) -> ConeGeometry:
        return ConeGeometry(
            np.zeros((0, 3)),
            np.zeros(0),
            np.zeros((0, 3)),
            samples=8,
            keep_in=KeepInCones(
                np.array([self.axis_body]),
                np.array([self.direction_inertial]),
                np.array([self.max_angle_deg]),
            ),
        )

    def margins_deg(self, sigma_bn: _Floats) -> _Floats:
        """This cone's exact margin at attitude(s) ``sigma_bn`` (shape ``(...)``)."""
        margins: _Floats = self.geometry().keep_in_margins_deg(sigma_bn)[..., 0]
        return margins


def keep_ins_of(scenarios: Iterable[Scenario]) -> list[KeepIn]:
    """Every keep-in cone of the scenarios, each distinct cone once, in order."""
    out: list[KeepIn] = []
    for sc in scenarios:
        for k, name in enumerate(sc.keep_in_names):
            cone = KeepIn(
                name,
                cast(Vec3, tuple(float(x) for x in sc.keep_in_axes_body[k])),
                cast(Vec3, tuple(float(x) for x in sc.keep_in_directions_inertial[k])),
                float(sc.keep_in_max_angles_deg[k]),
            )
            if not any(_same_keep_in(cone, other) for other in out):
                out.append(cone)
    return out


def _same_keep_in(p: KeepIn, q: KeepIn) -> bool:
    return (
        p.name == q.name
        and np.allclose(p.axis_body, q.axis_body, atol=1e-12)
        and np.allclose(p.direction_inertial, q.direction_inertial, atol=1e-12)
        and abs(p.max_angle_deg - q.max_angle_deg) < 1e-12
    )


def pairs_of(scenarios: Iterable[Scenario]) -> list[Pair]:
    """Every keep-out constraint (a pair an instrument avoids) of the scenarios, each
    distinct cone once, in order (instrument-major, as ``Scenario.constraint_names``)."""
    out: list[Pair] = []
    for sc in scenarios:
        sky = sc.sky
        directions, radii = sky.object_directions(0.0)
        for i, j, exclusion in zip(
            sky.pair_instrument.tolist(),
            sky.pair_object.tolist(),
            sky.pair_exclusion_deg.tolist(),
            strict=True,
        ):
            beta = float(sc.half_angles_deg[i])
            radius = float(radii[j])
            p = Pair(
                sc.instrument_names[i],
                sc.bright_object_names[j],
                cast(Vec3, tuple(float(x) for x in sc.boresights_body[i])),
                exclusion + radius,
                cast(Vec3, tuple(float(x) for x in directions[j])),
                exclusion_deg=exclusion if sky.objects[j].ephemeris is not None else None,
                radius_deg=radius,
                moving=sky.objects[j].moves,
                instrument_half_angle_deg=None if np.isnan(beta) else beta,
            )
            if not any(_same(p, q) for q in out):
                out.append(p)
    return out


def pair_index(sc: Scenario, pair: Pair) -> int | None:
    """The scenario's constraint (column of ``constraint_names``) equal to ``pair``."""
    sky = sc.sky
    directions, radii = sky.object_directions(0.0)
    for c, (i, j, exclusion) in enumerate(
        zip(sky.pair_instrument, sky.pair_object, sky.pair_exclusion_deg, strict=True)
    ):
        if (
            (sc.instrument_names[i], sc.bright_object_names[j]) == (pair.instrument, pair.obj)
            and np.allclose(directions[j], pair.direction_inertial)
            and abs(float(exclusion + radii[j]) - pair.half_angle_deg) < 1e-9
            and sky.objects[j].moves == pair.moving
        ):
            return c
    return None


def _same(p: Pair, q: Pair) -> bool:
    return (
        np.allclose(p.boresight_body, q.boresight_body, atol=1e-12)
        and abs(p.half_angle_deg - q.half_angle_deg) < 1e-12
        and np.allclose(p.direction_inertial, q.direction_inertial, atol=1e-12)
        and (p.moving, p.exclusion_deg) == (q.moving, q.exclusion_deg)
    )


def ra_dec_deg(v: _Floats) -> tuple[_Floats, _Floats]:
    """Right ascension in [0, 360) and declination in [-90, 90], degrees, of vectors (..., 3)."""
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    ra = np.degrees(np.arctan2(v[..., 1], v[..., 0])) % 360.0
    ra = np.where(ra >= 360.0, 0.0, ra)  # (-tiny) % 360 rounds to 360
    dec = np.degrees(np.arcsin(np.clip(v[..., 2], -1.0, 1.0)))
    return ra, dec


def break_wraps(ra: _Floats, dec: _Floats) -> tuple[_Floats, _Floats]:
    """Insert NaN where RA wraps between 0 and 360 so a line is not drawn across the plot."""
    cut = np.flatnonzero(np.abs(np.diff(ra)) > 180.0) + 1
    return np.insert(ra, cut, np.nan), np.insert(dec, cut, np.nan)


def small_circle(centre: npt.ArrayLike, radius_deg: float, n: int = 721) -> _Floats:
    """``n`` points (closed) of the small circle of angular radius ``radius_deg`` about
    ``centre`` (unit vectors)."""
    c = np.asarray(centre, dtype=float)
    c = c / np.linalg.norm(c)
    e1 = np.cross(c, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 0.5:
        e1 = np.cross(c, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(c, e1)
    phi = np.linspace(0.0, 2.0 * np.pi, n)[:, None]
    r = np.radians(radius_deg)
    points: _Floats = np.cos(r) * c + np.sin(r) * (np.cos(phi) * e1 + np.sin(phi) * e2)
    return points


def sky_grid(n_ra: int = 721, n_dec: int = 361) -> tuple[_Floats, _Floats, _Floats]:
    """RA/Dec mesh (degrees) and the unit vectors of its nodes, (n_dec, n_ra, 3)."""
    ra = np.linspace(0.0, 360.0, n_ra)
    dec = np.linspace(-90.0, 90.0, n_dec)
    RA, DEC = np.meshgrid(np.radians(ra), np.radians(dec))
    v = np.stack([np.cos(DEC) * np.cos(RA), np.cos(DEC) * np.sin(RA), np.sin(DEC)], -1)
    return ra, dec, v


def pair_margin_on_sky(pair: Pair, v: _Floats) -> _Floats:
    """Margin (deg) of a boresight pointing along inertial ``v`` (..., 3): angle to c - beta."""
    c = np.asarray(pair.direction_inertial) / np.linalg.norm(pair.direction_inertial)
    margin: _Floats = np.degrees(np.arccos(np.clip(v @ c, -1.0, 1.0))) - pair.half_angle_deg
    return margin


def keep_in_margin_on_sky(cone: KeepIn, v: _Floats) -> _Floats:
    """Keep-in margin (deg) of the axis pointing along inertial ``v`` (..., 3):
    ``max_angle_deg`` minus the angle to ``d`` (positive inside the cone)."""
    d = np.asarray(cone.direction_inertial) / np.linalg.norm(cone.direction_inertial)
    margin: _Floats = cone.max_angle_deg - np.degrees(np.arccos(np.clip(v @ d, -1.0, 1.0)))
    return margin


def boresight_inertial(sigma_bn: npt.ArrayLike, s_body: npt.ArrayLike) -> _Floats:
    """Boresight in inertial axes, ``C_BN(sigma)^T s`` for each row of ``sigma_bn``."""
    s = np.asarray(s_body, dtype=float)
    s = s / np.linalg.norm(s)
    inertial: _Floats = np.einsum("nki,k->ni", dcm_from_mrp(sigma_bn), s)
    return inertial


def break_jumps(points: _Floats, jump: float = 0.5) -> _Floats:
    """Insert a NaN row where consecutive rows jump by more than ``jump`` (shadow switches)."""
    points = np.asarray(points, dtype=float)
    cut = np.flatnonzero(np.linalg.norm(np.diff(points, axis=0), axis=1) > jump) + 1
    return np.insert(points, cut, np.nan, axis=0)


def mrp_surface(constraint: Pair | KeepIn, n: int = 48, extent: float = 1.0) -> _Floats | None:
    """Zero level set of a keep-out pair's or a keep-in cone's margin inside the unit
    ball, as triangles (T, 3, 3).

    Marching cubes on an ``n^3`` grid of the exact margin (``constraint.margins_deg``)
    over ``[-extent, extent]^3``, masked to the cells that reach into ``|sigma| <= 1``,
    then clipped exactly at the unit sphere. None when the boundary does not reach into
    the ball.
    """
    h = 2.0 * extent / (n - 1)
    axis = np.linspace(-extent, extent, n)
    grid = np.stack(np.meshgrid(axis, axis, axis, indexing="ij"), -1)
    margin = constraint.margins_deg(grid)
    # A cube is meshed when all its corners are in the mask: pad by a cell diagonal so
    # every cube that reaches into the ball is meshed.
    mask = np.linalg.norm(grid, axis=-1) <= 1.0 + 1.75 * h
    m = margin[mask]
    if m.size == 0 or m.min() >= 0.0 or m.max() <= 0.0:
        return None
    verts, faces, _, _ = marching_cubes(  # type: ignore[no-untyped-call]
        margin, 0.0, spacing=(h, h, h), mask=mask
    )
    tris = clip_to_unit_ball(verts[faces] - extent)
    return tris if len(tris) else None


def _exit_point(a: _Floats, b: _Floats) -> _Floats:
    """Where the segments from ``a`` (inside the unit ball) to ``b`` (outside) leave it."""
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    ad = np.einsum("ij,ij->i", a, d)
    aa = np.einsum("ij,ij->i", a, a)
    t = (-ad + np.sqrt(np.maximum(ad * ad - dd * (aa - 1.0), 0.0))) / np.where(dd > 0, dd, 1.0)
    exit_points: _Floats = a + np.clip(t, 0.0, 1.0)[:, None] * d
    return exit_points


def clip_to_unit_ball(tris: _Floats) -> _Floats:
    """The parts of triangles (T, 3, 3) inside ``|x| <= 1``, as triangles (orientation kept)."""
    inside = np.linalg.norm(tris, axis=-1) <= 1.0
    count = inside.sum(axis=1)
    out = [tris[count == 3]]
    rows = np.arange(len(tris))
    for n_in in (1, 2):
        sel = rows[count == n_in]
        if len(sel) == 0:
            continue
        # Rotate each triangle (cyclically) so the odd vertex comes first.
        k = np.argmax(inside[sel], axis=1) if n_in == 1 else np.argmin(inside[sel], axis=1)
        a, b, c = (tris[sel, (k + j) % 3] for j in range(3))
        if n_in == 1:  # a inside: keep the tip
            out.append(np.stack([a, _exit_point(a, b), _exit_point(a, c)], 1))
        else:  # a outside: keep the quad b, c, exit(c->a), exit(b->a)
            pb, pc = _exit_point(b, a), _exit_point(c, a)
            out.append(np.stack([b, c, pc], 1))
            out.append(np.stack([b, pc, pb], 1))
    return np.concatenate(out)


def best_view(
    points: npt.ArrayLike,
    elevations: tuple[float, ...] = (18.0, 28.0),
    default_azim: float = -58.0,
) -> tuple[float, float]:
    """(elev, azim) in degrees of a 3D view that shows ``points`` (N, 3) most spread out."""
    pts = np.asarray(points, dtype=float)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts) < 2:
        return elevations[0], default_azim
    pts = pts - pts.mean(axis=0)
    best, best_score = (elevations[0], default_azim), -np.inf
    for elev in elevations:
        e = np.radians(elev)
        for azim in np.arange(-180.0, 180.0, 5.0):
            a = np.radians(azim)
            right = np.array([-np.sin(a), np.cos(a), 0.0])
            up = np.array([-np.sin(e) * np.cos(a), -np.sin(e) * np.sin(a), np.cos(e)])
            sv = np.linalg.svd(pts @ np.stack([right, up], 1), compute_uv=False)
            # Spread first; a slight preference for the usual view breaks near ties.
            score = sv[0] + 0.5 * sv[1] - 1e-3 * abs((azim - default_azim + 180) % 360 - 180) / 180
            if score > best_score:
                best, best_score = (elev, float(azim)), score
    return best
