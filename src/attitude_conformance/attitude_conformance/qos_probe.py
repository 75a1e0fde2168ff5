"""The connection as the node sees it: incompatible-QoS events per topic, when to subscribe
the attitude (last), and each contract topic's endpoints in the graph (for
:func:`.checks_process.check_qos`)."""

from __future__ import annotations

from typing import Any

from rclpy.event_handler import PublisherEventCallbacks, SubscriptionEventCallbacks
from rclpy.qos import qos_policy_name_from_kind

from attitude_ros import contract as c

from .checks_process import TopicQos

DISCOVERY_GRACE_S = 2.0  # wait this long for the rate's match before listening to the attitude


class QosProbe:
    """Watches the endpoints of ``node`` (the tool's own publishers and subscriptions)."""

    def __init__(self, node: Any) -> None:
        self.node = node
        self.incompatible: dict[str, list[str]] = {}  # topic -> policies of the events
        self.attitude_seen_s: float | None = None

    def _record(self, name: str) -> Any:
        def record(info: Any) -> None:
            policy = qos_policy_name_from_kind(info.last_policy_kind)
            self.incompatible.setdefault(name, []).append(policy)

        return record

    def publisher_events(self, name: str) -> PublisherEventCallbacks:
        return PublisherEventCallbacks(incompatible_qos=self._record(name))

    def subscription_events(self, name: str) -> SubscriptionEventCallbacks:
        return SubscriptionEventCallbacks(incompatible_qos=self._record(name))

    def attitude_due(self, subs: dict[str, Any], now: float) -> bool:
        """Time to subscribe the attitude (``subs``: the subscriptions so far): the bridge
        starts when it is matched, so the rate (and clock, applied torque) subscriptions
        must be matched by then; or the attitude has been in the graph for a while, or an
        endpoint is incompatible."""
        if self.node.count_publishers(c.ATTITUDE) and self.attitude_seen_s is None:
            self.attitude_seen_s = now
        others = [n for n in subs if self.node.count_publishers(n)]
        matched = bool(others) and all(subs[n].get_publisher_count() for n in others)
        seen = self.attitude_seen_s
        grace = seen is not None and now - seen > DISCOVERY_GRACE_S
        return matched or grace or bool(self.incompatible)

    def topics(self, pubs: dict[str, Any], subs: dict[str, Any]) -> list[TopicQos]:
        """The state topics and the torque the plant steps on (with wheels: the wheel
        states and the motor torques), required; the others when the bridge has them or
        they had an event. The bridge's endpoints are the graph's but the tool's own."""
        node, me = self.node, self.node.get_name()
        out = []
        wheels = c.WHEEL_TORQUE in pubs
        steps_on = c.WHEEL_TORQUE if wheels else c.TORQUE
        wanted = [(c.ATTITUDE, True), (c.ANGULAR_VELOCITY, True), (c.APPLIED_TORQUE, False)]
        wanted += [(c.WHEEL_STATES, True)] if wheels else []
        wanted += [(c.CLOCK, False)] + [(name, name == steps_on) for name in pubs]
        for name, required in wanted:
            ours = name in pubs
            infos = (
                node.get_subscriptions_info_by_topic if ours else node.get_publishers_info_by_topic
            )(name)
            matched = 0
            if ours:
                matched = pubs[name].get_subscription_count()
            elif name in subs:
                matched = subs[name].get_publisher_count()
            out.append(
                TopicQos(
                    name,
                    "subscription" if ours else "publisher",
                    required,
                    matched,
                    self.incompatible.get(name, []),
                    [
                        (
                            i.node_namespace.rstrip("/") + "/" + i.node_name,
                            i.qos_profile.reliability.name,
                            i.qos_profile.durability.name,
                        )
                        for i in infos
                        if i.node_name != me
                    ],
                )
            )
        return [t for t in out if t.required or t.endpoints or t.incompatible]
