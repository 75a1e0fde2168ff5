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
from attitude_core.recording import EXIT_NO_PLANT, Outcome, StopRule
from attitude_core.scenario import is_ros_builtin, loads_scenario, scenario_yaml
from attitude_core.status import PlannerStatus
from attitude_ros import contract as c
from attitude_ros.params import declare_node_parameters, undeclared_parameters
from attitude_ros.runner import run
from attitude_tools.bag import BagWriter, qos_profile_yaml


def _stamp_ns(data: bytes) -> int:
    """Stamp of a message whose first field is a ``builtin_interfaces/Time`` (raw CDR)."""
    endian = "<" if data[1] & 1 else ">"
    sec, nanosec = struct.unpack_from(endian + "iI", data, 4)
    return sec * c.NS_PER_S + nanosec


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
        self.done, self.exit_code, self._drain_count = False, 0, -1
        self.last_stamp_ns: int | None = None
        self.unstamped: list[tuple[str, bytes, int]] = []  # before the first stamp
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
            wall = time.time_ns()
            if not stamped:  # logged at the latest stamp, so the bag is on the run's timeline
                if self.last_stamp_ns is None:
                    self.unstamped.append((name, data, wall))
                else:
                    self.writer.write(name, data, self.last_stamp_ns, wall)
                return
            log_time = _stamp_ns(data)
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

    def check_outcome(self) -> None:
        outcome = self.stop.poll(time.monotonic())
        if outcome is Outcome.NO_PLANT and not self.done:
            self.get_logger().error(
                f"no state on {c.ATTITUDE} after {self.stop.plant_timeout_s} s: is the "
                "simulator or the bridge running, on this ROS_DOMAIN_ID?"
            )
            self.done, self.exit_code = True, EXIT_NO_PLANT
        elif outcome is Outcome.DONE and not self.done:
            self.get_logger().info(f"recording complete ({self.stop.reason})")
            self.done = True

    def drained(self) -> bool:
        """True when nothing was written since the previous call (the runner drains the
        subscription queues on SIGINT/SIGTERM before closing the bag)."""
        count = self.writer.message_count
        drained, self._drain_count = count == self._drain_count, count
        return drained

    def close(self) -> None:
        self.writer.close()
        self.get_logger().info(
            f"bag closed: {self.writer.message_count} messages in {self.output_dir}"
        )


def main(args: list[str] | None = None) -> int:
    return run(BagRecorderNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
