"""rosbag2-compatible MCAP recorder of the topic contract (``ros2 run ... bag_recorder``).

Records every topic of :mod:`attitude_ros.contract` as raw CDR, exactly as received,
into ``output_dir`` (``metadata.yaml`` + ``<name>_0.mcap``, storage ``mcap``, profile
``ros2``), reliable and keep-all: a recorder that lags behind a lockstep run slows it
down instead of losing messages. Log times follow the run's timeline
(:mod:`attitude_bringup.timeline`: stamps, unstamped and implausibly stamped messages,
``custom_data.recorder_bad_stamps``); the receive wall time is the publish time.

Managed: it records while active; ``deactivate`` flushes. The writer finishes its chunk
every 0.25 s of wall time, so a recorder killed at any moment loses at most that much
(``attitude-bag-recover`` finishes the bag). A failed write stops the recording: exit
``EXIT_DISK_FULL`` (4) or ``EXIT_WRITE_FAILED`` (5). The bag is finished on every way out.

Parameters (:data:`attitude_core.config.node_parameters.RECORDER`): ``output_dir``;
``stop_on_planner_status`` (read from the stamped ``/diagnostics``, so the stop is
exact in run time); ``stop_delay_s`` of run time recorded after it; ``plant_timeout_s``;
``scenario_file`` (attached as ``scenario.yaml``, so a bag alone describes its run).
"""

from __future__ import annotations

import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.serialization import deserialize_message

from attitude_core.config import node_graph
from attitude_core.config.parameters import NodeParameterError
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.contract.faults import reported_status
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import NS_PER_S, Topic
from attitude_core.runtime.recording import (
    EXIT_DISK_FULL,
    EXIT_NO_PLANT,
    EXIT_WRITE_FAILED,
    Outcome,
    StopRule,
)
from attitude_ros import contract as c
from attitude_ros.endpoints import raw_subscription
from attitude_ros.node_base import StackNode
from attitude_ros.params import declare_node_parameters, undeclared_parameters
from attitude_ros.run_guard import RunGuard
from attitude_ros.runner import run

from .timeline import Timeline, open_bag, scenario_attachment


class BagRecorderNode(StackNode):
    spec = node_graph.RECORDER

    def configure(self) -> None:
        own, _ = declare_node_parameters(self, node_graph.RECORDER.parameters)
        source = f"node '{self.get_fully_qualified_name()}' parameters"
        self.output_dir = own.output_dir
        if not self.output_dir:
            raise NodeParameterError(source, "output_dir", "missing required parameter")
        # The scenario given to this node (its own rows are declared), or its file.
        scenario_text = scenario_attachment(own.scenario_file, undeclared_parameters(self))
        scenario = loads_scenario(scenario_text, source) if scenario_text else None
        run_time_s = None if scenario is None else scenario.sim_time_s
        self.stop_rule = StopRule(
            {PlannerStatus.parse(s) for s in own.stop_on_planner_status if s},
            own.stop_delay_s,
            started=time.monotonic(),
            scenario_time_s=run_time_s,
            plant_timeout_s=own.plant_timeout_s,
        )
        self.writer = open_bag(self.output_dir, scenario_text)
        self.timeline = Timeline(self.writer, self.stop_rule, run_time_s, self.get_logger().warning)
        self.reported = False  # a failed write was logged
        for topic in c.TOPICS + c.COMMAND_TOPICS:  # the goal: <run namespace>/planner/goal
            raw_subscription(self, topic.name, self.callback(topic))
        self.create_timer(0.1, self.check_outcome)
        # Foreign publishers on any contract topic are logged and counted (attitude-run
        # names them in the summary); the recorder records on.
        stamp = lambda: self.timeline.last_stamp_ns or 0
        self.guard = RunGuard(self, self.spec, scenario, lambda *_: None, stamp, stops=False)
        stops = sorted(s.value for s in self.stop_rule.stop_on)
        attached = "" if scenario is None else f"; scenario '{scenario.name}' attached"
        self.get_logger().info(f"recording to {self.output_dir}; stops on {stops}{attached}")

    def callback(self, topic: Topic) -> Any:
        stop_on = self.stop_rule.stop_on if topic.name == c.DIAGNOSTICS else ()
        markers = tuple(status.value.encode() for status in stop_on)  # looked for in the CDR

        def on_message(data: bytes) -> None:
            if not self.active:  # records while active only
                return
            done = self.timeline.record(topic, data, time.time_ns(), time.monotonic())
            if self.write_failed():
                return
            if done.past_stop:
                self.check_outcome()
            elif done.log_time_ns is not None and any(m in data for m in markers):
                self.check_stop(data, done.log_time_ns)

        return on_message

    def check_stop(self, data: bytes, stamp_ns: int) -> None:
        """A planner status that ends the recording: stop at its stamp plus ``stop_delay_s``
        once every stamped topic is there (none parsed once one has: later is later)."""
        stop = self.stop_rule
        for st in () if stop.status_stopped else deserialize_message(data, DiagnosticArray).status:
            status = reported_status(st.name, st.level[0], {kv.key: kv.value for kv in st.values})
            if status is None:
                continue
            if stop.on_status(status, stamp_ns) and stop.stop_at_ns is not None:
                self.get_logger().info(
                    f"planner status {status.value!r} at {stamp_ns / NS_PER_S:.3f} s: "
                    f"recording until {stop.stop_at_ns / NS_PER_S:.3f} s"
                )

    def write_failed(self) -> bool:
        """After a failed write (recording stopped): log path and cause once, exit non-zero."""
        err = self.timeline.failed()
        if err is None or self.reported:
            return err is not None
        self.reported = True
        self.get_logger().error(
            f"cannot record the bag: {'disk full' if err.disk_full else 'write failed'}: {err}; "
            f"recording stopped, {self.writer.message_count} messages kept for recovery "
            f"(attitude-bag-recover {self.output_dir})"
        )
        self.stop(EXIT_DISK_FULL if err.disk_full else EXIT_WRITE_FAILED)
        return True

    def activate(self) -> None:
        self.stop_rule.started = time.monotonic()  # the plant's time starts now

    def deactivate(self) -> None:
        if not self.timeline.flush():  # what was recorded is on disk
            self.write_failed()

    def check_outcome(self) -> None:
        if self.write_failed() or self.done or not self.active:
            return
        outcome = self.stop_rule.poll(time.monotonic())
        if outcome is Outcome.NO_PLANT:
            self.get_logger().error(
                f"no state on {c.ATTITUDE} after {self.stop_rule.plant_timeout_s} s: is the "
                "simulator or the bridge running, on this ROS_DOMAIN_ID?"
            )
            self.stop(EXIT_NO_PLANT)
        elif outcome is Outcome.DONE:
            if not self.timeline.flush():  # a full disk shows now, in the exit code
                self.write_failed()
                return
            self.get_logger().info(f"recording complete ({self.stop_rule.reason})")
            self.done = True

    def drained(self) -> bool:
        """Nothing written since the previous call (the runner drains on SIGINT/SIGTERM)."""
        drained = self.timeline.drained()
        self.write_failed()
        return drained

    def close(self) -> None:
        bad = self.timeline.bad_stamps
        self.timeline.close()
        self.write_failed()  # sets the exit code; the runner reads it after close
        state = "left unfinished for recovery" if self.writer.error else "closed"
        self.get_logger().info(
            f"bag {state}: {self.writer.message_count} messages in {self.output_dir}; "
            f"{bad} implausible stamps"
        )


def main(args: list[str] | None = None) -> int:
    return run(BagRecorderNode, args, fast_exit=True)


if __name__ == "__main__":
    raise SystemExit(main())
