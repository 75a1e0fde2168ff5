"""The planner-status vocabulary: one enum, with its numeric code and diagnostic level.

Every producer and consumer of a planner status (the FEPF core, the planner node's
``/planner/status`` and ``/diagnostics``, the recorder's stop rule, ``attitude-run``,
the trajectory record and its bag reader) uses :class:`PlannerStatus`; nothing else
spells a status.
"""

from __future__ import annotations

import enum

__all__ = ["DiagnosticLevel", "GoalOutcome", "PlannerStatus"]


class DiagnosticLevel(enum.IntEnum):
    """Levels of ``diagnostic_msgs/DiagnosticStatus`` (the message's byte values)."""

    OK = 0
    WARN = 1
    ERROR = 2
    STALE = 3


class PlannerStatus(enum.StrEnum):
    """What the planner says about the slew; the string is published verbatim.

    ``code`` is the integer stored in trajectories (``planner_status`` column) and
    ``level`` the diagnostic level; ``ends_slew`` marks a status after which the target
    no longer moves, so a run can stop recording once its settle time has passed.
    """

    code: int
    level: DiagnosticLevel
    ends_slew: bool

    def __new__(
        cls, value: str, code: int, level: DiagnosticLevel, ends_slew: bool
    ) -> PlannerStatus:
        member = str.__new__(cls, value)
        member._value_ = value
        member.code = code
        member.level = level
        member.ends_slew = ends_slew
        return member

    TRACKING = ("tracking", 0, DiagnosticLevel.OK, False)
    """The target is moving towards the goal."""
    ARRIVED = ("arrived", 1, DiagnosticLevel.OK, True)
    """The target is on the goal and the measured body within the arrival tolerances
    (``arrival.*``: attitude and rate)."""
    STUCK = ("stuck", 2, DiagnosticLevel.WARN, True)
    """Neither the target nor the body has come closer to the goal for
    ``planner.stuck_timeout_s`` (longer with actuator limits); the target is held."""
    INFEASIBLE = ("infeasible", 3, DiagnosticLevel.ERROR, True)
    """No route reaches the goal at the planner's resolution
    (:mod:`attitude_core.fsw.guidance.route`), decided before the first step; the target
    holds the start and the guidance's
    ``reason`` names the constraints that enclose the start or the goal."""

    BLOCKED = ("blocked", 4, DiagnosticLevel.WARN, False)
    """The moving sky covers the goal before the body can get there, or will while it
    holds there: the target is held clear of it, and the slew goes on when the goal
    clears; the guidance's ``reason`` names the constraint and the window."""

    SAFE_MODE = ("safe_mode", 5, DiagnosticLevel.ERROR, True)
    """No measured state for ``fdir.safe_after_s``: the flight software commands zero
    torque from then on and the run ends as a failure naming the lost state
    (:mod:`attitude_core.fsw.fdir.state_watchdog`)."""

    REFUSED = ("refused", 6, DiagnosticLevel.WARN, False)
    """A commanded goal (``/planner/goal``, or a plan's target) was refused before any
    torque: it would put an instrument inside a keep-out (now, or during its dwell on a
    moving sky), or no route reaches it; the goal in force stays. Reported at the state
    that judged it, with the goal's id and the reason in ``/diagnostics``
    (:class:`GoalOutcome`)."""
    COMPLETE = ("complete", 7, DiagnosticLevel.OK, True)
    """Every target of the scenario's plan (``plan.*``) is done: the last one held for
    its dwell (or refused, infeasible, not reached); the last goal stays in force."""

    @classmethod
    def parse(cls, text: str) -> PlannerStatus:
        """The status whose value is ``text`` (ValueError if none)."""
        for status in cls:
            if status.value == text:
                return status
        raise ValueError(f"{text!r} is not a planner status {[s.value for s in cls]}")

    @classmethod
    def from_code(cls, code: int) -> PlannerStatus:
        """The status whose ``code`` is ``code`` (ValueError if none)."""
        for status in cls:
            if status.code == code:
                return status
        raise ValueError(f"no planner status has code {code!r}")

    @classmethod
    def ending(cls) -> tuple[PlannerStatus, ...]:
        """The statuses that end a slew, in code order."""
        return tuple(s for s in cls if s.ends_slew)


class GoalOutcome(enum.StrEnum):
    """What became of one goal (a plan's target or a ``/planner/goal`` message): the
    ``outcome`` of each entry of ``summary.json`` ``goals`` and of its ``/diagnostics``
    report (``planner/goal``). ``level`` is the diagnostic level of the report."""

    level: DiagnosticLevel

    def __new__(cls, value: str, level: DiagnosticLevel) -> GoalOutcome:
        member = str.__new__(cls, value)
        member._value_ = value
        member.level = level
        return member

    ACCEPTED = ("accepted", DiagnosticLevel.OK)
    """Taken: the goal is in force (reported when it starts; not an end)."""
    REACHED = ("reached", DiagnosticLevel.OK)
    """The body arrived (``arrived``) and stayed in the arrival band for the dwell."""
    REFUSED = ("refused", DiagnosticLevel.WARN)
    """Refused before any torque (:attr:`PlannerStatus.REFUSED`)."""
    INFEASIBLE = ("infeasible", DiagnosticLevel.ERROR)
    """A plan's target no route reaches, or the actuators cannot fly: skipped."""
    BLOCKED = ("blocked", DiagnosticLevel.WARN)
    """The moving sky covered the goal until the goal was left (preempted or run end)."""
    PREEMPTED = ("preempted", DiagnosticLevel.OK)
    """A later goal took over before this one was reached."""
    NOT_REACHED = ("not_reached", DiagnosticLevel.WARN)
    """The run ended before the goal was reached (or before its dwell was over)."""

    @classmethod
    def parse(cls, text: str) -> GoalOutcome:
        """The outcome whose value is ``text`` (ValueError if none)."""
        for outcome in cls:
            if outcome.value == text:
                return outcome
        raise ValueError(f"{text!r} is not a goal outcome {[o.value for o in cls]}")
