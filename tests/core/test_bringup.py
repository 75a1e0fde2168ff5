"""Bring-up order and the transition watch (:mod:`attitude_core.runtime.bringup`)."""

from __future__ import annotations

from attitude_core.config import node_graph
from attitude_core.runtime.bringup import (
    TRANSITION_GOALS,
    TransitionWatch,
    bring_down_order,
    event_line,
    parse_event,
)


def test_bring_down_reverses_the_start_order_of_the_table():
    names = [n.node_name for n in node_graph.SENSING_NODES]
    down = bring_down_order(names)
    assert down[0] == node_graph.SIMULATOR.node_name  # stops stepping first
    assert down[-1] == node_graph.RECORDER.node_name  # records to the end
    assert sorted(down) == sorted(names)


def test_requested_transitions_pass_and_others_are_named_failures():
    w = TransitionWatch()
    w.request("/r/pd_controller", "configure")
    assert w.judge("/r/pd_controller", "unconfigured", "configuring") is None
    assert w.judge("/r/pd_controller", "configuring", "inactive") is None
    w.settle("/r/pd_controller", "inactive")
    w.request("/r/pd_controller", "activate")
    assert w.judge("/r/pd_controller", "activating", "active") is None
    w.settle("/r/pd_controller", "active")
    # Nobody asked: the node left the state the manager put it in.
    failure = w.judge("/r/pd_controller", "deactivating", "inactive")
    assert failure is not None and "unexpected transition" in failure and "active" in failure
    # ErrorProcessing is always a failure, named.
    failure = w.judge("/r/pd_controller", "active", "errorprocessing")
    assert failure is not None and "/r/pd_controller" in failure
    # A request that ends elsewhere than asked.
    w.request("/r/fepf_planner", "configure")
    failure = w.judge("/r/fepf_planner", "configuring", "unconfigured")
    assert failure is not None and "asked for inactive" in failure


def test_each_transition_ends_in_a_primary_state():
    assert TRANSITION_GOALS["activate"] == "active"
    assert TRANSITION_GOALS["shutdown"] == "finalized"


def test_events_round_trip_and_other_lines_are_not_events():
    line = event_line("plant", nodes=["/bsk_bridge"], adopted=True)
    assert parse_event(line) == {"event": "plant", "nodes": ["/bsk_bridge"], "adopted": True}
    assert parse_event("[INFO] [lifecycle_manager]: configured") is None
    assert parse_event("@bringup {not json") is None
