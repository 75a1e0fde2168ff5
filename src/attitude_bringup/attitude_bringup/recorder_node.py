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
from attitude_core.status import PlannerStatus
from attitude_ros import contract as c
from attitude_ros.params import declare_node_parameters
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
        self.output_dir = own["output_dir"]
        if not self.output_dir:
            raise NodeParameterError(
                f"node '{self.get_name()}' parameters", "output_dir", "missing required parameter"
            )
        self.stop_on = {PlannerStatus.parse(s) for s in own["stop_on_planner_status"] if s}
        self.stop_delay_ns = int(c.NS_PER_S * own["stop_delay_s"])
        self.stop_at_ns: int | None = None
        self.passed_stop: set[str] = set()
        self.stamped_topics = {t.name for t in c.TOPICS if t.stamped}
        scenario_file = own["scenario_file"]
        self.done = False
        self.exit_code = 0
        self._drain_count = -1
        self.last_stamp_ns: int | None = None
        self.writer = BagWriter(self.output_dir)
        if scenario_file:
            with open(scenario_file, "rb") as f:
                self.writer.add_attachment("scenario.yaml", f.read(), "application/yaml")
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
            )
        self.get_logger().info(
            f"recording {len(c.TOPICS)} topics to {self.output_dir}"
            + (f"; stops on status {sorted(s.value for s in self.stop_on)}" if self.stop_on else "")
        )

    def callback(self, topic):
        name, stamped = topic.name, topic.stamped
        watch = name == c.DIAGNOSTICS and bool(self.stop_on)
        markers = tuple(status.value.encode() for status in self.stop_on)

        def on_message(data: bytes) -> None:
            wall = time.time_ns()
            if stamped:
                log_time = _stamp_ns(data)
                if self.stop_at_ns is not None and log_time > self.stop_at_ns:
                    self.passed_stop.add(name)
                    if self.passed_stop >= self.stamped_topics:
                        self.done = True
                    return
                self.last_stamp_ns = max(log_time, self.last_stamp_ns or log_time)
            else:
                log_time = wall if self.last_stamp_ns is None else self.last_stamp_ns
            self.writer.write(name, data, log_time, wall)
            if watch and self.stop_at_ns is None and any(m in data for m in markers):
                self.check_stop(data, log_time)

        return on_message

    def check_stop(self, data: bytes, stamp_ns: int) -> None:
        """A planner diagnostics message whose status ends the recording: stop at its
        stamp plus ``stop_delay_s``, once every stamped topic has got there."""
        for st in deserialize_message(data, DiagnosticArray).status:
            try:
                status = PlannerDiagnostics.from_values(
                    {kv.key: kv.value for kv in st.values}
                ).status
            except ValueError:  # another node's diagnostics
                continue
            if status in self.stop_on:
                break
        else:
            return
        self.stop_at_ns = stamp_ns + self.stop_delay_ns
        self.get_logger().info(
            f"planner status {status.value!r} at {stamp_ns / 1e9:.3f} s: recording until "
            f"{self.stop_at_ns / 1e9:.3f} s"
        )

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
