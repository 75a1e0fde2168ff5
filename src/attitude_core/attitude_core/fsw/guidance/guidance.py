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
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from attitude_core import kernels
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.estimation.knowledge import PERFECT, Knowledge
from attitude_core.fsw.guidance.fepf import FepfPlanner, PlannerOutput
from attitude_core.fsw.guidance.goal_watch import Blockage
from attitude_core.fsw.guidance.guidance_state import GuidanceState
from attitude_core.fsw.guidance.moving_sky import (
    BLOCK_WINDOW_MAX_S,
    LEAVE_LEAD_S,
    LOOKAHEAD_S,
    PARK_WINDOW_S,
    ROUTE_REFRESH_S,
    SKY_REFRESH_S,
    SkyGuide,
    nominal_eta_s,
)
from attitude_core.fsw.guidance.profile_limits import (
    GYRO_SHARE,
    RATE_USE,
    TORQUE_USE,
    GuidanceLimits,
    time_bound_s,
)
from attitude_core.fsw.guidance.route import Route, RoutePlanner
from attitude_core.fsw.guidance.route_following import RouteFollower, braking_speed, corner_speed
from attitude_core.fsw.guidance.state_field import StateField
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
    angle_between_single,
    dcm_rows_from_mrp,
    mrp_rate_single,
    omega_from_mrp_rate_single,
    relative_single,
)

__all__ = [
    "TORQUE_USE",
    "GYRO_SHARE",
    "RATE_USE",
    "BRAKE_USE",
    "ROUTE_REPLANS",
    "ROUTE_LATENCY_S",
    "Executor",
    "ImmediateExecutor",
    "GuidanceLimits",
    "GuidanceOutput",
    "Guidance",
    "time_bound_s",
]

BRAKE_USE = 1.0
"""Fraction of the angle to the closest buffered rim that the braking curve may use."""


ROUTE_REPLANS = 2
"""Routes planned again from the target when it stalls, at most."""

ROUTE_LATENCY_S = 1.0
"""State time after its request at which a new route is taken: the same step offline,
in lockstep and in real time (a route takes well under this to plan; a thread that is
late is waited for)."""


class Executor(Protocol):
    """Where a route is planned during the run: ``submit(fn, *args)`` returns a future
    (a ``concurrent.futures`` executor, or :class:`ImmediateExecutor`)."""

    def submit(self, fn: Callable[..., Any], /, *args: Any) -> Future[Any]: ...


class ImmediateExecutor:
    """Runs the task at once (offline and lockstep runs: deterministic). Its result is
    still taken at the next update, as a thread's would be."""

    def submit(self, fn: Callable[..., Any], /, *args: Any) -> Future[Any]:
        future: Future[Any] = Future()
        future.set_result(fn(*args))
        return future


# Progress: a new best distance to the goal must beat the old one by this much (a
# target creeping towards the governor's hold point must not count).
_PROGRESS_RAD = 1e-3  # body, principal angle
_PROGRESS_MRP = 2.5e-4  # target, MRP distance along the route (about the same angle)
_MIN_HOLD_DEG = 0.1
_MIN_DERATING = 1.0 / 64.0
_DERATE_EVERY_S = 5.0


@dataclass(slots=True)
class GuidanceOutput:
    """The target of one state and what the guidance knows about the tracking."""

    target: PlannerOutput
    tracking_error_deg: float  # principal angle of sigma_B/R
    goal_error_deg: float  # principal angle of sigma_B/D
    speed_factor: float  # the governor's factor, 1 = full speed, 0 = held
    derating: float  # share of the declared acceleration the profile uses (1: all)


