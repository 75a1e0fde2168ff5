"""The guidance's global route (step 5 of :mod:`~attitude_core.fsw.guidance.guidance`):
the route taken and followed, a new one planned off the step path when the target
stalls, and its report."""

from __future__ import annotations

import math

import numpy as np

from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.guidance_base import (
    GuidanceBase,
)
from attitude_core.fsw.guidance.moving_sky import (
    PARK_WINDOW_S,
)
from attitude_core.fsw.guidance.route import Route
from attitude_core.fsw.guidance.route_following import RouteFollower
from attitude_core.models.mrp import (
    Vec3Like,
    angle_between_single,
)

__all__ = ["ROUTE_REPLANS", "ROUTE_LATENCY_S", "RouteUpdates"]

ROUTE_REPLANS = 2
"""Routes planned again from the target when it stalls, at most."""

ROUTE_LATENCY_S = 1.0
"""State time after its request at which a new route is taken: the same step offline,
in lockstep and in real time (a route takes well under this to plan; a thread that is
late is waited for)."""


class RouteUpdates(GuidanceBase):
    """The route part of a :class:`~attitude_core.fsw.guidance.guidance.Guidance`."""

    def _take_route(self, route: Route) -> None:
        """Follow ``route`` (its first waypoint is where the target is)."""
        self.route = route
        if math.isnan(self._first_route_deg):
            self._first_route_deg = math.degrees(route.rotation_rad)
        if self.follow_route:
            self.follower = RouteFollower(self.planner, route)

    def route_report(self) -> tuple[float, int, str]:
        """The route followed: its rotation (deg) and waypoints, or NaN, 0 and the reason
        no route exists (empty when there is no route at all)."""
        route = self.route
        if route is None or not route.feasible:
            return float("nan"), 0, self.reason
        return float(np.degrees(route.rotation_rad)), len(route.waypoints), ""

    @property
    def route_rotation_deg(self) -> float:
        """Rotation of the first feasible route planned, deg (NaN without one)."""
        return self._first_route_deg

    def remaining_rad(self, sigma_t: Vec3Like) -> float:
        """Rotation left to the goal from ``sigma_t``: along the route when one is
        followed, else the principal angle."""
        if self.follower is None:
            return angle_between_single(sigma_t, self.goal)
        return self.follower.remaining_rad(sigma_t)

    def _replan(self) -> None:
        """Plan a new route from the target, off the step path."""
        if self.routes is None or not self.follow_route or self._pending is not None:
            return
        if self.replans >= ROUTE_REPLANS:
            return
        self.replans += 1
        self._submit_route()

    def _submit_route(self) -> None:
        """Ask for a route from the target, off the step path (on a moving sky, clear of
        the cones swept over the expected slew)."""
        t = self.t_prev or 0.0
        start, goal = tuple(self.planner.sigma_t), tuple(self.goal)
        guide = self.sky_guide
        if guide is None:
            assert self.routes is not None
            self._pending = self.executor.submit(self.routes.plan, start, goal)
        elif self.blockage is not None:
            end = self.blockage.end_s
            window = PARK_WINDOW_S if end is None else end - t
            self._pending = self.executor.submit(guide.plan_park, t, window, start, goal)
        else:
            self._pending = self.executor.submit(guide.plan_route, t, self._eta_s(), start, goal)
        self._pending_at = t + ROUTE_LATENCY_S

    def _collect_route(self, t_s: float) -> None:
        pending = self._pending
        if pending is None or t_s < self._pending_at:
            return
        self._pending = None
        route = pending.result()
        if route.feasible and self.status == PlannerStatus.BLOCKED:
            self.planner.status = PlannerStatus.TRACKING  # off to the (new) place to wait
            self._take_route(route)
            return
        if (
            route.feasible
            and self.planner.status == PlannerStatus.TRACKING
            and self.status == PlannerStatus.TRACKING
        ):
            # The route starts where the target was when it was asked for; the target has
            # not moved much since (it stalled): aim at the route's next waypoint.
            self._take_route(route)
            # Progress is measured along the new route from here on (it may be longer).
            self._since_progress = 0.0
            self._best_body = self._best_target = math.inf
