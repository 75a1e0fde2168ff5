"""``attitude-offline SCENARIO.yaml --out DIR``: the closed loop in one process, no ROS.

Writes ``DIR/summary.json`` (:func:`attitude_core.record.trajectory.summarize`) and
``DIR/timeseries.csv``, staged and published whole (:mod:`attitude_tools.output.rundir`).
Exit code: 0 reached without violation, 1 otherwise (an infeasible slew says why on
stderr), 2 bad input.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
from typing import Any

import numpy as np

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract import diagnostics
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.goal_figures import goal_in_force, goals_settled
from attitude_core.record.summary import summarize
from attitude_core.record.trajectory import RunResult
from attitude_core.record.wheel_figures import inertial_momentum
from attitude_tools.output.rundir import check_replaceable, publish, stage
from attitude_tools.output.strict_json import dump_strict, dumps_strict

__all__ = ["TIMESERIES_COLUMNS", "ESTIMATE_COLUMNS", "wheel_columns", "write_run", "main"]


TIMESERIES_COLUMNS = (
    ["t_s"]
    + [f"sigma_bn_{i}" for i in (1, 2, 3)]
    + [f"omega_b_{i}_rad_s" for i in (1, 2, 3)]
    + [f"torque_b_{i}_nm" for i in (1, 2, 3)]
    + [f"sigma_t_{i}" for i in (1, 2, 3)]
    + [f"omega_t_{i}_rad_s" for i in (1, 2, 3)]
    + ["min_margin_deg", diagnostics.OBSTACLE_DISTANCE_MRP, "planner_status"]
)
"""The columns of every run; ``sigma_bn_*`` and ``omega_b_*`` are the true state."""

ESTIMATE_COLUMNS = (
    [f"sigma_bn_est_{i}" for i in (1, 2, 3)]
    + [f"omega_b_est_{i}_rad_s" for i in (1, 2, 3)]
    + ["attitude_3sigma_deg", "nees"]
)
"""Appended with declared sensors: the estimate the loop was fed, its 3-sigma and NEES."""


def wheel_columns(names: tuple[str, ...]) -> list[str]:
    """Appended with wheels: per wheel its speed relative to the body (rad/s), the motor
    torque commanded and applied (N m), then the system momentum, inertial axes (N m s)."""
    return (
        [f"{w}_speed_rad_s" for w in names]
        + [f"{w}_commanded_nm" for w in names]
        + [f"{w}_applied_nm" for w in names]
        + [f"h_system_n_{i}_nms" for i in (1, 2, 3)]
    )


GOAL_COLUMNS = ["goal_index", "goal_sigma_1", "goal_sigma_2", "goal_sigma_3"]
"""With goals (``summary.json`` ``goals``): the index of the goal in force (-1: none) and
its attitude ``sigma_DN`` (NaN: none)."""


def write_run(run: RunResult, summary: dict[str, Any], out_dir: str) -> None:
    """Write ``summary.json`` and ``timeseries.csv`` atomically into ``out_dir``.

    Files go to a temporary sibling directory that replaces ``out_dir`` only when
    complete; an existing ``out_dir`` is replaced only if it holds a previous run.
    """
    out = check_replaceable(out_dir, ("summary.json",), "run directory")
    tmp = stage(out, ".tmp-run-")
    try:
        margins = run.scenario.sky.min_margin_deg(run.t, run.sigma_bn)  # at each instant
        columns = list(TIMESERIES_COLUMNS)
        est = run.estimate
        extra = []
        if est is not None:
            columns += ESTIMATE_COLUMNS
            extra = [est.sigma_bn, est.omega_b, est.attitude_3sigma_deg, est.nees]
        wheels, array = run.wheels, run.scenario.wheels
        if wheels is not None and array is not None:
            columns += wheel_columns(array.names)
            extra += [
                wheels.speed_rad_s,
                wheels.commanded_nm,
                wheels.applied_nm,
                inertial_momentum(run),
            ]
        if run.goals:  # a plan or received goals: the goal in force per step
            index = goal_in_force(run)
            goals = np.array([g.sigma_goal for g in run.goals] + [[math.nan] * 3])
            columns += GOAL_COLUMNS
            extra += [index, goals[index]]
        table = np.column_stack(
            [
                run.t,
                run.sigma_bn,
                run.omega_b,
                run.torque_b,
                run.sigma_t,
                run.omega_t,
                margins,
                run.obstacle_distance_mrp,
                run.planner_status,
                *extra,
            ]
        )
        np.savetxt(
            tmp / "timeseries.csv",
            table,
            delimiter=",",
            header=",".join(columns),
            comments="",
            fmt="%.10g",
        )
        with open(tmp / "summary.json", "w") as f:
            dump_strict(summary, f, indent=2)  # NaN/inf -> null, named in non_finite
        publish(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="attitude-offline",
        description="Run a scenario closed-loop in one process (FEPF + PD + rigid body).",
    )
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
    summary = summarize(run).to_json()
    try:
        write_run(run, summary, args.out)
    except OSError as err:
        print(f"attitude-offline: error: {err}", file=sys.stderr)
        return 2
    if not args.quiet:
        print(dumps_strict(summary, indent=2))
    if summary["planner_infeasible"]:
        print(f"attitude-offline: infeasible: {summary['infeasible_reason']}", file=sys.stderr)
        return 1
    done = goals_settled(summary["goals"]) if summary["goals"] else summary["reached"]
    return 0 if done and summary["min_margin_deg"] > 0.0 else 1


if __name__ == "__main__":
    sys.exit(main())
