"""A node's guard against foreign publishers and mismatched peers (see
:mod:`attitude_core.runtime.run_identity` for the rules and why).

Every node of the table creates one :class:`RunGuard`. It

* audits the publishers of the topics the node takes, every :data:`AUDIT_PERIOD_S` and
  at once when a message arrives while the topic's publisher count changed (counted on
  the node's own subscription when it was given, :meth:`RunGuard.watch`); a foreign
  publisher is logged with its node name and counted; in a run's namespace the node then
  stops with ``EXIT_FOREIGN_PUBLISHER`` (``admit`` refuses the topic's samples from the
  moment it is seen, and while a writer on it is not identified yet: its node name
  comes a little after the endpoint, at most :data:`UNKNOWN_GRACE_S` is waited);
* publishes the node's identity (role, run namespace, scenario fingerprint, foreign
  publishers and refused messages so far) on ``/diagnostics`` every
  :data:`IDENTITY_PERIOD_S`;
* compares the fingerprints of its peers of the same namespace and stops the node with
  ``EXIT_FINGERPRINT_MISMATCH`` on a difference; :meth:`peers_agree` tells the
  simulator's start-up gate whether every loop node present has been heard and agrees.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from attitude_core.config import node_graph
from attitude_core.config.node_graph import NodeSpec
from attitude_core.config.scenario import Scenario
from attitude_core.runtime import run_identity as ri
from attitude_ros import contract as c
from attitude_ros.convert import set_stamp

AUDIT_PERIOD_S = 0.25
IDENTITY_PERIOD_S = 1.0
UNKNOWN_GRACE_S = 1.0
"""An endpoint whose node is not known yet (discovery in progress) is judged after this."""
_UNKNOWN = "_NODE_NAME_UNKNOWN_"

Fatal = Callable[[int, str], None]


def identity_qos(depth: int = 1) -> Any:
    """The run identity on ``/diagnostics``: reliable and transient-local (the last one
    of each node reaches a node that starts later). The recorder's and the tools'
    volatile ``/diagnostics`` readers take it as any other sample."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(  # type: ignore[no-untyped-call]
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL,
    )


def diagnostics_events(node: Node, publisher: bool) -> Any:
    """Event callbacks for a ``/diagnostics`` endpoint of ours. The guards' identity
    readers are transient-local so that they do not take the planner's volatile per-step
    diagnostics: DDS reports each such pair as incompatible DURABILITY, by design, which
    is logged at debug level. Any other incompatible policy warns, as rclpy's default."""
    from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
    from rclpy.qos import QoSPolicyKind

    log: Any = node.get_logger()  # type: ignore[no-untyped-call]  # unannotated
    other = "subscription" if publisher else "publisher"

    def on_incompatible(event: Any) -> None:
        policy = QoSPolicyKind(event.last_policy_kind)
        if policy is QoSPolicyKind.DURABILITY:
            log.debug(
                f"{c.DIAGNOSTICS}: a {other} of the other durability is not matched (by "
                "design: run identities are transient-local, per-step diagnostics volatile)"
            )
        else:
            log.warning(
                f"{c.DIAGNOSTICS}: a {other} with incompatible QoS ({policy.name}) was "
                "discovered; no messages pass between them"
            )

    if publisher:
        return PublisherEventCallbacks(incompatible_qos=on_incompatible)
    return SubscriptionEventCallbacks(incompatible_qos=on_incompatible)


def _short(readers: Mapping[str, int], wanted: Mapping[str, int]) -> bool:
    """Whether an output has fewer matched readers (``readers``: topic -> count) than
    ``wanted``; a topic missing from ``readers`` counts none."""
    return any(readers.get(name, 0) < n for name, n in wanted.items())


