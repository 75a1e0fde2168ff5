"""Global route over the attitude space: a roadmap of SO(3), edges checked continuously
against the exact cone margins, the shortest route by rotation angle, then shortcut.

The roadmap (:func:`roadmap`, built once per process and size) is ``n`` attitudes
spread evenly over SO(3) (a super-Fibonacci spiral of unit quaternions) joined to their
``k`` nearest neighbours; an edge is the short eigenaxis rotation between its two
attitudes and costs its rotation angle. For a scenario (:class:`RoutePlanner`):

1. Every node's exact margin (all keep-out pairs and keep-in cones, eq. 5) less the
   clearance; a node is free when it is positive.
2. Every edge between free nodes is checked over its whole rotation, not at its ends:
   a margin changes by at most the rotation angle (a body vector turns by at most that
   angle), so an edge with ``m_u + m_v >= theta`` is free; any other edge gets the exact
   smallest margin along its rotation in closed form
   (:func:`attitude_core.models.cone_math.arc_cos_extremes`).
3. The start and the goal join the roadmap through their nearest nodes (same check);
   a free direct rotation ends the search at once.
4. Dijkstra (SciPy) by rotation angle; then the route is shortcut greedily: from each
   waypoint, the farthest later waypoint whose direct rotation is free.

Clearance: the planner's buffer plus :data:`EXTRA_CLEARANCE_DEG`, so that the FEPF can
fly a route that grazes a buffered cone at speed; when no such route exists, the buffer
plus a quarter degree, then the buffer alone. With no route at the buffer on the
default roadmap, a roadmap :data:`FINE_FACTOR` times denser is searched; with none there
either the slew is infeasible at the planner's resolution, and the reason names the
constraints that block every edge leaving the smaller of the start's and the goal's
free regions (the ones enclosing it).
"""

from __future__ import annotations

import functools
import math
import time
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import numpy.typing as npt
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from attitude_core.models.cone_math import arc_cos_extremes
from attitude_core.models.constraints import RIM_FLOOR, ConeGeometry
from attitude_core.models.mrp import Vec3Like

__all__ = [
    "ROADMAP_NODES",
    "NEIGHBOURS",
    "EXTRA_CLEARANCE_DEG",
    "FINE_FACTOR",
    "Roadmap",
    "Route",
    "RoutePlanner",
    "roadmap",
    "super_fibonacci_quaternions",
]

_Floats = npt.NDArray[np.float64]

ROADMAP_NODES = 4096
"""Attitudes of the default roadmap (mean spacing about 12 deg of rotation)."""
NEIGHBOURS = 14
"""Nearest neighbours each roadmap node is joined to."""
EXTRA_CLEARANCE_DEG = 1.0
"""Clearance beyond the planner's buffer that a route keeps when it can."""
FINE_FACTOR = 4
"""Density of the roadmap searched before a slew is declared infeasible."""
_END_LINKS = 3 * NEIGHBOURS  # roadmap nodes the start and the goal are joined to
_PARK_LINKS = 12 * NEIGHBOURS  # from a start deep in swept cones, farther nodes too
_START_TOL_DEG = 1e-6  # a rotation leaving an attitude starts at that attitude's margin
_PULL_START_DEG = 4.0
_PULL_MIN_DEG = 0.05
_EDGE_CHUNK = 16384  # roadmap edges per vectorised block (bounds the memory)
_PULL_TRIES = 24
_PULL_BUDGET = 72  # tries over all the inner waypoints of a route


def super_fibonacci_quaternions(n: int) -> _Floats:
    """``n`` unit quaternions ``(x, y, z, w)`` spread evenly over the 3-sphere (Alexa's
    super-Fibonacci spiral): deterministic, with no clusters or gaps."""
    phi = math.sqrt(2.0)
    psi = 1.533751168755204288118041
    s = np.arange(n, dtype=float) + 0.5
    r = np.sqrt(s / n)
    big_r = np.sqrt(1.0 - s / n)
    alpha = 2.0 * np.pi * s / phi
    beta = 2.0 * np.pi * s / psi
    q = np.stack(
        [r * np.sin(alpha), r * np.cos(alpha), big_r * np.sin(beta), big_r * np.cos(beta)],
        axis=1,
    )
    unit: _Floats = q / np.linalg.norm(q, axis=1, keepdims=True)
    return unit


