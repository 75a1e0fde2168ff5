"""attitude_core.runtime.stamp_pairing: the planner's and controller's intake, without ROS."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from attitude_core.contract.topics import NS_PER_S
from attitude_core.runtime.stamp_gate import StampGate
from attitude_core.runtime.stamp_pairing import PENDING_MAX, Intake, StampPairing

WALL_NS = 1_800_000_000 * NS_PER_S  # this host's clock, far from simulated time


def pairing(slots: int = 2, pending_max: int = PENDING_MAX) -> StampPairing:
    return StampPairing(slots, StampGate(sim_time_s=150.0), pending_max)


def offer(p: StampPairing, slot: int, stamp_ns: int, value, reason: str | None = None):
    sec, nanosec = divmod(stamp_ns, NS_PER_S)
    return p.offer(slot, sec, nanosec, WALL_NS, value, reason)


def test_a_stamp_is_answered_once_its_inputs_are_all_in_in_slot_order():
    p = pairing(3)
    assert offer(p, 2, NS_PER_S, "c").intake is Intake.WAITING
    assert offer(p, 0, NS_PER_S, "a").intake is Intake.WAITING
    done = offer(p, 1, NS_PER_S, "b")
    assert done.intake is Intake.COMPLETE
    assert (done.stamp_ns, done.values) == (NS_PER_S, ("a", "b", "c"))
    assert p.gate.last_ns == NS_PER_S and p.pending == {}
    assert offer(p, 0, NS_PER_S, "a").intake is Intake.REPEAT  # a lockstep re-send
    assert p.rejected == 0


def test_completing_a_stamp_drops_the_older_half_pairs():
    p = pairing()
    offer(p, 0, 1 * NS_PER_S, "a1")  # its rate never comes
    offer(p, 1, 2 * NS_PER_S, "b2")
    offer(p, 0, 3 * NS_PER_S, "a3")
    assert offer(p, 1, 3 * NS_PER_S, "b3").values == ("a3", "b3")
    assert p.pending == {}
    refused = offer(p, 1, 1 * NS_PER_S, "b1")  # too late: older than the answered stamp
    assert refused.intake is Intake.REJECTED and "older than" in refused.reason


def test_stamp_and_content_refusals_are_counted_together():
    p = pairing()
    offer(p, 0, 2 * NS_PER_S, "a")
    offer(p, 1, 2 * NS_PER_S, "b")
    old = offer(p, 0, 1 * NS_PER_S, "a")  # the gate refuses it
    bad = offer(p, 1, 3 * NS_PER_S, None, "rate has a non-finite element")
    malformed = p.offer(0, -1, 0, WALL_NS, "a")
    assert [o.intake for o in (old, bad, malformed)] == [Intake.REJECTED] * 3
    assert (old.rejected, bad.rejected, malformed.rejected) == (1, 2, 3)
    assert bad.reason == "rate has a non-finite element"
    assert p.rejected == 3 and p.bad_values == 1 and p.gate.rejected == 2
    assert 3 * NS_PER_S not in p.pending  # a refused value never waits in a slot


def test_a_bad_value_of_the_answered_stamp_is_a_repeat_not_a_refusal():
    """The stamp decides first: the last answered stamp again is a re-send."""
    p = pairing()
    offer(p, 0, NS_PER_S, "a")
    offer(p, 1, NS_PER_S, "b")
    assert offer(p, 0, NS_PER_S, None, "bad").intake is Intake.REPEAT
    assert p.rejected == 0


def test_the_oldest_waiting_stamp_goes_first_when_too_many_wait():
    p = pairing(pending_max=4)
    for k in range(1, 11):
        assert offer(p, 0, k * NS_PER_S // 10, k).intake is Intake.WAITING
    assert sorted(p.pending) == [k * NS_PER_S // 10 for k in range(7, 11)]
    assert offer(p, 1, 1 * NS_PER_S // 10, "late").intake is Intake.WAITING  # its pair was dropped
    assert offer(p, 1, 9 * NS_PER_S // 10, "b").values == (9, "b")


def test_a_re_anchor_is_accepted_with_its_note():
    """The gate re-anchors on a consistent stream after its reference: the stamp that
    re-anchors is taken, and the caller gets the gate's note to log."""
    p = pairing(slots=1)
    offer(p, 0, 100 * NS_PER_S, "x")  # a reference 100 s into the run
    notes = [offer(p, 0, k * NS_PER_S // 10, k) for k in range(1, 11)]  # the real stream
    assert [o.intake for o in notes[:9]] == [Intake.REJECTED] * 9
    assert notes[9].intake is Intake.COMPLETE and "re-anchored" in notes[9].reason
    assert p.gate.last_ns == NS_PER_S


@pytest.mark.parametrize("slots, pending_max", [(0, 4), (2, 0)])
def test_bad_sizes_are_refused(slots, pending_max):
    with pytest.raises(ValueError, match="must be >= 1"):
        StampPairing(slots, StampGate(150.0), pending_max)


@given(
    st.lists(
        st.tuples(st.integers(0, 1), st.integers(0, 30)),  # (slot, stamp in 0.1 s steps)
        max_size=80,
    )
)
def test_answers_are_increasing_and_carry_what_was_offered(messages):
    """Whatever the order of arrival: stamps are answered at most once, in increasing
    order, with the values offered for that stamp; waiting stamps stay bounded."""
    p = pairing(pending_max=8)
    answered = []
    for slot, k in messages:
        o = offer(p, slot, k * NS_PER_S // 10, (slot, k))
        if o.intake is Intake.COMPLETE:
            assert o.values == ((0, k), (1, k))
            answered.append(o.stamp_ns)
        assert len(p.pending) <= 8
    assert answered == sorted(set(answered))
