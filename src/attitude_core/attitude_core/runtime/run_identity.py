"""Which nodes belong to a run, and whether they run the same scenario (no ROS import).

A run is identified by its **ROS namespace**: ``attitude-run`` starts every node of a
run with ``-r __ns:=/attitude_run_<id>`` (:func:`run_namespace`; ``--run-namespace``
takes any other but the root). The topics stay
absolute (``/spacecraft/attitude``, ...), so the topic contract is unchanged, but the
graph now tells whose a publisher is: an endpoint on a contract topic is the run's own
when its node is in the run's namespace and is a node the node table lets publish that
topic (:func:`foreign_publishers`). Why not the publisher GID of each sample: rclpy 7.1
(Jazzy) gives no ``publisher_gid`` in ``MessageInfo`` (only the timestamps and sequence
numbers), so samples of two writers on one topic cannot be told apart; a node that sees
a foreign writer on a topic it listens to therefore stops (``EXIT_FOREIGN_PUBLISHER``),
which ends the run at once with the writer named, before the writer's first sample can
matter (endpoint discovery precedes data).

The **plant** (the simulator, or a hardware bridge in its place) may live in any
namespace when the run adopts it by name (``plant_nodes``; ``attitude-run
--plant-node``, or the single node publishing both state topics, :func:`plant_candidates`):
then only it, besides the node table's own, may publish the plant's topics.

Nodes started by hand (namespace ``/``) are in no run: they log and count foreign
publishers but do not stop, since nothing distinguishes a stray twin from a restart.

Every node also carries the run's **scenario fingerprint** (:func:`scenario_fingerprint`,
a hash of the scenario it loaded) in ``/diagnostics``; a loop node whose fingerprint
differs from the simulator's or the planner's makes the run fail before the first step
(``EXIT_FINGERPRINT_MISMATCH``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import re
import secrets
from collections.abc import Iterable, Mapping
from typing import Any, NamedTuple

import numpy as np

from attitude_core.config import node_graph
from attitude_core.config.scenario import Scenario
from attitude_core.contract import topics as t
from attitude_core.contract.exit_codes import EXIT_FINGERPRINT_MISMATCH, EXIT_FOREIGN_PUBLISHER
from attitude_core.models.wheel_array import WheelArray

__all__ = [
    "RUN_NAMESPACE_PREFIX",
    "EXIT_FOREIGN_PUBLISHER",
    "EXIT_FINGERPRINT_MISMATCH",
    "IDENTITY_HARDWARE_ID",
    "ROLE",
    "RUN_NAMESPACE",
    "FINGERPRINT",
    "FOREIGN_PUBLISHERS",
    "FOREIGN_NAMES",
    "REJECTED_MESSAGES",
    "OUTPUTS_MATCHED",
    "MATCHED_READERS",
    "format_readers",
    "parse_readers",
    "MATCH_GRACE_S",
    "Endpoint",
    "run_namespace",
    "in_run",
    "namespace_error",
    "node_name_error",
    "scenario_fingerprint",
    "foreign_publishers",
    "plant_candidates",
    "PLANT_TOPICS",
    "foreign_run_nodes",
]

RUN_NAMESPACE_PREFIX = "attitude_run_"


# The identity a node publishes in /diagnostics (DiagnosticStatus.name is its full name).
IDENTITY_HARDWARE_ID = "attitude_run"
ROLE = "role"  # its role in the node table
RUN_NAMESPACE = "run_namespace"
FINGERPRINT = "scenario_fingerprint"
FOREIGN_PUBLISHERS = "foreign_publishers"  # foreign writers seen on its inputs so far
FOREIGN_NAMES = "foreign_publisher_names"  # "topic <- /ns/node", "; "-separated
REJECTED_MESSAGES = "rejected_messages"  # refused input messages so far
OUTPUTS_MATCHED = "outputs_matched"  # "1": every reader the graph shows of its outputs matched
MATCHED_READERS = "matched_readers"  # "topic=n;topic=n": readers matched per per-step output
MATCH_GRACE_S = 2.0
"""The simulator's first step waits at most this long, the rest of the graph ready, for
a peer whose outputs are not all matched (a reader of incompatible QoS never is)."""


def format_readers(readers: dict[str, int] | None) -> str:
    """``{topic: n}`` as the ``matched_readers`` value ``"topic=n;topic=n"`` (sorted)."""
    return ";".join(f"{name}={n}" for name, n in sorted((readers or {}).items()))


def parse_readers(text: str) -> dict[str, int]:
    """The ``matched_readers`` value back as ``{topic: n}``; malformed items are dropped
    (an older node, or another's identity, must not stop the start-up gate's reading)."""
    readers = {}
    for item in text.split(";"):
        name, sep, count = item.partition("=")
        if sep and name.startswith("/") and count.isdigit():
            readers[name] = int(count)
    return readers


class Endpoint(NamedTuple):
    """A publisher endpoint of the graph: the node's namespace and name."""

    namespace: str
    name: str

    @property
    def node(self) -> str:
        return self.namespace.rstrip("/") + "/" + self.name


