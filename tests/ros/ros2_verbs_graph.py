"""The known ROS graph of tests/ros/test_ros2_verbs.py, run as a process of its own.

``python ros2_verbs_graph.py`` starts, on the environment's ROS domain:

* ``/verbs/talker``: publishes ``geometry_msgs/msg/QuaternionStamped`` on
  ``/verbs/attitude`` at 10 Hz (reliable, volatile), the fixed values of ``QUATERNION``
  and ``FRAME``, stamp ``(k, 500)`` for the k-th message; declares ``PARAMETERS``;
* ``/verbs/lifecycle``: an ``rclpy.lifecycle.LifecycleNode`` that accepts every transition;
* ``/verbs/stubborn``: a LifecycleNode whose ``configure`` fails.

Prints ``ready`` once all exist, then spins until SIGINT or SIGTERM (rclpy's handlers).
"""

from __future__ import annotations

import contextlib
import sys

import rclpy
from geometry_msgs.msg import QuaternionStamped
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.qos import QoSProfile

NAMESPACE = "/verbs"
TOPIC = "/verbs/attitude"
FRAME = "inertial"
QUATERNION = {"x": 0.125, "y": -0.25, "z": 0.5, "w": 0.8}
PARAMETERS = {
    "frame": "inertial",
    "gain": 0.1,
    "steps": 3,
    "enabled": True,
    "axes": ["a", "b"],
    "weights": [1.5, 2.0],
}


class Stubborn(LifecycleNode):
    """A lifecycle node that refuses to be configured."""

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        return TransitionCallbackReturn.FAILURE


def main() -> int:
    rclpy.init(args=sys.argv)
    talker = rclpy.create_node("talker", namespace=NAMESPACE)
    for name, value in PARAMETERS.items():
        talker.declare_parameter(name, value)
    publisher = talker.create_publisher(QuaternionStamped, TOPIC, QoSProfile(depth=10))
    sent = [0]

    def publish() -> None:
        msg = QuaternionStamped()
        msg.header.stamp.sec, msg.header.stamp.nanosec = sent[0], 500
        msg.header.frame_id = FRAME
        for axis, value in QUATERNION.items():
            setattr(msg.quaternion, axis, value)
        publisher.publish(msg)
        sent[0] += 1

    talker.create_timer(0.1, publish)
    nodes = [
        talker,
        LifecycleNode("lifecycle", namespace=NAMESPACE),
        Stubborn("stubborn", namespace=NAMESPACE),
    ]
    executor = SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)
    print("ready", flush=True)
    with contextlib.suppress(KeyboardInterrupt, ExternalShutdownException):
        executor.spin()
    rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
