"""rosbag2-compatible MCAP recorder of the topic contract (``ros2 run attitude_bringup bag_recorder``).

Records every topic of :mod:`attitude_ros.contract` as raw CDR, exactly as received,
into ``output_dir`` (``metadata.yaml`` + ``<name>_0.mcap``, storage ``mcap``,
profile ``ros2``, schemas ``ros2msg``). It subscribes reliable and transient-local, so
samples published before its subscriptions matched still arrive.

Message log times are the message's own stamp (simulated time in lockstep, the state
clock in real time); unstamped messages (status, margin) get the latest stamp seen,
so the bag's timeline is the run's timeline. The receive wall time is kept as the
publish time. The bag is finished on every way out (end, SIGINT, SIGTERM).

Parameters: ``output_dir`` (required); ``stop_on_planner_status`` (statuses of
``/planner/status`` that end the recording, e.g. ``[arrived, stuck, infeasible]``;
empty: record until shut down); ``stop_delay_s`` (run time recorded after that
status, 1 s by default, so the bag shows the arrival settle); ``scenario_file`` (stored in the bag as an MCAP
attachment ``scenario.yaml``, so a bag alone describes its run).
"""

from __future__ import annotations

import struct
import time

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from std_msgs.msg import String

from attitude_core.scenario import ScenarioError
from attitude_ros import contract as c
from attitude_ros.params import declare
from attitude_ros.runner import run
from attitude_tools.bag import BagWriter, qos_profile_yaml


def _stamp_ns(data: bytes) -> int:
    """Stamp of a message whose first field is a ``builtin_interfaces/Time`` (raw CDR)."""
    endian = "<" if data[1] & 1 else ">"
    sec, nanosec = struct.unpack_from(endian + "iI", data, 4)
    return sec * 1_000_000_000 + nanosec


class BagRecorderNode(Node):
    def __init__(self) -> None:
        super().__init__("bag_recorder")
        self.output_dir = declare(self, "output_dir", "string", "bag directory to create")
        if not self.output_dir:
            raise ScenarioError(f"node '{self.get_name()}' parameters", "output_dir",
                                "missing required parameter")
        self.stop_on = set(declare(self, "stop_on_planner_status", "string_array",
                                   "planner statuses that end the recording", [""]) or ())
        self.stop_on.discard("")
        self.stop_delay_ns = int(1e9 * declare(
            self, "stop_delay_s", "double",
            "after a stop status, keep recording this much more run time (stamps), s",
            1.0, value_range=(0.0, 3600.0)))
        self.stop_at_ns = None
        scenario_file = declare(self, "scenario_file", "string",
                                "scenario file stored in the bag as an attachment", "")
        self.done = False
        self.exit_code = 0
        self.last_stamp_ns = None
        self.writer = BagWriter(self.output_dir)
        if scenario_file:
            with open(scenario_file, "rb") as f:
                self.writer.add_attachment("scenario.yaml", f.read(), "application/yaml")
        for topic in c.TOPICS:
            pub_qos = c.qos(topic)
            self.writer.add_topic(topic.name, topic.type_name, qos_profile_yaml(
                "reliable", "transient_local", pub_qos.depth))
            sub_qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=pub_qos.depth,
                                 reliability=ReliabilityPolicy.RELIABLE,
                                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
            self.create_subscription(c.message_class(topic.type_name), topic.name,
                                     self.callback(topic), sub_qos, raw=True)
        self.get_logger().info(f"recording {len(c.TOPICS)} topics to {self.output_dir}"
                               + (f"; stops on status {sorted(self.stop_on)}" if self.stop_on else ""))

    def callback(self, topic):
        name, stamped = topic.name, topic.stamped
        is_status = name == c.PLANNER_STATUS

        def on_message(data: bytes) -> None:
            if self.done:
                return
            wall = time.time_ns()
            if stamped:
                log_time = self.last_stamp_ns = _stamp_ns(data)
                if self.stop_at_ns is not None and log_time > self.stop_at_ns:
                    self.get_logger().info("recording complete")
                    self.done = True
                    return
            else:
                log_time = wall if self.last_stamp_ns is None else self.last_stamp_ns
            self.writer.write(name, data, log_time, wall)
            if is_status and self.stop_on:
                status = deserialize_message(data, String).data
                if status in self.stop_on and self.stop_at_ns is None:
                    self.stop_at_ns = log_time + self.stop_delay_ns
                    self.get_logger().info(
                        f"planner status {status!r} at {log_time / 1e9:.3f} s: recording "
                        f"{self.stop_delay_ns / 1e9:g} s more")
        return on_message

    def close(self) -> None:
        self.writer.close()
        self.get_logger().info(f"bag closed: {self.writer.message_count} messages in "
                               f"{self.output_dir}")


def main(args=None) -> int:
    return run(BagRecorderNode, args)


if __name__ == "__main__":
    raise SystemExit(main())
