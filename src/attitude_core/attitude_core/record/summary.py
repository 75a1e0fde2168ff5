"""A run's figures: the fields of ``summary.json``, defined once (:class:`Summary`).

Margins are measured on the body's attitude, densely
(:func:`attitude_core.record.metrics.dense_min_margin_deg`); the arrival is the body's
(:func:`attitude_core.record.metrics.arrival_time`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.assembly.guidance import buffer_deg
from attitude_core.config.scenario import Scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.goal_watch import goal_blockages, safe_until_s
from attitude_core.fsw.guidance.profile_limits import GuidanceLimits, time_bound_s
from attitude_core.models.mrp import principal_angle, relative
from attitude_core.record.goal_figures import final_goal, goal_entries, plan_reached
from attitude_core.record.metrics import arrival_time, dense_min_margin_deg, path_length_mrp
from attitude_core.record.trajectory import RunResult
from attitude_core.record.wheel_figures import wheel_figures, wheel_time_bound_s

__all__ = ["Summary", "SUMMARY_KEYS", "summarize"]


@dataclass(frozen=True)
class Summary:
    """Summary figures of one run, in ``summary.json`` order; None where a figure does
    not apply (no arrival, no actuator limit, no route)."""

    scenario: str
    planner_variant: str
    reached: bool  # the body arrived (attitude and rate within the arrival tolerances)
    t_reach_s: float | None
    t_plan_arrival_s: float | None  # the planner first reported arrived
    planner_stuck: bool
    planner_infeasible: bool
    infeasible_reason: str | None
    planner_blocked: bool  # the moving sky covered the goal (or was about to) at some point
    blocked_by: str | None  # the constraint that blocked it first
    blocked_window_s: list[float | None] | None  # [from, until] (until None: the run's end)
    blocked_reason: str | None
    goal_safe_until_s: float | None  # after the arrival (or the end): the goal next lacks
    # its clearance then; None: not within the run
    goal_min_margin_deg: float  # the goal attitude's least margin over the run, on the sky
    # of each recorded step (a goal the sky never covered: positive)
    t_goal_covered_s: float | None  # the first step with the goal attitude inside a
    # keep-out (or outside a keep-in); None: never in the run
    min_margin_deg: float  # dense minimum over every constraint, on the body
    t_min_margin_s: float
    min_margin_deg_per_pair: dict[str, float]  # per constraint name, at the samples
    path_length_mrp: float
    target_path_length_mrp: float
    final_attitude_error_deg: float
    final_rate_rad_s: float
    peak_rate_rad_s: float
    peak_torque_nm: float
    rotation_deg: float  # rotation flown up to the arrival
    time_bound_s: float | None  # rest-to-rest bound along that rotation
    time_ratio_to_bound: float | None
    peak_torque_to_bound: float | None
    peak_rate_to_bound: float | None
    # With wheels.* (None otherwise): record/wheel_figures.py
    peak_wheel_speed_frac: float | None
    peak_wheel_torque_frac: float | None
    momentum_error_nms: float | None
    route_rotation_deg: float | None  # the planner's first global route
    planner_step_us_median: float
    planner_step_us_p99: float
    # With declared sensors (None otherwise): the knowledge 3-sigma the guidance planned
    # with, the estimate's error against the truth ({median, p99, max}) and the filter's
    # consistency: the mean NEES (6 states; 6 when consistent) and the share of steps
    # whose NEES lies in the chi-square(6) 95 % interval (0.95 when consistent).
    knowledge_3sigma_deg: float | None
    estimation_error_deg: dict[str, float] | None
    rate_estimation_error_rad_s: dict[str, float] | None
    filter_nees_mean: float | None
    filter_nees_in_95pct: float | None
    # The faults of the run (:mod:`attitude_core.contract.faults`), in order of start, and
    # the windows with no measured state on record ([from, to], s): the margin and the
    # arrival are measured on the record's states only, never across such a window.
    faults: list[dict[str, Any]]
    unmeasured_windows_s: list[list[float]]
    # The plan's targets and the goals received, in order (record/goal_figures.py).
    goals: list[dict[str, Any]]
    sim_time_s: float
    dt_s: float
    wall_time_s: float

    def to_json(self) -> dict[str, Any]:
        """The fields as ``summary.json`` holds them, in order."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}


SUMMARY_KEYS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(Summary))
"""The keys of a run's ``summary.json`` that every runner writes."""


def _plain(value: Any) -> Any:
    if isinstance(value, dict):
        return dict(value)
    return list(value) if isinstance(value, list) else value


def _finite_stat(
    stat: Callable[[npt.NDArray[np.float64]], Any], values: npt.NDArray[np.float64]
) -> float:
    """``stat`` of the finite ``values``; NaN when there is none."""
    finite = values[np.isfinite(values)]
    return float(stat(finite)) if finite.size else math.nan


