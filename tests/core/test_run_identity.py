"""Run identity (:mod:`attitude_core.runtime.run_identity`): whose publisher is foreign, and the
scenario fingerprint."""

from __future__ import annotations

import shutil

import numpy as np
from support import ROOT

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract import topics as t
from attitude_core.runtime import run_identity as ri

E = ri.Endpoint


def test_only_the_runs_own_table_nodes_may_publish_a_contract_topic():
    ns = ri.run_namespace()
    assert ri.in_run(ns) and not ri.in_run("/")
    assert ri.foreign_publishers(t.ATTITUDE, [E(ns, "rigid_body_sim")], ns) == []
    stray = [E("/", "rigid_body_sim"), E("/attitude_run_other", "rigid_body_sim")]
    assert ri.foreign_publishers(t.ATTITUDE, [E(ns, "rigid_body_sim"), *stray], ns) == stray
    # In the run's namespace, a node may publish only what the table gives it...
    assert ri.foreign_publishers(t.ATTITUDE, [E(ns, "fepf_planner")], ns) == [E(ns, "fepf_planner")]
    assert ri.foreign_publishers(t.TORQUE, [E(ns, "pd_controller")], ns) == []
    assert ri.foreign_publishers(t.TORQUE, [E(ns, "my_bridge")], ns) == [E(ns, "my_bridge")]
    # ... and a plant outside the table (a hardware bridge) the plant's topics.
    assert ri.foreign_publishers(t.ANGULAR_VELOCITY, [E(ns, "my_bridge")], ns) == []


def test_other_runs_nodes_on_the_domain_are_named():
    ns = ri.run_namespace()
    nodes = [
        E(ns, "fepf_planner"),
        E("/", "pd_controller"),
        E("/", "rviz"),
        E("/x", "bag_recorder"),
    ]
    assert ri.foreign_run_nodes(nodes, None) == sorted(
        [E(ns, "fepf_planner"), E("/", "pd_controller"), E("/x", "bag_recorder")]
    )
    assert ri.foreign_run_nodes(nodes, ns) == [E("/", "pd_controller"), E("/x", "bag_recorder")]


def test_fingerprint_is_equal_for_the_same_scenario_and_differs_for_any_change(tmp_path):
    case1 = load_scenario(ROOT / "scenarios/case1.yaml")
    copy = tmp_path / "elsewhere.yaml"
    shutil.copyfile(ROOT / "scenarios/case1.yaml", copy)
    fp = ri.scenario_fingerprint(case1)
    assert len(fp) == 16 and fp == ri.scenario_fingerprint(load_scenario(copy))
    assert fp != ri.scenario_fingerprint(load_scenario(ROOT / "scenarios/case2.yaml"))
    text = (ROOT / "scenarios/case1.yaml").read_text()
    goal = case1.desired_mrp
    moved = np.array2string(goal + np.array([0.0, 0.0, 1e-6]), separator=", ")
    changed = tmp_path / "moved_goal.yaml"
    changed.write_text(text.replace(str(list(map(float, goal))), moved))
    assert load_scenario(changed).desired_mrp[2] != goal[2]
    assert ri.scenario_fingerprint(load_scenario(changed)) != fp


def test_diagnostics_may_come_from_any_node_of_the_run_and_from_other_tools():
    ns = ri.run_namespace()
    mine = [E(ns, "pd_controller"), E(ns, "bag_recorder"), E(ns, "my_bridge")]
    other_tool = E("/", "diagnostic_aggregator")
    other_run = E("/attitude_run_other", "fepf_planner")
    found = ri.foreign_publishers(t.DIAGNOSTICS, [*mine, other_tool, other_run], ns)
    assert found == [other_run]


def test_a_bridge_in_the_run_may_publish_every_plant_topic_the_simulator_does():
    ns = ri.run_namespace()
    for topic in (t.CLOCK, t.ATTITUDE, t.ANGULAR_VELOCITY, t.APPLIED_TORQUE):
        assert ri.foreign_publishers(topic, [E(ns, "spacecraft_bridge")], ns) == []


