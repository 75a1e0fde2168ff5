"""Broken bridge: the simulator with best-effort publishers (the contract is reliable), so
the tool's reliable state subscriptions cannot match (``attitude-bridge-check`` must FAIL
``qos``, naming the incompatible policy)."""

import sys

from rclpy.qos import ReliabilityPolicy

from attitude_ros import contract
from attitude_ros.runner import run

contract_qos = contract.qos


def best_effort(entry=None, *, subscriber=False):
    profile = contract_qos(entry, subscriber=subscriber)
    if not subscriber:
        profile.reliability = ReliabilityPolicy.BEST_EFFORT
    return profile


if __name__ == "__main__":
    contract.qos = best_effort  # before the node takes its QoS from the contract
    from spacecraft_sim.sim_node import RigidBodySimNode

    sys.exit(run(RigidBodySimNode))
