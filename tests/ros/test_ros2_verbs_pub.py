"""The shim's ``ros2 topic pub``: a message built from ros2cli's YAML reaches a reliable
subscriber (the planner's goal QoS) over real DDS with every field as given; a field the
message has not is a clear error and nothing is published."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest

pytestmark = [pytest.mark.ros]

TOPIC = "/verbs_pub/planner/goal"


def shim(env, *args, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "attitude_tools.ros2_cli", *args],
        env=env, capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip


@pytest.fixture
def listener(ros_domain, monkeypatch):
    """A reliable keep-last-10 subscriber of ``TOPIC`` (the goal's QoS), spun on demand."""
    import rclpy
    from geometry_msgs.msg import QuaternionStamped
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    ctx = rclpy.Context()
    rclpy.init(context=ctx, domain_id=ros_domain)
    node = rclpy.create_node("pub_listener", context=ctx)
    got: list = []
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(QuaternionStamped, TOPIC, got.append, qos)
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(node)

    def spin_until(condition, timeout_s=60.0):
        end = time.monotonic() + timeout_s
        while not condition() and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        return condition()

    yield got, spin_until
    executor.shutdown()
    node.destroy_node()
    ctx.try_shutdown()


def test_pub_once_delivers_the_yaml_values(listener, ros_env):
    got, spin_until = listener
    values = (
        "{header: {stamp: {sec: 7, nanosec: 5}, frame_id: inertial}, "
        "quaternion: {x: 0.0, y: -0.261438, z: -0.915033, w: 0.30719}}"
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "attitude_tools.ros2_cli", "topic", "pub", "--once", TOPIC,
         "geometry_msgs/msg/QuaternionStamped", values],
        env=ros_env(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    assert spin_until(lambda: bool(got) or proc.poll() is not None)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert "Waiting for at least 1 matching subscription(s)..." in out
    (msg,) = got
    assert (msg.header.stamp.sec, msg.header.stamp.nanosec, msg.header.frame_id) == (
        7,
        5,
        "inertial",
    )
    q = msg.quaternion
    assert (q.x, q.y, q.z, q.w) == (0.0, -0.261438, -0.915033, 0.30719)


def test_pub_header_auto_and_a_bad_field(listener, ros_env):
    got, spin_until = listener
    bad = shim(
        ros_env(), "topic", "pub", "--once", TOPIC, "geometry_msgs/msg/QuaternionStamped",
        "{quaternion: {v: 1.0}}",
    )  # fmt: skip
    assert bad.returncode != 0 and "quaternion.v: no such field" in bad.stderr
    before = time.time()
    res = shim(
        ros_env(), "topic", "pub", "-1", TOPIC, "geometry_msgs/msg/QuaternionStamped",
        "{header: auto, quaternion: {w: 1}}",
    )  # fmt: skip
    assert res.returncode == 0, res.stderr
    assert spin_until(lambda: bool(got))
    (msg,) = got  # the bad one published nothing
    assert msg.quaternion.w == 1.0 and msg.header.frame_id == ""
    assert abs(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9 - before) < 60.0
