"""Offline closed loop: FEPF planner, PD controller and rigid body in one process.

``attitude-offline SCENARIO.yaml --out DIR`` writes ``DIR/summary.json`` and
``DIR/timeseries.csv``. The loop at step ``k`` (``t_k = k dt``): the planner gives the
target ``(sigma_t, omega_t)`` for ``t_k``, the controller the torque ``u_k`` from the
body state at ``t_k``, and the body is propagated to ``t_{k+1}`` with ``u_k`` held.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import time
from dataclasses import dataclass

import numpy as np

from .control import PdGains, pd_torque
from .dynamics import RigidBody
from .fepf import FepfPlanner, PlannerStatus
from .metrics import arrival_time, dense_min_margin_deg, path_length_mrp
from .rundir import check_replaceable, publish, stage
from .scenario import Scenario, ScenarioError, load_scenario

__all__ = ["RunResult", "build_planner", "run_closed_loop", "summarize", "write_run", "main"]

STATUS_CODES = {PlannerStatus.TRACKING: 0, PlannerStatus.ARRIVED: 1, PlannerStatus.STUCK: 2,
                PlannerStatus.INFEASIBLE: 3}


@dataclass
class RunResult:
    """Sampled closed-loop trajectory; row ``k`` is time ``t_k`` (``N + 1`` rows)."""

    scenario: Scenario
    t: np.ndarray
    sigma_bn: np.ndarray
    omega_b: np.ndarray
    torque_b: np.ndarray          # torque applied over [t_k, t_k+1); last row repeats
    sigma_t: np.ndarray
    omega_t: np.ndarray
    obstacle_distance_mrp: np.ndarray
    planner_status: np.ndarray    # STATUS_CODES
    planner_step_s: np.ndarray    # wall time of each planner step call
    wall_time_s: float


def build_planner(scenario: Scenario, sigma_0=None) -> FepfPlanner:
    """FEPF planner for a scenario, starting at ``sigma_0`` (default: the scenario's).

    The safety buffer is the configured ``planner.safety_margin_deg``, reduced to half
    of the start or goal margin when either lies closer to a cone than that.
    """
    cfg = scenario.planner
    exact = scenario.keep_out()
    start = scenario.initial_mrp if sigma_0 is None else np.asarray(sigma_0, dtype=float)
    end_margin = min(float(exact.min_margin_deg(start)),
                     float(exact.min_margin_deg(scenario.desired_mrp)))
    inflation = min(cfg.safety_margin_deg, 0.5 * max(end_margin, 0.0))
    geometry = scenario.keep_out(inflation_deg=inflation, samples=cfg.obstacle_samples)
    return FepfPlanner(geometry, start, scenario.desired_mrp, scenario.dt_s, cfg,
                       scenario_dir=os.path.dirname(os.path.abspath(scenario.source)))


def run_closed_loop(scenario: Scenario) -> RunResult:
    """Simulate the whole scenario (``sim_time_s``) and return the sampled trajectory."""
    wall0 = time.perf_counter()
    n = scenario.n_steps
    dt = scenario.dt_s
    planner = build_planner(scenario)
    gains = PdGains(scenario.kp, scenario.kd)
    body = RigidBody(scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s)
    sigma = np.empty((n + 1, 3))
    omega = np.empty((n + 1, 3))
    torque = np.empty((n + 1, 3))
    sigma_t = np.empty((n + 1, 3))
    omega_t = np.empty((n + 1, 3))
    d_obs = np.empty(n + 1)
    status = np.empty(n + 1, dtype=np.int8)
    step_s = np.empty(n + 1)
    clock = time.perf_counter
    for k in range(n + 1):
        c0 = clock()
        target = planner.step()
        step_s[k] = clock() - c0
        u = pd_torque(gains, body.sigma_bn, body.omega_b, target.sigma_t, target.omega_t)
        sigma[k], omega[k], torque[k] = body.sigma_bn, body.omega_b, u
        sigma_t[k], omega_t[k] = target.sigma_t, target.omega_t
        d_obs[k] = target.obstacle_distance_mrp
        status[k] = STATUS_CODES[target.status]
        if k < n:
            body.step(u, dt)
    return RunResult(scenario, dt * np.arange(n + 1), sigma, omega, torque, sigma_t, omega_t,
                     d_obs, status, step_s, time.perf_counter() - wall0)


def summarize(run: RunResult) -> dict:
    """Summary figures of a run (the fields of ``summary.json``)."""
    sc = run.scenario
    geometry = sc.keep_out()
    min_margin, t_min = dense_min_margin_deg(geometry, run.t, run.sigma_bn, run.omega_b)
    reached, t_reach, err_deg = arrival_time(
        run.t, run.sigma_bn, run.omega_b, sc.desired_mrp,
        sc.arrival.attitude_tol_deg, sc.arrival.rate_tol_rad_s)
    arrived = np.flatnonzero(run.planner_status == STATUS_CODES[PlannerStatus.ARRIVED])
    stuck = bool(np.any(run.planner_status == STATUS_CODES[PlannerStatus.STUCK]))
    per_pair = geometry.margins_deg(run.sigma_bn).min(axis=0)
    # Planner cost while it is working (arrived/stuck steps return at once).
    tracking = run.planner_status == STATUS_CODES[PlannerStatus.TRACKING]
    step_s = run.planner_step_s[tracking] if tracking.any() else run.planner_step_s
    return {
        "scenario": sc.name,
        "planner_variant": sc.planner.variant,
        "reached": bool(reached),
        "t_reach_s": None if t_reach is None else round(t_reach, 9),
        "t_plan_arrival_s": round(float(run.t[arrived[0]]), 9) if len(arrived) else None,
        "planner_stuck": stuck,
        "min_margin_deg": min_margin,
        "t_min_margin_s": round(t_min, 9),
        "min_margin_deg_per_pair": {
            f"{sc.instrument_names[i]}/{sc.bright_object_names[j]}": float(per_pair[i, j])
            for i in range(len(sc.instrument_names)) for j in range(len(sc.bright_object_names))
        },
        "path_length_mrp": path_length_mrp(run.sigma_bn),
        "target_path_length_mrp": path_length_mrp(run.sigma_t),
        "final_attitude_error_deg": float(err_deg[-1]),
        "final_rate_rad_s": float(np.linalg.norm(run.omega_b[-1])),
        "peak_rate_rad_s": float(np.max(np.linalg.norm(run.omega_b, axis=1))),
        "peak_torque_nm": float(np.max(np.linalg.norm(run.torque_b, axis=1))),
        "planner_step_us_median": float(np.median(step_s) * 1e6),
        "planner_step_us_p99": float(np.percentile(step_s, 99) * 1e6),
        "sim_time_s": sc.sim_time_s,
        "dt_s": sc.dt_s,
        "wall_time_s": run.wall_time_s,
    }


TIMESERIES_COLUMNS = (
    ["t_s"] + [f"sigma_bn_{i}" for i in (1, 2, 3)] + [f"omega_b_{i}_rad_s" for i in (1, 2, 3)]
    + [f"torque_b_{i}_nm" for i in (1, 2, 3)] + [f"sigma_t_{i}" for i in (1, 2, 3)]
    + [f"omega_t_{i}_rad_s" for i in (1, 2, 3)]
    + ["min_margin_deg", "obstacle_distance_mrp", "planner_status"]
)


def write_run(run: RunResult, summary: dict, out_dir: str) -> None:
    """Write ``summary.json`` and ``timeseries.csv`` atomically into ``out_dir``.

    Files go to a temporary sibling directory that replaces ``out_dir`` only when
    complete; an existing ``out_dir`` is replaced only if it holds a previous run.
    """
    out = check_replaceable(out_dir, ("summary.json",), "run directory")
    tmp = stage(out, ".tmp-run-")
    try:
        margins = run.scenario.keep_out().min_margin_deg(run.sigma_bn)
        table = np.column_stack([run.t, run.sigma_bn, run.omega_b, run.torque_b, run.sigma_t,
                                 run.omega_t, margins, run.obstacle_distance_mrp,
                                 run.planner_status])
        np.savetxt(tmp / "timeseries.csv", table, delimiter=",",
                   header=",".join(TIMESERIES_COLUMNS), comments="", fmt="%.10g")
        with open(tmp / "summary.json", "w") as f:
            json.dump(summary, f, indent=2)
            f.write("\n")
        publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog="attitude-offline",
        description="Run a scenario closed-loop in one process (FEPF + PD + rigid body).")
    parser.add_argument("scenario", help="scenario YAML (ROS 2 parameters file)")
    parser.add_argument("--out", required=True, help="run directory to write")
    parser.add_argument("--quiet", action="store_true", help="do not print the summary")
    args = parser.parse_args(argv)
    try:
        scenario = load_scenario(args.scenario)
    except ScenarioError as err:
        print(f"attitude-offline: error: {err}", file=sys.stderr)
        return 2
    run = run_closed_loop(scenario)
    summary = summarize(run)
    try:
        write_run(run, summary, args.out)
    except OSError as err:
        print(f"attitude-offline: error: {err}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(json.dumps(summary, indent=2))
    return 0 if summary["reached"] and summary["min_margin_deg"] > 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
