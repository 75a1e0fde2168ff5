"""``ros2 run attitude_conformance bridge_check``: the node that checks a bridge.

It stands in for the planner and the controller (publishers of ``/controller/torque``,
``/planner/target_mrp`` and ``/planner/target_rate``, the latter two silent), listens to
what the bridge publishes (:mod:`.sampling`, :mod:`.qos_probe`), plays
:class:`.driver.Driver`'s script (:mod:`.watch`: when it gives up), then prints one line
per contract point and a summary (:mod:`.verdict`). Exit code 0 when every point passes
(or is skipped), 1 when one fails, 2 on bad parameters (:mod:`.loop`).
Parameters: ``mode``, ``scenario``, ``timeout_s``, ``launch`` (see :data:`PARAMETERS`).

With a scenario that declares ``wheels.*`` it stands in for the wheeled controller: it
answers each state on ``/controller/wheel_torque`` (the motor torques, by wheel name) and
the body torque they make on ``/controller/torque`` (for the record, as the controller
does), and listens to ``/spacecraft/wheel_states``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from attitude_core.config import node_graph
from attitude_core.config.node_parameters import NodeParameters
from attitude_core.config.parameters import Bounds, NodeParameterError, Param, ParamKind
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_ros import contract as c
from attitude_ros import convert as cv
from attitude_ros.endpoints import message, publisher
from attitude_ros.params import declare_node_parameters

from . import loop, verdict
from .bridge_process import start_bridge
from .driver import Driver, wheel_order
from .message_io import sample_of, wheel_command
from .qos_probe import QosProbe
from .record import Recording, Setup
from .sampling import Sampler, Torques
from .watch import Watch


@dataclass(frozen=True)
class CheckParams:
    mode: TimeMode
    scenario: str
    timeout_s: float
    launch: str


PARAMETERS = NodeParameters(
    values=CheckParams,
    own=(
        Param("mode", ParamKind.STR, "time mode of the bridge", "lockstep", choices=TimeMode),
        Param(
            "scenario",
            ParamKind.PATH,
            "scenario file the bridge runs (dt_s, inertia, initial state)",
        ),
        Param(
            "timeout_s",
            ParamKind.FLOAT,
            "wall-time limit of the whole check, s",
            60.0,
            Bounds(1.0, 3600.0),
        ),
        Param(
            "launch",
            ParamKind.STR,
            "command starting the bridge (empty: it is already running)",
            "",
        ),
    ),
    scenario=None,
)
PARAMETERS_SOURCE = "node 'bridge_check' parameters"


class BridgeCheckNode(loop.CheckNode):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__("bridge_check", **kwargs)
        own, _ = declare_node_parameters(self, PARAMETERS)
        self.mode = own.mode
        self.scenario = load_scenario(own.scenario)
        self.rec = Recording(Setup.from_scenario(self.scenario, self.mode))
        self.rec.system_offset_s = time.time() - time.monotonic()  # the link's latency
        self.driver = Driver(self.rec)
        self.sampler = Sampler(self.rec, self.driver)
        self.watch = Watch(self.driver, own.timeout_s, time.monotonic())
        self.done = False
        self.exit_code = 0
        self.probe = QosProbe(self)
        self.wheels = self.scenario.wheels
        ours = [*node_graph.readiness(1).min_publishers]
        heard = [c.ANGULAR_VELOCITY, c.APPLIED_TORQUE, c.CLOCK]
        if self.wheels is not None:  # the plant steps on the motor torques
            ours.append(c.WHEEL_TORQUE)
            heard.append(c.WHEEL_STATES)
        self.pubs = {
            name: publisher(self, name, event_callbacks=self.probe.publisher_events(name))
            for name in ours
        }
        self.subs = {name: self._subscribe(name) for name in heard}
        try:
            self.bridge = start_bridge(own.launch, own.scenario, self.mode)
        except OSError as err:
            raise NodeParameterError(PARAMETERS_SOURCE, "launch", str(err)) from err

    def _subscribe(self, name: str) -> Any:
        """The contract's class and subscriber QoS, as the stack's nodes have it (without
        the QoS overrides: the probe's profile is the contract's)."""
        entry = c.topic(name)
        return self.create_subscription(
            c.message_class(entry.type_name),
            name,
            lambda msg: self.on_message(name, msg),
            c.qos(entry, subscriber=True),
            event_callbacks=self.probe.subscription_events(name),
        )

    def on_message(self, name: str, msg: Any) -> None:
        now = time.monotonic()
        sample = sample_of(name, msg, now)
        self.send(self.sampler.heard(name, sample), now)

    def send(self, torques: Torques, now: float) -> None:
        for stamp, u in torques:
            order, body = None, u
            if self.wheels is not None:  # u: the motor torques, in the scenario's order
                order = wheel_order(self.driver.index.get(stamp, 0), len(self.wheels))
                wheel = wheel_command(self.wheels.names, u, order, stamp)
                self.pubs[c.WHEEL_TORQUE].publish(wheel)
                body = self.wheels.body_torque_b(u)
            msg = message(c.TORQUE)
            cv.set_stamp(msg.header.stamp, stamp)
            cv.set_vector3(msg.wrench.torque, body)
            self.pubs[c.TORQUE].publish(msg)
            self.sampler.sent(stamp, u, now, order)

    def tick(self) -> None:
        """Called by the loop between callbacks. The attitude is subscribed last: the
        bridge starts when it is matched."""
        now = time.monotonic()
        if c.ATTITUDE not in self.subs and self.probe.attitude_due(self.subs, now):
            self.subs[c.ATTITUDE] = self._subscribe(c.ATTITUDE)
        self.send(self.driver.on_tick(now), now)
        incompatible = bool(self.probe.incompatible)
        self.watch.check(now, incompatible, bool(self.rec.attitude), self.bridge)
        self.done = self.driver.done

    def abort(self, reason: str) -> None:
        self.driver.abort(reason, time.monotonic())

    def report(self) -> None:
        """Judge, stop a launched bridge, print; sets the exit code."""
        topics = self.probe.topics(self.pubs, self.subs)
        what = f"{self.mode}, scenario {self.scenario.name}"
        incompatible = bool(self.probe.incompatible)
        self.exit_code = verdict.report(self.rec, topics, incompatible, self.bridge, what)

    def close(self) -> None:
        if self.bridge is not None:
            self.bridge.close()


def main(args: list[str] | None = None) -> int:
    """Spin until the script ends (or SIGINT/SIGTERM), drain, report."""
    return loop.run(BridgeCheckNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
