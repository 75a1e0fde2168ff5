"""The planner's goal input: ``<run namespace>/planner/goal`` (the contract's
:data:`~attitude_core.contract.topics.GOAL`, resolved in the node's namespace) handed to
the planner's core as (goal id = header stamp in ns, frame, x y z w); the core checks it
(:meth:`attitude_core.runtime.planner_stepper.PlannerStepper.command`) and what it
refuses at once is logged."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from attitude_core.contract.goals import GoalReport, goal_name
from attitude_core.contract.topics import GOAL, stamp_ns
from attitude_core.runtime.planner_stepper import goal_log
from attitude_ros.convert import log_events
from attitude_ros.endpoints import subscription

__all__ = ["subscribe_goal"]

Command = Callable[[int, str, tuple[float, float, float, float]], list[GoalReport]]


def subscribe_goal(node: Any, command: Command) -> Any:
    """Subscribe the goal topic; each message goes to ``command``."""
    logger = node.get_logger()

    def on_goal(msg: Any) -> None:
        q, goal_id = msg.quaternion, stamp_ns(msg.header.stamp)
        logger.info(f"goal {goal_name(goal_id)} received")
        refused = command(goal_id, msg.header.frame_id, (q.x, q.y, q.z, q.w))
        log_events(logger, [goal_log(g) for g in refused])

    return subscription(node, GOAL, on_goal)