def summarize(run: RunResult) -> Summary:
    """Summary figures of a run (the fields of ``summary.json``).

    ``min_margin_deg`` is the dense minimum over every constraint;
    ``min_margin_deg_per_pair`` the minimum at the samples of each constraint, keyed by
    :attr:`Scenario.constraint_names` (``"<instrument>/<object>"`` keep-out pairs, then
    ``"keep_in/<name>"`` keep-in cones).
    """
    sc = run.scenario
    min_margin, t_min, unmeasured = _measured_min_margin(run)
    tol = sc.true_arrival  # the declared tolerances with perfect knowledge
    goal = final_goal(run) if run.goals else sc.desired_mrp
    reached, t_reach, err_deg = arrival_time(
        run.t, run.sigma_bn, run.omega_b, goal, tol.attitude_tol_deg, tol.rate_tol_rad_s
    )
    if sc.plan:  # the plan as a whole: every target reached, the last one's arrival
        reached, t_reach = plan_reached(run)
    arrived = np.flatnonzero(run.planner_status == PlannerStatus.ARRIVED.code)
    stuck = bool(np.any(run.planner_status == PlannerStatus.STUCK.code))
    infeasible = bool(np.any(run.planner_status == PlannerStatus.INFEASIBLE.code))
    blocked_at = np.flatnonzero(run.planner_status == PlannerStatus.BLOCKED.code)
    blockages = []  # a static sky never blocks the goal (goal_blockages)
    if not sc.sky.static:
        blockages = goal_blockages(
            sc.sky,
            sc.desired_mrp,
            0.0,
            sc.sim_time_s,
            buffer_deg(sc, sc.initial_mrp),
            sc.constraint_names,
        )
    first_block = None
    if len(blocked_at):
        t_blocked = float(run.t[blocked_at[0]])
        first_block = next((b for b in blockages if b.end_s is None or b.end_s > t_blocked), None)
    safe_until = safe_until_s(blockages, float(run.t[-1]) if t_reach is None else t_reach)
    held = np.asarray(goal, dtype=float)[None, :]  # a static sky: once, for every step
    if not sc.sky.static:
        held = np.broadcast_to(held, (len(run.t), 3))
    goal_margin = np.broadcast_to(
        constraint_margins_deg(sc, run.t, held).min(axis=1), (len(run.t),)
    )
    covered = np.flatnonzero(goal_margin <= 0.0)
    # Every constraint (keep-out pairs, then keep-in cones), at the samples.
    per_constraint = constraint_margins_deg(sc, run.t, run.sigma_bn).min(axis=0)
    # Planner cost while it is working (arrived/stuck steps return at once).
    tracking = run.planner_status == PlannerStatus.TRACKING.code
    step_s = run.planner_step_s[tracking] if tracking.any() else run.planner_step_s
    limits = _against_limits(run, t_reach)
    return Summary(
        scenario=sc.name,
        planner_variant=sc.planner.variant.value,
        reached=bool(reached),
        t_reach_s=None if t_reach is None else round(t_reach, 9),
        t_plan_arrival_s=round(float(run.t[arrived[0]]), 9) if len(arrived) else None,
        planner_stuck=stuck,
        planner_infeasible=infeasible,
        infeasible_reason=(run.planner_reason or None) if infeasible else None,
        planner_blocked=bool(len(blocked_at)),
        blocked_by=None if first_block is None else first_block.constraint,
        blocked_window_s=(
            None if first_block is None else [first_block.start_s, first_block.end_s]
        ),
        blocked_reason=None if first_block is None else first_block.reason(),
        goal_safe_until_s=None if not np.isfinite(safe_until) else float(safe_until),
        goal_min_margin_deg=float(goal_margin.min()),
        t_goal_covered_s=round(float(run.t[covered[0]]), 9) if len(covered) else None,
        min_margin_deg=min_margin,
        t_min_margin_s=round(t_min, 9),
        min_margin_deg_per_pair={
            name: float(m) for name, m in zip(sc.constraint_names, per_constraint, strict=True)
        },
        path_length_mrp=path_length_mrp(run.sigma_bn),
        target_path_length_mrp=path_length_mrp(run.sigma_t),
        final_attitude_error_deg=float(err_deg[-1]),
        final_rate_rad_s=float(np.linalg.norm(run.omega_b[-1])),
        peak_rate_rad_s=float(np.max(np.linalg.norm(run.omega_b, axis=1))),
        peak_torque_nm=float(np.max(np.linalg.norm(run.torque_b, axis=1))),
        **limits,
        **wheel_figures(run),
        route_rotation_deg=(
            None if not np.isfinite(run.route_rotation_deg) else float(run.route_rotation_deg)
        ),
        # Over the steps with a step time: a recorded step can lack the planner's report
        # (the last states of a run whose planner was stopped first).
        planner_step_us_median=_finite_stat(np.median, step_s) * 1e6,
        planner_step_us_p99=_finite_stat(lambda v: np.percentile(v, 99), step_s) * 1e6,
        **_estimation(run),
        faults=[f.to_json() for f in run.faults],
        unmeasured_windows_s=unmeasured,
        goals=goal_entries(run),
        sim_time_s=sc.sim_time_s,
        dt_s=sc.dt_s,
        wall_time_s=run.wall_time_s,
    )


