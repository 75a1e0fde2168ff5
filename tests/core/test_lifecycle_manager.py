"""The run's lifecycle manager without ROS (:mod:`attitude_core.runtime.lifecycle_manager`).

Driven with a fake graph and fake managed nodes that record every request: the
bring-up order (configure all, then activate in table order), the bring-down in
reverse order, nodes that are gone (``stop NODE``, ``gone NODE``, out of the graph)
skipped, nothing done once the parent process has died, a transition nobody asked for
and a refused configure named as failures (exit 1 once stopped), a scenario mismatch,
plant adoption, the hold, and the event lines.
"""

from __future__ import annotations

import io
import os
from types import SimpleNamespace

from attitude_core.config import node_graph
from attitude_core.config.node_parameters import ManagerParams
from attitude_core.runtime import run_identity as ri
from attitude_core.runtime.bringup import TRANSITION_GOALS, parse_event
from attitude_core.runtime.lifecycle_manager import UNKNOWN_NODE, LifecycleManager

NS = "/attitude_run_test"
SPECS = (node_graph.RECORDER, node_graph.PLANNER, node_graph.CONTROLLER, node_graph.SIMULATOR)
NAMES = [f"{NS}/{spec.node_name}" for spec in SPECS]
REC, PLANNER, CONTROLLER, SIM = NAMES


class Done:
    """A service call that has answered ``value``."""

    def __init__(self, value) -> None:
        self.value = value

    def done(self) -> bool:
        return True

    def result(self):
        return self.value


class FakeNode:
    """A managed node: its state, and every request in the shared ``journal``."""

    def __init__(self, name, on_event, journal, refuse=()) -> None:
        self.name = name
        self.on_event = on_event
        self.journal = journal
        self.refuse = refuse
        self.current = "unconfigured"
        self.plant_nodes = None

    def ready(self) -> bool:
        return True

    def _go(self, label: str) -> bool:
        self.journal.append((label, self.name))
        if label in self.refuse:
            return False
        self.on_event(self.name, self.current, TRANSITION_GOALS[label])
        self.current = TRANSITION_GOALS[label]
        return True

    def transition(self, label, timeout_s, gone=None):
        return self._go(label)

    def transition_async(self, label):
        return Done(SimpleNamespace(success=self._go(label)))

    def state(self, timeout_s, gone=None):
        self.journal.append(("get_state", self.name))
        return self.current

    def params_ready(self) -> bool:
        return True

    def set_strings_async(self, key, values):
        self.plant_nodes = list(values)
        return Done(SimpleNamespace(results=[SimpleNamespace(successful=True)]))


class FakeGraph:
    """The graph: the nodes alive, publishers by topic, the log; ``on_spin`` runs at
    every spin (what arrives meanwhile)."""

    def __init__(self) -> None:
        self.nodes = set(NAMES)
        self.pubs: dict[str, list[ri.Endpoint]] = {}
        self.logs: list[tuple[str, str]] = []
        self.on_spin = lambda: None

    def spin(self, timeout_s: float) -> None:
        self.on_spin()

    def alive(self) -> set[str]:
        return set(self.nodes)

    def publishers(self, topic: str) -> list[ri.Endpoint]:
        return list(self.pubs.get(topic, []))

    def namespace(self) -> str:
        return NS

    def log(self, level: str, text: str) -> None:
        self.logs.append((level, text))


def make(parent_pid=None, fingerprints=("f",) * 4, refuse=None, **params):
    """A manager of the four nodes, their identities heard; ``refuse``: node ->
    transitions it fails."""
    values = dict(
        node_names=tuple(NAMES),
        plant_nodes=("",),
        plant_topics=("",),
        plant_timeout_s=0.3,
        transition_timeout_s=0.3,
        hold=False,
    )
    values.update(params)
    graph = FakeGraph()
    journal: list[tuple[str, str]] = []
    out = io.StringIO()
    refuse = refuse or {}
    client = lambda name, on_event: FakeNode(name, on_event, journal, refuse.get(name, ()))
    pid = os.getppid() if parent_pid is None else parent_pid
    m = LifecycleManager(ManagerParams(**values), graph, client, pid, out=out)
    for spec, name, fp in zip(SPECS, NAMES, fingerprints, strict=True):
        m.on_identity(name, {ri.ROLE: spec.role, ri.FINGERPRINT: fp})
    m.on_identity("/elsewhere/fepf_planner", {ri.ROLE: "planner", ri.FINGERPRINT: "other"})
    return m, graph, journal, out


def events(out: io.StringIO) -> list[dict]:
    return [e for line in out.getvalue().splitlines() if (e := parse_event(line))]


def requests(journal, label):
    return [name for lbl, name in journal if lbl == label]


