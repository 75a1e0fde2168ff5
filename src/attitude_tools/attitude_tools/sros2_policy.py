"""The SROS2 access-control policy of the node graph, generated from the node table.

``python -m attitude_tools.sros2_policy [--enclave-root /attitude]`` prints the policy
(SROS2 policy format 0.2.0) that a full ROS 2 install turns into signed DDS permissions
with ``ros2 security create_permission`` (see docs/robustness.md, "DDS security"). One
enclave per node (``<root>/<role>``); each node may publish and subscribe exactly the
topics :mod:`attitude_core.config.node_graph` gives it, plus what every rclpy node needs
(``/rosout``, its parameter services, ``/parameter_events``) and ``/diagnostics``, where
every node publishes its run identity and listens to its peers'. Topic names are
absolute (but the goal, ``planner/goal``, resolved in the run's namespace as the
planner subscribes it), so the policy holds in any run namespace (``profile ns="*"`` is
not used: the profile's namespace is the run's, given by ``--namespace``).

docs/sros2/attitude_run.policy.xml is this output; a test keeps it current.
"""

from __future__ import annotations

import argparse
import sys
import xml.etree.ElementTree as ET
from typing import Any

from attitude_core.config import node_graph
from attitude_core.contract import topics as t

__all__ = ["PARAMETER_SERVICES", "granted", "permissions", "policy_xml"]

PARAMETER_SERVICES = (
    "~/describe_parameters",
    "~/get_parameter_types",
    "~/get_parameters",
    "~/get_type_description",
    "~/list_parameters",
    "~/set_parameters",
    "~/set_parameters_atomically",
)
"""The services rclpy creates on every node (it answers them)."""


def permissions(spec: node_graph.NodeSpec[Any]) -> tuple[list[str], list[str]]:
    """(published, subscribed) topics of one node, sorted: with and without wheels
    (:data:`attitude_core.config.node_graph.WHEELED`)."""
    wheeled = node_graph.with_wheels(spec, True)
    publish = {granted(n) for n in set(spec.publishes) | set(wheeled.publishes)}
    publish |= {t.DIAGNOSTICS, "/rosout", "/parameter_events"}
    subscribe = {granted(n) for n in set(spec.subscribes) | set(wheeled.subscribes)}
    subscribe |= {t.DIAGNOSTICS}
    return sorted(publish), sorted(subscribe)


def granted(name: str) -> str:
    """A contract topic as the policy names it: absolute, but an operator's topic (the
    goal) relative, in the profile's namespace (the run's), as the node resolves it."""
    return t.topic(name).node_name


def policy_xml(enclave_root: str = "/attitude", namespace: str = "/") -> str:
    """The policy document, one enclave per node of the table (the estimator included)."""
    policy = ET.Element("policy", version="0.2.0")
    enclaves = ET.SubElement(policy, "enclaves")
    for spec in node_graph.SENSING_NODES:
        enclave = ET.SubElement(enclaves, "enclave", path=f"{enclave_root}/{spec.role}")
        profiles = ET.SubElement(enclave, "profiles")
        profile = ET.SubElement(profiles, "profile", ns=namespace, node=spec.node_name)
        publish, subscribe = permissions(spec)
        for access, names in (("publish", publish), ("subscribe", subscribe)):
            topics = ET.SubElement(profile, "topics", {access: "ALLOW"})
            for name in names:
                ET.SubElement(topics, "topic").text = name
        services = ET.SubElement(profile, "services", reply="ALLOW")
        for name in PARAMETER_SERVICES:
            ET.SubElement(services, "service").text = name
    ET.indent(policy, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(policy, "unicode") + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m attitude_tools.sros2_policy",
        description="Print the SROS2 access-control policy of the node graph.",
    )
    parser.add_argument("--enclave-root", default="/attitude", help="default: /attitude")
    parser.add_argument(
        "--namespace", default="/", help="the run's namespace the nodes are in (default /)"
    )
    args = parser.parse_args(argv)
    sys.stdout.write(policy_xml(args.enclave_root, args.namespace))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