@dataclass(frozen=True, eq=False)
class Roadmap:
    """A scenario-free roadmap of SO(3): node attitudes and eigenaxis edges."""

    rotations: Rotation  # node attitudes, C_NB (body to inertial)
    quats: _Floats  # (n, 4) x, y, z, w
    tree: cKDTree  # over (quats; -quats): the nearest attitudes of any attitude
    edges: npt.NDArray[np.int64]  # (E, 2), u < v
    axes: _Floats  # (E, 3) inertial eigenaxis from u to v
    angles: _Floats  # (E,) rotation angle, rad

    @property
    def size(self) -> int:
        return len(self.quats)

    def nearest(self, rotation: Rotation, k: int) -> npt.NDArray[np.int64]:
        """The ``k`` roadmap nodes nearest to one attitude."""
        q = rotation.as_quat()
        _, idx = self.tree.query(q, k=min(2 * k, 2 * self.size))
        return _first_unique(np.asarray(idx) % self.size, k)


def _first_unique(idx: npt.NDArray[np.int64], k: int) -> npt.NDArray[np.int64]:
    seen: dict[int, None] = {}
    for i in idx.tolist():
        seen.setdefault(int(i), None)
        if len(seen) == k:
            break
    return np.fromiter(seen, dtype=np.int64)


def _eigen_rotations(r_from: Rotation, r_to: Rotation) -> tuple[_Floats, _Floats]:
    """Inertial unit axes and angles of the short rotations ``r_from -> r_to``."""
    rotvec = np.atleast_2d((r_to * r_from.inv()).as_rotvec())
    angle = np.linalg.norm(rotvec, axis=1)
    axis = rotvec / np.where(angle > 0.0, angle, 1.0)[:, None]
    axis[angle == 0.0] = (1.0, 0.0, 0.0)
    return axis, angle


def roadmap(n: int = ROADMAP_NODES, k: int = NEIGHBOURS) -> Roadmap:
    """The roadmap of ``n`` attitudes, each joined to its ``k`` nearest (built once per
    process and size)."""
    return _roadmap(int(n), int(k))


