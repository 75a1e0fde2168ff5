"""The planner's ``/diagnostics`` values of one guidance step (no ROS).

Inputs: the guidance (:class:`attitude_core.fsw.guidance.guidance.Guidance`, None before the first
state), its output for the step, the step's wall time, the measured attitude's exact
margin and the count of refused messages. Output: :class:`PlannerDiagnostics`, with the
route followed, the reason the slew is infeasible or blocked, and, on a moving sky, when
the goal next lacks its clearance and the blockage's constraint and window.
"""

from __future__ import annotations

import math

from attitude_core.contract.diagnostics import PlannerDiagnostics
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.fsw.guidance.guidance_base import GuidanceOutput

__all__ = ["planner_diagnostics"]


def planner_diagnostics(
    guidance: Guidance | None,
    result: GuidanceOutput,
    step_s: float,
    margin_deg: float,
    rejected: int,
) -> PlannerDiagnostics:
    """One step's diagnostics (module docstring)."""
    out = result.target
    rotation, waypoints, reason = math.nan, 0, ""
    block = None
    safe_until = math.inf
    if guidance is not None:
        rotation, waypoints, reason = guidance.route_report()
        block = guidance.blockage
        safe_until = guidance.goal_safe_until_s
        if block is not None:
            reason = guidance.reason
    return PlannerDiagnostics(
        out.status,
        step_s,
        out.obstacle_distance_mrp,
        margin_deg,
        out.m_a,
        out.m_r,
        rejected,
        result.tracking_error_deg,
        result.goal_error_deg,
        result.speed_factor,
        result.derating,
        rotation,
        waypoints,
        reason,
        safe_until,
        "" if block is None else block.constraint,
        math.nan if block is None else block.start_s,
        math.nan if block is None else (math.inf if block.end_s is None else block.end_s),
    )
