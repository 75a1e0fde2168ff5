"""The planner's ``/diagnostics`` contract: status name, hardware id and value keys.

The planner node writes one ``diagnostic_msgs/DiagnosticStatus`` per state stamp with
the key/value pairs of :class:`PlannerDiagnostics`; the recorder (its stop rule) and the
bag reader parse them back with :meth:`PlannerDiagnostics.from_values`. Values are text,
as ``diagnostic_msgs/KeyValue`` requires: floats by ``repr`` (round-trip exact), the
step time in microseconds with three decimals.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

from attitude_core.contract.status import PlannerStatus

__all__ = [
    "STATUS_NAME",
    "ESTIMATOR_STATUS_NAME",
    "ATTITUDE_3SIGMA_DEG",
    "GYRO_BIAS_RAD_S",
    "HARDWARE_ID",
    "STATUS",
    "STEP_TIME_US",
    "OBSTACLE_DISTANCE_MRP",
    "KEEP_OUT_MARGIN_DEG",
    "M_A",
    "M_R",
    "REJECTED_MESSAGES",
    "TRACKING_ERROR_DEG",
    "GOAL_ERROR_DEG",
    "SPEED_FACTOR",
    "ACCEL_DERATING",
    "ROUTE_ROTATION_DEG",
    "ROUTE_WAYPOINTS",
    "REASON",
    "GOAL_SAFE_UNTIL_S",
    "BLOCKED_BY",
    "BLOCKED_FROM_S",
    "BLOCKED_UNTIL_S",
    "KEYS",
    "PlannerDiagnostics",
]

# The planner node's name and package (node_graph.PLANNER; a test keeps them equal):
STATUS_NAME = "fepf_planner"  # DiagnosticStatus.name
ESTIMATOR_STATUS_NAME = "mekf_estimator"  # the estimator's per-step report
ATTITUDE_3SIGMA_DEG = "attitude_3sigma_deg"  # its key: 3 sqrt(trace P_att), deg
GYRO_BIAS_RAD_S = "gyro_bias_rad_s"  # its key: the bias estimate, "x y z", rad/s
HARDWARE_ID = "attitude_planner"  # DiagnosticStatus.hardware_id

STATUS = "status"  # a PlannerStatus
STEP_TIME_US = "step_time_us"  # wall time of the planner step, us
OBSTACLE_DISTANCE_MRP = "obstacle_distance_mrp"  # MRP distance to the closest inflated cone
KEEP_OUT_MARGIN_DEG = "keep_out_margin_deg"  # exact margin of the measured attitude, deg
M_A = "m_a"  # attractive FIS magnitude, MRP/s (eq. 6)
M_R = "m_r"  # repulsive FIS magnitude, MRP/s (eq. 6)
REJECTED_MESSAGES = "rejected_messages"  # refused input messages so far
TRACKING_ERROR_DEG = "tracking_error_deg"  # principal angle body to target, deg
GOAL_ERROR_DEG = "goal_error_deg"  # principal angle body to goal, deg
SPEED_FACTOR = "speed_factor"  # the tracking governor's factor (1 full speed, 0 held)
ACCEL_DERATING = "accel_derating"  # share of the declared acceleration used (1: all)
ROUTE_ROTATION_DEG = "route_rotation_deg"  # rotation of the global route followed, deg
ROUTE_WAYPOINTS = "route_waypoints"  # waypoints of that route, start and goal included
REASON = "reason"  # why the slew is infeasible or blocked (empty otherwise)
GOAL_SAFE_UNTIL_S = (
    "goal_safe_until_s"  # when the goal next lacks its clearance (inf: not in the run)
)
BLOCKED_BY = "blocked_by"  # the constraint that blocks the goal (empty unless blocked)
BLOCKED_FROM_S = "blocked_from_s"  # the blockage's window, s after the epoch (NaN unless
BLOCKED_UNTIL_S = "blocked_until_s"  # blocked; until inf: beyond the run)
KEYS = (
    STATUS,
    STEP_TIME_US,
    OBSTACLE_DISTANCE_MRP,
    KEEP_OUT_MARGIN_DEG,
    M_A,
    M_R,
    REJECTED_MESSAGES,
    TRACKING_ERROR_DEG,
    GOAL_ERROR_DEG,
    SPEED_FACTOR,
    ACCEL_DERATING,
    ROUTE_ROTATION_DEG,
    ROUTE_WAYPOINTS,
    REASON,
    GOAL_SAFE_UNTIL_S,
    BLOCKED_BY,
    BLOCKED_FROM_S,
    BLOCKED_UNTIL_S,
)


@dataclass(frozen=True, slots=True)
class PlannerDiagnostics:
    """One planner step as reported on ``/diagnostics``."""

    status: PlannerStatus
    step_time_s: float
    obstacle_distance_mrp: float
    keep_out_margin_deg: float
    m_a: float
    m_r: float
    rejected_messages: int
    tracking_error_deg: float = float("nan")
    goal_error_deg: float = float("nan")
    speed_factor: float = float("nan")
    accel_derating: float = float("nan")
    route_rotation_deg: float = float("nan")
    route_waypoints: int = 0
    reason: str = ""
    goal_safe_until_s: float = float("inf")
    blocked_by: str = ""
    blocked_from_s: float = float("nan")
    blocked_until_s: float = float("nan")

    def values(self) -> list[tuple[str, str]]:
        """The key/value pairs, in :data:`KEYS` order."""
        return [
            (STATUS, self.status.value),
            (STEP_TIME_US, f"{self.step_time_s * 1e6:.3f}"),
            (OBSTACLE_DISTANCE_MRP, repr(float(self.obstacle_distance_mrp))),
            (KEEP_OUT_MARGIN_DEG, repr(float(self.keep_out_margin_deg))),
            (M_A, repr(float(self.m_a))),
            (M_R, repr(float(self.m_r))),
            (REJECTED_MESSAGES, str(int(self.rejected_messages))),
            (TRACKING_ERROR_DEG, repr(float(self.tracking_error_deg))),
            (GOAL_ERROR_DEG, repr(float(self.goal_error_deg))),
            (SPEED_FACTOR, repr(float(self.speed_factor))),
            (ACCEL_DERATING, repr(float(self.accel_derating))),
            (ROUTE_ROTATION_DEG, repr(float(self.route_rotation_deg))),
            (ROUTE_WAYPOINTS, str(int(self.route_waypoints))),
            (REASON, self.reason),
            (GOAL_SAFE_UNTIL_S, repr(float(self.goal_safe_until_s))),
            (BLOCKED_BY, self.blocked_by),
            (BLOCKED_FROM_S, repr(float(self.blocked_from_s))),
            (BLOCKED_UNTIL_S, repr(float(self.blocked_until_s))),
        ]

    @classmethod
    def from_values(cls, values: Mapping[str, str]) -> PlannerDiagnostics:
        """Parse the pairs of one status; a missing number is NaN (-1 for the count).

        Raises ``ValueError`` when the status is missing or not a planner status.
        """

        def number(key: str) -> float:
            return float(values.get(key, "nan"))

        if STATUS not in values:
            raise ValueError(f"planner diagnostics without a {STATUS!r} value")
        return cls(
            status=PlannerStatus.parse(values[STATUS]),
            step_time_s=number(STEP_TIME_US) * 1e-6,
            obstacle_distance_mrp=number(OBSTACLE_DISTANCE_MRP),
            keep_out_margin_deg=number(KEEP_OUT_MARGIN_DEG),
            m_a=number(M_A),
            m_r=number(M_R),
            rejected_messages=int(values.get(REJECTED_MESSAGES, "-1")),
            tracking_error_deg=number(TRACKING_ERROR_DEG),
            goal_error_deg=number(GOAL_ERROR_DEG),
            speed_factor=number(SPEED_FACTOR),
            accel_derating=number(ACCEL_DERATING),
            route_rotation_deg=number(ROUTE_ROTATION_DEG),
            route_waypoints=int(values.get(ROUTE_WAYPOINTS, "0")),
            reason=values.get(REASON, ""),
            goal_safe_until_s=float(values.get(GOAL_SAFE_UNTIL_S, "inf")),
            blocked_by=values.get(BLOCKED_BY, ""),
            blocked_from_s=number(BLOCKED_FROM_S),
            blocked_until_s=number(BLOCKED_UNTIL_S),
        )
