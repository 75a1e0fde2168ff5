"""When a recording ends: the recorder's stop rule, without ROS.

A recording ends ``stop_delay_s`` of run time (message stamps) after the planner reports
a status in ``stop_on``, or at the scenario's end (``sim_time_s`` after the first state
stamp), whichever comes first; messages stamped after that point are not recorded. It
closes once every stamped topic that has been seen has passed that point, so a plant
that publishes no ``/clock`` or no applied torque still ends the recording; a topic
that falls silent (a node that died, a state link that died) holds it open for at most
``grace_s`` of wall time after the first topic passed. It fails when no state arrives
within ``plant_timeout_s``.

Time is given explicitly: stamps in integer nanoseconds, ``now`` in monotonic seconds.
"""

from __future__ import annotations

import enum
from collections.abc import Iterable

from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import ATTITUDE, NS_PER_S

__all__ = [
    "Outcome",
    "StopRule",
    "EXIT_NO_PLANT",
    "EXIT_DISK_FULL",
    "EXIT_WRITE_FAILED",
    "STAMP_AHEAD_LIMIT_S",
    "implausible_stamp",
]

# The recorder's exit codes (the table is attitude_core.contract.exit_codes).
from attitude_core.contract.exit_codes import EXIT_DISK_FULL, EXIT_NO_PLANT, EXIT_WRITE_FAILED
from attitude_core.runtime.stamp_gate import timelines

STAMP_AHEAD_LIMIT_S = 60.0
"""A stamp more than this much run time ahead of the latest plausible stamp is
implausible (run time, not wall time: lockstep runs much faster than the wall)."""


def implausible_stamp(
    sec: int,
    nanosec: int,
    last_good_ns: int | None,
    wall_ns: int | None = None,
    sim_time_s: float | None = None,
) -> str | None:
    """Why a message stamp (``builtin_interfaces/Time`` fields) is implausible, or None.

    Plausible: ``sec >= 0``, ``0 <= nanosec < 1e9`` and, once a plausible stamp
    exists, at most :data:`STAMP_AHEAD_LIMIT_S` ahead of the latest one. Before one
    exists, with the receive time ``wall_ns`` and the scenario's ``sim_time_s``, the
    stamp must be on a timeline a run can have (:func:`attitude_core.runtime.stamp_gate.timelines`:
    simulated time, or this host's clock), so a stray first stamp cannot become the
    reference.
    """
    if sec < 0:
        return f"negative seconds ({sec})"
    if not 0 <= nanosec < NS_PER_S:
        return f"nanosec {nanosec} out of [0, 1e9)"
    stamp = sec * NS_PER_S + nanosec
    if (
        last_good_ns is None
        and wall_ns is not None
        and sim_time_s is not None
        and not timelines(stamp, wall_ns, sim_time_s)
    ):
        return (
            f"{stamp / NS_PER_S:.9g} s is neither simulated time of the scenario nor "
            "near this host's clock"
        )
    ahead_ns = sec * NS_PER_S + nanosec - (last_good_ns if last_good_ns is not None else 0)
    if last_good_ns is not None and ahead_ns > STAMP_AHEAD_LIMIT_S * NS_PER_S:
        return f"{ahead_ns / NS_PER_S:.6g} s ahead of the latest stamp"
    return None


class Outcome(enum.Enum):
    RECORDING = "recording"
    DONE = "done"  # the stop point is passed: close the bag, exit 0
    NO_PLANT = "no plant"  # no state within plant_timeout_s: close the bag, fail


class StopRule:
    """The stop rule of one recording (see the module docstring)."""

    def __init__(
        self,
        stop_on: Iterable[PlannerStatus],
        stop_delay_s: float,
        started: float,
        scenario_time_s: float | None = None,
        plant_timeout_s: float = 0.0,
        grace_s: float = 2.0,
    ) -> None:
        self.stop_on = frozenset(stop_on)
        self.stop_delay_ns = int(round(stop_delay_s * NS_PER_S))
        self.scenario_ns = (
            None if scenario_time_s is None else int(round(scenario_time_s * NS_PER_S))
        )
        self.started = started
        self.plant_timeout_s = plant_timeout_s
        self.grace_s = grace_s
        self.first_state_ns: int | None = None
        self.stop_at_ns: int | None = None
        self.status_stopped = False
        """A planner status that ends the recording was taken into account: a later one
        (of a later stamp) cannot move the stop earlier."""
        self.reason: str | None = None
        self.seen: set[str] = set()
        self.passed: set[str] = set()
        self.state_passed_at: float | None = None

    def on_stamped(self, topic: str, stamp_ns: int, now: float) -> bool:
        """A stamped message arrived; True if it is to be recorded."""
        self.seen.add(topic)
        if topic == ATTITUDE and self.first_state_ns is None:
            self.first_state_ns = stamp_ns
            if self.scenario_ns is not None:
                self._stop_at(stamp_ns + self.scenario_ns, "scenario time ended")
        if self.stop_at_ns is None or stamp_ns <= self.stop_at_ns:
            return True
        self.passed.add(topic)
        if self.state_passed_at is None:  # the run's time is past the stop
            self.state_passed_at = now
        return False

    def on_status(self, status: PlannerStatus, stamp_ns: int) -> bool:
        """The planner's status at a stamp; True if it set the stop point."""
        if status not in self.stop_on:
            return False
        self.status_stopped = True  # taken into account: a later one would stop later
        return self._stop_at(stamp_ns + self.stop_delay_ns, f"planner status {status.value}")

    def poll(self, now: float) -> Outcome:
        """The outcome so far (call after each message and periodically)."""
        if self.first_state_ns is None:
            if self.plant_timeout_s > 0.0 and now - self.started > self.plant_timeout_s:
                return Outcome.NO_PLANT
            return Outcome.RECORDING
        if self.stop_at_ns is not None and self.passed >= self.seen:
            return Outcome.DONE
        if self.state_passed_at is not None and now - self.state_passed_at > self.grace_s:
            return Outcome.DONE
        return Outcome.RECORDING

    def _stop_at(self, stop_ns: int, reason: str) -> bool:
        if self.stop_at_ns is not None and self.stop_at_ns <= stop_ns:
            return False
        self.stop_at_ns, self.reason = stop_ns, reason
        return True