class Guidance:
    """FEPF guidance closed on the measured state (see the module docstring).

    Its mutable state is one record, :attr:`state` (a
    :class:`~attitude_core.fsw.guidance.guidance_state.GuidanceState`, compiled with the
    kernels): the attributes below are its fields. The compiled step
    (``_kernels.GuidanceCore``) steps the same record and the planner's; it calls back
    :meth:`_collect_route`, :meth:`_time_scaled` and :meth:`_replan` as its documented
    hooks (``kernels/guidance.pxi``).
    """

    status = StateField[PlannerStatus]()
    t_prev = StateField[float | None]()
    omega_prev = StateField[npt.NDArray[np.float64]]()
    derating = StateField[float]()  # share of the declared acceleration the plant has shown
    _derated_at = StateField[float]()
    _behind_since = StateField[float | None]()  # the governor has held since (state time)
    _since_progress = StateField[float]()
    _best_body = StateField[float]()
    _best_target = StateField[float]()
    _pending = StateField[Future[Route] | None]()
    follower = StateField[RouteFollower | None]()  # the route being flown

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
            0.5 * (planner.geometry.inflation_deg - knowledge.attitude_3sigma_deg), _MIN_HOLD_DEG
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
                (_PROGRESS_RAD, _PROGRESS_MRP, _DERATE_EVERY_S, _MIN_DERATING),
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

    def _to_rim(self, sigma_t: Vec3Like, omega_t: npt.NDArray[np.float64], rim_deg: float) -> float:
        """Rotation (rad) about the rate ``omega_t`` (target axes) until a constraint's
        margin falls to ``rim_deg`` (:meth:`ConeGeometry.rotation_to_rim_deg`)."""
        size = math.hypot(float(omega_t[0]), float(omega_t[1]), float(omega_t[2]))
        if size == 0.0:
            return math.inf
        r0, r1, r2 = dcm_rows_from_mrp(sigma_t)  # C_TN: inertial axis = C_TN^T omega_hat
        w = [float(x) / size for x in omega_t]
        axis = tuple(w[0] * r0[i] + w[1] * r1[i] + w[2] * r2[i] for i in range(3))
        return math.radians(self.planner.geometry.rotation_to_rim_deg(sigma_t, axis, rim_deg))

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

    # ------------------------------------------------------------------------------

    def _time_scaled(self, out: PlannerOutput, dt: float) -> npt.NDArray[np.float64]:
        """Step 3 of the module docstring: the FEPF rate within the limits."""
        lim = self.limits
        omega = np.array(out.omega_t, dtype=float)
        if lim.max_rate_rad_s is None and lim.accel_rad_s2 is None:
            return omega
        speed = math.hypot(*omega)
        cap = math.inf if lim.max_rate_rad_s is None else RATE_USE * lim.max_rate_rad_s
        alpha = None if lim.accel_rad_s2 is None else lim.accel_rad_s2 * self.derating
        if alpha is not None:
            sigma_t = out.sigma_t
            theta = self.remaining_rad(sigma_t)
            # Rotation to the buffered rim: a rotation by theta moves a boresight by at
            # most theta, so the exact margin less the buffer bounds it from below.
            geometry = self.planner.geometry
            margin = self.planner.margin_deg()  # at sigma_t, the target just proposed
            theta_obs = math.radians(max(margin - geometry.inflation_deg, 0.0))
            if self.follower is not None:
                # On a route, the rotation to the rim along the way the target turns (its
                # rate now and the rate asked for): alongside a cone, no braking. The rim
                # is the buffer's, or RIM_FLOOR of it for a target already at the rim.
                rim = self.planner.sight_margin_deg()
                ahead = min(
                    self._to_rim(sigma_t, self.omega_prev, rim), self._to_rim(sigma_t, omega, rim)
                )
                theta_obs = max(math.radians(max(margin - rim, 0.0)), ahead)
            theta = min(theta, BRAKE_USE * theta_obs)
            cap = min(cap, braking_speed(alpha, theta, dt))
            if self.follower is not None:
                cap = min(cap, self.follower.corner_cap(sigma_t, alpha, dt))
        wanted = cap
        follower = self.follower
        if alpha is not None and speed > 0.0 and follower is not None:
            # Turn before speeding up (on a route): the speed aimed at while the rate vector
            # turns to the new direction keeps the swing of the turn within the route's
            # slack (a soft cap, reached at alpha).
            prev = math.hypot(*self.omega_prev)
            want = self.planner.wanted_omega
            size = math.hypot(*want)
            if prev > 0.0 and size > 0.0:
                cos_turn = float(np.dot(want, self.omega_prev)) / (size * prev)
                turn = math.acos(min(max(cos_turn, -1.0), 1.0))
                wanted = min(cap, corner_speed(alpha, turn, math.radians(follower.swing_deg)))
        if speed > wanted:
            omega *= wanted / speed
        if alpha is not None:
            change = omega - self.omega_prev
            size = math.hypot(*change)
            if size > alpha * dt:
                omega = self.omega_prev + change * (alpha * dt / size)
            # The braking caps are hard: when turning used up the acceleration bound,
            # braking takes what it needs (from the controller's reserve).
            speed = math.hypot(*omega)
            if speed > cap:
                omega *= cap / speed
        return omega

    @property
    def stuck_timeout_s(self) -> float:
        """``planner.stuck_timeout_s`` plus, with limits, the time to stop from the rate
        cap at the profile's derated acceleration (slow actuators turn round slowly),
        counting the derating down to a quarter only, so that a dead plant is still
        reported."""
        lim = self.limits
        timeout = self.planner.cfg.stuck_timeout_s
        if lim.accel_rad_s2 is not None and lim.max_rate_rad_s is not None:
            timeout += lim.max_rate_rad_s / (lim.accel_rad_s2 * max(self.derating, 0.25))
        return timeout

    def _derate(self, factor: float, t_s: float) -> None:
        """A plant that falls behind a profile within its declared limits is weaker than
        declared: halve the profile's acceleration (at most once per settling time),
        down to :data:`_MIN_DERATING`. On estimates the governor must have held for the
        knowledge's decision window first (noise alone must not derate)."""
        if factor >= 1.0 or self.limits.accel_rad_s2 is None:
            self._behind_since = None
            return
        if self._behind_since is None:
            self._behind_since = t_s
        if t_s - self._behind_since < self.knowledge.decision_window_s:
            return
        if t_s - self._derated_at < _DERATE_EVERY_S:
            return
        self.derating = max(0.5 * self.derating, _MIN_DERATING)
        self._derated_at = t_s

    # -- moving sky -------------------------------------------------------------------

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
        if body < self._best_body - _PROGRESS_RAD:
            self._best_body, progressed = body, True
        if target < self._best_target - _PROGRESS_MRP:
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
