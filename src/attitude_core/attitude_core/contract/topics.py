"""The topic contract of the stack: names, message types and frames, in one place.

Plain data (no ROS import): the nodes (through ``attitude_ros.contract``, which adds
the QoS), the recorder and the bag readers all take their names from here.

==================================  ===============================  ==========================
topic                               type                             publisher
==================================  ===============================  ==========================
``/clock``                          rosgraph_msgs/msg/Clock          simulator
``/spacecraft/attitude``            geometry_msgs/msg/QuaternionStamped  simulator (or HIL bridge);
                                                                     the estimator with sensors
``/spacecraft/angular_velocity``    geometry_msgs/msg/Vector3Stamped simulator (or HIL bridge);
                                                                     the estimator with sensors
``/spacecraft/imu``                 sensor_msgs/msg/Imu              simulator with sensors (or HIL)
``/spacecraft/star_tracker``        geometry_msgs/msg/PoseWithCovarianceStamped  the same
``/spacecraft/truth/attitude``      geometry_msgs/msg/QuaternionStamped  simulator with sensors
``/spacecraft/truth/angular_velocity``  geometry_msgs/msg/Vector3Stamped  simulator with sensors
``/planner/target_mrp``             geometry_msgs/msg/Vector3Stamped planner
``/planner/target_rate``            geometry_msgs/msg/Vector3Stamped planner
``/planner/status``                 std_msgs/msg/String              planner (latched)
``/planner/keep_out_margin_deg``    std_msgs/msg/Float64             planner
``/diagnostics``                    diagnostic_msgs/msg/DiagnosticArray  planner; every node
``/controller/torque``              geometry_msgs/msg/WrenchStamped  controller
``/spacecraft/applied_torque``      geometry_msgs/msg/WrenchStamped  simulator
``/spacecraft/wheel_states``        sensor_msgs/msg/JointState       simulator with wheels (or HIL)
``/controller/wheel_torque``        sensor_msgs/msg/JointState       controller with wheels
``<ns>/planner/goal``               geometry_msgs/msg/QuaternionStamped  an operator (read by
                                                                     the planner; recorded)
==================================  ===============================  ==========================

``<ns>/planner/goal`` is the one topic resolved in the run's namespace (``<ns>``, the
namespace ``attitude-run`` starts the nodes in; ``/`` for nodes started by hand): a goal
attitude, the body in the inertial frame as ``/spacecraft/attitude`` (x y z w), frame
``inertial``, its header stamp the goal's id. The planner judges it at the next state
(:mod:`attitude_core.assembly.goal_sequence`) and reports it on ``/diagnostics``
(:mod:`attitude_core.contract.goals`). The bag records it as ``/planner/goal``.

Every stamped message of one step carries the stamp of the state it answers.

With declared sensors (``sensors.*``) the simulator publishes no state the loop reads:
it publishes the raw measurements and, for the record only, the true state on
``/spacecraft/truth/*``; the estimator (``attitude_estimation``) publishes its estimate
on ``/spacecraft/attitude`` and ``/spacecraft/angular_velocity`` with the stamp of the
measurements it filtered. Message conventions of the sensors:

* ``/spacecraft/imu``, ``sensor_msgs/Imu``, frame ``body``, every step: the gyro in
  ``angular_velocity`` (rad/s, body axes, bias and noise included) with its white-noise
  variance on the diagonal of ``angular_velocity_covariance``; no orientation and no
  acceleration (``orientation_covariance[0]`` and ``linear_acceleration_covariance[0]``
  are -1, the message's own "not provided" convention).
* ``/spacecraft/star_tracker``, ``geometry_msgs/PoseWithCovarianceStamped``, frame
  ``inertial``, at the tracker's rate: ``pose.orientation`` the measured attitude (the
  body in the inertial frame, as ``/spacecraft/attitude``); the rotation block of
  ``covariance`` (rows and columns 3-5, rad^2, about body x, y, z) the tracker's noise;
  the position is unused (zero, with zero covariance).

With a reaction wheel array (``wheels.*``) the controller still publishes the body
torque it wants on ``/controller/torque`` (for the record) and the plant takes the
motor torques of ``/controller/wheel_torque`` instead. Both wheel topics are
``sensor_msgs/JointState``, frame ``body``, read by wheel name (any order; every
declared wheel present, each once), ``position`` empty:

* ``/spacecraft/wheel_states``, stamped like the state, every step: ``velocity`` the
  wheel speeds ``Omega_i`` relative to the body (rad/s, positive about the wheel's spin
  axis); ``effort`` the motor torque (N m, on the wheel about its spin axis; the body
  gets its reaction ``-g_i u_i``) each wheel applied over the step that ended at the
  stamp (a zero-order hold: what a bench samples at that instant), zero at the first.
* ``/controller/wheel_torque``, the stamp of the state it answers: ``effort`` the
  commanded motor torque of each wheel (N m); ``velocity`` empty.
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
IMU = "/spacecraft/imu"  # the gyro (with sensors)
STAR_TRACKER = "/spacecraft/star_tracker"  # the star tracker (with sensors)
TRUTH_ATTITUDE = "/spacecraft/truth/attitude"  # the true state (with sensors), record only
TRUTH_ANGULAR_VELOCITY = "/spacecraft/truth/angular_velocity"
WHEEL_STATES = "/spacecraft/wheel_states"  # the wheels' speeds and applied torques
WHEEL_TORQUE = "/controller/wheel_torque"  # the commanded motor torques
GOAL = "/planner/goal"  # a commanded goal; subscribed relative: <run namespace>/planner/goal

INERTIAL_FRAME = "inertial"  # N
BODY_FRAME = "body"  # B
TARGET_FRAME = "target"  # R: the planner's target attitude

# Depth of the nodes' subscription queues (keep-last).
HISTORY_DEPTH = 200

STATE_TOPICS = (ATTITUDE, ANGULAR_VELOCITY)  # what a plant (simulator or bridge) publishes
SENSOR_TOPICS = (IMU, STAR_TRACKER)  # ... or, with sensors, what it measures
TRUTH_TOPICS = (TRUTH_ATTITUDE, TRUTH_ANGULAR_VELOCITY)
WHEEL_TOPICS = (WHEEL_STATES, WHEEL_TORQUE)  # with a wheel array


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
    relative: bool = False  # resolved in the node's namespace (the run's), not absolute

    @property
    def node_name(self) -> str:
        """The name a node creates its endpoint with: relative ones in its namespace."""
        return self.name.lstrip("/") if self.relative else self.name


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
    Topic(IMU, "sensor_msgs/msg/Imu", True, frame=BODY_FRAME),
    Topic(STAR_TRACKER, "geometry_msgs/msg/PoseWithCovarianceStamped", True, frame=INERTIAL_FRAME),
    Topic(TRUTH_ATTITUDE, "geometry_msgs/msg/QuaternionStamped", True, frame=INERTIAL_FRAME),
    Topic(TRUTH_ANGULAR_VELOCITY, "geometry_msgs/msg/Vector3Stamped", True, frame=BODY_FRAME),
    Topic(WHEEL_STATES, "sensor_msgs/msg/JointState", True, frame=BODY_FRAME),
    Topic(WHEEL_TORQUE, "sensor_msgs/msg/JointState", True, frame=BODY_FRAME),
)


COMMAND_TOPICS = (
    # The goal: the header stamp is the goal's id, not on the run's timeline (the
    # recorder logs it at the latest stamp); subscribed reliable, volatile, keep last
    # GOAL_DEPTH, so a default rclpy publisher and `ros2 topic pub` reach it.
    Topic(GOAL, "geometry_msgs/msg/QuaternionStamped", False, frame=INERTIAL_FRAME, relative=True),
)
"""Topics an operator publishes (no node of the graph does): recorded like the others,
each under its contract name."""
GOAL_DEPTH = 10


def topic(name: str) -> Topic:
    """The contract entry of a topic name (KeyError if none)."""
    for t in TOPICS + COMMAND_TOPICS:
        if t.name == name:
            return t
    raise KeyError(name)
