"""The planner's settings: ``planner.*`` as a record, its modes as enums.

A leaf: the FEPF (:mod:`attitude_core.fsw.guidance.fepf`), the guidance, the scenario's
schema and loader (:mod:`attitude_core.config`) all read it, and it imports nothing of
the project.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

__all__ = ["PlannerVariant", "DirectionAxis", "PlanningFrame", "PlannerConfig"]


class PlannerVariant(StrEnum):
    """``planner.variant``: whose defaults apply (the improved planner's or the paper's)."""

    IMPROVED = "improved"
    PAPER = "paper"


class DirectionAxis(StrEnum):
    """``planner.direction_axis``: the repulsive rotation axis (eq. 9)."""

    GOAL_PLANE = "goal_plane"  # normal to the plane of the goal and obstacle directions
    PAPER = "paper"  # the paper's axis


class PlanningFrame(StrEnum):
    """``planner.planning_frame``: the MRPs the FEPF is formed in."""

    TARGET = "target"  # relative to the current target (the short way)
    INERTIAL = "inertial"  # sigma_BN, the paper's


@dataclass(frozen=True)
class PlannerConfig:
    """``planner.*``: the FEPF's and the global route's settings (modes as enums)."""

    variant: PlannerVariant
    direction_axis: DirectionAxis
    gamma_deg: float
    fis_attractive: str
    fis_repulsive: str
    max_attractive_rate_mrp_s: float
    max_repulsive_rate_mrp_s: float
    influence_distance_mrp: float
    safety_margin_deg: float
    max_accel_mrp_s2: float
    terminal_time_constant_s: float
    goal_tolerance_mrp: float
    stuck_timeout_s: float
    obstacle_samples: int
    planning_frame: PlanningFrame
    global_route: bool
    roadmap_nodes: int

    def __post_init__(self) -> None:  # defaults arrive as their strings
        object.__setattr__(self, "variant", PlannerVariant(self.variant))
        object.__setattr__(self, "direction_axis", DirectionAxis(self.direction_axis))
        object.__setattr__(self, "planning_frame", PlanningFrame(self.planning_frame))
