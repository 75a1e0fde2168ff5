"""Guidance on a moving sky: which cones the planner avoids, and when, while the objects
move (Sun, Moon, Earth, or directions turning at a constant rate).

The FEPF and the route planner work on a fixed :class:`ConeGeometry`; on a moving sky the
guidance hands them geometries built from the sky (:meth:`Sky.geometry`) whose cones hold
every position of the true cones over a time window, and replaces them at a bounded rate:

* **Local field** (the FEPF, its safe steps, the braking to the rims): every
  :data:`SKY_REFRESH_S` of state time, the cones of ``[t, t + SKY_REFRESH_S +
  LOOKAHEAD_S]``. The target keeps the buffer from cones that already include where the
  objects will be :data:`LOOKAHEAD_S` after the next refresh, so a cone moving towards the
  boresight is braked for and avoided before it arrives.
* **Global route**: planned on the cones swept over the expected slew,
  ``[t, t + min(eta, ROUTE_WINDOW_MAX_S)]`` (a route that stays clear of where the
  objects will be while the body flies it), and planned again every
  :data:`ROUTE_REFRESH_S` off the step path. With none there, on the local field's
  cones.
* **Goal blocked** (:mod:`attitude_core.fsw.guidance.goal_watch`): the windows in which the goal
  lacks the buffer are known from the start. When one begins before the body can arrive
  (or within :data:`LEAVE_LEAD_S` while it holds the goal) the status is ``blocked`` and
  the route is replaced by one to a place to wait (:meth:`RoutePlanner.park`): the
  roadmap attitude nearest the goal that stays clear of the cones swept over the next
  :data:`PARK_WINDOW_S`, chosen again every :data:`ROUTE_REFRESH_S`. Without routes
  (``planner.global_route: false``) the local field's window reaches the blockage's start
  instead (at most :data:`BLOCK_WINDOW_MAX_S`): the goal is then inside a cone and the
  FEPF holds the target clear of it. When the window ends the goal is taken again, with
  a new route.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from attitude_core.fsw.guidance.goal_watch import Blockage, goal_blockages, safe_until_s
from attitude_core.fsw.guidance.route import Route, RoutePlanner
from attitude_core.models.constraints import ConeGeometry
from attitude_core.models.mrp import Vec3Like
from attitude_core.models.sky import Sky

__all__ = [
    "SKY_REFRESH_S",
    "LOOKAHEAD_S",
    "ROUTE_REFRESH_S",
    "ROUTE_WINDOW_MAX_S",
    "LEAVE_LEAD_S",
    "BLOCK_WINDOW_MAX_S",
    "SETTLE_S",
    "PARK_WINDOW_S",
    "PARK_SWEEP_DEG",
    "SkyGuide",
    "nominal_eta_s",
]

SKY_REFRESH_S = 1.0
"""State time between two local-field geometries, s."""
LOOKAHEAD_S = 5.0
"""How far beyond the next refresh the local field's cones reach, s."""
ROUTE_REFRESH_S = 20.0
"""State time between two routes on a moving sky, s."""
ROUTE_WINDOW_MAX_S = 300.0
"""Longest window a route's swept cones cover, s."""
LEAVE_LEAD_S = 30.0
"""How long before a blockage a body holding the goal starts to leave it, s."""
BLOCK_WINDOW_MAX_S = 120.0
"""Longest window of the local field's cones while the goal is blocked, s."""
PARK_WINDOW_S = 120.0
"""How long a place to wait while the goal is blocked must stay clear, s (a new place is
chosen every :data:`ROUTE_REFRESH_S`)."""
PARK_SWEEP_DEG = 20.0
"""Largest sweep of the fastest object over a place's window (a shorter window for fast
objects, never below twice :data:`ROUTE_REFRESH_S`)."""
SETTLE_S = 20.0
"""Time allowed for the body to settle on the goal in the arrival estimate, s."""


