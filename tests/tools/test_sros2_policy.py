"""The SROS2 policy (:mod:`attitude_tools.sros2_policy`) grants each node exactly its
table's topics, and the copy in docs/ is current."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from support import ROOT

from attitude_core.config import node_graph
from attitude_core.contract import topics as t
from attitude_tools.sros2_policy import granted, policy_xml


def _grants(xml: str) -> dict[str, dict[str, set[str]]]:
    root = ET.fromstring(xml)
    out = {}
    for profile in root.iter("profile"):
        out[profile.get("node")] = {
            access: {
                topic.text
                for topics in profile.findall("topics")
                if topics.get(access) == "ALLOW"
                for topic in topics
            }
            for access in ("publish", "subscribe")
        }
    return out


def test_every_node_gets_its_table_topics_and_no_other_contract_topic():
    grants = _grants(policy_xml())
    assert set(grants) == {n.node_name for n in node_graph.SENSING_NODES}
    contract = {topic.node_name for topic in t.TOPICS + t.COMMAND_TOPICS}
    for spec in node_graph.SENSING_NODES:
        got = grants[spec.node_name]
        wheeled = node_graph.with_wheels(spec, True)  # a wheel run's wiring too
        publishes = {granted(n) for n in set(spec.publishes) | set(wheeled.publishes)}
        assert got["publish"] & contract == publishes | {t.DIAGNOSTICS}
        subscribes = {granted(n) for n in set(spec.subscribes) | set(wheeled.subscribes)}
        assert got["subscribe"] & contract == subscribes | {t.DIAGNOSTICS}
    # The operator's goal: read by the planner (and recorded), relative (the run's
    # namespace); no node of the graph may publish it.
    assert sorted(n for n, g in grants.items() if "planner/goal" in g["subscribe"]) == [
        "bag_recorder",
        "fepf_planner",
    ]
    assert not [n for n, g in grants.items() if "planner/goal" in g["publish"]]
    # Who may command the body: the controller alone publishes the torque; only the
    # simulator (the plant) publishes the state, or with sensors the estimator its
    # estimate; only the plant publishes the measurements.
    assert [n for n, g in grants.items() if t.TORQUE in g["publish"]] == ["pd_controller"]
    assert sorted(n for n, g in grants.items() if t.ATTITUDE in g["publish"]) == [
        "mekf_estimator",
        "rigid_body_sim",
    ]
    assert [n for n, g in grants.items() if t.IMU in g["publish"]] == ["rigid_body_sim"]


def test_the_documented_policy_is_the_generated_one():
    documented = (ROOT / "docs" / "sros2" / "attitude_run.policy.xml").read_text()
    assert documented == policy_xml(), "regenerate: python -m attitude_tools.sros2_policy"
