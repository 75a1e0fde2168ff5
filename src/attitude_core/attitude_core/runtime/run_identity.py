"""Which nodes belong to a run, and whether they run the same scenario (no ROS import).

A run is identified by its **ROS namespace**: ``attitude-run`` starts every node of a
run with ``-r __ns:=/attitude_run_<id>`` (:func:`run_namespace`). The topics stay
absolute (``/spacecraft/attitude``, ...), so the topic contract is unchanged, but the
graph now tells whose a publisher is: an endpoint on a contract topic is the run's own
when its node is in the run's namespace and is a node the node table lets publish that
topic (:func:`foreign_publishers`). Why not the publisher GID of each sample: rclpy 7.1
(Jazzy) gives no ``publisher_gid`` in ``MessageInfo`` (only the timestamps and sequence
numbers), so samples of two writers on one topic cannot be told apart; a node that sees
a foreign writer on a topic it listens to therefore stops (``EXIT_FOREIGN_PUBLISHER``),
which ends the run at once with the writer named, before the writer's first sample can
matter (endpoint discovery precedes data).

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
import secrets
from collections.abc import Iterable
from typing import Any, NamedTuple

import numpy as np

from attitude_core.config.scenario import Scenario
from attitude_core.contract import node_graph
from attitude_core.contract import topics as t
from attitude_core.contract.exit_codes import EXIT_FINGERPRINT_MISMATCH, EXIT_FOREIGN_PUBLISHER

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
    "Endpoint",
    "run_namespace",
    "in_run",
    "scenario_fingerprint",
    "foreign_publishers",
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


def in_run(namespace: str) -> bool:
    """True for a run's namespace (nodes started by ``attitude-run``)."""
    return namespace.startswith("/" + RUN_NAMESPACE_PREFIX)


_TABLE_NAMES = frozenset(n.node_name for n in node_graph.NODES)
_PLANT_TOPICS = frozenset(node_graph.SIMULATOR.publishes) | frozenset(t.STATE_TOPICS)


def _may_publish(topic: str, name: str) -> bool:
    """Whether a node called ``name`` may publish ``topic`` in a run: the node table's
    publishers of it, and on the plant's topics a plant outside the table (a bridge)."""
    if any(name == n.node_name and topic in n.publishes for n in node_graph.NODES):
        return True
    return topic in _PLANT_TOPICS and name not in _TABLE_NAMES


def foreign_publishers(
    topic: str, endpoints: Iterable[Endpoint], own_namespace: str
) -> list[Endpoint]:
    """The publishers of ``topic`` that are not the run's own (see the module docstring).

    In the root namespace (nodes started by hand) every node of the table publishing its
    own topics counts as own, and so does any plant. On ``/diagnostics``, where every
    node publishes its identity and other tools may report too, only the table's nodes
    of another namespace (another run) are foreign."""
    if topic == t.DIAGNOSTICS:  # every node reports there; other tools may too
        return [e for e in endpoints if e.namespace != own_namespace and e.name in _TABLE_NAMES]
    return [e for e in endpoints if e.namespace != own_namespace or not _may_publish(topic, e.name)]


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
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            value = dataclasses.asdict(value)
        values[f.name] = _plain(value)
    del values["source"]
    text = json.dumps(values, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]
