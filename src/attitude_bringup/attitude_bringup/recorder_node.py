"""rosbag2-compatible MCAP recorder of the topic contract (``ros2 run ... bag_recorder``).

Records every topic of :mod:`attitude_ros.contract` as raw CDR, exactly as received,
into ``output_dir`` (``metadata.yaml`` + ``<name>_0.mcap``, storage ``mcap``,
profile ``ros2``, schemas ``ros2msg``). It subscribes reliable and keep-all, and the
publishers keep every sample until all readers have it, so a recorder that lags
behind a lockstep run slows it down instead of losing messages.

Message log times are the message's own stamp (simulated time in lockstep, the state
clock in real time); unstamped messages (status, margin) get the latest stamp seen,
so the bag's timeline is the run's timeline. The receive wall time is kept as the
publish time. The bag is finished on every way out (end, SIGINT, SIGTERM).

A message with an implausible stamp (``attitude_core.recording.implausible_stamp``:
negative fields, or more than ``STAMP_AHEAD_LIMIT_S`` of run time ahead of the latest
plausible stamp) is still recorded, at the latest plausible stamp, like an unstamped
one; it never moves the timeline or the stop rule. It is counted, warned about
(throttled, naming topic and stamp), the count is in the close log line and in the
bag's metadata.yaml ``custom_data.recorder_bad_stamps``.

The bag writer finishes its chunk every 0.25 s of wall time, so a recorder killed at
any moment loses at most that much (``attitude-bag-recover`` or ``attitude-run``
finishes the bag). A failed write (a full disk) stops the recording: the error is
logged with the path and cause and the recorder exits ``EXIT_DISK_FULL`` (4) or
``EXIT_WRITE_FAILED`` (5), leaving the bag for recovery.

Parameters: ``output_dir`` (required); ``stop_on_planner_status`` (planner statuses
that end the recording, ``PlannerStatus`` values, read from the stamped
``/diagnostics`` so the stop is exact in run time; empty: record until shut down);
``stop_delay_s`` (run time recorded after that status, 1 s by default, so the bag shows
the settle; the recording ends when every stamped topic has passed it);
``scenario_file`` (stored in the bag as an MCAP attachment ``scenario.yaml``, so a
bag alone describes its run).
"""

from __future__ import annotations

import struct
import time
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.serialization import deserialize_message

from attitude_core import node_graph
from attitude_core.diagnostics import PlannerDiagnostics
from attitude_core.parameters import NodeParameterError
from attitude_core.recording import (
    EXIT_DISK_FULL,
    EXIT_NO_PLANT,
    EXIT_WRITE_FAILED,
    Outcome,
    StopRule,
    implausible_stamp,
)
from attitude_core.scenario import is_ros_builtin, loads_scenario, scenario_yaml
from attitude_core.status import PlannerStatus
from attitude_ros import contract as c
from attitude_ros.params import declare_node_parameters, undeclared_parameters
from attitude_ros.run_guard import RunGuard
from attitude_ros.runner import run
from attitude_tools.bag import BagWriteError, BagWriter, qos_profile_yaml

BAD_STAMP_WARN_EVERY_S = 5.0
"""Wall time between two warnings about implausible stamps (the first is logged at once)."""


def _stamp(data: bytes) -> tuple[int, int]:
    """(sec, nanosec) of a message whose first field is a ``builtin_interfaces/Time``."""
    endian = "<" if data[1] & 1 else ">"
    sec, nanosec = struct.unpack_from(endian + "iI", data, 4)
    return sec, nanosec