def run_namespace() -> str:
    """A fresh namespace for one run, ``/attitude_run_<12 hex>``."""
    return "/" + RUN_NAMESPACE_PREFIX + secrets.token_hex(6)


_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_FQN = re.compile(r"(/[A-Za-z_][A-Za-z0-9_]*)+\Z")


def namespace_error(namespace: str) -> str | None:
    """Why ``namespace`` cannot be a run's (ROS 2's namespace rules, and not the root,
    where nodes started by hand live); None when it can."""
    if namespace in ("", "/"):
        return "the root namespace holds the nodes started by hand: give a run its own"
    if not namespace.startswith("/"):
        return "must be absolute (start with '/')"
    if len(namespace) > 200:
        return "longer than 200 characters"
    for token in namespace[1:].split("/"):
        if not _TOKEN.match(token):
            return (
                f"token {token!r}: each '/'-separated part is letters, digits and '_', "
                "not starting with a digit (no empty part, no trailing '/')"
            )
    return None


def node_name_error(name: str) -> str | None:
    """Why ``name`` is not a fully qualified node name (``/ns/node``); None when it is."""
    return None if _FQN.match(name) else "expected a fully qualified node name like /bsk_bridge"


def in_run(namespace: str) -> bool:
    """True for a run's namespace: any but the root (nodes started by hand)."""
    return namespace not in ("", "/")


_TABLE_NAMES = frozenset(n.node_name for n in node_graph.SENSING_NODES)
PLANT_TOPICS = frozenset(node_graph.WHEELED[node_graph.SIMULATOR.role].publishes) | frozenset(
    t.STATE_TOPICS
)
"""The topics a plant publishes (the simulator's, or a bridge's in its place)."""


_TABLE: tuple[node_graph.NodeSpec[Any], ...] = (
    *node_graph.SENSING_NODES,
    *node_graph.WHEELED.values(),
)


def _table_publishes(topic: str, name: str) -> bool:
    return any(name == n.node_name and topic in n.publishes for n in _TABLE)


def _own(topic: str, e: Endpoint, own_namespace: str, plant_nodes: frozenset[str]) -> bool:
    if e.namespace == own_namespace and _table_publishes(topic, e.name):
        return True
    if topic not in PLANT_TOPICS:
        return False
    if plant_nodes:  # adopted by name, in any namespace: only they
        return e.node in plant_nodes
    return e.namespace == own_namespace and e.name not in _TABLE_NAMES  # a bridge joined


def foreign_publishers(
    topic: str,
    endpoints: Iterable[Endpoint],
    own_namespace: str,
    plant_nodes: Iterable[str] = (),
) -> list[Endpoint]:
    """The publishers of ``topic`` that are not the run's own (see the module docstring).

    Own: the node table's publishers of ``topic`` in the run's namespace; on the plant's
    topics (:data:`PLANT_TOPICS`) the adopted ``plant_nodes`` (fully qualified names, any
    namespace) or, when none is named, a node outside the table in the run's namespace.
    On ``/diagnostics``, where every node publishes its identity and other tools may
    report too, only the table's nodes of another namespace (another run) are foreign."""
    if topic == t.DIAGNOSTICS:  # every node reports there; other tools may too
        return [e for e in endpoints if e.namespace != own_namespace and e.name in _TABLE_NAMES]
    plants = frozenset(plant_nodes)
    return [e for e in endpoints if not _own(topic, e, own_namespace, plants)]


def plant_candidates(
    publishers: Mapping[str, Iterable[Endpoint]], state_topics: Iterable[str], own_namespace: str
) -> list[Endpoint]:
    """The nodes that publish every one of ``state_topics`` (``publishers``: topic ->
    its publishers), bar the node table's own in the run's namespace: the plants a run
    may adopt when none is named (it adopts a single one; a second is foreign)."""
    sets = [
        {
            e
            for e in publishers.get(topic, ())
            if not (e.namespace == own_namespace and e.name in _TABLE_NAMES)
        }
        for topic in state_topics
    ]
    return sorted(set.intersection(*sets)) if sets else []


def foreign_run_nodes(nodes: Iterable[Endpoint], own_namespace: str | None) -> list[Endpoint]:
    """Nodes of the node table alive in another namespace or in none (another run, or a
    run started by hand), which a new run on this domain would talk to."""
    return sorted(e for e in nodes if e.name in _TABLE_NAMES and e.namespace != own_namespace)


def _plain(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (tuple, list)):
        return [_plain(v) for v in value]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, float) and value != value:
        return "nan"
    return value


def scenario_fingerprint(scenario: Scenario) -> str:
    """16 hex digits of SHA-256 over the loaded scenario's values (its file path aside):
    equal for two nodes exactly when they run the same scenario."""
    values = {}
    for f in dataclasses.fields(scenario):
        value = getattr(scenario, f.name)
        if isinstance(value, WheelArray):  # its wheels, in order
            value = [dataclasses.asdict(w) for w in value.wheels]
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            value = dataclasses.asdict(value)
        values[f.name] = _plain(value)
    del values["source"]
    text = json.dumps(values, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
