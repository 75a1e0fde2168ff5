"""The guidance's status on the body (step 7 of
:mod:`~attitude_core.fsw.guidance.guidance`): ``arrived`` only with the target on the goal
and the body within the arrival tolerances (on estimates, the means over the decision
window), withdrawn beyond twice them; ``stuck`` when neither target nor body progresses;
the band in which the offline loop may hold the body on the goal."""

from __future__ import annotations

import math

from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.guidance_base import (
    PROGRESS_MRP,
    PROGRESS_RAD,
    GuidanceBase,
)
from attitude_core.models.mrp import (
    Vec3Like,
    relative_single,
)

__all__ = ["ArrivalJudge"]


class ArrivalJudge(GuidanceBase):
    """The arrival part of a :class:`~attitude_core.fsw.guidance.guidance.Guidance`."""

    def _window_mean(
        self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like
    ) -> tuple[float, float]:
        """The arrival's decision values on estimates: the attitude error (deg) and the
        rate (rad/s) of the mean ``sigma_B/D`` and ``omega_B`` over the last decision
        window; infinite until the window is full (a filtered decision, never one noisy
        sample: white noise shrinks by the square root of the samples)."""
        window = self.knowledge.decision_window_s
        err = relative_single(sigma_bn, self.goal)
        w = (float(omega_b[0]), float(omega_b[1]), float(omega_b[2]))
        recent = self._recent
        recent.append((t_s, err, w))
        while recent[0][0] < t_s - window - 1e-9:
            recent.popleft()
        if t_s - recent[0][0] < window - 1e-9:
            return math.inf, math.inf
        n = len(recent)
        mean_e = [sum(r[1][i] for r in recent) / n for i in range(3)]
        mean_w = [sum(r[2][i] for r in recent) / n for i in range(3)]
        e_deg = math.degrees(4.0 * math.atan(math.hypot(*mean_e)))
        return e_deg, math.hypot(*mean_w)

    def _judge(self, dt: float, e_goal_deg: float, decide: tuple[float, float]) -> None:
        """Step 7 of the module docstring: the arrival on ``decide`` (the attitude error,
        deg, and the rate, rad/s: the body's, or on estimates their window means), the
        progress on ``e_goal_deg``."""
        planner = self.planner
        if self.status in (PlannerStatus.STUCK, PlannerStatus.INFEASIBLE, PlannerStatus.BLOCKED):
            return
        on_goal = planner.status == PlannerStatus.ARRIVED
        e_dec, rate_dec = decide
        if on_goal and e_dec <= self.attitude_tol_deg and rate_dec <= self.rate_tol_rad_s:
            self.status = PlannerStatus.ARRIVED
        elif self.status == PlannerStatus.ARRIVED and (
            e_dec > 2.0 * self.attitude_tol_deg or rate_dec > 2.0 * self.rate_tol_rad_s
        ):
            self.status = PlannerStatus.TRACKING
        if self.status == PlannerStatus.ARRIVED:
            self._since_progress = 0.0
            return
        body = math.radians(e_goal_deg)
        target = planner.goal_distance_mrp if not on_goal else 0.0
        progressed = False
        if body < self._best_body - PROGRESS_RAD:
            self._best_body, progressed = body, True
        if target < self._best_target - PROGRESS_MRP:
            self._best_target, progressed = target, True
        if progressed:
            self._since_progress = 0.0
            return
        self._since_progress += dt
        if self._since_progress >= 0.5 * planner.cfg.stuck_timeout_s:
            self._replan()
        if self._since_progress >= self.stuck_timeout_s:
            self.status = PlannerStatus.STUCK
            planner.hold(PlannerStatus.STUCK)  # the target holds where it is

    def hold_band(self) -> tuple[float, float] | None:
        """While the guidance holds the body on the goal (``arrived``, the target on the
        goal) and nothing but the body can change its answer (a static sky, no route
        pending, no decision window, the estimate settled), the band about the goal
        (attitude error, deg, and rate, rad/s: twice the arrival tolerances) inside
        which every state gets the last target again and leaves the guidance as it was
        but for :meth:`held_to`; None otherwise. The offline loop steps such states in
        one compiled call (:meth:`attitude_core.loop.loop_plant.LoopPlant.hold`)."""
        if (
            self.status != PlannerStatus.ARRIVED
            or self.planner.status != PlannerStatus.ARRIVED
            or self.sky_guide is not None
            or self._pending is not None
            or self.knowledge.decision_window_s > 0.0
            or self.t_prev is None
            or self.t_prev < self.knowledge.settle_s
        ):
            return None
        return 2.0 * self.attitude_tol_deg, 2.0 * self.rate_tol_rad_s

    def held_to(self, t_s: float) -> None:
        """The states up to ``t_s`` (s) got the last target again, inside
        :meth:`hold_band`'s band."""
        if self.t_prev is not None and float(t_s) < self.t_prev:
            raise ValueError(f"state time {t_s} s is before the previous {self.t_prev} s")
        self.t_prev = float(t_s)