@functools.lru_cache(maxsize=4)
def _roadmap(n: int, k: int) -> Roadmap:
    quats = super_fibonacci_quaternions(n)
    tree = cKDTree(np.concatenate([quats, -quats]))
    _, idx = tree.query(quats, k=k + 1)
    idx = np.asarray(idx) % n
    u = np.repeat(np.arange(n), k + 1)
    v = idx.ravel()
    keep = u != v
    lo, hi = np.minimum(u[keep], v[keep]), np.maximum(u[keep], v[keep])
    keys = np.unique(lo.astype(np.int64) * n + hi)  # each pair once, in order
    pairs = np.stack([keys // n, keys % n], axis=1)
    rotations = Rotation.from_quat(quats)
    axes, angles = _eigen_rotations(rotations[pairs[:, 0]], rotations[pairs[:, 1]])
    return Roadmap(rotations, quats, tree, pairs.astype(np.int64), axes, angles)


@dataclass(frozen=True)
class Route:
    """A route from the start to the goal, or the reason there is none.

    ``waypoints`` are MRPs ``sigma_BN`` (first the start, last the goal), joined by short
    eigenaxis rotations whose exact margin is at least ``clearance_deg`` all along;
    ``rotation_rad`` is the sum of their angles.
    """

    feasible: bool
    waypoints: _Floats  # (m, 3)
    rotation_rad: float
    clearance_deg: float
    reason: str = ""
    roadmap_nodes: int = 0
    planning_s: float = 0.0
    blocking: tuple[str, ...] = field(default_factory=tuple)

    @property
    def legs(self) -> int:
        return max(len(self.waypoints) - 1, 0)


class RoutePlanner:
    """Routes for one constraint geometry (see the module docstring).

    Parameters
    ----------
    geometry : the exact cones (its inflation is not used; margins are exact).
    buffer_deg : the planner's safety buffer: the smallest clearance a route may keep.
    constraint_names : one label per constraint, in the geometry's numbering, for the
        infeasibility reason.
    nodes : roadmap size (the planner's resolution).
    """

    def __init__(
        self,
        geometry: ConeGeometry,
        buffer_deg: float,
        constraint_names: Sequence[str] | None = None,
        nodes: int = ROADMAP_NODES,
    ) -> None:
        self.geometry = geometry
        self.buffer_deg = float(buffer_deg)
        n_c = geometry.n_constraints
        self.names = (
            tuple(constraint_names)
            if constraint_names is not None
            else tuple(f"constraint {c}" for c in range(n_c))
        )
        if len(self.names) != n_c:
            raise ValueError(f"{len(self.names)} constraint names for {n_c} constraints")
        self.nodes = int(nodes)
        g = geometry
        self._s = g.boresights_body
        self._beta = np.radians(g.pair_angles_deg)  # per keep-out constraint
        self._inst, self._obj = g.pair_instrument, g.pair_object
        self._c = g.directions_inertial
        self._a = g.keep_in_axes_body
        self._gamma = np.radians(g.keep_in_max_angles_deg)
        self._d = g.keep_in_directions_inertial
        self._cache: dict[int, tuple[_Floats, _Floats]] = {}

    # --- margins ------------------------------------------------------------------

    def _node_vectors(self, rotations: Rotation) -> tuple[_Floats, _Floats]:
        """Each attitude's boresights ``(n, n_i, 3)`` and keep-in axes ``(n, n_k, 3)`` in
        inertial axes."""
        n = len(rotations)
        b = np.stack([rotations.apply(x) for x in self._s], axis=1) if len(self._s) else None
        a = np.stack([rotations.apply(x) for x in self._a], axis=1) if len(self._a) else None
        return (
            np.zeros((n, 0, 3)) if b is None else b.reshape(n, -1, 3),
            np.zeros((n, 0, 3)) if a is None else a.reshape(n, -1, 3),
        )

    def _node_margins(
        self, rotations: Rotation, vectors: tuple[_Floats, _Floats] | None = None
    ) -> _Floats:
        """Exact margins of every constraint at each attitude, rad, ``(n, n_c)``."""
        n = len(rotations)
        b, a = self._node_vectors(rotations) if vectors is None else vectors
        out = np.empty((n, self.geometry.n_constraints))
        n_o = self.geometry.n_keep_out
        if n_o:
            cos = np.clip(np.einsum("nik,jk->nij", b, self._c), -1.0, 1.0)
            out[:, :n_o] = np.arccos(cos[:, self._inst, self._obj]) - self._beta[None, :]
        if len(self._gamma):
            cos = np.clip(np.einsum("nkx,kx->nk", a, self._d), -1.0, 1.0)
            out[:, n_o:] = self._gamma[None, :] - np.arccos(cos)
        return out

    def _pair_arc_margins(
        self,
        vectors: tuple[_Floats, _Floats],
        start: npt.NDArray[np.int64],
        axes: _Floats,
        angles: _Floats,
        constraint: npt.NDArray[np.int64],
    ) -> _Floats:
        """Exact smallest margin (rad) of one constraint along one rotation, per pair:
        from node ``start[p]`` by ``angles[p]`` about ``axes[p]``, ``constraint[p]``."""
        b, a = vectors
        n_o = self.geometry.n_keep_out
        out = np.empty(len(start))
        out_mask = constraint < n_o
        if out_mask.any():
            c = constraint[out_mask]
            inst, obj = self._inst[c], self._obj[c]
            hi, _ = arc_cos_extremes(
                b[start[out_mask], inst], axes[out_mask], angles[out_mask], self._c[obj]
            )
            out[out_mask] = np.arccos(hi) - self._beta[c]
        if (~out_mask).any():
            k = constraint[~out_mask] - n_o
            _, lo = arc_cos_extremes(
                a[start[~out_mask], k], axes[~out_mask], angles[~out_mask], self._d[k]
            )
            out[~out_mask] = self._gamma[k] - np.arccos(lo)
        return out

    def _arc_margins(self, start: Rotation, axes: _Floats, angles: _Floats) -> _Floats:
        """Exact smallest margin of every constraint along each rotation (closed form),
        rad, ``(E, n_c)``: ``start`` turned by ``angles`` about the inertial ``axes``."""
        e, n_c = len(angles), self.geometry.n_constraints
        arc = np.repeat(np.arange(e), n_c)
        constraint = np.tile(np.arange(n_c), e)
        margins = self._pair_arc_margins(
            self._node_vectors(start), arc, axes[arc], angles[arc], constraint
        )
        return margins.reshape(e, n_c)

    def _roadmap_margins(self, rm: Roadmap) -> tuple[_Floats, _Floats]:
        """Per roadmap: node margins ``(n, n_c)`` and each edge's smallest margin along its
        rotation, rad (scenario-dependent, computed once per planner). A margin changes by
        at most the rotation angle, so ``(m_u + m_v - theta) / 2`` bounds a constraint's
        margin along an edge from below; the exact closed form is computed only for the
        constraints of edges with free ends whose bound falls below the largest clearance
        the roadmap is searched at (the dense roadmap: the buffer alone)."""
        cached = self._cache.get(rm.size)
        if cached is not None:
            return cached
        vectors = self._node_vectors(rm.rotations)
        node = self._node_margins(rm.rotations, vectors)
        node_min = node.min(axis=1)
        lowest = math.radians(self.buffer_deg)
        top = (
            math.radians(self.buffer_deg + EXTRA_CLEARANCE_DEG) if rm.size == self.nodes else lowest
        )
        edge_min = np.empty(len(rm.edges))
        for lo in range(0, len(rm.edges), _EDGE_CHUNK):
            sl = slice(lo, lo + _EDGE_CHUNK)
            u, v, ang = rm.edges[sl, 0], rm.edges[sl, 1], rm.angles[sl]
            bound = 0.5 * (node[u] + node[v] - ang[:, None])  # (E, n_c)
            free_ends = (node_min[u] > lowest) & (node_min[v] > lowest)
            e_idx, c_idx = np.nonzero(free_ends[:, None] & (bound < top))
            if len(e_idx):
                bound[e_idx, c_idx] = self._pair_arc_margins(
                    vectors, u[e_idx], rm.axes[sl][e_idx], ang[e_idx], c_idx
                )
            edge_min[sl] = bound.min(axis=1)
        self._cache[rm.size] = (node, edge_min)
        return node, edge_min

    # --- search -------------------------------------------------------------------

    def plan(self, sigma_start: Vec3Like, sigma_goal: Vec3Like) -> Route:
        """The shortest route (rotation angle) from ``sigma_start`` to ``sigma_goal``."""
        t0 = time.perf_counter()
        start = np.asarray(sigma_start, dtype=float)
        goal = np.asarray(sigma_goal, dtype=float)
        ends = Rotation.from_mrp(np.stack([start, goal]))
        end_margins = self._node_margins(ends).min(axis=1)
        direct_axis, direct_angle = _eigen_rotations(ends[:1], ends[1:])
        direct = float(self._arc_margins(ends[:1], direct_axis, direct_angle).min())
        levels = self._clearances(end_margins)
        if direct >= levels[0]:
            return self._route([start, goal], levels[0], 0, t0)
        # The largest clearance first; failing that, the smallest (if the ends are apart
        # there, they are at every level), then the ones between, largest first.
        rm = roadmap(self.nodes)
        order = [levels[0]] + ([levels[-1]] + levels[1:-1] if len(levels) > 1 else [])
        found_at: dict[float, list[_Floats]] = {}
        for level in order:
            if direct >= level:
                return self._route([start, goal], level, 0, t0)
            found = self._search(rm, ends, end_margins, level)
            if found[0] is not None:
                found_at[level] = found[0]
                if level == levels[0] or len(found_at) > 1 or len(levels) == 2:
                    break
            elif level == levels[-1]:
                break
        if found_at:
            level = max(found_at)
            path = self._pull(self._shortcut(found_at[level], level), level)
            return self._route(path, level, rm.size, t0)
        # None at the buffer: the dense roadmap, at the buffer, before declaring infeasible.
        dense = roadmap(FINE_FACTOR * self.nodes)
        found = self._search(dense, ends, end_margins, levels[-1])
        if found[0] is not None:
            path = self._pull(self._shortcut(found[0], levels[-1]), levels[-1])
            return self._route(path, levels[-1], dense.size, t0)
        return self._infeasible(dense, found[1], found[2], levels[-1], ends, t0)

    def park(self, sigma_start: Vec3Like, sigma_near: Vec3Like) -> Route:
        """A route from ``sigma_start`` to a place to wait while ``sigma_near`` is blocked:
        of the roadmap attitudes it reaches keeping the buffer plus
        :data:`EXTRA_CLEARANCE_DEG`, the one with the least rotation to get there plus
        principal angle from there to ``sigma_near``; infeasible when it reaches none."""
        t0 = time.perf_counter()
        start = np.asarray(sigma_start, dtype=float)
        ends = Rotation.from_mrp(np.stack([start, start]))
        end_margins = self._node_margins(ends).min(axis=1)
        level = math.radians(self.buffer_deg + EXTRA_CLEARANCE_DEG)
        rm = roadmap(self.nodes)
        _, dist, pred = self._search(rm, ends, end_margins, level, _PARK_LINKS)
        n = rm.size
        reached = np.flatnonzero(np.isfinite(dist[:n]))
        if len(reached) == 0:
            return replace(
                self._route([start], level, rm.size, t0),
                feasible=False,
                reason="no roadmap attitude is reachable from here",
            )
        near = Rotation.from_mrp(np.asarray(sigma_near, dtype=float))
        to_near = (rm.rotations[reached] * near.inv()).magnitude()
        best = int(reached[int(np.argmin(to_near + dist[reached]))])
        path_idx = [best]
        while path_idx[-1] != n:
            path_idx.append(int(pred[path_idx[-1]]))
        path_idx.reverse()
        path = [start] + [rm.rotations[i].as_mrp() for i in path_idx[1:]]
        return self._route(self._shortcut(path, level), level, rm.size, t0)

    def _clearances(self, end_margins: _Floats) -> list[float]:
        """Clearance levels, rad, largest first, each below the start's and the goal's
        margins (halfway between them and the buffer)."""
        buffer = math.radians(self.buffer_deg)
        cap = buffer + 0.5 * max(float(end_margins.min()) - buffer, 0.0)
        levels: list[float] = []
        for extra in (EXTRA_CLEARANCE_DEG, 0.25, 0.0):
            level = min(buffer + math.radians(extra), cap)
            if not levels or level < levels[-1] - 1e-12:
                levels.append(level)
        return levels

    def _search(
        self,
        rm: Roadmap,
        ends: Rotation,
        end_margins: _Floats,
        level: float,
        links: int = _END_LINKS,
    ) -> tuple[list[_Floats] | None, _Floats, npt.NDArray[np.int64]]:
        """Dijkstra on the roadmap plus the two ends at one clearance level: the path's
        attitudes (MRPs) or None, the distances from the start and the predecessors."""
        node, edge_min = self._roadmap_margins(rm)
        n = rm.size
        free_edges = edge_min > level
        u, v, w = rm.edges[free_edges, 0], rm.edges[free_edges, 1], rm.angles[free_edges]
        # Join the start (n) and the goal (n + 1) to their nearest free nodes.
        node_free = node.min(axis=1) > level
        extra_u, extra_v, extra_w = [], [], []
        for end in range(2):
            near = rm.nearest(ends[end], links)
            near = near[node_free[near]]
            if len(near) == 0:
                continue
            r_end = Rotation.concatenate([ends[end]] * len(near))
            axes, angles = _eigen_rotations(r_end, rm.rotations[near])
            arcs = self._arc_margins(r_end, axes, angles).min(axis=1)
            # An end closer to a cone than the clearance (a stalled target, planned from
            # again) leaves it on rotations that keep RIM_FLOOR of the buffer, or its own
            # margin if lower.
            floor = level
            if end_margins[end] <= level:
                rim = RIM_FLOOR * math.radians(self.buffer_deg)
                floor = min(rim, float(end_margins[end])) - math.radians(_START_TOL_DEG)
            ok = arcs > floor
            extra_u.append(np.full(int(ok.sum()), n + end))
            extra_v.append(near[ok])
            extra_w.append(angles[ok])
        rows = np.concatenate([u, *extra_u])
        cols = np.concatenate([v, *extra_v])
        weights = np.concatenate([w, *extra_w])
        graph = coo_matrix((weights, (rows, cols)), shape=(n + 2, n + 2)).tocsr()
        dist, pred = dijkstra(graph, directed=False, indices=n, return_predecessors=True)
        if not np.isfinite(dist[n + 1]):
            return None, dist, pred
        path_idx = [n + 1]
        while path_idx[-1] != n:
            path_idx.append(int(pred[path_idx[-1]]))
        path_idx.reverse()
        mrps = [ends[0].as_mrp()]
        mrps += [rm.rotations[i].as_mrp() for i in path_idx[1:-1]]
        mrps.append(ends[1].as_mrp())
        return mrps, dist, pred

    def _shortcut(self, path: list[_Floats], level: float) -> list[_Floats]:
        """Greedy shortcut: from each kept waypoint, the farthest later one whose direct
        rotation keeps the clearance."""
        rots = Rotation.from_mrp(np.stack(path))
        out = [path[0]]
        i, last = 0, len(path) - 1
        while i < last:
            later = np.arange(i + 1, last + 1)
            r_from = Rotation.concatenate([rots[i]] * len(later))
            axes, angles = _eigen_rotations(r_from, rots[later])
            ok = self._arc_margins(r_from, axes, angles).min(axis=1) >= level
            ok[0] = True  # the roadmap edge itself (checked at this level already)
            i = int(later[np.flatnonzero(ok)[-1]])
            out.append(path[i])
        return out

    def _pull(self, path: list[_Floats], level: float) -> list[_Floats]:
        """Shorten the route locally: each inner waypoint moves by small rotations about
        the inertial axes (a pattern search, step halved down to :data:`_PULL_MIN_DEG`,
        at most :data:`_PULL_TRIES` tries a waypoint and :data:`_PULL_BUDGET` in all,
        which bounds the planning time)
        while the rotation angle through it falls and both of its rotations keep the
        clearance (roadmap nodes are not where a shortest route bends)."""
        rots = [Rotation.from_mrp(p) for p in path]
        steps = Rotation.from_rotvec(np.concatenate([np.eye(3), -np.eye(3)]))
        n = len(steps)
        inner = max(len(rots) - 2, 1)
        tries = min(_PULL_TRIES, _PULL_BUDGET // inner)
        for k in range(1, len(rots) - 1):
            prev, nxt = (
                Rotation.concatenate([rots[k - 1]] * n),
                Rotation.concatenate([rots[k + 1]] * n),
            )
            here = rots[k]
            cost = (here * rots[k - 1].inv()).magnitude() + (rots[k + 1] * here.inv()).magnitude()
            h = math.radians(_PULL_START_DEG)
            for _ in range(tries):
                if h < math.radians(_PULL_MIN_DEG):
                    break
                cands = Rotation.from_rotvec(steps.as_rotvec() * h) * here
                a1, t1 = _eigen_rotations(prev, cands)
                a2, t2 = _eigen_rotations(cands, nxt)
                total = t1 + t2
                better = total < cost - 1e-9
                if better.any():
                    idx = np.flatnonzero(better)
                    ok = (self._arc_margins(prev[idx], a1[idx], t1[idx]).min(axis=1) >= level) & (
                        self._arc_margins(cands[idx], a2[idx], t2[idx]).min(axis=1) >= level
                    )
                    if ok.any():
                        j = int(idx[np.flatnonzero(ok)[np.argmin(total[idx][ok])]])
                        here, cost = cands[j], float(total[j])
                        continue
                h *= 0.5
            rots[k] = here
        return [r.as_mrp() for r in rots]

    def _route(self, path: list[_Floats], level: float, nodes: int, t0: float) -> Route:
        wp = np.stack([np.asarray(p, dtype=float) for p in path])
        rots = Rotation.from_mrp(wp)
        angles = (rots[1:] * rots[:-1].inv()).magnitude() if len(wp) > 1 else np.zeros(0)
        return Route(
            True,
            wp,
            float(np.sum(angles)),
            math.degrees(level),
            "",
            nodes,
            time.perf_counter() - t0,
        )

    def _infeasible(
        self,
        rm: Roadmap,
        dist: _Floats,
        pred: npt.NDArray[np.int64],
        level: float,
        ends: Rotation,
        t0: float,
    ) -> Route:
        """No route: name the constraints that enclose the start's or the goal's region."""
        node, edge_min = self._roadmap_margins(rm)
        n = rm.size
        reach_start = np.isfinite(dist[:n])
        # The goal's region: Dijkstra from the goal on the same free graph.
        graph_free = edge_min > level
        u, v = rm.edges[graph_free, 0], rm.edges[graph_free, 1]
        goal_near = rm.nearest(ends[1], _END_LINKS)
        node_min = node.min(axis=1)
        goal_links = goal_near[node_min[goal_near] > level]
        rows = np.concatenate([u, np.full(len(goal_links), n)])
        cols = np.concatenate([v, goal_links])
        graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n + 1, n + 1)).tocsr()
        reach_goal = np.isfinite(dijkstra(graph, directed=False, indices=n, unweighted=True)[:n])
        n_start, n_goal = int(reach_start.sum()), int(reach_goal.sum())
        if n_goal <= n_start:
            end, region = "goal", reach_goal
        else:
            end, region = "start", reach_start
        blocking = self._blocking(rm, node, region, level)
        if not region.any():  # no free node near the end at all: the cones around it
            margins = self._node_margins(ends[1:] if end == "goal" else ends[:1])[0]
            near = rm.nearest(ends[1] if end == "goal" else ends[0], _END_LINKS)
            counts = Counter(int(c) for c in np.argmin(node[near], axis=1))
            blocking = [self.names[c] for c, _ in counts.most_common()]
            if not blocking:
                blocking = [self.names[int(np.argmin(margins))]]
        names = ", ".join(blocking)
        reason = (
            f"no route keeps the {self.buffer_deg:g} deg buffer on a {rm.size}-attitude "
            f"roadmap: the {end} is enclosed by {names}"
        )
        return Route(
            False,
            np.zeros((0, 3)),
            math.inf,
            math.degrees(level),
            reason,
            rm.size,
            time.perf_counter() - t0,
            tuple(blocking),
        )

    def _blocking(
        self, rm: Roadmap, node: _Floats, region: npt.NDArray[np.bool_], level: float
    ) -> list[str]:
        """The constraints that block the roadmap edges leaving ``region``, most first."""
        u, v = rm.edges[:, 0], rm.edges[:, 1]
        leaving = region[u] != region[v]
        idx = np.flatnonzero(leaving)
        if len(idx) == 0:
            return []
        inside = np.where(region[u[idx]], u[idx], v[idx])
        outside = np.where(region[u[idx]], v[idx], u[idx])
        axes, angles = _eigen_rotations(rm.rotations[inside], rm.rotations[outside])
        arcs = self._arc_margins(rm.rotations[inside], axes, angles)
        counts = Counter(int(c) for c in np.argmin(arcs, axis=1))
        return [self.names[c] for c, _ in counts.most_common()]
