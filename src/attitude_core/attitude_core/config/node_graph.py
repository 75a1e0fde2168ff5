"""The node graph of one run, defined once: packages, executables, topics, start order,
and who waits for whom.

``attitude-run`` starts :data:`NODES` in this order and stops them in
:data:`STOP_ORDER`; the launch file and the tests take the same table; the simulator's
readiness gate is :func:`readiness`. With declared sensors (``sensors.*``) the run is
:data:`SENSING_NODES`: the estimator joins the loop between the simulator's
measurements and the state the planner and controller read (:func:`graph`). Plain
data, no ROS import.

With a reaction wheel array (``wheels.*``) the loop's nodes are the wheeled variants
(:data:`WHEELED`): the simulator takes ``/controller/wheel_torque`` and publishes
``/spacecraft/wheel_states``; the controller reads the wheel states and publishes the
wheel torques beside the body torque; the planner reads both (which wheels still
answer: the slew is re-budgeted on the rest). :func:`with_wheels` gives a node's
variant, :func:`graph` the run's.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
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
    "per_step_outputs",
    "readiness",
    "ESTIMATOR",
    "MANAGER",
    "SENSING_NODES",
    "SENSING_LOOP",
    "SENSING_STOP_ORDER",
    "Graph",
    "graph",
    "WHEELED",
    "with_wheels",
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
    "mekf_estimator": "estimator_node",
    "lifecycle_manager": "lifecycle_manager_node",
}

RECORDER = NodeSpec(
    "recorder",
    "attitude_bringup",
    "bag_recorder",
    "bag_recorder",
    subscribes=tuple(topic.name for topic in t.TOPICS + t.COMMAND_TOPICS),
    publishes=(),
    parameters=params.RECORDER,
)
PLANNER = NodeSpec(
    "planner",
    "attitude_planner",
    "fepf_planner",
    "fepf_planner",
    subscribes=(t.ATTITUDE, t.ANGULAR_VELOCITY, t.GOAL),  # the goal: an operator's
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
    # The state without sensors; the measurements and the truth with them.
    publishes=(
        t.CLOCK,
        t.ATTITUDE,
        t.ANGULAR_VELOCITY,
        t.APPLIED_TORQUE,
        *t.SENSOR_TOPICS,
        *t.TRUTH_TOPICS,
    ),
    parameters=params.SIMULATOR,
)
ESTIMATOR = NodeSpec(
    "estimator",
    "attitude_estimation",
    "mekf_estimator",
    "mekf_estimator",
    subscribes=t.SENSOR_TOPICS,
    publishes=(t.ATTITUDE, t.ANGULAR_VELOCITY, t.DIAGNOSTICS),
    parameters=params.ESTIMATOR,
)

MANAGER = NodeSpec(
    "manager",
    "attitude_bringup",
    "lifecycle_manager",
    "lifecycle_manager",
    subscribes=(t.DIAGNOSTICS,),  # the run identities it checks
    publishes=(),
    parameters=params.MANAGER,
)
"""The lifecycle manager ``attitude-run`` starts beside the table's nodes: it configures
them, checks the run, activates them in :data:`NODES` order and brings them down in
reverse (:mod:`attitude_core.runtime.bringup`). Not a managed node itself."""


def _wheeled(
    spec: NodeSpec[P], subscribes: tuple[str, ...], publishes: tuple[str, ...]
) -> NodeSpec[P]:
    return replace(
        spec,
        subscribes=tuple(n for n in spec.subscribes if n not in subscribes) + subscribes,
        publishes=spec.publishes + publishes,
    )


WHEELED: dict[str, NodeSpec[Any]] = {
    PLANNER.role: _wheeled(PLANNER, (t.WHEEL_STATES, t.WHEEL_TORQUE), ()),
    CONTROLLER.role: _wheeled(CONTROLLER, (t.WHEEL_STATES,), (t.WHEEL_TORQUE,)),
    SIMULATOR.role: replace(
        SIMULATOR, subscribes=(t.WHEEL_TORQUE,), publishes=SIMULATOR.publishes + (t.WHEEL_STATES,)
    ),
}
"""The loop nodes with a wheel array, by role."""


def with_wheels(spec: NodeSpec[P], wheels: bool) -> NodeSpec[P]:
    """``spec``, or its wheeled variant when the scenario declares ``wheels.*``."""
    return WHEELED.get(spec.role, spec) if wheels else spec


NODES = (RECORDER, PLANNER, CONTROLLER, SIMULATOR)
"""Start order: the recorder first (nothing is missed), the simulator last (it waits)."""
LOOP = (PLANNER, CONTROLLER, SIMULATOR)
"""The closed loop; a recorder or a test probe only observes it."""
STOP_ORDER = ((SIMULATOR, PLANNER, CONTROLLER), (RECORDER,))
"""Shutdown in two waves: the loop, then the recorder (it drains its queues)."""
SENSING_NODES = (RECORDER, ESTIMATOR, PLANNER, CONTROLLER, SIMULATOR)
SENSING_LOOP = (ESTIMATOR, PLANNER, CONTROLLER, SIMULATOR)
SENSING_STOP_ORDER = ((SIMULATOR, ESTIMATOR, PLANNER, CONTROLLER), (RECORDER,))


@dataclass(frozen=True)
class Graph:
    """The node graph of one run: start order, the closed loop, stop waves."""

    nodes: tuple[NodeSpec[Any], ...]
    loop: tuple[NodeSpec[Any], ...]
    stop_order: tuple[tuple[NodeSpec[Any], ...], ...]

    @property
    def sensing(self) -> bool:
        return ESTIMATOR in self.nodes


def graph(sensing: bool, wheels: bool = False) -> Graph:
    """The graph of a run with (``sensing``: the scenario declares ``sensors.*`` and our
    estimator runs) or without an estimator; ``wheels``: its wheeled variant."""
    found = (
        Graph(SENSING_NODES, SENSING_LOOP, SENSING_STOP_ORDER)
        if sensing
        else Graph(NODES, LOOP, STOP_ORDER)
    )
    if not wheels:
        return found

    def w(specs: tuple[NodeSpec[Any], ...]) -> tuple[NodeSpec[Any], ...]:
        return tuple(with_wheels(n, True) for n in specs)

    return Graph(w(found.nodes), w(found.loop), tuple(w(wave) for wave in found.stop_order))


def node(role: str) -> NodeSpec[Any]:
    """The entry of ``role`` (KeyError if none)."""
    for spec in SENSING_NODES:
        if spec.role == role:
            return spec
    raise KeyError(role)


def _plant_state(nodes: tuple[NodeSpec[Any], ...]) -> str:
    """The first topic the simulator publishes for the loop: the state, or the gyro."""
    return t.IMU if ESTIMATOR in nodes else t.ATTITUDE


def state_listeners(nodes: tuple[NodeSpec[Any], ...] = NODES) -> int:
    """How many of ``nodes`` listen to the state the simulator publishes (the gyro with
    sensors): the value of ``lockstep.expected_subscribers`` for that graph."""
    state = _plant_state(nodes)
    return sum(1 for n in nodes if n.role != SIMULATOR.role and state in n.subscribes)


@dataclass(frozen=True)
class Readiness:
    """Endpoint counts the simulator waits for before its first step: readers and
    writers in its own view of the graph, and ``min_readers``: per loop node (role), the
    readers each of its per-step outputs must have matched, as that node reports them
    (the simulator's view can be ahead of a peer's: a reader it sees may not have
    matched the peer's writer yet)."""

    min_subscribers: dict[str, int]
    min_publishers: dict[str, int]
    min_readers: dict[str, dict[str, int]] = field(default_factory=dict)


def per_step_outputs(spec: NodeSpec[Any]) -> tuple[str, ...]:
    """The topics ``spec`` publishes at every step whose readers are counted before the
    first one: not a latched topic. ``/clock`` counts its observers (the recorder: a
    report calls a run lockstep when every state stamp is on a recorded ``/clock``); a
    node that reads it for its time source (``use_sim_time``, best effort) only adds to
    the count. On ``/diagnostics`` the count is of the per-step (volatile) writer's
    readers: the run identities' transient-local readers (every node's guard, the
    lifecycle manager) do not match it."""
    return tuple(name for name in spec.publishes if not t.topic(name).latched)


def readiness(expected_subscribers: int, sensing: bool = False, wheels: bool = False) -> Readiness:
    """What the simulator waits for when ``expected_subscribers`` nodes listen to its state
    (the gyro with ``sensing``); ``wheels``: the wheeled graph.

    The listeners beyond the loop's own are observers (a recorder, a probe), each taken
    to observe every topic the loop exchanges. A topic then needs the loop nodes that
    subscribe it (the simulator's own subscription included) plus the observers; each
    topic that a loop peer publishes for another needs that publisher.
    """
    loop = graph(sensing, wheels).loop
    state = _plant_state(loop)
    observers = expected_subscribers - sum(
        1 for n in loop if n.role != SIMULATOR.role and state in n.subscribes
    )
    commands = {topic.name for topic in t.COMMAND_TOPICS}  # an operator's, in the namespace
    exchanged = sorted({name for n in loop for name in n.subscribes if name not in commands})
    subs = {name: max(sum(name in n.subscribes for n in loop) + observers, 0) for name in exchanged}
    pubs = {
        name: 1
        for n in loop
        if n.role != SIMULATOR.role
        for name in n.publishes
        if any(name in m.subscribes for m in loop)
    }
    readers = {
        n.role: {
            name: sum(name in m.subscribes for m in loop) + max(observers, 0)
            for name in per_step_outputs(n)
        }
        for n in loop
    }
    readers = {role: {k: v for k, v in wants.items() if v > 0} for role, wants in readers.items()}
    return Readiness(subs, dict(sorted(pubs.items())), readers)
