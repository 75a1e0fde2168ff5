"""The recorder's stop rule (attitude_core.runtime.recording.StopRule), with explicit times."""

from __future__ import annotations

import pytest

from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import ANGULAR_VELOCITY, APPLIED_TORQUE, ATTITUDE, CLOCK, TORQUE
from attitude_core.runtime.recording import Outcome, StopRule

S = 1_000_000_000  # ns per s
ENDING = PlannerStatus.ending()


def feed(rule: StopRule, topics, stamp_ns: int, now: float) -> list[bool]:
    return [rule.on_stamped(t, stamp_ns, now) for t in topics]


def test_records_until_the_status_plus_the_delay_then_closes_when_every_seen_topic_passed():
    rule = StopRule(ENDING, stop_delay_s=1.0, started=0.0)
    topics = (ATTITUDE, ANGULAR_VELOCITY, TORQUE)  # no /clock, no applied torque: a bridge
    for k in range(5):
        assert feed(rule, topics, k * S, 0.1 * k) == [True] * 3
    assert rule.poll(0.5) is Outcome.RECORDING
    assert not rule.on_status(PlannerStatus.TRACKING, 4 * S)
    assert not rule.status_stopped  # the scenario's end is no planner status
    assert rule.on_status(PlannerStatus.ARRIVED, 4 * S)
    assert rule.stop_at_ns == 5 * S and rule.reason == "planner status arrived"
    assert rule.status_stopped  # the recorder parses no later status
    late = StopRule(ENDING, stop_delay_s=100.0, started=0.0, scenario_time_s=10.0)
    late.on_stamped(ATTITUDE, 0, 0.0)  # the scenario's end, 10 s, comes first
    assert not late.on_status(PlannerStatus.ARRIVED, 4 * S) and late.status_stopped
    assert not rule.on_status(PlannerStatus.ARRIVED, 4 * S + 1)  # a later one cannot move it
    assert rule.stop_at_ns == 5 * S
    assert feed(rule, topics, 5 * S, 0.6) == [True] * 3  # the stop stamp itself is recorded
    assert rule.on_stamped(ATTITUDE, 6 * S, 0.7) is False
    assert rule.poll(0.7) is Outcome.RECORDING  # rate and torque have not passed yet
    assert feed(rule, (ANGULAR_VELOCITY, TORQUE), 6 * S, 0.8) == [False, False]
    assert rule.poll(0.8) is Outcome.DONE


def test_a_topic_seen_once_then_silent_holds_the_close_for_the_grace_time_only():
    rule = StopRule(ENDING, stop_delay_s=0.0, started=0.0, grace_s=2.0)
    feed(rule, (ATTITUDE, APPLIED_TORQUE), 0, 0.0)
    rule.on_status(PlannerStatus.STUCK, 0)
    rule.on_stamped(ATTITUDE, S, 1.0)  # passed; the applied torque never comes again
    assert rule.poll(2.9) is Outcome.RECORDING
    assert rule.poll(3.1) is Outcome.DONE


def test_scenario_end_stops_when_the_planner_never_finishes():
    rule = StopRule(ENDING, stop_delay_s=10.0, started=0.0, scenario_time_s=3.0)
    first = 1_700_000_000 * S  # a wall-clock stamp, as in real time
    assert rule.on_stamped(ATTITUDE, first, 0.0)
    assert rule.stop_at_ns == first + 3 * S and rule.reason == "scenario time ended"
    assert rule.on_stamped(ATTITUDE, first + 3 * S, 3.0)
    assert not rule.on_stamped(ATTITUDE, first + 3 * S + 1, 3.1)
    assert rule.poll(3.1) is Outcome.DONE
    # A later status cannot move the stop point past the scenario's end.
    assert not rule.on_status(PlannerStatus.ARRIVED, first + 2 * S)


def test_an_earlier_status_moves_the_scenario_end_forward():
    rule = StopRule(ENDING, stop_delay_s=1.0, started=0.0, scenario_time_s=100.0)
    rule.on_stamped(ATTITUDE, 0, 0.0)
    assert rule.on_status(PlannerStatus.ARRIVED, 10 * S)
    assert rule.stop_at_ns == 11 * S and rule.reason == "planner status arrived"


def test_without_stop_statuses_a_status_never_stops():
    rule = StopRule((), stop_delay_s=1.0, started=0.0)
    rule.on_stamped(CLOCK, 0, 0.0)
    rule.on_stamped(ATTITUDE, 0, 0.0)
    assert not rule.on_status(PlannerStatus.ARRIVED, 0)
    assert rule.on_stamped(ATTITUDE, 10**6 * S, 1.0)
    assert rule.poll(1e6) is Outcome.RECORDING


@pytest.mark.parametrize("timeout, outcome", [(0.0, Outcome.RECORDING), (5.0, Outcome.NO_PLANT)])
def test_no_state_within_the_plant_timeout(timeout, outcome):
    rule = StopRule(ENDING, stop_delay_s=1.0, started=100.0, plant_timeout_s=timeout)
    assert rule.poll(104.9) is Outcome.RECORDING
    rule.on_stamped(TORQUE, 0, 104.95)  # not a state: the plant is still missing
    assert rule.poll(105.1) is outcome
    rule.on_stamped(ATTITUDE, 0, 105.2)
    assert rule.poll(1000.0) is Outcome.RECORDING