class SkyGuide:
    """What the guidance needs of a moving sky (module docstring).

    Parameters
    ----------
    sky : the scenario's sky (not static).
    goal : the goal ``sigma_DN``.
    buffer_deg : the planner's buffer (the clearance the goal must keep too).
    samples : rim samples of the local field's cones.
    names : the constraints' names.
    horizon_s : how far ahead the goal's blockages are predicted (the run's end).
    roadmap_nodes : the route planner's roadmap size.
    """

    def __init__(
        self,
        sky: Sky,
        goal: Vec3Like,
        buffer_deg: float,
        samples: int,
        names: Sequence[str],
        horizon_s: float,
        roadmap_nodes: int,
    ) -> None:
        self.sky = sky
        self.buffer_deg = float(buffer_deg)
        self.samples = int(samples)
        self.names = tuple(names)
        self.roadmap_nodes = int(roadmap_nodes)
        self.blockages = goal_blockages(sky, goal, 0.0, horizon_s, buffer_deg, self.names)
        self.next_refresh_s = -math.inf
        self.next_route_s = ROUTE_REFRESH_S

    def blockage_ahead(self, t_s: float, lead_s: float) -> Blockage | None:
        """The blockage covering ``t_s`` or beginning within ``lead_s`` of it."""
        for b in self.blockages:
            if (b.end_s is None or b.end_s > t_s) and b.start_s <= t_s + lead_s:
                return b
        return None

    def safe_until_s(self, t_s: float) -> float:
        """When the goal next lacks the buffer after ``t_s`` (``inf``: not in the run)."""
        return safe_until_s(self.blockages, t_s)

    def local_geometry(self, t_s: float, window_s: float) -> ConeGeometry:
        """The local field's cones from ``t_s`` over ``window_s``, with the buffer."""
        return self.sky.geometry(t_s, window_s, self.buffer_deg, self.samples)

    def route_planner(self, t_s: float, window_s: float) -> RoutePlanner:
        """A route planner on the cones swept over ``[t_s, t_s + window_s]``."""
        return RoutePlanner(
            self.sky.geometry(t_s, window_s),
            self.buffer_deg,
            self.names,
            self.roadmap_nodes,
        )

    def plan_route(self, t_s: float, eta_s: float, start: Vec3Like, goal: Vec3Like) -> Route:
        """A route from ``start`` to ``goal`` clear of the cones swept over the expected
        slew; with none, one clear of the local field's window."""
        window = min(max(eta_s, SKY_REFRESH_S + LOOKAHEAD_S), ROUTE_WINDOW_MAX_S)
        route = self.route_planner(t_s, window).plan(start, goal)
        if route.feasible or window <= SKY_REFRESH_S + LOOKAHEAD_S:
            return route
        return self.route_planner(t_s, SKY_REFRESH_S + LOOKAHEAD_S).plan(start, goal)

    def plan_park(self, t_s: float, window_s: float, start: Vec3Like, goal: Vec3Like) -> Route:
        """A route from ``start`` to a place clear of the cones swept over
        ``[t_s, t_s + window_s]``, as near the (blocked) goal as the roadmap allows."""
        fastest = float(np.max(self.sky.rate_bounds_deg_s, initial=0.0))
        longest = PARK_WINDOW_S if fastest <= 0.0 else min(PARK_WINDOW_S, PARK_SWEEP_DEG / fastest)
        window = min(
            max(window_s, SKY_REFRESH_S + LOOKAHEAD_S), max(longest, 2.0 * ROUTE_REFRESH_S)
        )
        return self.route_planner(t_s, window).park(start, goal)


def nominal_eta_s(rotation_rad: float, speed_rad_s: float, bound_s: float | None) -> float:
    """Expected time to arrive after a rotation: the actuators' rest-to-rest bound with
    a third more, or the rotation at the nominal speed, plus :data:`SETTLE_S`."""
    nominal = rotation_rad / speed_rad_s if speed_rad_s > 0.0 else math.inf
    if bound_s is not None:
        nominal = max(nominal, 1.3 * bound_s)
    return float(np.float64(nominal)) + SETTLE_S