def test_a_clean_run_comes_up_in_order_and_goes_down_in_reverse():
    m, _, journal, out = make()
    m.commands.put("stop")
    assert m.session([]) == 0
    assert requests(journal, "configure") == NAMES
    assert requests(journal, "activate") == NAMES
    assert requests(journal, "deactivate") == NAMES[::-1]
    assert requests(journal, "shutdown") == NAMES[::-1]
    assert journal.index(("activate", REC)) > journal.index(("configure", SIM))
    kinds = [e["event"] for e in events(out)]
    assert kinds == ["transition"] * 4 + ["configured"] + ["transition"] * 4 + ["active", "down"]
    assert events(out)[4] == {"event": "configured", "plant_nodes": []}
    assert m.failures == []


def test_a_signal_ends_the_watch_too():
    m, graph, journal, _ = make()
    stop: list[int] = []
    graph.on_spin = lambda: stop.append(15)
    assert m.session(stop) == 0
    assert requests(journal, "shutdown") == NAMES[::-1]


def test_nodes_that_are_gone_are_skipped_in_the_bring_down():
    m, graph, journal, out = make()
    m.commands.put(f"stop {SIM}")  # exited before the bring-down
    m.commands.put(f"gone {CONTROLLER}")  # exits during it
    graph.nodes.discard(PLANNER)  # left the graph: destroyed
    assert m.session([]) == 0
    assert requests(journal, "deactivate") == [REC]
    assert requests(journal, "shutdown") == [REC]
    assert set(requests(journal, "get_state")) == {REC}  # no waiting on the others
    assert events(out)[-1] == {"event": "down"}


def test_nothing_is_brought_down_once_the_parent_has_died():
    m, _, journal, out = make(parent_pid=os.getppid() + 100_000)
    assert m.orphaned()
    m.commands.put("stop")
    assert m.session([]) == 0
    assert requests(journal, "activate") == NAMES
    assert requests(journal, "get_state") == []
    assert requests(journal, "deactivate") == requests(journal, "shutdown") == []
    assert events(out)[-1] == {"event": "down"}


def test_a_transition_nobody_asked_for_is_a_failure_reported_once():
    m, graph, journal, out = make()
    spins = []

    def unasked() -> None:
        spins.append(1)
        m.on_event(CONTROLLER, "deactivating", "inactive")  # a hand deactivate
        if len(spins) == 3:
            m.commands.put("stop")

    graph.on_spin = unasked
    assert m.session([]) == 1
    failures = [e for e in events(out) if e["event"] == "failure"]
    assert len(failures) == 1 and "unexpected transition" in failures[0]["reason"]
    assert CONTROLLER in failures[0]["reason"]
    assert ("error", failures[0]["reason"]) in graph.logs
    assert requests(journal, "shutdown") == NAMES[::-1]


def test_a_refused_configure_is_named_and_the_nodes_wait_for_stop():
    m, graph, journal, out = make(refuse={CONTROLLER: ("configure",)})
    m.commands.put("stop")
    assert m.session([]) == 1
    reason = f"{CONTROLLER}: configure failed (see its log)"
    assert [e for e in events(out) if e["event"] == "failure"] == [
        {"event": "failure", "reason": reason}
    ]
    assert ("error", reason) in graph.logs
    assert requests(journal, "activate") == []
    assert requests(journal, "deactivate") == []  # none active
    assert requests(journal, "shutdown") == NAMES[::-1]


def test_a_scenario_mismatch_among_the_loop_nodes_fails_the_run():
    m, _, journal, out = make(fingerprints=("rec", "a", "b", "a"))
    m.commands.put("stop")
    assert m.session([]) == 1
    (failure,) = [e["reason"] for e in events(out) if e["event"] == "failure"]
    assert failure.startswith("scenario mismatch") and f"{PLANNER} a" in failure
    assert f"{CONTROLLER} b" in failure and REC not in failure  # the recorder's is not one
    assert requests(journal, "activate") == []


def test_the_single_node_publishing_the_plant_topics_is_adopted():
    topics = ("/spacecraft/attitude", "/spacecraft/angular_velocity")
    m, graph, journal, out = make(plant_topics=topics)
    bridge = ri.Endpoint("/", "bsk_bridge")
    graph.pubs = {t: [ri.Endpoint("/", UNKNOWN_NODE)] for t in topics}
    graph.on_spin = lambda: graph.pubs.update({t: [bridge] for t in topics})  # discovered
    m.commands.put("stop")
    assert m.session([]) == 0
    assert {"event": "plant", "nodes": ["/bsk_bridge"], "adopted": True} in events(out)
    assert all(node.plant_nodes == ["/bsk_bridge"] for node in m.nodes.values())


