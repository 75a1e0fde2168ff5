"""The node graph of one run, defined once: packages, executables, topics, start order,
and who waits for whom.

``attitude-run`` starts :data:`NODES` in this order and stops them in
:data:`STOP_ORDER`; the launch file and the tests take the same table; the simulator's
readiness gate is :func:`readiness`. Plain data, no ROS import.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from attitude_core.config import node_parameters as params
from attitude_core.contract import topics as t

__all__ = [
    "NodeSpec",
    "RECORDER",
    "PLANNER",
    "CONTROLLER",
    "SIMULATOR",
    "NODES",
    "LOOP",
    "STOP_ORDER",
    "node",
    "state_listeners",
    "Readiness",
    "readiness",
]


P = TypeVar("P")


@dataclass(frozen=True)
class NodeSpec(Generic[P]):
    """One node: ``role`` is its short name (log file, ``--param`` prefix)."""

    role: str
    package: str
    executable: str
    node_name: str
    subscribes: tuple[str, ...]
    publishes: tuple[str, ...]
    parameters: params.NodeParameters[P]

    @property
    def module(self) -> str:
        """``package.module`` of the executable's entry point (see each setup.py)."""
        return f"{self.package}.{_MODULES[self.executable]}"


_MODULES = {
    "bag_recorder": "recorder_node",
    "fepf_planner": "planner_node",
    "pd_controller": "controller_node",
    "rigid_body_sim": "sim_node",
}

RECORDER = NodeSpec(
    "recorder",
    "attitude_bringup",
    "bag_recorder",
    "bag_recorder",
    subscribes=tuple(topic.name for topic in t.TOPICS),
    publishes=(),
    parameters=params.RECORDER,
)
PLANNER = NodeSpec(
    "planner",
    "attitude_planner",
    "fepf_planner",
    "fepf_planner",
    subscribes=(t.ATTITUDE, t.ANGULAR_VELOCITY),
    publishes=(t.TARGET_MRP, t.TARGET_RATE, t.PLANNER_STATUS, t.KEEP_OUT_MARGIN, t.DIAGNOSTICS),
    parameters=params.PLANNER,
)
CONTROLLER = NodeSpec(
    "controller",
    "attitude_controller",
    "pd_controller",
    "pd_controller",
    subscribes=(t.ATTITUDE, t.ANGULAR_VELOCITY, t.TARGET_MRP, t.TARGET_RATE),
    publishes=(t.TORQUE,),
    parameters=params.CONTROLLER,
)
SIMULATOR = NodeSpec(
    "simulator",
    "spacecraft_sim",
    "rigid_body_sim",
    "rigid_body_sim",
    subscribes=(t.TORQUE,),
    publishes=(t.CLOCK, t.ATTITUDE, t.ANGULAR_VELOCITY, t.APPLIED_TORQUE),
    parameters=params.SIMULATOR,
)

NODES = (RECORDER, PLANNER, CONTROLLER, SIMULATOR)
"""Start order: the recorder first (nothing is missed), the simulator last (it waits)."""
LOOP = (PLANNER, CONTROLLER, SIMULATOR)
"""The closed loop; a recorder or a test probe only observes it."""
STOP_ORDER = ((SIMULATOR, PLANNER, CONTROLLER), (RECORDER,))
"""Shutdown in two waves: the loop, then the recorder (it drains its queues)."""


def node(role: str) -> NodeSpec[Any]:
    """The entry of ``role`` (KeyError if none)."""
    for spec in NODES:
        if spec.role == role:
            return spec
    raise KeyError(role)


def state_listeners(nodes: tuple[NodeSpec[Any], ...] = NODES) -> int:
    """How many of ``nodes`` listen to the state the simulator publishes: the value of
    ``lockstep.expected_subscribers`` for that graph."""
    return sum(1 for n in nodes if n is not SIMULATOR and t.ATTITUDE in n.subscribes)


@dataclass(frozen=True)
class Readiness:
    """Endpoint counts the simulator waits for before its first step."""

    min_subscribers: dict[str, int]
    min_publishers: dict[str, int]


def readiness(expected_subscribers: int) -> Readiness:
    """What the simulator waits for when ``expected_subscribers`` nodes listen to its state.

    Every state listener is taken to observe each topic the loop exchanges (state,
    target, torque) except where the table says otherwise: the planner listens to the
    state only. A topic then needs the state listeners less the loop nodes that do
    not subscribe it, plus the simulator's own subscription; each topic that a loop
    peer publishes for another needs that publisher.
    """
    listeners = [n for n in LOOP if n is not SIMULATOR and t.ATTITUDE in n.subscribes]
    exchanged = sorted({name for n in LOOP for name in n.subscribes})
    subs = {}
    for name in exchanged:
        missing = sum(name not in n.subscribes for n in listeners)
        own = int(name in SIMULATOR.subscribes)
        subs[name] = max(expected_subscribers - missing + own, 0)
    pubs = {
        name: 1
        for n in LOOP
        if n is not SIMULATOR
        for name in n.publishes
        if any(name in m.subscribes for m in LOOP)
    }
    return Readiness(subs, dict(sorted(pubs.items())))