def _measured_min_margin(run: RunResult) -> tuple[float, float, list[list[float]]]:
    """The dense minimum margin over the record's spans with measured states, its time,
    and the windows between them: two records further apart than the state watchdog's
    timeout (``fdir.state_timeout_s``: a record of the loop's states across a link
    outage) bound a window nobody measured, and no margin is claimed inside it."""
    t = np.asarray(run.t, dtype=float)
    timeout = run.scenario.watchdog.state_timeout_s
    gaps = np.flatnonzero(np.diff(t) > timeout + 1e-9) if len(t) > 1 else np.zeros(0, int)
    bounds = [0, *(gaps + 1).tolist(), len(t)]
    best, t_best = math.inf, float(t[0]) if len(t) else math.nan
    for a, b in zip(bounds[:-1], bounds[1:], strict=True):
        m, tm = dense_min_margin_deg(run.scenario.sky, t[a:b], run.sigma_bn[a:b], run.omega_b[a:b])
        if m < best:
            best, t_best = m, tm
    windows = [[round(float(t[g]), 9), round(float(t[g + 1]), 9)] for g in gaps.tolist()]
    return best, t_best, windows


def _spread(x: np.ndarray) -> dict[str, float]:
    return {
        "median": float(np.median(x)),
        "p99": float(np.percentile(x, 99)),
        "max": float(np.max(x)),
    }


def _estimation(run: RunResult) -> dict[str, Any]:
    """The estimate against the truth (the ``Summary`` fields after ``planner_step``)."""
    est = run.estimate
    if est is None:
        return dict.fromkeys(
            (
                "knowledge_3sigma_deg",
                "estimation_error_deg",
                "rate_estimation_error_rad_s",
                "filter_nees_mean",
                "filter_nees_in_95pct",
            )
        )
    ok = np.isfinite(est.sigma_bn).all(axis=1)
    err = np.degrees(principal_angle(relative(est.sigma_bn[ok], run.sigma_bn[ok])))
    rate_err = np.linalg.norm(est.omega_b[ok] - run.omega_b[ok], axis=1)
    from scipy.stats import chi2  # only with sensors: a heavy import

    nees = est.nees[np.isfinite(est.nees)]
    lo, hi = chi2.ppf([0.025, 0.975], 6)
    return {
        "knowledge_3sigma_deg": run.scenario.knowledge.attitude_3sigma_deg,
        "estimation_error_deg": _spread(err) if len(err) else None,
        "rate_estimation_error_rad_s": _spread(rate_err) if len(err) else None,
        # a bag holds no true bias: no NEES
        "filter_nees_mean": float(np.mean(nees)) if len(nees) else None,
        "filter_nees_in_95pct": float(np.mean((nees >= lo) & (nees <= hi))) if len(nees) else None,
    }


def constraint_margins_deg(sc: Scenario, t: np.ndarray, sigma_bn: np.ndarray) -> np.ndarray:
    """Exact margins ``(N, n_c)`` of the attitudes at their times (the scenario's sky)."""
    if sc.sky.static:
        return sc.sky.exact_geometry.constraint_margins_deg(sigma_bn)
    return sc.sky.constraint_margins_deg(t, sigma_bn)


def _against_limits(run: RunResult, t_reach: float | None) -> dict[str, Any]:
    """The run against its actuator limits.

    ``rotation_deg`` is the rotation flown up to the arrival (the integral of
    ``|omega_B| dt``); ``time_bound_s`` the rest-to-rest bound along it
    (:func:`attitude_core.fsw.guidance.profile_limits.time_bound_s`) and
    ``time_ratio_to_bound`` the arrival time over that bound (None without limits or
    without an arrival).
    ``peak_torque_to_bound`` is the largest ``|u_i| / max_torque_nm_i`` and
    ``peak_rate_to_bound`` the peak body rate over ``max_rate_rad_s``.
    """
    act = run.scenario.actuators
    end = len(run.t) if t_reach is None else int(np.searchsorted(run.t, t_reach)) + 1
    speed = np.linalg.norm(run.omega_b[:end], axis=1)
    flown = float(np.sum(0.5 * (speed[1:] + speed[:-1]) * np.diff(run.t[:end])))
    if run.scenario.wheels is not None:  # the momentum-limited bound
        bound = wheel_time_bound_s(run, flown)
    else:
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
