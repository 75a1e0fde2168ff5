"""The ``ros2`` verbs of our shim beyond ``run``, for machines without ros2cli (pip-only ROS 2).

Each verb is a module with ``main(argv) -> int`` (argv after the verb), dispatched by
``attitude_tools.ros2_cli``: ``topic`` (list, echo, hz), ``node`` (list), ``lifecycle``
(nodes, get, set, list), ``param`` (list, get) and ``bag`` (info). They print what ros2cli
(Jazzy) prints for the options they have; each module's docstring says where they differ.
The graph verbs use rclpy (``graph``: a hidden node that spins a moment for discovery, as
ros2cli's ``--no-daemon`` path does); ``bag info`` reads the bag with ``mcap``.
"""

VERBS = {
    "topic": "attitude_tools.ros2cli.topic",
    "node": "attitude_tools.ros2cli.node",
    "lifecycle": "attitude_tools.ros2cli.lifecycle",
    "param": "attitude_tools.ros2cli.param",
    "bag": "attitude_tools.ros2cli.bag_info",
}
"""Verb name -> module implementing it (imported only when the verb is used)."""
