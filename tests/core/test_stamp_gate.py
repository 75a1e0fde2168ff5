"""The stamp gate of the planner and the controller (:mod:`attitude_core.runtime.stamp_gate`):
malformed and implausible stamps are refused and counted and never become the reference;
one stray stamp cannot lock the loop out; a consistent stream re-anchors it."""

from __future__ import annotations

from attitude_core.runtime.stamp_gate import (
    MAX_JUMP_S,
    MAX_LEAD_S,
    REANCHOR_AFTER,
    StampGate,
    Timeline,
)

NS = 10**9
DT = NS // 10
WALL = 1_796_000_000 * NS  # this host's clock, ns


def feed(gate: StampGate, stamp: int, wall: int = WALL) -> bool:
    """One state stamp as a receiver handles it: screen, and take it if accepted."""
    verdict = gate.screen(stamp // NS, stamp % NS, wall)
    if verdict.accept:
        gate.take(stamp, wall)
    return verdict.accept


def test_lockstep_stream_is_answered_and_repeats_are_recognised():
    gate = StampGate(sim_time_s=120.0)
    for k in range(50):
        assert feed(gate, k * DT)
    assert gate.timeline is Timeline.SIMULATED and gate.rejected == 0
    assert gate.screen(4, 900_000_000, WALL).repeat  # the last one, re-sent


def test_a_stamp_1000_s_ahead_is_refused_and_never_becomes_the_reference():
    """The probe: one attitude stamped 1000 s ahead used to lock out every real state."""
    gate = StampGate(sim_time_s=120.0)
    for k in range(10):
        assert feed(gate, k * DT)
    verdict = gate.screen(1000 + 1, 0, WALL)
    assert not verdict.accept and "not within [0, 130] s of simulated time" in verdict.reason
    assert gate.rejected == 1 and gate.last_ns == 9 * DT
    for k in range(10, 600):  # every real state after it is answered
        assert feed(gate, k * DT)
    assert gate.rejected == 1


def test_negative_and_malformed_stamps_are_refused():
    gate = StampGate(sim_time_s=120.0)
    feed(gate, 0)
    for sec, nanosec, why in ((-5, 0, "negative seconds"), (1, NS, "nanosec")):
        verdict = gate.screen(sec, nanosec, WALL)
        assert not verdict.accept and why in verdict.reason
    assert gate.rejected == 2 and gate.last_ns == 0


def test_realtime_stamps_ahead_of_this_hosts_clock_are_refused():
    gate = StampGate(sim_time_s=120.0)
    assert feed(gate, WALL - 5 * NS)
    assert gate.timeline is Timeline.WALL
    day_ahead = WALL + 86_400 * NS
    assert not feed(gate, day_ahead)
    assert not feed(gate, WALL + int((MAX_LEAD_S + 0.1) * NS))
    assert not feed(gate, 12 * NS)  # simulated time is not this run's timeline
    assert gate.rejected == 3 and feed(gate, WALL - 5 * NS + DT)


def test_a_jump_ahead_within_the_timeline_is_refused():
    gate = StampGate(sim_time_s=120.0)
    feed(gate, 10 * NS)
    verdict = gate.screen(10 + int(MAX_JUMP_S) + 1, 0, WALL)
    assert not verdict.accept and "jumps" in verdict.reason
    assert feed(gate, 10 * NS + DT)


def test_a_wrong_reference_is_left_after_a_consistent_stream():
    """If a stray stamp got through (within the jump bound), the real stream re-anchors
    the gate after REANCHOR_AFTER states instead of being refused for ever; an
    inconsistent stream of refused stamps never does."""
    gate = StampGate(sim_time_s=120.0)
    feed(gate, 10 * NS)
    assert feed(gate, 14 * NS)  # stray, 4 s ahead: accepted (nothing can tell)
    answered = [feed(gate, 10 * NS + k * DT) for k in range(1, REANCHOR_AFTER + 5)]
    assert answered[: REANCHOR_AFTER - 1] == [False] * (REANCHOR_AFTER - 1)
    assert answered[REANCHOR_AFTER - 1 :] == [True] * 5
    assert gate.last_ns == 10 * NS + (REANCHOR_AFTER + 4) * DT
    # Refused stamps that do not form an increasing stream never move the reference.
    gate = StampGate(sim_time_s=120.0)
    feed(gate, 50 * NS)
    for k in range(3 * REANCHOR_AFTER):
        assert not feed(gate, (10 + (k % 2) * 20) * NS)
    assert gate.last_ns == 50 * NS


def test_the_two_halves_of_a_state_count_once_towards_re_anchoring():
    gate = StampGate(sim_time_s=120.0)
    feed(gate, 60 * NS)
    for k in range(REANCHOR_AFTER - 1):
        for _ in range(2):  # attitude and rate of one stamp
            assert not gate.screen(10 + k // 10, (k % 10) * DT, WALL).accept
    assert gate.screen(10, (REANCHOR_AFTER - 1) * DT, WALL).accept
