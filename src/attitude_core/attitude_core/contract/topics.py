"""The topic contract of the stack: names, message types and frames, in one place.

Plain data (no ROS import): the nodes (through ``attitude_ros.contract``, which adds
the QoS), the recorder and the bag readers all take their names from here.

==================================  ===============================  ==========================
topic                               type                             publisher
==================================  ===============================  ==========================
``/clock``                          rosgraph_msgs/msg/Clock          simulator
``/spacecraft/attitude``            geometry_msgs/msg/QuaternionStamped  simulator (or HIL bridge)
``/spacecraft/angular_velocity``    geometry_msgs/msg/Vector3Stamped simulator (or HIL bridge)
``/planner/target_mrp``             geometry_msgs/msg/Vector3Stamped planner
``/planner/target_rate``            geometry_msgs/msg/Vector3Stamped planner
``/planner/status``                 std_msgs/msg/String              planner (latched)
``/planner/keep_out_margin_deg``    std_msgs/msg/Float64             planner
``/diagnostics``                    diagnostic_msgs/msg/DiagnosticArray  planner; every node
``/controller/torque``              geometry_msgs/msg/WrenchStamped  controller
``/spacecraft/applied_torque``      geometry_msgs/msg/WrenchStamped  simulator
==================================  ===============================  ==========================

Every stamped message of one step carries the stamp of the state it answers.
"""

from __future__ import annotations

from typing import NamedTuple, Protocol

CLOCK = "/clock"
ATTITUDE = "/spacecraft/attitude"
ANGULAR_VELOCITY = "/spacecraft/angular_velocity"
TARGET_MRP = "/planner/target_mrp"
TARGET_RATE = "/planner/target_rate"
PLANNER_STATUS = "/planner/status"
KEEP_OUT_MARGIN = "/planner/keep_out_margin_deg"
DIAGNOSTICS = "/diagnostics"
TORQUE = "/controller/torque"
APPLIED_TORQUE = "/spacecraft/applied_torque"  # what the simulator applied over the step

INERTIAL_FRAME = "inertial"  # N
BODY_FRAME = "body"  # B
TARGET_FRAME = "target"  # R: the planner's target attitude

# Depth of the nodes' subscription queues (keep-last).
HISTORY_DEPTH = 200

STATE_TOPICS = (ATTITUDE, ANGULAR_VELOCITY)  # what a plant (simulator or bridge) publishes


NS_PER_S = 1_000_000_000


class Stamp(Protocol):
    """A ``builtin_interfaces/Time`` as the stamp helpers use it."""

    sec: int
    nanosec: int


def stamp_ns(stamp: Stamp) -> int:
    """A ``builtin_interfaces/Time`` (any object with ``sec``, ``nanosec``) as integer
    nanoseconds: stamps are compared and keyed exactly, ``k dt`` in lockstep."""
    return stamp.sec * NS_PER_S + stamp.nanosec


class Topic(NamedTuple):
    name: str
    type_name: str  # pkg/msg/Type
    stamped: bool  # first field is a header (or a Time): the recorder logs at that stamp
    latched: bool = False
    frame: str | None = None  # the header's frame_id, checked by the receivers


TOPICS = (
    Topic(CLOCK, "rosgraph_msgs/msg/Clock", True),
    Topic(ATTITUDE, "geometry_msgs/msg/QuaternionStamped", True, frame=INERTIAL_FRAME),
    Topic(ANGULAR_VELOCITY, "geometry_msgs/msg/Vector3Stamped", True, frame=BODY_FRAME),
    Topic(TARGET_MRP, "geometry_msgs/msg/Vector3Stamped", True, frame=INERTIAL_FRAME),
    Topic(TARGET_RATE, "geometry_msgs/msg/Vector3Stamped", True, frame=TARGET_FRAME),
    Topic(PLANNER_STATUS, "std_msgs/msg/String", False, latched=True),
    Topic(KEEP_OUT_MARGIN, "std_msgs/msg/Float64", False),
    Topic(DIAGNOSTICS, "diagnostic_msgs/msg/DiagnosticArray", True),
    Topic(TORQUE, "geometry_msgs/msg/WrenchStamped", True, frame=BODY_FRAME),
    Topic(APPLIED_TORQUE, "geometry_msgs/msg/WrenchStamped", True, frame=BODY_FRAME),
)


def topic(name: str) -> Topic:
    """The contract entry of a topic name (KeyError if none)."""
    for t in TOPICS:
        if t.name == name:
            return t
    raise KeyError(name)
