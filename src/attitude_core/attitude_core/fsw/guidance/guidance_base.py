"""What the parts of the guidance share: its output, its tuning, where routes are
planned, and the attributes every part reads (:class:`GuidanceBase`).

The guidance (:class:`~attitude_core.fsw.guidance.guidance.Guidance`) is one object
made of parts, one concept each: the route it follows
(:mod:`~attitude_core.fsw.guidance.guidance_routes`), the time scaling to the actuator
limits (:mod:`~attitude_core.fsw.guidance.time_scaling`), the watch on a moving sky
(:mod:`~attitude_core.fsw.guidance.sky_watch`) and the arrival judged on the body
(:mod:`~attitude_core.fsw.guidance.arrival`). Its mutable state is one record
(:class:`~attitude_core.fsw.guidance.guidance_state.GuidanceState`), read and written
through the :class:`~attitude_core.fsw.guidance.state_field.StateField` attributes
declared here.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
import numpy.typing as npt

from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.estimation.knowledge import Knowledge
from attitude_core.fsw.guidance.fepf import FepfPlanner, PlannerOutput
from attitude_core.fsw.guidance.goal_watch import Blockage
from attitude_core.fsw.guidance.guidance_state import GuidanceState
from attitude_core.fsw.guidance.moving_sky import (
    SkyGuide,
)
from attitude_core.fsw.guidance.profile_limits import (
    GuidanceLimits,
)
from attitude_core.fsw.guidance.route import Route, RoutePlanner
from attitude_core.fsw.guidance.route_following import RouteFollower
from attitude_core.fsw.guidance.state_field import StateField
from attitude_core.models.mrp import (
    Vec3,
    Vec3Like,
)

__all__ = [
    "PROGRESS_RAD",
    "PROGRESS_MRP",
    "MIN_HOLD_DEG",
    "MIN_DERATING",
    "DERATE_EVERY_S",
    "Executor",
    "ImmediateExecutor",
    "GuidanceOutput",
    "GuidanceBase",
]


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
PROGRESS_RAD = 1e-3  # body, principal angle
PROGRESS_MRP = 2.5e-4  # target, MRP distance along the route (about the same angle)
MIN_HOLD_DEG = 0.1
MIN_DERATING = 1.0 / 64.0
DERATE_EVERY_S = 5.0


@dataclass(slots=True)
class GuidanceOutput:
    """The target of one state and what the guidance knows about the tracking."""

    target: PlannerOutput
    tracking_error_deg: float  # principal angle of sigma_B/R
    goal_error_deg: float  # principal angle of sigma_B/D
    speed_factor: float  # the governor's factor, 1 = full speed, 0 = held
    derating: float  # share of the declared acceleration the profile uses (1: all)


class GuidanceBase:
    """The guidance's state record's fields and the attributes its parts share; the
    methods below are the parts' own (declared here so that each part can call
    another's)."""

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

    # Set by Guidance.__init__ (see there).
    state: GuidanceState
    planner: FepfPlanner
    limits: GuidanceLimits
    attitude_tol_deg: float
    rate_tol_rad_s: float
    knowledge: Knowledge
    hold_deg: float
    _recent: deque[tuple[float, Vec3, Vec3]]
    goal: npt.NDArray[np.float64]
    routes: RoutePlanner | None
    follow_route: bool
    executor: Executor
    route: Route | None
    reason: str
    replans: int
    _pending_at: float
    _first_route_deg: float
    sky_guide: SkyGuide | None
    blockage: Blockage | None
    goal_safe_until_s: float
    _core: Any

    def remaining_rad(self, sigma_t: Vec3Like) -> float:
        raise NotImplementedError  # guidance_routes.RouteUpdates

    def _replan(self) -> None:
        raise NotImplementedError  # guidance_routes.RouteUpdates

    def _submit_route(self) -> None:
        raise NotImplementedError  # guidance_routes.RouteUpdates

    def _eta_s(self) -> float:
        raise NotImplementedError  # sky_watch.SkyWatch

    @property
    def stuck_timeout_s(self) -> float:
        raise NotImplementedError  # time_scaling.TimeScaling
