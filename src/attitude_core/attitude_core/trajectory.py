"""The sampled closed-loop trajectory of a run and its summary figures.

One record for every source of a run: the offline loop
(:func:`attitude_core.closed_loop.run_closed_loop`), a run rebuilt from its bag
(``attitude_tools.bag_run``) and the reports. :func:`summarize` gives the fields of
``summary.json``; margins are measured on the body's attitude, densely
(:func:`attitude_core.metrics.dense_min_margin_deg`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .guidance import GuidanceLimits, time_bound_s
from .metrics import arrival_time, dense_min_margin_deg, path_length_mrp
from .scenario import Scenario
from .status import PlannerStatus

__all__ = ["RunResult", "summarize"]


@dataclass
class RunResult:
    """Sampled closed-loop trajectory; row ``k`` is time ``t_k`` (``N + 1`` rows)."""

    scenario: Scenario
    t: np.ndarray
    sigma_bn: np.ndarray
    omega_b: np.ndarray
    torque_b: np.ndarray  # torque applied over [t_k, t_k+1); last row repeats
    sigma_t: np.ndarray
    omega_t: np.ndarray
    obstacle_distance_mrp: np.ndarray
    planner_status: np.ndarray  # PlannerStatus.code
    planner_step_s: np.ndarray  # wall time of each planner step call
    wall_time_s: float
    planner_reason: str = ""  # why the planner reported infeasible ("" otherwise)
    route_rotation_deg: float = float("nan")  # the planner's first global route, deg


def summarize(run: RunResult) -> dict[str, Any]:
    """Summary figures of a run (the fields of ``summary.json``).

    ``min_margin_deg`` is the dense minimum over every constraint;
    ``min_margin_deg_per_pair`` the minimum at the samples of each constraint, keyed by
    :attr:`Scenario.constraint_names` (``"<instrument>/<object>"`` keep-out pairs, then
    ``"keep_in/<name>"`` keep-in cones).
    """
    sc = run.scenario
    geometry = sc.cone_geometry()
    min_margin, t_min = dense_min_margin_deg(geometry, run.t, run.sigma_bn, run.omega_b)
    reached, t_reach, err_deg = arrival_time(
        run.t,
        run.sigma_bn,
        run.omega_b,
        sc.desired_mrp,
        sc.arrival.attitude_tol_deg,
        sc.arrival.rate_tol_rad_s,
    )
    arrived = np.flatnonzero(run.planner_status == PlannerStatus.ARRIVED.code)
    stuck = bool(np.any(run.planner_status == PlannerStatus.STUCK.code))
    infeasible = bool(np.any(run.planner_status == PlannerStatus.INFEASIBLE.code))
    # Every constraint (keep-out pairs, then keep-in cones), at the samples.
    per_constraint = geometry.constraint_margins_deg(run.sigma_bn).min(axis=0)
    # Planner cost while it is working (arrived/stuck steps return at once).
    tracking = run.planner_status == PlannerStatus.TRACKING.code
    step_s = run.planner_step_s[tracking] if tracking.any() else run.planner_step_s
    return {
        "scenario": sc.name,
        "planner_variant": sc.planner.variant,
        "reached": bool(reached),
        "t_reach_s": None if t_reach is None else round(t_reach, 9),
        "t_plan_arrival_s": round(float(run.t[arrived[0]]), 9) if len(arrived) else None,
        "planner_stuck": stuck,
        "planner_infeasible": infeasible,
        "infeasible_reason": (run.planner_reason or None) if infeasible else None,
        "min_margin_deg": min_margin,
        "t_min_margin_s": round(t_min, 9),
        "min_margin_deg_per_pair": {
            name: float(m) for name, m in zip(sc.constraint_names, per_constraint, strict=True)
        },
        "path_length_mrp": path_length_mrp(run.sigma_bn),
        "target_path_length_mrp": path_length_mrp(run.sigma_t),
        "final_attitude_error_deg": float(err_deg[-1]),
        "final_rate_rad_s": float(np.linalg.norm(run.omega_b[-1])),
        "peak_rate_rad_s": float(np.max(np.linalg.norm(run.omega_b, axis=1))),
        "peak_torque_nm": float(np.max(np.linalg.norm(run.torque_b, axis=1))),
        **_against_limits(run, t_reach),
        "route_rotation_deg": (
            None if not np.isfinite(run.route_rotation_deg) else float(run.route_rotation_deg)
        ),
        "planner_step_us_median": float(np.median(step_s) * 1e6),
        "planner_step_us_p99": float(np.percentile(step_s, 99) * 1e6),
        "sim_time_s": sc.sim_time_s,
        "dt_s": sc.dt_s,
        "wall_time_s": run.wall_time_s,
    }


def _against_limits(run: RunResult, t_reach: float | None) -> dict[str, Any]:
    """The run against its actuator limits.

    ``rotation_deg`` is the rotation flown up to the arrival (the integral of
    ``|omega_B| dt``); ``time_bound_s`` the rest-to-rest bound along it
    (:func:`attitude_core.guidance.time_bound_s`) and ``time_ratio_to_bound`` the arrival
    time over that bound (None without limits or without an arrival).
    ``peak_torque_to_bound`` is the largest ``|u_i| / max_torque_nm_i`` and
    ``peak_rate_to_bound`` the peak body rate over ``max_rate_rad_s``.
    """
    act = run.scenario.actuators
    end = len(run.t) if t_reach is None else int(np.searchsorted(run.t, t_reach)) + 1
    speed = np.linalg.norm(run.omega_b[:end], axis=1)
    flown = float(np.sum(0.5 * (speed[1:] + speed[:-1]) * np.diff(run.t[:end])))
    limits = GuidanceLimits.from_actuators(
        run.scenario.inertia_kgm2, act.max_torque_nm, act.max_rate_rad_s
    )
    bound = time_bound_s(flown, act.max_rate_rad_s, limits.alpha_max_rad_s2)
    ratio = None if bound is None or t_reach is None or bound <= 0.0 else t_reach / bound
    torque_ratio = None
    if act.max_torque_nm is not None:
        torque_ratio = float(np.max(np.abs(run.torque_b) / np.asarray(act.max_torque_nm)))
    rate_ratio = None
    if act.max_rate_rad_s is not None:
        rate_ratio = float(np.max(np.linalg.norm(run.omega_b, axis=1)) / act.max_rate_rad_s)
    return {
        "rotation_deg": float(np.degrees(flown)),
        "time_bound_s": bound,
        "time_ratio_to_bound": ratio,
        "peak_torque_to_bound": torque_ratio,
        "peak_rate_to_bound": rate_ratio,
    }
