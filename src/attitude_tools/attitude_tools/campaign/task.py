"""One campaign task: run ``i`` with one planner variant through the offline closed loop
(the same core as the nodes), as one row of the results table.

:func:`run_task` depends only on the SPEC and ``(i, variant)``; the Dask workers run a
few of them per task (:func:`run_tasks` on a group of :func:`batches`). Timing columns
(``*_s`` walls, the planner step median) are the only ones that differ between two
executions of the same task.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import Any

from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import principal_angle, relative
from attitude_core.record.summary import summarize

from .draw import base_parameters, draw_run, scenario_text
from .spec import CampaignSpec

__all__ = [
    "OUTCOMES",
    "FAILURES",
    "TIMING_COLUMNS",
    "BATCH_STEPS",
    "outcome_of",
    "run_task",
    "run_tasks",
    "batches",
    "reproducer",
]

OUTCOMES = ("reached", "violated", "stuck", "infeasible", "blocked", "not_reached")
FAILURES = ("violated", "infeasible", "blocked", "stuck", "not_reached")  # worst first
TIMING_COLUMNS = ("planner_step_us_median", "wall_time_s", "loop_s", "metrics_s", "task_s")
BATCH_STEPS = 8000
"""Simulated steps of the runs one Dask task may hold (:func:`batches`): four runs of
150 s at 0.1 s, two of 400 s, one of 600 s."""
BATCHES_PER_WORKER = 8
"""Tasks per worker at least, when there are enough runs (the end of a campaign is
shared out evenly)."""


def outcome_of(summary: dict[str, Any]) -> str:
    """The outcome of a run from its summary (``summarize(run).to_json()``, margins
    against the sky of each instant): ``violated`` (the body inside a keep-out cone or
    outside a keep-in cone, dense), else ``reached``, else what the planner reported:
    ``infeasible``, ``blocked`` (the moving sky covered the goal, status
    ``PlannerStatus.BLOCKED``) or ``stuck``, else ``not_reached``."""
    if summary["min_margin_deg"] <= 0.0:
        return "violated"
    if summary["reached"]:
        return "reached"
    if summary["planner_infeasible"]:
        return "infeasible"
    if summary["planner_blocked"]:
        return "blocked"
    if summary["planner_stuck"]:
        return "stuck"
    return "not_reached"


def _or_nan(value: float | None) -> float:
    return math.nan if value is None else float(value)


def _sensor_columns(sc: Any, summary: dict[str, Any]) -> dict[str, float]:
    """The run's sensors and its estimate against the truth (NaN without sensors)."""
    spec = sc.sensors
    error = summary["estimation_error_deg"] or {}
    arcsec = math.degrees(1.0) * 3600.0
    return {
        "star_tracker_noise_arcsec_max": (
            math.nan if spec is None else max(spec.star_tracker_noise_rad) * arcsec
        ),
        "star_tracker_rate_hz": math.nan if spec is None else spec.star_tracker_rate_hz,
        "gyro_noise_rad_s": math.nan if spec is None else spec.gyro_noise_rad_s,
        "gyro_bias_rad_s_norm": (math.nan if spec is None else math.hypot(*spec.gyro_bias_rad_s)),
        "knowledge_3sigma_deg": _or_nan(summary["knowledge_3sigma_deg"]),
        "estimation_error_deg_p99": _or_nan(error.get("p99")),
        "estimation_error_deg_max": _or_nan(error.get("max")),
        "filter_nees_mean": _or_nan(summary["filter_nees_mean"]),
        "final_attitude_error_deg": summary["final_attitude_error_deg"],
    }


def reproducer(spec: CampaignSpec, i: int, variant: str) -> str:
    """A complete scenario file that reproduces run ``i`` with ``variant``."""
    draw = draw_run(spec, base_parameters(spec), i, variant)
    head = (
        f"# Campaign '{spec.name}' ({spec.source}), seed {spec.seed}: run {i}, "
        f"planner variant {variant}.\n# attitude-offline and attitude-run take it as is.\n"
    )
    return head + scenario_text(draw.flat)


def _fault_columns(summary: dict[str, Any]) -> dict[str, Any]:
    """The faults of a run behind a rehearsal link: how many, the time flown without a
    fresh state (ended faults; s), and whether it ended in safe mode."""
    faults = summary["faults"]
    lost = [f for f in faults if f["kind"] == "state_lost" and f["t_end_s"] is not None]
    return {
        "n_faults": len(faults),
        "stale_s": float(sum(f["t_end_s"] - f["t_start_s"] for f in lost)),
        "safe_mode": any(f["kind"] == "safe_mode" for f in faults),
    }


def _wheel_columns(sc: Any, summary: dict[str, Any]) -> dict[str, Any]:
    """A wheel run's array and figures (empty and NaN without wheels)."""
    array = sc.wheels
    failed = [] if array is None else [w.name for w in array.wheels if w.fails_at_s is not None]
    return {
        "failed_wheel": failed[0] if failed else "",
        "peak_wheel_speed_frac": _or_nan(summary["peak_wheel_speed_frac"]),
        "peak_wheel_torque_frac": _or_nan(summary["peak_wheel_torque_frac"]),
        "momentum_error_nms": _or_nan(summary["momentum_error_nms"]),
    }