def test_a_plant_adopted_by_name_may_live_in_any_namespace_and_only_it():
    ns = "/hil"
    bridge, stray, sim = E("/", "bsk_bridge"), E("/", "other_bridge"), E(ns, "rigid_body_sim")
    plants = ["/bsk_bridge"]
    for topic in (t.ATTITUDE, t.ANGULAR_VELOCITY, t.CLOCK, t.IMU, t.STAR_TRACKER):
        assert ri.foreign_publishers(topic, [bridge], ns, plants) == []
        assert ri.foreign_publishers(topic, [bridge, stray], ns, plants) == [stray]
    # Named, it is the plant: another non-table node in the run's namespace is not.
    joined = E(ns, "my_bridge")
    assert ri.foreign_publishers(t.ATTITUDE, [bridge, joined], ns, plants) == [joined]
    # The table's own publishers stay own (the estimator's state, the simulator's).
    est = E(ns, "mekf_estimator")
    assert ri.foreign_publishers(t.ATTITUDE, [est, bridge], ns, plants) == []
    assert ri.foreign_publishers(t.ATTITUDE, [sim], ns, [f"{ns}/rigid_body_sim"]) == []
    # Adoption gives no right beyond the plant's topics.
    assert ri.foreign_publishers(t.TORQUE, [bridge], ns, plants) == [bridge]
    # Without a name, a plant outside the namespace is foreign, as before.
    assert ri.foreign_publishers(t.ATTITUDE, [bridge], ns) == [bridge]


def test_plant_candidates_are_the_nodes_publishing_every_state_topic():
    ns = "/attitude_run_x"
    bridge, half, est = E("/", "bsk_bridge"), E("/", "attitude_only"), E(ns, "mekf_estimator")
    pubs = {t.ATTITUDE: [bridge, half, est], t.ANGULAR_VELOCITY: [est, bridge]}
    states = (t.ATTITUDE, t.ANGULAR_VELOCITY)
    assert ri.plant_candidates(pubs, states, ns) == [bridge]
    second = E("/bench", "bsk_bridge")
    pubs = {t.ATTITUDE: [bridge, second], t.ANGULAR_VELOCITY: [second, bridge]}
    assert ri.plant_candidates(pubs, states, ns) == [bridge, second]  # two: none adopted
    assert ri.plant_candidates({t.ATTITUDE: [bridge]}, states, ns) == []


def test_a_run_namespace_is_any_valid_namespace_but_the_root():
    for ns in ("/hil", "/attitude_run_ab12", "/bench/hil_1", "/_x"):
        assert ri.namespace_error(ns) is None and ri.in_run(ns)
    for ns, part in [("/", "root"), ("", "root"), ("hil", "absolute"), ("/hil/", "token"),
                     ("/1hil", "token"), ("/h-il", "token"), ("//hil", "token")]:  # fmt: skip
        reason = ri.namespace_error(ns)
        assert reason is not None and part in reason, (ns, reason)
    assert ri.node_name_error("/bsk_bridge") is None
    assert ri.node_name_error("/bench/bsk_bridge") is None
    assert ri.node_name_error("bsk_bridge") is not None
    assert ri.node_name_error("/bsk-bridge") is not None


def test_matched_readers_round_trip_and_malformed_items_are_dropped():
    readers = {"/planner/target_mrp": 2, "/diagnostics": 1, "/controller/torque": 0}
    text = ri.format_readers(readers)
    assert text == "/controller/torque=0;/diagnostics=1;/planner/target_mrp=2"
    assert ri.parse_readers(text) == readers
    assert ri.format_readers(None) == "" and ri.parse_readers("") == {}
    assert ri.parse_readers("/a=1;b=2;/c=x;/d;/e=-1;/f=3") == {"/a": 1, "/f": 3}
