"""The lifecycle manager of one run without ROS: it drives the managed nodes through
their transitions, as nav2's lifecycle manager does, in the order of
:mod:`attitude_core.runtime.bringup`.

Inputs: the manager's parameters (:data:`attitude_core.config.node_parameters.MANAGER`),
the graph (:class:`ManagerGraph`: spin, the nodes alive, a topic's publishers, the
log), one :class:`ManagedNode` per managed node (its lifecycle services), the run
identities the nodes publish (:meth:`LifecycleManager.on_identity`), their transition
events (:meth:`LifecycleManager.on_event`) and command lines from ``attitude-run``
(:meth:`LifecycleManager.read_commands`). Outputs: the transitions requested, the
event lines (:func:`attitude_core.runtime.bringup.event_line`) on ``out`` and the exit
code of :meth:`LifecycleManager.session`.

1. ``configure`` each node as soon as its lifecycle services are there, in parallel (a
   refused scenario fails its configure: the node names the key and exits 2);
2. check: every loop node publishes its run identity with one scenario fingerprint;
   the plant is there: the named ``plant_nodes``, or the single node publishing every
   one of ``plant_topics`` (adopted: a second one is foreign), within
   ``plant_timeout_s``; ``plant_nodes`` is then set on every managed node;
3. with ``hold``, wait for a line ``activate`` (an operator's check point);
4. ``activate`` each in order; then watch: a transition the manager did not ask for is
   a failure; a line ``stop [NODE ...]`` (the nodes named there have exited), SIGINT
   or SIGTERM (``stop``) brings the nodes down: ``deactivate``, then ``shutdown``, in
   reverse order. A node that is gone (a line ``gone NODE ...``, or no longer in the
   graph) is skipped, and nothing is waited for once the parent process
   (``attitude-run``) has died.
"""

from __future__ import annotations

import functools
import os
import queue
import sys
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, Protocol, TextIO

from attitude_core.config import node_graph
from attitude_core.config.node_parameters import ManagerParams
from attitude_core.runtime import run_identity as ri
from attitude_core.runtime.bringup import (
    TRANSITION_GOALS,
    TransitionWatch,
    bring_down_order,
    event_line,
)

__all__ = [
    "POLL_S",
    "UNKNOWN_NODE",
    "Failure",
    "Call",
    "ManagedNode",
    "ManagerGraph",
    "LifecycleManager",
]

POLL_S = 0.05
"""How long one spin of a wait handles the graph's callbacks, s."""
UNKNOWN_NODE = "_NODE_NAME_UNKNOWN_"
"""rmw's name of an endpoint whose node is not known yet."""

OnEvent = Callable[[str, str, str], None]

LOST_ANSWER_S = 5.0
"""How long after a node's transition event to its goal the manager waits for the
call's answer before taking the event for it (at most half the transition timeout);
also how long a call waits with neither its answer nor the event before the manager asks
the node's state (``get_state``), and how often it asks again."""
STATE_PROBE_S = 2.0
"""How long one ``get_state`` probe of a node that has not answered waits, s."""


class Failure(Exception):
    """The run cannot go on: the reason names the node."""


class Call(Protocol):
    """A service call in flight (a future)."""

    def done(self) -> bool: ...

    def result(self) -> Any: ...


class ManagedNode(Protocol):
    """A managed node's lifecycle interface
    (:class:`attitude_ros.lifecycle_client.LifecycleClient`): a transition's call
    answers with ``success``; a parameter call with ``results``, each ``successful``."""

    def ready(self) -> bool: ...

    def transition(
        self, label: str, timeout_s: float, gone: Callable[[], bool] | None = None
    ) -> bool | None: ...

    def transition_async(self, label: str) -> Call: ...

    def state(self, timeout_s: float, gone: Callable[[], bool] | None = None) -> str | None: ...

    def params_ready(self) -> bool: ...

    def set_strings_async(self, key: str, values: Sequence[str]) -> Call: ...


