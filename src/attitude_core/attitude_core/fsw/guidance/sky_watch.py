"""The guidance's watch on a moving sky (step 6 of
:mod:`~attitude_core.fsw.guidance.guidance`): the FEPF's windowed cones refreshed, routes
on swept cones, a goal the sky will cover reported ``blocked`` before it happens, the
target held clear, and the slew resumed when the goal clears."""

from __future__ import annotations

import math

from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.guidance_base import (
    GuidanceBase,
)
from attitude_core.fsw.guidance.moving_sky import (
    BLOCK_WINDOW_MAX_S,
    LEAVE_LEAD_S,
    LOOKAHEAD_S,
    ROUTE_REFRESH_S,
    SKY_REFRESH_S,
    nominal_eta_s,
)
from attitude_core.fsw.guidance.profile_limits import (
    time_bound_s,
)

__all__ = ["SkyWatch"]


class SkyWatch(GuidanceBase):
    """The moving-sky part of a :class:`~attitude_core.fsw.guidance.guidance.Guidance`."""

    def _eta_s(self) -> float:
        """Expected time for the body to arrive from here (moving sky)."""
        planner = self.planner
        rotation = self.remaining_rad(planner.sigma_t)
        lim = self.limits
        bound = time_bound_s(rotation, lim.max_rate_rad_s, lim.alpha_max_rad_s2)
        return nominal_eta_s(rotation, planner.cfg.max_attractive_rate_mrp_s, bound)

    def _watch_sky(self, t_s: float) -> None:
        """Step 6 of the module docstring, at most every ``SKY_REFRESH_S``."""
        guide = self.sky_guide
        assert guide is not None
        self.goal_safe_until_s = guide.safe_until_s(t_s)
        if t_s < guide.next_refresh_s:
            return
        guide.next_refresh_s = t_s + SKY_REFRESH_S
        planner = self.planner
        held = self.status == PlannerStatus.ARRIVED
        lead = LEAVE_LEAD_S + (0.0 if held else self._eta_s())
        block = self.blockage  # blocked: until that blockage ends (no flapping)
        if block is None or (block.end_s is not None and block.end_s <= t_s):
            block = None
            if self.status != PlannerStatus.INFEASIBLE:
                block = guide.blockage_ahead(t_s, lead)
        window = SKY_REFRESH_S + LOOKAHEAD_S
        if block is not None:
            if not self.follow_route:  # no place to wait: keep the goal inside a cone
                window = max(window, min(block.start_s - t_s + LOOKAHEAD_S, BLOCK_WINDOW_MAX_S))
            if self.status != PlannerStatus.BLOCKED:
                self.status, self.blockage, self.reason = (
                    PlannerStatus.BLOCKED,
                    block,
                    block.reason(),
                )
                self.follower = None
                planner.status = PlannerStatus.TRACKING
                # Hold (pushed out by a cone that comes over it) until a place to wait is
                # planned; without routes, towards the goal but short of it.
                planner.set_goal(
                    self.goal if not self.follow_route else planner.sigma_t, final=False
                )
                guide.next_route_s = t_s
        elif self.status == PlannerStatus.BLOCKED:
            self.status, self.blockage, self.reason = PlannerStatus.TRACKING, None, ""
            self.follower = None
            planner.status = PlannerStatus.TRACKING
            planner.set_goal(self.goal, final=True)
            self._since_progress = 0.0
            self._best_body = self._best_target = math.inf
            guide.next_route_s = t_s  # a route from here, now
        planner.set_geometry(guide.local_geometry(t_s, window))
        if (
            self.status in (PlannerStatus.TRACKING, PlannerStatus.BLOCKED)
            and self.follow_route
            and self._pending is None
            and t_s >= guide.next_route_s
        ):
            guide.next_route_s = t_s + ROUTE_REFRESH_S
            self._submit_route()