def test_two_plants_are_a_failure_naming_both():
    topics = ("/spacecraft/attitude",)
    m, graph, _, out = make(plant_topics=topics)
    graph.pubs = {topics[0]: [ri.Endpoint("/", "bridge_a"), ri.Endpoint("/", "bridge_b")]}
    m.commands.put("stop")
    assert m.session([]) == 1
    (failure,) = [e["reason"] for e in events(out) if e["event"] == "failure"]
    assert "/bridge_a" in failure and "/bridge_b" in failure and "--plant-node" in failure


def test_a_named_plant_that_never_appears_times_out():
    m, _, _, out = make(plant_nodes=("/bsk_bridge",))
    m.commands.put("stop")
    assert m.session([]) == 1
    (failure,) = [e["reason"] for e in events(out) if e["event"] == "failure"]
    assert failure == "plant node /bsk_bridge not found within 0.3 s"


def test_hold_waits_for_the_activate_line():
    m, graph, journal, out = make(hold=True)
    m.commands.put("status")  # not 'activate': the hold goes on
    held = []

    def operator() -> None:
        seen = [e["event"] for e in events(out)]
        if "active" in seen:
            m.commands.put("stop")
        elif "holding" in seen:
            held.append(requests(journal, "activate"))
            if len(held) == 3:
                m.commands.put("activate")

    graph.on_spin = operator
    assert m.session([]) == 0
    assert held == [[], [], []]  # nothing activated while holding
    assert requests(journal, "activate") == NAMES


def test_a_signal_during_the_hold_brings_the_nodes_down_without_activating():
    m, graph, journal, _ = make(hold=True)
    stop: list[int] = []
    graph.on_spin = lambda: stop.append(2)
    assert m.session(stop) == 0
    assert requests(journal, "activate") == []
    assert requests(journal, "shutdown") == NAMES[::-1]


def test_events_go_to_the_log_when_nobody_reads_them():
    class Closed(io.StringIO):
        def write(self, s):
            raise BrokenPipeError

    m, graph, _, _ = make()
    m.out = Closed()
    m.emit("down")
    assert graph.logs == [("info", "event down {} (no reader)")]


class Lost:
    """A service call whose answer never comes (the middleware failed to send it)."""

    def done(self) -> bool:
        return False

    def result(self):
        raise AssertionError("no answer")


def test_a_configure_answer_lost_on_the_way_is_taken_from_the_transition_event():
    """The node configured (its transition event says so) but its answer was lost: the
    bring-up goes on; a node that neither answers nor configures is named."""
    m, graph, journal, out = make()
    planner = m.nodes[PLANNER]

    def configure_silently(label):
        planner._go(label)  # the node's transition happens, its event is heard
        return Lost()

    planner.transition_async = configure_silently
    m.commands.put("stop")
    assert m.session([]) == 0
    assert requests(journal, "activate") == NAMES
    assert ("warning", f"{PLANNER}: configure answer lost; it is inactive") in graph.logs
    m, graph, journal, out = make()
    planner = m.nodes[PLANNER]

    def configure_unheard(label):
        planner.current = TRANSITION_GOALS[label]  # configured; answer and event lost
        return Lost()

    planner.transition_async = configure_unheard
    m.commands.put("stop")
    assert m.session([]) == 0  # its get_state says it configured
    up = journal[: journal.index(("activate", NAMES[0]))]
    assert requests(up, "get_state") == [PLANNER]
    assert requests(journal, "activate") == NAMES
    assert ("warning", f"{PLANNER}: configure answer lost; it is inactive") in graph.logs
    m, graph, journal, out = make()
    m.nodes[PLANNER].transition_async = lambda label: Lost()  # nothing happens
    m.commands.put("stop")
    assert m.session([]) == 1
    (failure,) = [e["reason"] for e in events(out) if e["event"] == "failure"]
    assert failure == f"{PLANNER}: configure no answer (see its log)"
    assert requests(journal, "get_state").count(PLANNER) >= 1  # asked, still unconfigured


def test_an_activate_answer_lost_is_taken_from_the_nodes_state():
    """activate answered by nothing, but the node is active: the run goes on, warned;
    a node that neither answers nor activates is named."""
    m, graph, journal, out = make()
    planner = m.nodes[PLANNER]

    def activate_unheard(label, timeout_s, gone=None):
        planner.current = TRANSITION_GOALS[label]
        return None

    planner.transition = activate_unheard
    m.commands.put("stop")
    assert m.session([]) == 0
    assert ("warning", f"{PLANNER}: activate answer lost; it is active") in graph.logs
    m, graph, journal, out = make()
    m.nodes[PLANNER].transition = lambda label, timeout_s, gone=None: None
    m.commands.put("stop")
    assert m.session([]) == 1
    (failure,) = [e["reason"] for e in events(out) if e["event"] == "failure"]
    assert failure == f"{PLANNER}: activate no answer (see its log)"
