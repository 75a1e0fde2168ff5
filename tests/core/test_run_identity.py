"""Run identity (:mod:`attitude_core.runtime.run_identity`): whose publisher is foreign, and the
scenario fingerprint."""

from __future__ import annotations

import shutil

import numpy as np
from support import ROOT

from attitude_core.config.scenario import load_scenario
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
