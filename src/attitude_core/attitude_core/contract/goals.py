"""The goal contract: one goal's report, as ``summary.json`` ``goals``, ``/diagnostics``
and the bag reader know it, defined once (:class:`GoalReport`).

A goal is a plan's target (``plan.<name>``, source ``plan``), a ``<run
namespace>/planner/goal`` message (``geometry_msgs/QuaternionStamped``, frame
``inertial``, the body's attitude in the inertial frame, x y z w: :data:`GOAL_FRAME`;
source ``topic``) or the scenario's own ``desired_mrp`` (source ``scenario``: flown first
when there is no plan, never in ``summary.json`` ``goals``). Its id is the goal
message's header stamp (ns), or the plan target's index; its name the plan name, or
``goal@<stamp s>``. The planner publishes a ``DiagnosticStatus`` named
:data:`GOAL_DIAGNOSTIC_NAME` when a goal is taken (``accepted``) and when it ends (its
:class:`~attitude_core.contract.status.GoalOutcome`), stamped with the state that
decided it; the last report of each id is its record. Times are the run's: seconds since
its first state.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from attitude_core.contract.status import GoalOutcome

__all__ = [
    "GOAL_DIAGNOSTIC_NAME",
    "GOAL_FRAME",
    "GoalReport",
    "goal_name",
    "SOURCE_PLAN",
    "SOURCE_SCENARIO",
    "SOURCE_TOPIC",
]

SOURCE_PLAN = "plan"  # a target of the scenario's plan.*
SOURCE_SCENARIO = "scenario"  # the scenario's own desired_mrp
SOURCE_TOPIC = "topic"  # a goal message received on <run namespace>/planner/goal

GOAL_DIAGNOSTIC_NAME = "planner/goal"
"""``DiagnosticStatus.name`` of the planner's goal reports."""
GOAL_FRAME = "inertial"
"""The ``header.frame_id`` a goal must carry (the attitude's frame)."""

_TIMES = ("t_commanded_s", "t_start_s", "t_reach_s", "t_end_s")
_FLOATS = (*_TIMES, "rotation_deg", "dwell_s")


def goal_name(stamp_ns: int) -> str:
    """The name of a goal received on ``/planner/goal``: ``goal@<stamp in s>``."""
    return f"goal@{stamp_ns // 10**9}.{stamp_ns % 10**9:09d}"


@dataclass(frozen=True)
class GoalReport:
    """One goal: its id and name, the goal attitude (``sigma_DN``, MRP), its dwell (s;
    inf: held until the next goal), the outcome so far, and the times (s): commanded,
    in force (``t_start_s``; NaN if never), first arrival, end (NaN while in force);
    the rotation from the body's attitude when it came in force to the goal (deg) and
    the reason of a refusal or an infeasible goal."""

    source: str  # SOURCE_PLAN, SOURCE_SCENARIO or SOURCE_TOPIC
    goal_id: int
    name: str
    sigma_goal: tuple[float, float, float]
    dwell_s: float
    outcome: GoalOutcome
    t_commanded_s: float
    t_start_s: float = math.nan
    t_reach_s: float = math.nan
    t_end_s: float = math.nan
    rotation_deg: float = math.nan
    reason: str = ""
    origin_ns: int = 0  # the stamp of the planner's first state: its times' zero

    def rebased(self, origin_ns: int) -> GoalReport:
        """The same report with its times counted from the stamp ``origin_ns`` (a
        recording's first step) instead of the planner's first state."""
        shift = (self.origin_ns - origin_ns) * 1e-9
        moved = {key: getattr(self, key) + shift for key in _TIMES}
        return replace(self, origin_ns=origin_ns, **moved)

    @property
    def final(self) -> bool:
        """Its outcome is an end (not ``accepted``)."""
        return self.outcome is not GoalOutcome.ACCEPTED

    def ended(self, outcome: GoalOutcome, t_s: float, reason: str | None = None) -> GoalReport:
        """This goal ended at ``t_s`` with ``outcome``."""
        return replace(
            self, outcome=outcome, t_end_s=t_s, reason=self.reason if reason is None else reason
        )

    def diagnostic_values(self) -> list[tuple[str, str]]:
        """Its ``/diagnostics`` key/values (floats by ``repr``: round-trip exact)."""
        return [
            ("source", self.source),
            ("goal_id", str(self.goal_id)),
            ("name", self.name),
            ("outcome", self.outcome.value),
            ("sigma_goal", " ".join(repr(float(x)) for x in self.sigma_goal)),
            *((key, repr(float(getattr(self, key)))) for key in _FLOATS),
            ("reason", self.reason),
            ("origin_ns", str(self.origin_ns)),
        ]

    @classmethod
    def from_values(cls, values: Mapping[str, str]) -> GoalReport:
        """Parse :meth:`diagnostic_values` (ValueError naming the key if malformed)."""
        try:
            sigma = tuple(float(x) for x in values["sigma_goal"].split())
            if len(sigma) != 3:
                raise ValueError(f"sigma_goal has {len(sigma)} numbers, not 3")
            floats = {key: float(values[key]) for key in _FLOATS}
            return cls(
                source=values["source"],
                goal_id=int(values["goal_id"]),
                name=values["name"],
                sigma_goal=(sigma[0], sigma[1], sigma[2]),
                outcome=GoalOutcome.parse(values["outcome"]),
                reason=values.get("reason", ""),
                origin_ns=int(values.get("origin_ns", "0")),
                **floats,
            )
        except KeyError as err:
            raise ValueError(f"goal report without {err.args[0]!r}") from None

    def to_json(self, min_margin_deg: float | None) -> dict[str, Any]:
        """Its ``summary.json`` ``goals`` entry; ``min_margin_deg``: the body's smallest
        margin while it was in force (dense; None if it never was)."""

        def num(x: float) -> float | None:
            return None if math.isnan(x) else float(x)

        return {
            "name": self.name,
            "outcome": self.outcome.value,
            "t_commanded_s": num(self.t_commanded_s),
            "t_reach_s": num(self.t_reach_s),
            "min_margin_deg": min_margin_deg,
            "rotation_deg": num(self.rotation_deg),
            "source": self.source,
            "goal_id": self.goal_id,
            "t_start_s": num(self.t_start_s),
            "t_end_s": num(self.t_end_s),
            "dwell_s": None if math.isinf(self.dwell_s) else float(self.dwell_s),
            "sigma_goal": list(self.sigma_goal),
            "reason": self.reason,
        }
