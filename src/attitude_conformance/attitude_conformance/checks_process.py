"""Checks of the connection and the process: ``qos``, ``plant`` and ``sigint``, from plain
data."""

from __future__ import annotations

from dataclasses import dataclass, field

from attitude_core.contract.topics import STATE_TOPICS

from .record import FAIL, PASS, SKIP, Result

SIGINT_GRACE_S = 5.0


@dataclass
class TopicQos:
    """One contract topic as the tool saw it: ``matched`` endpoints of the bridge on the
    tool's own endpoint, the policies of incompatible-QoS events, and the bridge's
    endpoints in the graph as ``(node, reliability, durability)``."""

    topic: str
    bridge_role: str  # "publisher" or "subscription"
    required: bool
    matched: int = 0
    incompatible: list[str] = field(default_factory=list)
    endpoints: list[tuple[str, str, str]] = field(default_factory=list)


def _endpoints(t: TopicQos) -> str:
    if not t.endpoints:
        return f"no {t.bridge_role} in the graph"
    return ", ".join(f"{node or '?'} {rel}/{dur}" for node, rel, dur in t.endpoints)


def check_qos(topics: list[TopicQos], domain: str = "") -> Result:
    """Reliable, volatile endpoints matched on every required topic; an incompatible
    profile is named."""
    for t in topics:
        if t.incompatible:
            return Result(
                "qos",
                FAIL,
                f"{t.topic}: a {t.bridge_role} with incompatible QoS "
                f"({', '.join(sorted(set(t.incompatible)))}): {_endpoints(t)}; the contract "
                f"is reliable, volatile (attitude_ros.contract.qos){_override_hint(t.topic)}",
            )
    for t in topics:
        if t.required and t.matched == 0:
            where = f" on ROS_DOMAIN_ID {domain}" if domain else ""
            return Result(
                "qos", FAIL, f"{t.topic}: no {t.bridge_role} matched{where} ({_endpoints(t)})"
            )
        best_effort = [e for e in t.endpoints if e[1] != "RELIABLE"]
        if best_effort:
            return Result(
                "qos",
                FAIL,
                f"{t.topic}: {t.bridge_role} {_endpoints(t)}; the contract is reliable"
                f"{_override_hint(t.topic)}",
            )
    names = ", ".join(t.topic for t in topics if t.matched)
    return Result("qos", PASS, f"reliable, volatile endpoints matched on {names}")


def check_plant(topics: list[TopicQos]) -> Result:
    """The node ``attitude-run --plant external`` would adopt: the single node publishing
    both state topics (any namespace). Two such nodes is a failure (a run adopts none);
    a state split over several nodes needs each named (``--plant-node``): SKIP."""
    publishers = {t.topic: {e[0] for e in t.endpoints} for t in topics if t.topic in STATE_TOPICS}
    if set(publishers) != set(STATE_TOPICS) or not all(publishers.values()):
        return Result("plant", SKIP, "no publisher of both state topics in the graph")
    both = sorted(set.intersection(*publishers.values()))
    if len(both) == 1:
        return Result(
            "plant",
            PASS,
            f"{both[0]} publishes both state topics: attitude-run --plant external adopts "
            f"it (or names it: --plant-node {both[0]})",
        )
    if len(both) > 1:
        return Result(
            "plant",
            FAIL,
            f"{len(both)} nodes publish both state topics ({', '.join(both)}): a run adopts "
            "none of them; stop the strays or name the plant with --plant-node",
        )
    split = sorted(set.union(*publishers.values()))
    flags = " ".join(f"--plant-node {n}" for n in split)
    return Result("plant", SKIP, f"the state is split over {', '.join(split)}: run with {flags}")


def _override_hint(topic: str) -> str:
    """For a best-effort state publisher: how the stack connects it anyway."""
    if topic not in STATE_TOPICS:
        return ""
    return (
        f" (a best-effort driver is connected by setting "
        f"qos_overrides.{topic}.subscription.reliability:=best_effort on the planner, the "
        "controller and the recorder; docs/hil_bridge.md, section 5)"
    )


def check_sigint(
    launched: bool, exited_before: int | None, code: int | None, took_s: float, output: str
) -> Result:
    """The bridge the tool started exits 0 within 5 s of SIGINT, without a traceback."""
    if not launched:
        return Result("sigint", SKIP, "the bridge was not started by the tool (--launch)")
    if exited_before is not None:
        return Result("sigint", FAIL, f"the bridge exited by itself with code {exited_before}")
    if code is None:
        return Result("sigint", FAIL, f"still running {SIGINT_GRACE_S:g} s after SIGINT (killed)")
    if code != 0:
        return Result("sigint", FAIL, f"exit code {code} after SIGINT, expected 0")
    if "Traceback" in output:
        return Result("sigint", FAIL, "exit code 0 but a Traceback in its output")
    return Result("sigint", PASS, f"exit code 0, {took_s:.2f} s after SIGINT, no Traceback")
