"""The guidance of a scenario: the FEPF planner, the guidance and what they share.

Inputs: a :class:`~attitude_core.config.scenario.Scenario` and the start ``sigma_0``
(``sigma_BN``; default the scenario's). Outputs: :func:`planner_from_scenario` (the FEPF
of eqs. 6-10, 12 with its buffered cones), :func:`guidance_from_scenario` (the FEPF
closed on the measured state, with limits, route, moving sky and knowledge),
:func:`prepare_guidance` (FIS tables, roadmap, first route: once, before the first
state), :func:`buffer_deg` (the safety-buffer rule), :func:`scenario_eta_s`.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np

from attitude_core.assembly.guidance_limits import scenario_limits, wheel_infeasibility
from attitude_core.config.scenario import Scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.fepf import FepfPlanner, load_planner_fis
from attitude_core.fsw.guidance.fuzzy import MamdaniFis, lookup_table
from attitude_core.fsw.guidance.goal_watch import goal_margin_bounds_deg
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.fsw.guidance.guidance_base import Executor
from attitude_core.fsw.guidance.moving_sky import SkyGuide, nominal_eta_s
from attitude_core.fsw.guidance.profile_limits import time_bound_s
from attitude_core.fsw.guidance.route import Route, RoutePlanner
from attitude_core.models.mrp import Vec3Like, angle_between_single

__all__ = [
    "PreparedGuidance",
    "buffer_deg",
    "scenario_fis",
    "planner_from_scenario",
    "scenario_eta_s",
    "guidance_from_scenario",
    "moving_sky_guide",
    "prepare_guidance",
    "route_planner",
]


@dataclass(frozen=True)
class PreparedGuidance:
    """What a guidance needs before its first state (:func:`prepare_guidance`): the FIS
    (their lookup tables built), the route planner (its roadmap built) and the route from
    the scenario's start."""

    fis: tuple[MamdaniFis, MamdaniFis]
    routes: RoutePlanner
    initial_route: Route


def buffer_deg(
    scenario: Scenario, sigma_0: Vec3Like, t0_s: float = 0.0, hold_until_s: float | None = None
) -> float:
    """The planner's safety buffer, deg: ``planner.safety_margin_deg``, reduced to half
    of the start's (``sigma_0``) or the goal's margin when either lies closer to a cone.
    With declared sensors the knowledge 3-sigma (:attr:`Scenario.knowledge`, through the
    longest declared tracker outage) is added to ``safety_margin_deg``: the true
    boresight may be that far from the estimated one.

    One rule for a static and a moving sky. On a moving sky the start's margin is taken
    at ``t0_s`` (the state the guidance starts from) and the goal's is its least over
    the time it is held, ``[t0_s, hold_until_s]`` (default and at most: the run's end,
    ``sim_time_s``), a lower bound between samples
    (:func:`~attitude_core.fsw.guidance.goal_watch.goal_margin_bounds_deg`): a goal the
    sky never covers in that span is never blocked. When the sky does cover it (its
    least margin not positive), the cap is half its greatest margin over the span: the
    goal is blocked while its margin is below the buffer, around the coverage
    (:mod:`attitude_core.fsw.guidance.goal_watch`)."""
    wanted = scenario.planner.safety_margin_deg + scenario.knowledge.buffer_3sigma_deg
    sky = scenario.sky
    if sky.static:
        exact = scenario.exact_geometry()  # margins only: no fine rim sampling needed
        ends = [np.asarray(sigma_0, dtype=float), scenario.desired_mrp]
        end_margin = min(float(exact.min_margin_deg(end)) for end in ends)
        return min(wanted, 0.5 * max(end_margin, 0.0))
    start = float(np.min(sky.constraint_margins_deg(t0_s, np.asarray(sigma_0, dtype=float))))
    until = scenario.sim_time_s if hold_until_s is None else min(hold_until_s, scenario.sim_time_s)
    least, greatest = goal_margin_bounds_deg(sky, scenario.desired_mrp, t0_s, until)
    goal = least if least > 0.0 else greatest if greatest > 0.0 else math.inf
    return min(wanted, 0.5 * max(min(start, goal), 0.0))


def scenario_fis(scenario: Scenario) -> tuple[MamdaniFis, MamdaniFis]:
    """The attractive and repulsive FIS of a scenario (paths relative to its file)."""
    return load_planner_fis(scenario.planner, os.path.dirname(os.path.abspath(scenario.source)))


def planner_from_scenario(
    scenario: Scenario,
    sigma_0: Vec3Like | None = None,
    watchdog: bool = True,
    fis: tuple[MamdaniFis, MamdaniFis] | None = None,
    t0_s: float = 0.0,
    hold_until_s: float | None = None,
) -> FepfPlanner:
    """The planner of a scenario, starting at ``sigma_0`` (default: the scenario's) at
    ``t0_s``, with ``fis`` if already loaded (:func:`scenario_fis`).

    The safety buffer is :func:`buffer_deg` (the goal held until ``hold_until_s``).
    """
    cfg = scenario.planner
    start = scenario.initial_mrp if sigma_0 is None else np.asarray(sigma_0, dtype=float)
    inflation = buffer_deg(scenario, start, t0_s, hold_until_s)
    geometry = scenario.cone_geometry(inflation_deg=inflation, samples=cfg.obstacle_samples)
    return FepfPlanner(
        geometry,
        start,
        scenario.desired_mrp,
        scenario.dt_s,
        cfg,
        scenario_fis(scenario) if fis is None else fis,
        watchdog,
    )