def _plan_columns(spec: CampaignSpec, summary: dict[str, Any]) -> dict[str, Any]:
    """A plan run's targets (none without ``dispersions.plan``): per target ``k`` its
    outcome, arrival and dense margin while in force, and the outcome of the run:
    ``violated``, else ``reached`` when every target was, else that of the first target
    not reached (refused or infeasible: ``infeasible``; ``blocked``; stuck; else
    ``not_reached``)."""
    if not spec.plan_targets:
        return {}
    goals = summary["goals"]
    out: dict[str, Any] = {"goals_reached": sum(g["outcome"] == "reached" for g in goals)}
    for k in range(spec.plan_targets):
        g = goals[k]
        out[f"target_{k}_outcome"] = g["outcome"]
        out[f"target_{k}_t_reach_s"] = _or_nan(g["t_reach_s"])
        out[f"target_{k}_min_margin_deg"] = _or_nan(g["min_margin_deg"])
        out[f"target_{k}_rotation_deg"] = _or_nan(g["rotation_deg"])
    if summary["min_margin_deg"] > 0.0 and not summary["reached"]:
        first = next(g for g in goals if g["outcome"] != "reached")
        out["outcome"] = _PLAN_OUTCOME.get(first["outcome"], "not_reached")
        if first["reason"] == "stuck":
            out["outcome"] = "stuck"
    return out


_PLAN_OUTCOME = {"refused": "infeasible", "infeasible": "infeasible", "blocked": "blocked"}
"""A plan target's outcome as a run outcome (:data:`OUTCOMES`); others: ``not_reached``."""


def run_task(spec: CampaignSpec, i: int, variant: str) -> dict[str, Any]:
    """The results row of run ``i`` flown by ``variant``."""
    t0 = time.perf_counter()
    draw = draw_run(spec, base_parameters(spec), i, variant)
    sc = draw.scenario
    t1 = time.perf_counter()
    run = run_closed_loop(sc)
    t2 = time.perf_counter()
    summary = summarize(run).to_json()
    t3 = time.perf_counter()
    eigen_deg = math.degrees(float(principal_angle(relative(sc.initial_mrp, sc.desired_mrp))))
    rotation = summary["rotation_deg"]
    act = sc.actuators
    torque = act.max_torque_nm or (math.nan, math.nan, math.nan)
    row: dict[str, Any] = {
        "run": i,
        "variant": variant,
        "seed": spec.seed,
        "n_instruments": len(sc.instrument_names),
        "n_objects": len(sc.bright_object_names),
        "n_keep_in": len(sc.keep_in_names),
        "redraws_refused": draw.refused_by_loader,
        "redraws_too_close": draw.too_close_to_a_cone,
        **{f"sigma_0_{k + 1}": float(sc.initial_mrp[k]) for k in range(3)},
        **{f"sigma_d_{k + 1}": float(sc.desired_mrp[k]) for k in range(3)},
        "eigenaxis_deg": eigen_deg,
        "max_torque_nm_min": float(min(torque)),
        "max_rate_rad_s": math.nan if act.max_rate_rad_s is None else act.max_rate_rad_s,
        "outcome": outcome_of(summary),
        "t_reach_s": math.nan if summary["t_reach_s"] is None else summary["t_reach_s"],
        "min_margin_deg": summary["min_margin_deg"],
        "rotation_deg": rotation,
        "rotation_ratio": rotation / eigen_deg if eigen_deg > 1e-9 else math.nan,
        "route_rotation_deg": _or_nan(summary["route_rotation_deg"]),
        "rotation_to_route": (
            rotation / summary["route_rotation_deg"]
            if summary["route_rotation_deg"] and summary["reached"]
            else math.nan
        ),
        "t_reach_x_peak_rate_rad": (
            summary["t_reach_s"] * summary["peak_rate_rad_s"] if summary["reached"] else math.nan
        ),
        "time_ratio_to_bound": (
            math.nan if summary["time_ratio_to_bound"] is None else summary["time_ratio_to_bound"]
        ),
        "goal_min_margin_deg": summary["goal_min_margin_deg"],
        "t_goal_covered_s": _or_nan(summary["t_goal_covered_s"]),
        "peak_rate_rad_s": summary["peak_rate_rad_s"],
        "peak_torque_nm": summary["peak_torque_nm"],
        "planner_step_us_median": summary["planner_step_us_median"],
        "wall_time_s": summary["wall_time_s"],
        "loop_s": t2 - t1,
        "metrics_s": t3 - t2,
        **_sensor_columns(sc, summary),
        **_fault_columns(summary),
        **_wheel_columns(sc, summary),
        **_plan_columns(spec, summary),
    }
    row["task_s"] = time.perf_counter() - t0
    return row


def run_tasks(spec: CampaignSpec, tasks: Sequence[tuple[int, str]]) -> list[dict[str, Any]]:
    """The rows of ``tasks`` (``(i, variant)`` pairs), in order: what one Dask task runs
    (:func:`batches`)."""
    return [run_task(spec, i, variant) for i, variant in tasks]


def batches(
    spec: CampaignSpec, todo: Sequence[tuple[int, str]], workers: int
) -> list[list[tuple[int, str]]]:
    """``todo`` in consecutive groups, one Dask task each: as many runs as fit in
    :data:`BATCH_STEPS` simulated steps, and at least :data:`BATCHES_PER_WORKER` groups
    per worker when there are enough runs. Scheduling a Dask task costs about 1 ms of
    its worker and 4 ms of the driver; a short run takes about 60 ms. A group is retried
    whole, and its rows reach the driver together."""
    base = base_parameters(spec)
    sim_time_s = spec.sim_time_s if spec.sim_time_s is not None else base["sim_time_s"]
    steps = max(1, round(float(sim_time_s) / float(base["dt_s"])))
    size = min(BATCH_STEPS // steps, len(todo) // (BATCHES_PER_WORKER * max(workers, 1)))
    size = max(size, 1)
    return [list(todo[k : k + size]) for k in range(0, len(todo), size)]
