"""Guidance closed on the measured state: the FEPF target, timed by the state stamps,
time-scaled to the actuator limits, held when the body falls behind, and an arrival
judged on the body.

:meth:`Guidance.update` takes one measured state ``(t, sigma_BN, omega_B)`` and returns
the target for that instant:

1. **Real time.** The target is moved along the rate held since the previous state for
   the real interval between the two stamps (:meth:`FepfPlanner.advance`, safety-checked),
   so states at 5, 10 or 20 Hz give the same target trajectory in time.
2. **FEPF.** The paper's law (eqs. 6-10) proposes the rate at the new target.
3. **Time scaling** (only with ``actuators`` limits), in body-rate space (eq. 12):

   * ``|omega_t| <=`` :data:`RATE_USE` ``max_rate_rad_s``, lowered when the gyroscopic
     torque at the rate bound would take more than :data:`GYRO_SHARE` of the torque;
   * the rate vector changes by at most ``alpha dt``, ``alpha`` a fraction
     (:data:`TORQUE_USE`) of what the smallest torque bound gives about the largest
     principal axis after the worst gyroscopic torque at the rate cap, so the PD law
     keeps the rest for its corrections and its command stays inside the bound;
   * the speed is capped, hard, by the sampled braking curve ``sqrt(2 alpha theta)`` to
     the goal (``theta`` the principal angle left) and to the closest buffered cone rim
     (``theta`` the exact margin less the buffer: a boresight moves by at most the
     rotation angle). The cap is isotropic: a cap on the approach component alone can
     demand a stop the body cannot make, as the closest point moves when the target
     slides along a cone; the isotropic cap falls no faster than ``alpha``.
   * The rate published is the one the target flies: the planner's step bound
     (:meth:`FepfPlanner.hold_rate`) is applied to the shaped rate.
4. **Tracking governor.** With ``e`` the principal angle of ``sigma_B/R``, the rate is
   scaled by ``clip(2 - e / e_hold, 0, 1)``: full speed up to ``e_hold``, held at
   ``2 e_hold``. ``e_hold`` is half the planner's buffer: the target stops at the
   buffered rim, and a boresight moves by at most the rotation angle between two
   attitudes, so while ``e <= e_hold`` the measured body keeps half the buffer. A body
   that falls behind a profile within the declared limits shows a plant weaker than
   declared: the profile's acceleration is then halved (at most every 5 s, down to
   1/64; :attr:`Guidance.derating`).
5. **Global route** (:mod:`attitude_core.fsw.guidance.route`). Before the first step the guidance
   plans a route over the attitude space from the start to the goal (edges checked
   continuously against the exact margins). None at the planner's resolution: the
   status is ``infeasible`` at once, :attr:`Guidance.reason` names the constraints that
   enclose the start or the goal, and the target holds the start. With
   ``planner.global_route`` the route's waypoints are the FEPF's intermediate goals: the
   next waypoint is taken as soon as the whole rotation to it keeps the route's
   clearance (or the target is within half the route's slack, its clearance beyond the
   buffer, of the current one); the braking curve to the goal runs along the rest of
   the route, and braking curves to each turn at a waypoint keep the swing of the turn
   within half the slack (:func:`corner_speed`). While the rotation to the current
   waypoint keeps the buffer the cone braking is not needed (the target flies that
   rotation). When the target makes no progress for half ``planner.stuck_timeout_s``, a new
   route is planned from the target off the step path (``executor``, e.g. a thread)
   and followed :data:`ROUTE_LATENCY_S` of state time later, at most
   :data:`ROUTE_REPLANS` times.
6. **Moving sky** (:mod:`attitude_core.fsw.guidance.moving_sky`). The FEPF's cones are those of
   the next few seconds, replaced every second of state time; routes avoid the cones
   swept over the expected slew and are planned again at a bounded rate, off the step
   path; a goal the sky will cover before the body gets there (or while it holds there)
   is reported ``blocked`` before it happens, with the constraint and the window in
   :attr:`Guidance.reason`, the target is held clear of it, and the slew goes on when
   the goal clears. :attr:`Guidance.goal_safe_until_s` says when the goal next loses
   its clearance.
7. **Status on the body.** ``arrived`` only once the target is on the goal *and* the
   body is within the arrival tolerances (attitude and rate); it is withdrawn if the
   body leaves twice those tolerances. On estimates (declared sensors,
   :mod:`attitude_core.fsw.estimation.knowledge`) the tolerances are at least the knowledge
   3-sigma and the body's error and rate are those of the means over the last decision
   window; the start is held while the filter settles; the buffer holds the knowledge
   3-sigma (the governor's ``e_hold`` stays half of the rest). ``stuck`` when neither
   the target's nor the body's distance to the goal has improved for
   ``planner.stuck_timeout_s`` (plus, with limits, the time to stop from the rate
   bound); the target then holds.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

import numpy as np

from attitude_core import kernels
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.estimation.knowledge import PERFECT, Knowledge
from attitude_core.fsw.guidance.arrival import ArrivalJudge
from attitude_core.fsw.guidance.fepf import FepfPlanner
from attitude_core.fsw.guidance.goal_watch import Blockage
from attitude_core.fsw.guidance.guidance_base import (
    DERATE_EVERY_S,
    MIN_DERATING,
    MIN_HOLD_DEG,
    PROGRESS_MRP,
    PROGRESS_RAD,
    Executor,
    GuidanceOutput,
    ImmediateExecutor,
)
from attitude_core.fsw.guidance.guidance_routes import RouteUpdates
from attitude_core.fsw.guidance.guidance_state import GuidanceState
from attitude_core.fsw.guidance.moving_sky import (
    SkyGuide,
)
from attitude_core.fsw.guidance.profile_limits import (
    GuidanceLimits,
)
from attitude_core.fsw.guidance.route import Route, RoutePlanner
from attitude_core.fsw.guidance.sky_watch import SkyWatch
from attitude_core.fsw.guidance.time_scaling import TimeScaling
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    angle_between_single,
    mrp_rate_single,
    omega_from_mrp_rate_single,
    to_principal,
)

__all__ = ["Guidance"]


class Guidance(RouteUpdates, TimeScaling, SkyWatch, ArrivalJudge):
    """FEPF guidance closed on the measured state (see the module docstring).

    Its mutable state is one record, :attr:`state` (a
    :class:`~attitude_core.fsw.guidance.guidance_state.GuidanceState`, compiled with the
    kernels): the attributes below are its fields. The compiled step
    (``_kernels.GuidanceCore``) steps the same record and the planner's; it calls back
    :meth:`_collect_route`, :meth:`_time_scaled` and :meth:`_replan` as its documented
    hooks (``kernels/guidance.pxi``).
    """

    def __init__(
        self,
        planner: FepfPlanner,
        limits: GuidanceLimits,
        attitude_tol_deg: float,
        rate_tol_rad_s: float,
        routes: RoutePlanner | None = None,
        follow_route: bool = True,
        executor: Executor | None = None,
        initial_route: Route | None = None,
        sky_guide: SkyGuide | None = None,
        knowledge: Knowledge = PERFECT,
    ) -> None:
        if planner.watchdog:
            raise ValueError("Guidance: give it a planner without its own stuck watchdog")
        k = kernels.compiled
        self.state: GuidanceState = GuidanceState() if k is None else k.GuidanceState()
        self.planner = planner  # progress is judged here, on the body too
        self.limits = limits
        self.attitude_tol_deg = attitude_tol_deg
        self.rate_tol_rad_s = rate_tol_rad_s
        self.knowledge = knowledge
        # The buffer holds the knowledge 3-sigma on top of the declared margin: the hold
        # point keeps half of the rest (step 4 of the module docstring).
        self.hold_deg = max(
            0.5 * (planner.geometry.inflation_deg - knowledge.attitude_3sigma_deg), MIN_HOLD_DEG
        )
        self._behind_since = None
        # On estimates: the last decision window of (time, sigma_B/D, omega_B).
        self._recent: deque[tuple[float, Vec3, Vec3]] = deque()
        self.derating = 1.0
        self._derated_at = -math.inf
        self.goal = np.asarray(planner.goal, dtype=float)
        self.t_prev = None
        self.omega_prev = np.zeros(3)
        self.status = PlannerStatus.TRACKING
        self._best_body = math.inf
        self._best_target = math.inf
        self._since_progress = 0.0
        self.routes = routes
        self.follow_route = follow_route and routes is not None
        self.executor: Executor = ImmediateExecutor() if executor is None else executor
        self.route: Route | None = None
        self.reason = ""  # why the slew is infeasible
        self.replans = 0
        self._pending = None
        self._pending_at = math.inf  # state time at which the pending route is taken
        self._first_route_deg = math.nan
        self.follower = None
        self.sky_guide = sky_guide  # a moving sky (None: static)
        self.blockage: Blockage | None = None  # the goal's blockage while blocked
        self.goal_safe_until_s = math.inf  # when the goal next loses its clearance
        if sky_guide is not None:
            planner.evade = True
        # The compiled step on self.state and the planner's (kernels.compiled.GuidanceCore)
        # on a static sky with a decision on each state; None: the Python reference.
        # Its configuration is read once, here; its hooks are given by name.
        fepf = planner.compiled_core
        self._core: Any = (
            None
            if k is None
            or fepf is None
            or sky_guide is not None
            or knowledge.decision_window_s != 0.0
            else k.GuidanceCore(
                self.state,
                fepf,
                self,
                (
                    PlannerStatus.TRACKING,
                    PlannerStatus.ARRIVED,
                    PlannerStatus.STUCK,
                    PlannerStatus.INFEASIBLE,
                    PlannerStatus.BLOCKED,
                ),
                GuidanceOutput,
                (PROGRESS_RAD, PROGRESS_MRP, DERATE_EVERY_S, MIN_DERATING),
                (self._collect_route, self._time_scaled, self._replan),
            )
        )
        if routes is not None:
            first = (
                initial_route
                if initial_route is not None
                else routes.plan(planner.sigma_t, self.goal)
            )
            if first.feasible:
                self._take_route(first)
            elif sky_guide is not None and sky_guide.blockage_ahead(0.0, self._eta_s()):
                self.route = None  # the goal is blocked: no route until it clears
            else:
                self.route = first
                self.reason = first.reason
                self.status = PlannerStatus.INFEASIBLE
                planner.hold(PlannerStatus.INFEASIBLE)  # the target holds the start

    def declare_infeasible(self, reason: str) -> None:
        """The slew cannot be flown (e.g. the wheels left cannot control the body, or
        have no momentum free for it): status ``infeasible`` with ``reason``, the target
        held where it is."""
        self.reason = reason
        self.status = PlannerStatus.INFEASIBLE
        self.planner.hold(PlannerStatus.INFEASIBLE)

    def resume(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> None:
        """Go on from the measured state after a gap in the states (the state watchdog,
        :mod:`attitude_core.fsw.fdir.state_watchdog`), before :meth:`update` of the state
        at ``t_s``: the target does not fly the gap (the controller flew the body on its
        prediction meanwhile); while tracking, it restarts at the measured attitude with
        the measured rate as the profile's previous rate, so the profile continues from
        what the body does; the lag the gap made is no sign of a weak plant (no
        derating) nor of a stall (the progress timers restart)."""
        nominal = self.planner.dt
        if self.t_prev is not None and float(t_s) - nominal > self.t_prev:
            self.t_prev = float(t_s) - nominal
        self._behind_since = None
        self._since_progress = 0.0
        self._best_body = math.inf
        self._best_target = math.inf
        self._recent.clear()
        if self.status != PlannerStatus.TRACKING or self.planner.status != PlannerStatus.TRACKING:
            return
        sigma = to_principal(np.asarray(sigma_bn, dtype=float))
        self.planner.reset(sigma)
        self.omega_prev = np.array(omega_b, dtype=float)
        if self.follower is not None:
            self.follower.aim_in_sight()

    def update(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> GuidanceOutput:
        """The target for the measured state at time ``t_s`` (s, non-decreasing).
        Compiled on a static sky with a decision on each state (the kernels built and
        the planner's step compiled), :meth:`update_reference` otherwise (to the bit)."""
        core = self._core
        if core is not None:
            out: GuidanceOutput = core.update(t_s, sigma_bn, omega_b)
            return out
        return self.update_reference(t_s, sigma_bn, omega_b)

    def update_reference(self, t_s: float, sigma_bn: Vec3Like, omega_b: Vec3Like) -> GuidanceOutput:
        """:meth:`update` in Python."""
        planner = self.planner
        nominal = planner.dt
        dt = 0.0 if self.t_prev is None else float(t_s) - self.t_prev
        if dt < 0.0:
            raise ValueError(f"state time {t_s} s is before the previous {self.t_prev} s")
        if dt == 0.0 and self.t_prev is not None:
            raise ValueError(f"state time {t_s} s repeats the previous one")
        self.t_prev = float(t_s)
        planner.advance(dt)
        if self.sky_guide is not None:
            self._watch_sky(float(t_s))
        self._collect_route(float(t_s))
        if planner.status == PlannerStatus.TRACKING and self.follower is not None:
            self.follower.advance()
        out = planner.propose(dt if dt > 0.0 else nominal, max(nominal, dt))
        e_track = math.degrees(angle_between_single(sigma_bn, out.sigma_t))
        e_goal = math.degrees(angle_between_single(sigma_bn, self.goal))
        factor = 1.0
        settling = float(t_s) < self.knowledge.settle_s  # the estimate still converging
        if planner.status == PlannerStatus.TRACKING:
            omega_t = self._time_scaled(out, dt if dt > 0.0 else nominal)
            factor = min(max(2.0 - e_track / self.hold_deg, 0.0), 1.0)
            if settling:
                factor = 0.0  # the target holds the start
            else:
                self._derate(factor, float(t_s))
            omega_t = factor * omega_t
            sigma_t = (float(out.sigma_t[0]), float(out.sigma_t[1]), float(out.sigma_t[2]))
            rate = mrp_rate_single(
                sigma_t, (float(omega_t[0]), float(omega_t[1]), float(omega_t[2]))
            )
            safe = planner.hold_rate(rate, max(nominal, dt))
            if safe != rate:  # the planner's step bound shortened it: publish what it flies
                rate = safe
                omega_t = omega_from_mrp_rate_single(sigma_t, safe)
            self.omega_prev = omega_t
            # ``out`` is this step's own (propose makes a new one each call): set in place
            out.sigma_t_dot, out.omega_t = np.array(rate), omega_t
        else:
            self.omega_prev = np.zeros(3)
            if planner.status == PlannerStatus.STUCK:
                factor = 0.0  # held
        rate_b = math.hypot(float(omega_b[0]), float(omega_b[1]), float(omega_b[2]))
        if not settling:
            decide = (e_goal, rate_b)
            if self.knowledge.decision_window_s > 0.0:
                decide = self._window_mean(float(t_s), sigma_bn, omega_b)
            self._judge(dt, e_goal, decide)
        out.status = self.status
        return GuidanceOutput(out, e_track, e_goal, factor, self.derating)
