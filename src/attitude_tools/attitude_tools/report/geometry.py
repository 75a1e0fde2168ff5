"""Numbers behind the figures: sky coordinates, keep-out and keep-in circles, boresight
and keep-in axis paths, and the MRP-space surfaces of both kinds of constraint. Plain
NumPy (and scikit-image for marching cubes).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import cast

import numpy as np
from skimage.measure import marching_cubes

from attitude_core.constraints import ConeGeometry, KeepInCones
from attitude_core.mrp import Vec3, dcm_from_mrp

__all__ = [
    "Pair",
    "pairs_of",
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


@dataclass(frozen=True)
class Pair:
    """One keep-out cone: instrument (boresight ``s``, half-angle ``beta``) and object ``c``."""

    instrument: str
    obj: str
    boresight_body: tuple[float, float, float]
    half_angle_deg: float
    direction_inertial: tuple[float, float, float]

    @property
    def key(self) -> str:
        return f"{self.instrument}/{self.obj}"

    def geometry(self) -> ConeGeometry:
        return ConeGeometry(
            np.array([self.boresight_body]),
            np.array([self.half_angle_deg]),
            np.array([self.direction_inertial]),
            samples=8,
        )

    def margins_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """This cone's exact margin at attitude(s) ``sigma_bn`` (shape ``(...)``)."""
        margins: np.ndarray = self.geometry().margins_deg(sigma_bn)[..., 0, 0]
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

    def margins_deg(self, sigma_bn: np.ndarray) -> np.ndarray:
        """This cone's exact margin at attitude(s) ``sigma_bn`` (shape ``(...)``)."""
        margins: np.ndarray = self.geometry().keep_in_margins_deg(sigma_bn)[..., 0]
        return margins


def keep_ins_of(scenarios) -> list[KeepIn]:
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


def pairs_of(scenarios) -> list[Pair]:
    """Every (instrument, object) pair of the scenarios, each distinct cone once, in order."""
    out: list[Pair] = []
    for sc in scenarios:
        for i, name in enumerate(sc.instrument_names):
            for j, obj in enumerate(sc.bright_object_names):
                p = Pair(
                    name,
                    obj,
                    cast(Vec3, tuple(float(x) for x in sc.boresights_body[i])),
                    float(sc.half_angles_deg[i]),
                    cast(Vec3, tuple(float(x) for x in sc.directions_inertial[j])),
                )
                if not any(_same(p, q) for q in out):
                    out.append(p)
    return out


def _same(p: Pair, q: Pair) -> bool:
    return (
        np.allclose(p.boresight_body, q.boresight_body, atol=1e-12)
        and abs(p.half_angle_deg - q.half_angle_deg) < 1e-12
        and np.allclose(p.direction_inertial, q.direction_inertial, atol=1e-12)
    )


def ra_dec_deg(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Right ascension in [0, 360) and declination in [-90, 90], degrees, of vectors (..., 3)."""
    v = np.asarray(v, dtype=float)
    v = v / np.linalg.norm(v, axis=-1, keepdims=True)
    ra = np.degrees(np.arctan2(v[..., 1], v[..., 0])) % 360.0
    ra = np.where(ra >= 360.0, 0.0, ra)  # (-tiny) % 360 rounds to 360
    dec = np.degrees(np.arcsin(np.clip(v[..., 2], -1.0, 1.0)))
    return ra, dec


def break_wraps(ra: np.ndarray, dec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Insert NaN where RA wraps between 0 and 360 so a line is not drawn across the plot."""
    cut = np.flatnonzero(np.abs(np.diff(ra)) > 180.0) + 1
    return np.insert(ra, cut, np.nan), np.insert(dec, cut, np.nan)


def small_circle(centre: np.ndarray, radius_deg: float, n: int = 721) -> np.ndarray:
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
    return np.cos(r) * c + np.sin(r) * (np.cos(phi) * e1 + np.sin(phi) * e2)


def sky_grid(n_ra: int = 721, n_dec: int = 361):
    """RA/Dec mesh (degrees) and the unit vectors of its nodes, (n_dec, n_ra, 3)."""
    ra = np.linspace(0.0, 360.0, n_ra)
    dec = np.linspace(-90.0, 90.0, n_dec)
    RA, DEC = np.meshgrid(np.radians(ra), np.radians(dec))
    v = np.stack([np.cos(DEC) * np.cos(RA), np.cos(DEC) * np.sin(RA), np.sin(DEC)], -1)
    return ra, dec, v


def pair_margin_on_sky(pair: Pair, v: np.ndarray) -> np.ndarray:
    """Margin (deg) of a boresight pointing along inertial ``v`` (..., 3): angle to c - beta."""
    c = np.asarray(pair.direction_inertial) / np.linalg.norm(pair.direction_inertial)
    return np.degrees(np.arccos(np.clip(v @ c, -1.0, 1.0))) - pair.half_angle_deg


def keep_in_margin_on_sky(cone: KeepIn, v: np.ndarray) -> np.ndarray:
    """Keep-in margin (deg) of the axis pointing along inertial ``v`` (..., 3):
    ``max_angle_deg`` minus the angle to ``d`` (positive inside the cone)."""
    d = np.asarray(cone.direction_inertial) / np.linalg.norm(cone.direction_inertial)
    return cone.max_angle_deg - np.degrees(np.arccos(np.clip(v @ d, -1.0, 1.0)))


def boresight_inertial(sigma_bn: np.ndarray, s_body: np.ndarray) -> np.ndarray:
    """Boresight in inertial axes, ``C_BN(sigma)^T s`` for each row of ``sigma_bn``."""
    s = np.asarray(s_body, dtype=float)
    s = s / np.linalg.norm(s)
    return np.einsum("nki,k->ni", dcm_from_mrp(sigma_bn), s)


def break_jumps(points: np.ndarray, jump: float = 0.5) -> np.ndarray:
    """Insert a NaN row where consecutive rows jump by more than ``jump`` (shadow switches)."""
    points = np.asarray(points, dtype=float)
    cut = np.flatnonzero(np.linalg.norm(np.diff(points, axis=0), axis=1) > jump) + 1
    return np.insert(points, cut, np.nan, axis=0)


def mrp_surface(constraint: Pair | KeepIn, n: int = 48, extent: float = 1.0):
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
    verts, faces, _, _ = marching_cubes(margin, 0.0, spacing=(h, h, h), mask=mask)
    tris = clip_to_unit_ball(verts[faces] - extent)
    return tris if len(tris) else None


def _exit_point(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Where the segments from ``a`` (inside the unit ball) to ``b`` (outside) leave it."""
    d = b - a
    dd = np.einsum("ij,ij->i", d, d)
    ad = np.einsum("ij,ij->i", a, d)
    aa = np.einsum("ij,ij->i", a, a)
    t = (-ad + np.sqrt(np.maximum(ad * ad - dd * (aa - 1.0), 0.0))) / np.where(dd > 0, dd, 1.0)
    return a + np.clip(t, 0.0, 1.0)[:, None] * d


def clip_to_unit_ball(tris: np.ndarray) -> np.ndarray:
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


def best_view(points: np.ndarray, elevations=(18.0, 28.0), default_azim: float = -58.0):
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
