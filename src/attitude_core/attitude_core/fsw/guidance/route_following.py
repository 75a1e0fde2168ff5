"""Flying a global route with the FEPF: its waypoints as the FEPF's intermediate goals.

:class:`RouteFollower` holds the route being flown and, once per state (before the FEPF
proposes), moves the FEPF's goal along it (:meth:`RouteFollower.advance`):

* **Passing waypoints.** The next waypoint is taken as soon as the whole rotation from
  the target to it keeps the route's clearance (closed form,
  :meth:`ConeGeometry.arc_min_margin_deg_single`), or when the target is within the
  allowed swing (half the route's slack, its clearance beyond the buffer) of the
  current one.
* **Back on the leg.** When the target has swung off the leg so that the rotation to the
  current waypoint no longer keeps the FEPF's sight margin, the goal is the farthest
  of a few points of the leg (:data:`CARROTS`) that is in sight; with none, the
  waypoint stays the goal and the FEPF steers round it.

For the time scaling it gives the rotation left along the route
(:meth:`RouteFollower.remaining_rad`) and the braking curves to the turns at the
waypoints ahead (:meth:`RouteFollower.corner_cap`, :func:`corner_speed`).
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from attitude_core.fsw.guidance.fepf import FepfPlanner
from attitude_core.fsw.guidance.route import Route
from attitude_core.models.cone_math import short_rotation_single
from attitude_core.models.mrp import Vec3, Vec3Like, angle_between_single, compose, relative

__all__ = ["CARROTS", "MIN_SLACK_DEG", "RouteFollower", "braking_speed", "corner_speed"]

CARROTS = (0.75, 0.5, 0.25)
"""Points of the current leg (share of its rotation) the target aims back at."""

MIN_SLACK_DEG = 0.05
"""Smallest swing and capture angle at a waypoint (a route that keeps only the buffer)."""


def braking_speed(alpha: float, theta: float, dt: float, end_speed: float = 0.0) -> float:
    """The largest speed from which steps of ``dt`` decelerating at ``alpha`` are down
    to ``end_speed`` within ``theta``:
    ``sqrt(end^2 + 2 alpha theta + (alpha dt / 2)^2) - alpha dt / 2`` (the sampled form
    of ``sqrt(end^2 + 2 alpha theta)``)."""
    half = 0.5 * alpha * dt
    return math.sqrt(end_speed * end_speed + 2.0 * alpha * theta + half * half) - half


def corner_speed(alpha: float, turn_rad: float, swing_rad: float) -> float:
    """The speed at which a target turning by ``turn_rad`` at a waypoint, with its rate
    vector changing by at most ``alpha``, swings at most ``swing_rad`` off the route:
    ``sqrt(alpha swing / (1 - cos(turn)))`` (the swing of a turn of radius
    ``v^2 / alpha``)."""
    bend = 1.0 - math.cos(min(turn_rad, math.pi))
    if bend < 1e-12:
        return math.inf
    return math.sqrt(alpha * swing_rad / bend)


class RouteFollower:
    """The FEPF's goal along ``route`` (see the module docstring); aims at its first
    leg at once."""

    def __init__(self, planner: FepfPlanner, route: Route) -> None:
        self.planner = planner
        self.route = route
        wp = route.waypoints
        legs = [angle_between_single(wp[i], wp[i + 1]) for i in range(len(wp) - 1)]
        self._after = [sum(legs[i:]) for i in range(len(legs))] + [0.0]  # rad left after wp
        # Each leg as (unit eigenaxis in the leg's start frame, angle): points along it.
        self._legs: list[tuple[npt.NDArray[np.float64], float]] = []
        for k in range(len(wp) - 1):
            rel = relative(wp[k + 1], wp[k])
            size = float(np.linalg.norm(rel))
            self._legs.append((rel / size if size > 0.0 else rel, legs[k]))
        # Turn at each inner waypoint: the angle between the inertial eigenaxes of the
        # rotations in and out of it (the directions of the body rate).
        self._turn = [0.0] * len(wp)
        for k in range(1, len(wp) - 1):
            e_in, _ = short_rotation_single(wp[k - 1], wp[k])
            e_out, _ = short_rotation_single(wp[k], wp[k + 1])
            cos_turn = sum(a * b for a, b in zip(e_in, e_out, strict=True))
            self._turn[k] = math.acos(min(max(cos_turn, -1.0), 1.0))
        slack = max(route.clearance_deg - planner.geometry.inflation_deg, 0.0)
        self.swing_deg = max(0.5 * slack, MIN_SLACK_DEG)
        """Allowed swing off the route at a turn, and the capture angle of a waypoint."""
        self.waypoints: list[Vec3] = [(float(w[0]), float(w[1]), float(w[2])) for w in wp]
        """The route's waypoints as tuples of floats (the per-step calls take them as
        they are)."""
        self.leg = 0
        """The waypoint aimed at (or the leg ending there, aimed back at)."""
        self.aim_at(1)

    # The compiled route following (``kernels/route_following.pxi``) reads
    # ``waypoints``, ``leg``, ``swing_deg`` and ``route.clearance_deg``, and moves the
    # goal with :meth:`aim_at` and :meth:`aim_in_sight`: the same steps as :meth:`advance`.

    def aim_at(self, leg: int) -> None:
        """Aim the planner at waypoint ``leg`` (its goal, final at the route's end)."""
        wp = self.waypoints
        self.leg = leg
        # The FIS goal distance runs along the rest of the route (tan(theta / 4) ~ theta / 4).
        self.planner.set_goal(wp[leg], final=leg == len(wp) - 1, beyond_mrp=0.25 * self._after[leg])

    def advance(self) -> None:
        """Pass the waypoints behind the target, then keep its goal in sight."""
        planner = self.planner
        wp = self.waypoints
        last = len(wp) - 1
        clearance = self.route.clearance_deg
        while self.leg < last:
            here = planner.sigma_t
            near = math.degrees(angle_between_single(here, wp[self.leg])) <= self.swing_deg
            if not near and (
                planner.geometry.arc_min_margin_deg_single(here, wp[self.leg + 1]) < clearance
            ):
                break
            self.aim_at(self.leg + 1)
        self.aim_in_sight()

    def aim_in_sight(self) -> None:
        """Keep the goal in sight: the current waypoint when the rotation to it keeps
        the planner's sight margin, else the farthest point of the leg in sight
        (:data:`CARROTS`); with none, the waypoint stays the goal."""
        planner = self.planner
        leg = self.leg
        wp = self.waypoints
        here = planner.sigma_t
        need = planner.sight_margin_deg()
        geometry = planner.geometry
        if planner.arc_margin_deg(wp[leg]) >= need:
            if planner.goal != wp[leg]:
                self.aim_at(leg)
            return
        rel, theta = self._legs[leg - 1]
        for f in CARROTS:
            point = compose(math.tan(0.25 * f * theta) * rel, wp[leg - 1])
            if geometry.arc_min_margin_deg_single(here, point) >= need:
                beyond = (1.0 - f) * theta + self._after[leg]
                planner.set_goal(point, final=False, beyond_mrp=0.25 * beyond)
                return

    def remaining_rad(self, sigma_t: Vec3Like) -> float:
        """Rotation left to the goal from ``sigma_t`` along the route, rad."""
        leg = self.leg
        return angle_between_single(sigma_t, self.waypoints[leg]) + self._after[leg]

    def corner_cap(self, sigma_t: Vec3Like, alpha: float, dt: float) -> float:
        """The braking curves to the turns at the waypoints ahead (:func:`corner_speed`)."""
        wp = self.waypoints
        cap = math.inf
        to_next = angle_between_single(sigma_t, wp[self.leg])
        for k in range(self.leg, len(wp) - 1):
            ahead = to_next + self._after[self.leg] - self._after[k]
            v_turn = corner_speed(alpha, self._turn[k], math.radians(self.swing_deg))
            if v_turn < cap:
                cap = min(cap, braking_speed(alpha, ahead, dt, v_turn))
        return cap