class ManagerGraph(Protocol):
    """The manager's view of the ROS graph (the node shell implements it)."""

    def spin(self, timeout_s: float) -> None:
        """Handle the callbacks that are due, waiting at most ``timeout_s``."""

    def alive(self) -> set[str]:
        """The fully qualified names of the nodes in the graph."""

    def publishers(self, topic: str) -> list[ri.Endpoint]:
        """The publishers of ``topic`` (a node not known yet: :data:`UNKNOWN_NODE`)."""

    def namespace(self) -> str:
        """The manager's own namespace (the run's)."""

    def log(self, level: str, text: str) -> None:
        """Log ``text`` at ``level`` (info, warning, error)."""


class LifecycleManager:
    """See the module docstring. ``client(name, on_event)`` makes the lifecycle
    interface of the node ``name``; ``parent_pid``: the process that started this one
    (attitude-run), whose death ends the run without a bring-down; ``out``: where event
    lines go (default: stdout)."""

    def __init__(
        self,
        params: ManagerParams,
        graph: ManagerGraph,
        client: Callable[[str, OnEvent], ManagedNode],
        parent_pid: int,
        out: TextIO | None = None,
    ) -> None:
        self.p = params
        self.graph = graph
        self.parent_pid = parent_pid
        self.out = out
        self.names = [n for n in params.node_names if n]
        self.watch = TransitionWatch()
        self.reached: dict[str, str] = {}  # node -> the goal of its last transition event
        self.reached_at: dict[str, float] = {}  # ... and when it was heard (monotonic)
        self.failures: list[str] = []
        self.fingerprints: dict[str, tuple[str, str]] = {}  # node -> (role, fingerprint)
        self.nodes = {n: client(n, self.on_event) for n in self.names}
        self.commands: queue.Queue[str] = queue.Queue()
        self.gone: set[str] = set()  # nodes whose processes have ended (attitude-run says)

    # -- inputs ------------------------------------------------------------------------

    def emit(self, event: str, **fields: Any) -> None:
        """Print one event line (the log keeps it when attitude-run is gone)."""
        try:
            print(event_line(event, **fields), file=self.out or sys.stdout, flush=True)
        except (BrokenPipeError, OSError):
            self.graph.log("info", f"event {event} {fields} (no reader)")

    def on_event(self, name: str, start: str, goal: str) -> None:
        """A transition event of ``name``: one it was not asked for is a failure."""
        self.reached[name], self.reached_at[name] = goal, time.monotonic()
        failure = self.watch.judge(name, start, goal)
        if failure is not None and failure not in self.failures:
            self.failures.append(failure)
            self.graph.log("error", failure)
            self.emit("failure", reason=failure)

    def on_identity(self, name: str, values: Mapping[str, str]) -> None:
        """The run identity ``name`` published (role, scenario fingerprint)."""
        if name in self.nodes:
            self.fingerprints[name] = (values.get(ri.ROLE, ""), values.get(ri.FINGERPRINT, ""))

    def read_commands(self, lines: Iterable[str]) -> None:
        """Queue each command line (run on a thread: it blocks on ``lines``)."""
        for line in lines:
            self.commands.put(line.strip())

    def command(self) -> str | None:
        try:
            return self.commands.get_nowait()
        except queue.Empty:
            return None

    # -- the run -----------------------------------------------------------------------

    def session(self, stop: list[int]) -> int:
        """Bring up, watch until ``stop`` (a signal) or a line ``stop``, bring down: the
        exit code, 0 after a clean run, 1 after a failure."""
        try:
            try:
                self.bring_up(stop)
                self.run(stop)
                return 1 if self.failures else 0
            except Failure as err:
                self.graph.log("error", str(err))
                if str(err) not in self.failures:
                    self.emit("failure", reason=str(err))
                self.run(stop)  # attitude-run decides when the nodes go down
                return 1
        finally:
            self.bring_down()  # none when attitude-run died: the nodes have gone with it
            self.emit("down")

    def spin_until(self, done: Callable[[], Any], timeout_s: float, what: str) -> None:
        deadline = time.monotonic() + timeout_s
        while not done():
            if self.failures:
                raise Failure(self.failures[0])
            if time.monotonic() > deadline:
                raise Failure(f"{what} within {timeout_s:g} s")
            self.graph.spin(POLL_S)

    def transition(self, name: str, label: str) -> None:
        self.watch.request(name, label)
        ok = self.nodes[name].transition(label, self.p.transition_timeout_s)
        if ok is None and self.nodes[name].state(STATE_PROBE_S) == TRANSITION_GOALS[label]:
            self.graph.log(
                "warning", f"{name}: {label} answer lost; it is {TRANSITION_GOALS[label]}"
            )
            ok = True
        if not ok:
            why = "no answer" if ok is None else "failed"
            raise Failure(f"{name}: {label} {why} (see its log)")
        self.watch.settle(name, TRANSITION_GOALS[label])
        self.emit("transition", node=name, transition=label)

    def bring_up(self, stop: list[int]) -> None:
        self.configure_all()
        self.check_identities()
        plants = self.find_plant()
        self.set_plant(plants)
        self.emit("configured", plant_nodes=plants)
        if self.p.hold:
            self.emit("holding")
            self.spin_until(lambda: stop or self.command() == "activate", 1e9, "activate")
            if stop:
                return
        for name in self.names:
            self.transition(name, "activate")
        self.emit("active")

    def configure_all(self) -> None:
        """Configure every node, each as soon as its lifecycle services are there: the
        nodes configure in parallel (configure does not depend on the order; activate
        does, and stays in order)."""
        deadline = time.monotonic() + self.p.transition_timeout_s
        pending: dict[str, Call] = {}
        goal, now = TRANSITION_GOALS["configure"], time.monotonic

        grace = min(LOST_ANSWER_S, 0.5 * self.p.transition_timeout_s)
        asked: dict[str, float] = {}  # node -> when it was last asked (configure or state)
        confirmed: set[str] = set()  # nodes whose get_state says they configured

        def answered(name: str) -> bool:
            # The call's answer, or the node's own transition event to the goal with no
            # answer for a while after it: a response the middleware failed to send
            # ("failed to send response (timeout)") must not fail a node that did
            # configure (the event usually comes just before the answer).
            if pending[name].done() or name in confirmed:
                return True
            at = self.reached_at.get(name)
            return self.reached.get(name) == goal and at is not None and now() - at >= grace

        def probe(name: str) -> None:
            # Neither the answer nor the event for a while: both can be lost while the
            # node's writers still match the manager's readers (discovery is matched
            # one side at a time on a loaded machine); get_state, asked again on its
            # own, says whether the node configured.
            if now() - asked[name] >= grace:
                if self.nodes[name].state(STATE_PROBE_S) == goal:
                    confirmed.add(name)
                asked[name] = now()

        while len(pending) < len(self.names) or not all(answered(n) for n in pending):
            for name in self.names:
                if name not in pending and self.nodes[name].ready():
                    self.watch.request(name, "configure")
                    pending[name] = self.nodes[name].transition_async("configure")
                    asked[name] = now()
                elif name in pending and not answered(name):
                    probe(name)
            if self.failures:
                raise Failure(self.failures[0])
            if time.monotonic() > deadline:
                late = [n for n in self.names if n not in pending]
                if late:
                    raise Failure(
                        f"no lifecycle services of {late[0]} within "
                        f"{self.p.transition_timeout_s:g} s"
                    )
                silent = next(n for n in self.names if not answered(n))
                raise Failure(f"{silent}: configure no answer (see its log)")
            self.graph.spin(POLL_S)
        for name in self.names:  # in table order: the first refusal is the one named
            if not pending[name].done():  # configured, its answer lost on the way
                self.graph.log("warning", f"{name}: configure answer lost; it is {goal}")
            elif not pending[name].result().success:
                raise Failure(f"{name}: configure failed (see its log)")
            self.watch.settle(name, TRANSITION_GOALS["configure"])
            self.emit("transition", node=name, transition="configure")

    def check_identities(self) -> None:
        def heard() -> bool:
            return all(n in self.fingerprints for n in self.names)

        self.spin_until(heard, self.p.transition_timeout_s, "no run identity from every node")
        loop = {
            n: fp
            for n, (role, fp) in self.fingerprints.items()
            if role != node_graph.RECORDER.role and fp
        }
        if len(set(loop.values())) > 1:
            listed = ", ".join(f"{n} {fp}" for n, fp in sorted(loop.items()))
            raise Failure(f"scenario mismatch: the nodes run different scenarios ({listed})")

    def find_plant(self) -> list[str]:
        named = [n for n in self.p.plant_nodes if n]
        topics = [t for t in self.p.plant_topics if t]
        if named:
            self.spin_until(
                lambda: set(named) <= self.graph.alive(),
                self.p.plant_timeout_s,
                f"plant node {', '.join(sorted(set(named) - self.graph.alive()))} not found",
            )
            self.emit("plant", nodes=named, adopted=False)
            return named
        if not topics:
            return []
        found: list[ri.Endpoint] = []

        def one() -> bool:
            found[:] = self.candidates(topics)
            return bool(found)

        self.spin_until(one, self.p.plant_timeout_s, f"no plant published {topics[0]}")
        if len(found) > 1:
            names = ", ".join(e.node for e in found)
            raise Failure(
                f"{len(found)} nodes publish {' and '.join(topics)} ({names}): name the "
                "plant with --plant-node"
            )
        self.emit("plant", nodes=[found[0].node], adopted=True)
        return [found[0].node]

    def candidates(self, topics: list[str]) -> list[ri.Endpoint]:
        """The plants a run may adopt now; none while a publisher's node is still being
        discovered (its name comes a little after its endpoint)."""
        pubs: dict[str, list[ri.Endpoint]] = {}
        for t in topics:
            pubs[t] = self.graph.publishers(t)
            if any(e.name == UNKNOWN_NODE for e in pubs[t]):
                return []
        return ri.plant_candidates(pubs, topics, self.graph.namespace())

    def set_plant(self, plants: list[str]) -> None:
        """``plant_nodes`` on every node, in parallel."""
        timeout = self.p.transition_timeout_s
        for name in self.names:
            self.spin_until(self.nodes[name].params_ready, timeout, f"{name}: plant_nodes not set")
        futures = {n: self.nodes[n].set_strings_async("plant_nodes", plants) for n in self.names}
        for name, future in futures.items():
            self.spin_until(future.done, timeout, f"{name}: plant_nodes not set")
            result = future.result()
            if result is None or not all(r.successful for r in result.results):
                raise Failure(f"{name}: plant_nodes not set")

    def run(self, stop: list[int]) -> None:
        """Watch until ``stop`` or a line ``stop [NODE ...]`` (the nodes named there
        have exited already: attitude-run saw their processes end)."""
        while not stop:
            words = (self.command() or "").split()
            if words[:1] == ["stop"]:
                self.gone.update(words[1:])
                return
            self.graph.spin(POLL_S)

    # -- the bring-down ----------------------------------------------------------------

    def orphaned(self) -> bool:
        """Whether the process that started this one has died (its nodes get the same
        parent-death signal and end with it). Asked again at every wait of the
        bring-down: the kernel sends that signal when the *thread* that started the
        process exits, so it can come while the parent's other threads are still
        ending, and this process is reparented only after the last one."""
        return os.getppid() != self.parent_pid

    def has_gone(self, name: str) -> bool:
        """Whether ``name`` is no longer there to bring down: attitude-run says its
        process has ended with a line ``gone NODE ...`` (a node may end by itself, e.g.
        the simulator at the scenario's end); or the node has left the graph (a node
        leaves it when it is destroyed: stopped by the same signal as this manager);
        or attitude-run itself has died (:meth:`orphaned`). No waiting on its services
        then."""
        while (line := self.command()) is not None:
            words = line.split()
            if words[:1] == ["gone"]:
                self.gone.update(words[1:])
        return name in self.gone or name not in self.graph.alive() or self.orphaned()

    def bring_down(self) -> None:
        """Deactivate, then shut down, in reverse order; a node that is gone (exited,
        or not in the graph) is skipped; nothing is done once attitude-run has died."""
        order = bring_down_order(self.names)
        for label in ("deactivate", "shutdown"):
            for name in order:
                gone = functools.partial(self.has_gone, name)
                state = None if gone() else self.nodes[name].state(1.0, gone)
                if (
                    state is None
                    or state == "finalized"
                    or (label == "deactivate" and state != "active")
                ):
                    continue
                self.watch.request(name, label)
                if self.nodes[name].transition(label, 5.0, gone):
                    self.watch.settle(name, TRANSITION_GOALS[label])
