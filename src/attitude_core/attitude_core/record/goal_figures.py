"""The goals of a run in its summary: ``summary.json`` ``goals``, one entry per plan
target or received goal, in order (:class:`~attitude_core.contract.goals.GoalReport`),
each with the body's dense smallest margin while it was in force.

With a plan, the single-slew fields speak of the plan as a whole: ``reached`` when every
target was reached, ``t_reach_s`` the last target's arrival, and the final attitude error
against the goal in force at the end (:func:`final_goal`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from attitude_core.contract.goals import SOURCE_PLAN, GoalReport
from attitude_core.contract.status import GoalOutcome, PlannerStatus
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.trajectory import RunResult

__all__ = [
    "SETTLED_OUTCOMES",
    "goals_settled",
    "final_goals",
    "goal_entries",
    "final_goal",
    "in_force_rows",
    "goal_in_force",
    "plan_reached",
]


def in_force_rows(run: RunResult, goal: GoalReport) -> slice:
    """The rows of ``run`` while ``goal`` was in force (empty if it never was)."""
    if math.isnan(goal.t_start_s):
        return slice(0, 0)
    t = np.asarray(run.t, dtype=float)
    end = float(t[-1]) if math.isnan(goal.t_end_s) else goal.t_end_s
    a = int(np.searchsorted(t, goal.t_start_s - 1e-9, side="left"))
    b = int(np.searchsorted(t, end + 1e-9, side="right"))
    return slice(a, b)


def goal_in_force(run: RunResult) -> np.ndarray:
    """Per row, the index in ``run.goals`` of the goal in force (-1: none, or the
    scenario's own goal)."""
    out = np.full(len(run.t), -1, dtype=np.int64)
    for k, goal in enumerate(run.goals):
        rows = in_force_rows(run, goal)
        out[rows] = k
    return out


def final_goals(run: RunResult) -> list[GoalReport]:
    """``run.goals`` with an outcome each: a goal whose last report is ``accepted`` (a
    recording that ended while it was in force or waiting, e.g. stopped by the operator)
    ends at the run's end: ``reached`` if the body had arrived (a goal held until the
    next), else ``blocked`` if the planner said so last, else ``not_reached``."""
    t_end = float(run.t[-1])
    last = int(run.planner_status[-1]) if len(run.planner_status) else -1
    out = []
    for goal in run.goals:
        if not goal.final:
            if not math.isnan(goal.t_reach_s) and math.isinf(goal.dwell_s):
                goal = goal.ended(GoalOutcome.REACHED, t_end)
            elif last == PlannerStatus.BLOCKED.code and not math.isnan(goal.t_start_s):
                goal = goal.ended(GoalOutcome.BLOCKED, t_end)
            else:
                goal = goal.ended(GoalOutcome.NOT_REACHED, t_end, goal.reason or "the run ended")
        out.append(goal)
    return out


def goal_entries(run: RunResult) -> list[dict[str, Any]]:
    """``summary.json`` ``goals``: each goal's report (:func:`final_goals`) and its dense
    smallest margin on the body while it was in force (None if it never was)."""
    entries = []
    for goal in final_goals(run):
        rows = in_force_rows(run, goal)
        margin = None
        if rows.stop > rows.start:
            m, _ = dense_min_margin_deg(
                run.scenario.sky, run.t[rows], run.sigma_bn[rows], run.omega_b[rows]
            )
            margin = float(m)
        entries.append(goal.to_json(margin))
    return entries


def final_goal(run: RunResult) -> np.ndarray:
    """The goal in force at the run's end (the scenario's ``desired_mrp`` without
    goals or before any was in force)."""
    started = [g for g in run.goals if not math.isnan(g.t_start_s)]
    if not started:
        return np.asarray(run.scenario.desired_mrp, dtype=float)
    return np.asarray(started[-1].sigma_goal, dtype=float)


def plan_reached(run: RunResult) -> tuple[bool, float | None]:
    """Every plan target reached, and the last one's arrival time."""
    planned = [g for g in final_goals(run) if g.source == SOURCE_PLAN]
    reached = bool(planned) and all(g.outcome is GoalOutcome.REACHED for g in planned)
    return reached, (planned[-1].t_reach_s if reached else None)


SETTLED_OUTCOMES = (GoalOutcome.REACHED, GoalOutcome.REFUSED, GoalOutcome.INFEASIBLE)
"""Goal outcomes of a successful run: reached, or refused or skipped with the reason."""


def goals_settled(entries: list[dict[str, Any]]) -> bool:
    """Whether every ``summary.json`` ``goals`` entry is reached, refused or infeasible
    (a run with goals succeeds on these, and no keep-out entered)."""
    return all(e["outcome"] in SETTLED_OUTCOMES for e in entries)