class RunGuard:
    def __init__(
        self,
        node: Node,
        spec: NodeSpec[Any],
        scenario: Scenario | None,
        on_fatal: Fatal,
        stamp_ns: Callable[[], int] = lambda: 0,
        stops: bool = True,
    ) -> None:
        """``stops``: False for an observer (the recorder), which logs and counts foreign
        publishers but records on, and checks no peers."""
        self.node, self.spec, self.on_fatal, self.stamp_ns = node, spec, on_fatal, stamp_ns
        self.log: Any = node.get_logger()  # type: ignore[no-untyped-call]  # unannotated
        self.namespace = node.get_namespace()
        self.strict = stops and ri.in_run(self.namespace)
        self.stops = stops
        self.fingerprint = "" if scenario is None else ri.scenario_fingerprint(scenario)
        # The inputs whose publishers are the run's own: not an operator's (the goal).
        commands = {topic.name for topic in c.COMMAND_TOPICS}
        self.inputs = tuple(name for name in spec.subscribes if name not in commands)
        self.foreign: dict[tuple[str, ri.Endpoint], float] = {}  # -> when first seen
        self.compromised: set[str] = set()
        self.refused_foreign = 0
        self._counts: dict[str, int] = {}  # publishers per input at the last audit
        self._subscriptions: dict[str, Any] = {}  # input -> the node's subscription (watch)
        self._unknown_since: dict[str, float] = {}
        self.peers: dict[str, str] = {}  # role -> fingerprint, same namespace
        self.peers_matched: dict[str, bool] = {}  # role -> its outputs all matched
        self.peers_readers: dict[str, dict[str, int]] = {}  # role -> topic -> matched readers
        self._readers_said: dict[str, int] | None = None  # as last published
        self.matched = False  # as last published
        self._agreed_since: float | None = None
        self.fatal = False
        self.pub = node.create_publisher(DiagnosticArray, c.DIAGNOSTICS, identity_qos())
        # Peers' identities: transient-local, so a late joiner gets each peer's last one at
        # once; and it does not match the planner's volatile per-step diagnostics (taking
        # those in every node would cost 10 % of the lockstep rate).
        self.sub: Any = None
        if stops:
            self.sub = node.create_subscription(
                DiagnosticArray,
                c.DIAGNOSTICS,
                self._on_diagnostics,
                identity_qos(depth=16),
                event_callbacks=diagnostics_events(node, publisher=False),
            )
        node.create_timer(AUDIT_PERIOD_S, self.audit)
        node.create_timer(IDENTITY_PERIOD_S, self.publish_identity)
        self.publish_identity()
        # Checked every 20 ms until the loop runs (a cheap test while inactive): the
        # identity is published again at once when the matched readers change.
        self._match_timer: Any = node.create_timer(0.02, self._check_matched) if stops else None

    # -- foreign publishers --------------------------------------------------------

    def watch(self, topic: str, subscription: Any) -> Any:
        """Count ``topic``'s writers on the node's own ``subscription`` of it (its matched
        publishers: one cheap call per message, no graph query) in :meth:`admit`;
        returns the subscription."""
        self._subscriptions[topic] = subscription
        return subscription

    def _publisher_count(self, topic: str) -> int:
        sub = self._subscriptions.get(topic)
        count: int = (
            sub.get_publisher_count() if sub is not None else self.node.count_publishers(topic)
        )
        return count

    def admit(self, topic: str) -> bool:
        """Whether a sample just taken from ``topic`` may be used (call per message)."""
        if self._match_timer is not None:  # the loop runs: the start-up gate is passed
            self._match_timer.cancel()
            self._match_timer = None
        if self._publisher_count(topic) != self._counts.get(topic):
            self.audit()
        if topic in self.compromised or (self.strict and topic in self._unknown_since):
            self.refused_foreign += 1  # foreign, or a writer not identified yet
            return False
        return True

    def audit(self) -> None:
        now = time.monotonic()
        plants = self.plant_nodes()
        # In a run, before activation and with no plant named yet, a plant outside the
        # namespace is not judged: the lifecycle manager adopts one first. This holds for
        # the observer (the recorder) too, which would otherwise log the plant as foreign.
        adopting = (
            ri.in_run(self.namespace) and not plants and not getattr(self.node, "active", True)
        )
        if plants and self.foreign:  # seen before the plant was named, adopted since
            for topic, endpoint in list(self.foreign):
                if not ri.foreign_publishers(topic, [endpoint], self.namespace, plants):
                    del self.foreign[(topic, endpoint)]
        for topic in self.inputs:
            infos = self.node.get_publishers_info_by_topic(topic)
            self._counts[topic] = self._publisher_count(topic)
            endpoints = []
            pending = False
            for info in infos:
                if info.node_name == _UNKNOWN:  # its node is not discovered yet
                    since = self._unknown_since.setdefault(topic, now)
                    if now - since < UNKNOWN_GRACE_S:
                        pending = True
                        continue
                endpoints.append(ri.Endpoint(info.node_namespace, info.node_name))
            if not pending:
                self._unknown_since.pop(topic, None)
            for endpoint in ri.foreign_publishers(topic, endpoints, self.namespace, plants):
                if adopting and topic in ri.PLANT_TOPICS:
                    continue  # the manager names the plant before it activates the node
                self._found(topic, endpoint, now, plants)

    def plant_nodes(self) -> tuple[str, ...]:
        """The adopted plant's nodes (the node's ``plant_nodes`` parameter)."""
        get = getattr(self.node, "plant_nodes", None)
        return tuple(get()) if get is not None else ()

    def _found(
        self, topic: str, endpoint: ri.Endpoint, now: float, plants: tuple[str, ...] = ()
    ) -> None:
        key = (topic, endpoint)
        if key in self.foreign:
            return
        self.foreign[key] = now
        if endpoint.namespace == self.namespace:
            where = "this run's namespace, not a publisher of this topic"
        else:
            where = "another run" if ri.in_run(endpoint.namespace) else "no run"
        adopted = (
            f"; adopted plant {', '.join(plants)}" if topic in ri.PLANT_TOPICS and plants else ""
        )
        text = (
            f"foreign publisher {endpoint.node} ({where}) on {topic}, which this node "
            f"takes; run namespace {self.namespace}{adopted}"
        )
        self.log.error(text)
        if self.strict:
            self.compromised.add(topic)
            self._fatal(ri.EXIT_FOREIGN_PUBLISHER, text)
        self.publish_identity()

    def foreign_names(self) -> list[str]:
        return [f"{topic} <- {e.node}" for topic, e in self.foreign]

    # -- identity and peers --------------------------------------------------------

    # -- outputs matched before the first step --------------------------------------

    def _outputs(self) -> list[Any]:
        """The node's publishers of per-step contract topics (not the latched status nor
        ``/diagnostics``, whose identity readers are of another durability)."""
        per_step = {
            name
            for name in self.spec.publishes
            if name != c.DIAGNOSTICS and not c.topic(name).latched
        }
        return [pub for pub in self.node.publishers if pub.topic_name in per_step]

    def outputs_matched(self) -> bool:
        """Whether the node is active and each of its per-step outputs has matched at
        least the readers the graph shows of it (each is sure to get the first sample)."""
        if not getattr(self.node, "active", True):
            return False
        return all(
            pub.get_subscription_count() >= self.node.count_subscribers(pub.topic_name)
            for pub in self._outputs()
        )

    def matched_readers(self) -> dict[str, int]:
        """Readers matched by each of the node's per-step outputs, as its writers count
        them (:func:`~attitude_core.config.node_graph.per_step_outputs`; on
        ``/diagnostics`` the per-step writer, not the identity's)."""
        per_step = set(node_graph.per_step_outputs(self.spec))
        return {
            pub.topic_name: pub.get_subscription_count()
            for pub in self.node.publishers
            if pub.topic_name in per_step and pub is not self.pub
        }

    def _check_matched(self) -> None:
        """Say it as soon as the matched readers change (and every IDENTITY_PERIOD_S)."""
        if self.matched_readers() != self._readers_said or self.outputs_matched() != self.matched:
            self.publish_identity()

    def publish_identity(self) -> None:
        self.matched = self.outputs_matched()
        self._readers_said = self.matched_readers()
        values = {
            ri.ROLE: self.spec.role,
            ri.RUN_NAMESPACE: self.namespace,
            ri.FINGERPRINT: self.fingerprint,
            ri.FOREIGN_PUBLISHERS: str(len(self.foreign)),
            ri.FOREIGN_NAMES: "; ".join(self.foreign_names()),
            ri.REJECTED_MESSAGES: str(
                int(getattr(self.node, "rejected", 0)) + self.refused_foreign
            ),
            ri.OUTPUTS_MATCHED: "1" if self.matched else "0",
            ri.MATCHED_READERS: ri.format_readers(self._readers_said),
        }
        status = DiagnosticStatus(
            level=DiagnosticStatus.ERROR if self.foreign else DiagnosticStatus.OK,
            name=self.node.get_fully_qualified_name(),
            message="foreign publisher" if self.foreign else "run identity",
            hardware_id=ri.IDENTITY_HARDWARE_ID,
            values=[KeyValue(key=k, value=v) for k, v in values.items()],
        )
        msg = DiagnosticArray(status=[status])
        set_stamp(msg.header.stamp, self.stamp_ns())
        self.pub.publish(msg)

    def _on_diagnostics(self, msg: Any) -> None:
        for status in msg.status:
            if status.hardware_id != ri.IDENTITY_HARDWARE_ID:
                continue
            values = {kv.key: kv.value for kv in status.values}
            role, fingerprint = values.get(ri.ROLE), values.get(ri.FINGERPRINT, "")
            if values.get(ri.RUN_NAMESPACE) != self.namespace or role is None:
                continue
            if role == self.spec.role or not fingerprint or not self.fingerprint:
                continue  # itself, or a node without a scenario (the recorder)
            self.peers[role] = fingerprint
            self.peers_matched[role] = values.get(ri.OUTPUTS_MATCHED, "1") == "1"
            self.peers_readers[role] = ri.parse_readers(values.get(ri.MATCHED_READERS, ""))
            if fingerprint != self.fingerprint:
                self._fatal(
                    ri.EXIT_FINGERPRINT_MISMATCH,
                    f"scenario mismatch: {status.name} ({role}) runs scenario fingerprint "
                    f"{fingerprint}, this node ({self.spec.role}) {self.fingerprint}: were "
                    "they started with the same scenario file?",
                )

    def peers_agree(self, min_readers: Mapping[str, Mapping[str, int]] | None = None) -> bool:
        """True once every loop node of this namespace in the graph has been heard with
        this node's fingerprint, and with its outputs and this node's matched (the
        simulator's start-up gate; for at most :data:`~ri.MATCH_GRACE_S` the matching
        is waited for, then the run starts with a warning naming who is unmatched).

        ``min_readers`` (:attr:`~attitude_core.config.node_graph.Readiness.min_readers`):
        per role, the readers each per-step output must have matched, counted by the
        node that publishes it (this node's own, and each present peer's as it last
        said): every expected reader then takes the first sample."""
        present = {
            name
            for name, namespace in self.node.get_node_names_and_namespaces()
            if namespace == self.namespace
        }
        wanted = min_readers or {}
        own = self.matched_readers()
        # Of its own outputs, those it has (a simulator publishes the state or the
        # sensors, as the run has them).
        mine = {name: n for name, n in wanted.get(self.spec.role, {}).items() if name in own}
        unmatched = [] if self.outputs_matched() else [self.spec.role]
        if not unmatched and _short(own, mine):
            unmatched.append(self.spec.role)
        for spec in node_graph.SENSING_LOOP:
            if spec.role == self.spec.role or spec.node_name not in present:
                continue
            if self.peers.get(spec.role) != self.fingerprint:
                if spec in node_graph.LOOP:
                    self._agreed_since = None
                    return False
                continue  # the estimator's identity is not waited for
            readers = self.peers_readers.get(spec.role, {})
            if not self.peers_matched.get(spec.role, True) or _short(
                readers, wanted.get(spec.role, {})
            ):
                unmatched.append(spec.role)
        if not unmatched:
            return True
        now = time.monotonic()
        self._agreed_since = self._agreed_since or now
        if now - self._agreed_since < ri.MATCH_GRACE_S:
            return False
        self.log.warning(
            f"starting with outputs of {', '.join(unmatched)} not matched by every reader "
            f"after {ri.MATCH_GRACE_S:g} s (a reader of incompatible QoS?)",
            throttle_duration_sec=5.0,
        )
        return True

    def _fatal(self, code: int, text: str) -> None:
        if not self.stops:
            self.log.error(text, throttle_duration_sec=5.0)
            return
        if not self.fatal:
            self.fatal = True
            self.log.error(f"stopping: {text}")
            self.on_fatal(code, text)
