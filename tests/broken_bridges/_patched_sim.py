"""Shared by the broken bridges: the real ``RigidBodySimNode`` run in-process with the
publish path of its state topics patched (each message copied, then changed)."""

from __future__ import annotations

import copy
import sys
from collections.abc import Callable

from attitude_ros.runner import run
from spacecraft_sim.sim_node import RigidBodySimNode

Patch = Callable[[object, RigidBodySimNode], None]


def run_patched(attitude: Patch | None = None, rate: Patch | None = None) -> int:
    """Run the simulator with ``attitude(msg, node)`` / ``rate(msg, node)`` applied to a
    copy of each attitude / angular-velocity message before it is published."""

    def wrap(publisher, patch: Patch, node: RigidBodySimNode) -> None:
        publish = publisher.publish

        def patched(msg) -> None:
            out = copy.deepcopy(msg)
            patch(out, node)
            publish(out)

        publisher.publish = patched

    class PatchedSim(RigidBodySimNode):
        def __init__(self, **kwargs) -> None:
            super().__init__(**kwargs)
            if attitude is not None:
                wrap(self.out.state.pub_att, attitude, self)
            if rate is not None:
                wrap(self.out.state.pub_rate, rate, self)

    return run(PatchedSim, sys.argv)