class BagRecorderNode(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__(node_graph.RECORDER.node_name, **kwargs)
        own, _ = declare_node_parameters(self, node_graph.RECORDER.parameters)
        source = f"node '{self.get_fully_qualified_name()}' parameters"
        self.output_dir = own["output_dir"]
        if not self.output_dir:
            raise NodeParameterError(source, "output_dir", "missing required parameter")
        scenario_text = self.scenario_text(own["scenario_file"])
        scenario = loads_scenario(scenario_text, source) if scenario_text else None
        self.stop = StopRule(
            {PlannerStatus.parse(s) for s in own["stop_on_planner_status"] if s},
            own["stop_delay_s"],
            started=time.monotonic(),
            scenario_time_s=None if scenario is None else scenario.sim_time_s,
            plant_timeout_s=own["plant_timeout_s"],
        )
        self.scenario_time_s = None if scenario is None else scenario.sim_time_s
        self.done, self.exit_code, self._drain_count = False, 0, -1
        self.last_stamp_ns: int | None = None
        self.unstamped: list[tuple[str, bytes, int]] = []  # before the first stamp
        self.bad_stamps, self._bad_warned_at = 0, -float("inf")
        self.write_error: BagWriteError | None = None
        self.writer = BagWriter(self.output_dir)
        if scenario_text:
            self.writer.add_attachment("scenario.yaml", scenario_text.encode(), "application/yaml")
        for topic in c.TOPICS:
            pub_qos = c.qos(topic)
            self.writer.add_topic(
                topic.name,
                topic.type_name,
                qos_profile_yaml(
                    "reliable",
                    "transient_local" if topic.latched else "volatile",
                    pub_qos.depth,
                    "keep_last" if topic.latched else "keep_all",
                ),
            )
            self.create_subscription(
                c.message_class(topic.type_name),
                topic.name,
                self.callback(topic),
                c.recorder_qos(topic),
                raw=True,
                qos_overriding_options=c.state_qos_overrides(topic),
            )
        self.create_timer(0.1, self.check_outcome)
        # Foreign publishers on any contract topic are logged and counted (attitude-run
        # names them in the summary); the recorder records on.
        self.guard = RunGuard(
            self,
            node_graph.RECORDER,
            scenario,
            lambda code, reason: None,
            stamp_ns=lambda: self.last_stamp_ns or 0,
            stops=False,
        )
        stops = sorted(s.value for s in self.stop.stop_on)
        self.get_logger().info(
            f"recording {len(c.TOPICS)} topics to {self.output_dir}"
            + (f"; stops on status {stops}" if stops else "")
            + ("" if scenario is None else f"; scenario '{scenario.name}' attached")
        )

    def scenario_text(self, scenario_file: str) -> str | None:
        """The scenario to attach: ``scenario_file``, else the scenario parameters given
        to this node (the nodes' ``--params-file``), else None."""
        if scenario_file:
            with open(scenario_file, encoding="utf-8") as f:
                return f.read()
        given = undeclared_parameters(self)  # its own rows are declared
        flat = {key: value for key, value in given.items() if not is_ros_builtin(key)}
        return scenario_yaml(flat) if flat else None

    def callback(self, topic):
        name, stamped = topic.name, topic.stamped
        watch = name == c.DIAGNOSTICS and bool(self.stop.stop_on)
        markers = tuple(status.value.encode() for status in self.stop.stop_on)

        def on_message(data: bytes) -> None:
            if self.write_error is not None:
                return  # recording stopped
            try:
                record(data)
            except BagWriteError as err:
                self.on_write_failed(err)

        def record(data: bytes) -> None:
            wall = time.time_ns()
            bad = None
            unstamped = not stamped
            if stamped:
                sec, nanosec = _stamp(data)
                # A zero stamp on /diagnostics: a node's run identity before its first state.
                unstamped = name == c.DIAGNOSTICS and sec == 0 and nanosec == 0
                bad = None
                if not unstamped:
                    bad = implausible_stamp(
                        sec, nanosec, self.last_stamp_ns, wall, self.scenario_time_s
                    )
                if bad is not None:
                    self.on_bad_stamp(name, sec, nanosec, bad)
            if unstamped or bad is not None:  # logged at the latest stamp: on the timeline
                if self.last_stamp_ns is None:
                    self.unstamped.append((name, data, wall))
                else:
                    self.writer.write(name, data, self.last_stamp_ns, wall)
                return
            log_time = sec * c.NS_PER_S + nanosec
            if not self.stop.on_stamped(name, log_time, time.monotonic()):
                self.check_outcome()
                return
            self.last_stamp_ns = max(log_time, self.last_stamp_ns or log_time)
            for held in self.unstamped:
                self.writer.write(held[0], held[1], log_time, held[2])
            self.unstamped.clear()
            self.writer.write(name, data, log_time, wall)
            if watch and any(m in data for m in markers):
                self.check_stop(data, log_time)

        return on_message

    def check_stop(self, data: bytes, stamp_ns: int) -> None:
        """A planner diagnostics message whose status ends the recording: stop at its
        stamp plus ``stop_delay_s``, once every stamped topic has got there."""
        for st in deserialize_message(data, DiagnosticArray).status:
            try:
                values = {kv.key: kv.value for kv in st.values}
                status = PlannerDiagnostics.from_values(values).status
            except ValueError:  # another node's diagnostics
                continue
            if self.stop.on_status(status, stamp_ns) and self.stop.stop_at_ns is not None:
                self.get_logger().info(
                    f"planner status {status.value!r} at {stamp_ns / 1e9:.3f} s: recording "
                    f"until {self.stop.stop_at_ns / 1e9:.3f} s"
                )

    def on_bad_stamp(self, topic: str, sec: int, nanosec: int, why: str) -> None:
        """Count a message with an implausible stamp; warn, throttled."""
        self.bad_stamps += 1
        now = time.monotonic()
        if now - self._bad_warned_at < BAD_STAMP_WARN_EVERY_S:
            return
        self._bad_warned_at = now
        at = (
            "held until the first stamp"
            if self.last_stamp_ns is None
            else (f"recorded at the latest stamp {self.last_stamp_ns / 1e9:.3f} s")
        )
        self.get_logger().warning(
            f"implausible stamp on {topic}: sec={sec} nanosec={nanosec} ({why}); {at}; "
            f"{self.bad_stamps} implausible stamps so far"
        )
        self.writer.update_custom_data(recorder_bad_stamps=str(self.bad_stamps))

    def on_write_failed(self, err: BagWriteError) -> None:
        """Stop recording after a failed write: log path and cause, exit non-zero."""
        if self.write_error is not None:
            return
        self.write_error = err
        cause = f"disk full: {err}" if err.disk_full else f"write failed: {err}"
        self.get_logger().error(
            f"cannot record the bag: {cause}; recording stopped, {self.writer.message_count} "
            f"messages kept for recovery (attitude-bag-recover {self.output_dir})"
        )
        self.done = True
        self.exit_code = EXIT_DISK_FULL if err.disk_full else EXIT_WRITE_FAILED

    def check_outcome(self) -> None:
        if self.write_error is None and self.writer.error is not None:  # the flusher failed
            self.on_write_failed(self.writer.error)
        if self.write_error is not None:
            return
        outcome = self.stop.poll(time.monotonic())
        if outcome is Outcome.NO_PLANT and not self.done:
            self.get_logger().error(
                f"no state on {c.ATTITUDE} after {self.stop.plant_timeout_s} s: is the "
                "simulator or the bridge running, on this ROS_DOMAIN_ID?"
            )
            self.done, self.exit_code = True, EXIT_NO_PLANT
        elif outcome is Outcome.DONE and not self.done:
            try:
                self.writer.flush()  # a full disk shows now, in the exit code
            except BagWriteError as err:
                self.on_write_failed(err)
                return
            self.get_logger().info(f"recording complete ({self.stop.reason})")
            self.done = True

    def drained(self) -> bool:
        """True when nothing was written since the previous call (the runner drains the
        subscription queues on SIGINT/SIGTERM before closing the bag)."""
        count = self.writer.message_count
        drained, self._drain_count = count == self._drain_count, count
        if drained and self.write_error is None:
            try:
                self.writer.flush()  # a full disk shows now, in the exit code
            except BagWriteError as err:
                self.on_write_failed(err)
        return drained

    def close(self) -> None:
        self.writer.custom_data["recorder_bad_stamps"] = str(self.bad_stamps)
        try:
            self.writer.close()
        except BagWriteError as err:  # sets the exit code; the runner reads it after close
            self.on_write_failed(err)
        state = "left unfinished for recovery" if self.writer.error else "closed"
        self.get_logger().info(
            f"bag {state}: {self.writer.message_count} messages in {self.output_dir}; "
            f"{self.bad_stamps} implausible stamps"
        )


def main(args: list[str] | None = None) -> int:
    return run(BagRecorderNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