def scenario_eta_s(scenario: Scenario, sigma_0: Vec3Like) -> float:
    """Expected slew time of a scenario from ``sigma_0``: the principal angle to the goal
    with half again for the detours (:func:`nominal_eta_s`)."""
    rotation = 1.5 * angle_between_single(sigma_0, scenario.desired_mrp)
    lim = scenario_limits(scenario, sigma_0)
    bound = time_bound_s(rotation, lim.max_rate_rad_s, lim.alpha_max_rad_s2)
    return nominal_eta_s(rotation, scenario.planner.max_attractive_rate_mrp_s, bound)


def guidance_from_scenario(
    scenario: Scenario,
    sigma_0: Vec3Like | None = None,
    executor: Executor | None = None,
    routes: RoutePlanner | None = None,
    initial_route: Route | None = None,
    prepared: PreparedGuidance | None = None,
    t0_s: float = 0.0,
    hold_until_s: float | None = None,
) -> Guidance:
    """The guidance of a scenario from ``sigma_0`` (default: the scenario's start);
    ``routes`` may be a prepared :func:`route_planner` of the same scenario and
    ``initial_route`` a route it planned from ``sigma_0`` (planned here otherwise).
    ``prepared`` (:func:`prepare_guidance`) gives both: its route is taken when ``sigma_0`` is
    the scenario's start (on estimates: within the first fix's 3-sigma of it; the
    planner node then answers its first state without planning a route). ``t0_s``: the
    state time of ``sigma_0`` (a goal commanded during the run: the moving sky's route
    is planned from then); ``hold_until_s``: until when the goal is held (a plan's
    target: the end of its dwell; default the run's end), for :func:`buffer_deg`."""
    fis = None if prepared is None else prepared.fis
    planner = planner_from_scenario(scenario, sigma_0, False, fis, t0_s, hold_until_s)
    if prepared is not None:
        routes = prepared.routes
        fresh = np.allclose(planner.sigma_t, scenario.initial_mrp, rtol=0.0, atol=1e-9)
        first_fix_deg = scenario.knowledge.first_fix_3sigma_deg  # 0: perfect knowledge
        if not fresh and first_fix_deg > 0.0:  # an estimated start: the start within it
            off = math.degrees(angle_between_single(planner.sigma_t, scenario.initial_mrp))
            fresh = off <= first_fix_deg
        initial_route = prepared.initial_route if fresh else None
    sky_guide = moving_sky_guide(scenario, planner.geometry.inflation_deg)
    if routes is None or routes.buffer_deg != planner.geometry.inflation_deg:
        routes = route_planner(scenario, planner.geometry.inflation_deg)
    if initial_route is None and sky_guide is not None:
        eta = scenario_eta_s(scenario, planner.sigma_t)
        initial_route = sky_guide.plan_route(t0_s, eta, planner.sigma_t, planner.goal)
    guidance = Guidance(
        planner,
        scenario_limits(scenario, planner.sigma_t),
        scenario.guidance_arrival.attitude_tol_deg,
        scenario.guidance_arrival.rate_tol_rad_s,
        routes,
        scenario.planner.global_route,
        executor,
        initial_route,
        sky_guide,
        scenario.knowledge,
    )
    why = wheel_infeasibility(scenario, planner.sigma_t)
    if why is not None and guidance.status is not PlannerStatus.INFEASIBLE:
        guidance.declare_infeasible(why)
    return guidance


def moving_sky_guide(scenario: Scenario, buffer_deg: float) -> SkyGuide | None:
    """The moving-sky guide of a scenario (None on a static sky)."""
    if scenario.sky.static:
        return None
    return SkyGuide(
        scenario.sky,
        scenario.desired_mrp,
        buffer_deg,
        scenario.planner.obstacle_samples,
        scenario.constraint_names,
        scenario.sim_time_s,
        scenario.planner.roadmap_nodes,
    )


def prepare_guidance(scenario: Scenario) -> PreparedGuidance:
    """Everything worth doing before the first state, once: the FIS lookup tables
    (cached per process), the roadmap and the route from the scenario's start."""
    fis = scenario_fis(scenario)
    for one in fis:
        lookup_table(one)
    buffer = buffer_deg(scenario, scenario.initial_mrp)
    routes = route_planner(scenario, buffer)
    guide = moving_sky_guide(scenario, buffer)
    if guide is None:
        initial_route = routes.plan(scenario.initial_mrp, scenario.desired_mrp)
    else:
        eta = scenario_eta_s(scenario, scenario.initial_mrp)
        initial_route = guide.plan_route(0.0, eta, scenario.initial_mrp, scenario.desired_mrp)
    return PreparedGuidance(fis, routes, initial_route)


def route_planner(scenario: Scenario, buffer_deg: float) -> RoutePlanner:
    """The route planner of a scenario for a planner buffer of ``buffer_deg``."""
    return RoutePlanner(
        scenario.exact_geometry(),
        buffer_deg,
        scenario.constraint_names,
        scenario.planner.roadmap_nodes,
    )
