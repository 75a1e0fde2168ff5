"""The sampled closed-loop trajectory of a run.

One record for every source of a run: the offline loop
(:func:`attitude_core.loop.closed_loop.run_closed_loop`), a run rebuilt from its bag
(``attitude_tools.bag.run_record``) and the reports; :mod:`attitude_core.record.summary`
turns it into the run's figures.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from attitude_core.config.scenario import Scenario
from attitude_core.contract.faults import Fault
from attitude_core.contract.goals import GoalReport

__all__ = ["RunResult", "Estimates", "WheelRecord"]


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
    # With declared sensors (None otherwise): sigma_bn and omega_b above are the TRUE
    # state; the loop was fed these estimates (NaN rows before the filter's first fix).
    estimate: Estimates | None = None
    faults: list[Fault] = field(default_factory=list)  # in order of start
    wheels: WheelRecord | None = None  # with wheels.* (None otherwise)
    # The plan's targets and the goals received, in order, with their outcomes (empty: the
    # scenario's one goal, desired_mrp).
    goals: list[GoalReport] = field(default_factory=list)


@dataclass
class Estimates:
    """The estimator's output at each row of a :class:`RunResult` (``N + 1`` rows)."""

    sigma_bn: np.ndarray  # estimated MRP sigma_BN
    omega_b: np.ndarray  # bias-corrected rate, body axes, rad/s
    attitude_3sigma_deg: np.ndarray  # the filter's 3 sqrt(trace P_att), deg
    nees: np.ndarray  # normalised estimation error squared, 6 states (NaN: no truth)


@dataclass
class WheelRecord:
    """The wheels at each row of a :class:`RunResult` (``N + 1`` rows, one column per
    wheel of ``scenario.wheels``); ``torque_b`` of the run is the body torque they made."""

    speed_rad_s: np.ndarray  # Omega_i relative to the body at t_k
    commanded_nm: np.ndarray  # motor torque commanded over [t_k, t_k+1)
    applied_nm: np.ndarray  # motor torque applied over [t_k, t_k+1)
    external_b: np.ndarray  # (N + 1, 3) external torque over [t_k, t_k+1), body axes
