"""``ros2 bag info`` of the shim (attitude_tools.ros2cli.bag_info) on bags written here with
attitude_tools.bag's writer: rosbag2's fields and formats, and its errors.

The shim runs as ``python -m attitude_tools.ros2_cli bag info ...`` in a subprocess with
``TZ=UTC``, so Start and End (local time, as rosbag2 prints them) are known.
"""

import os
import shutil
import subprocess
import sys

import pytest
from geometry_msgs.msg import QuaternionStamped
from rclpy.serialization import serialize_message
from std_msgs.msg import String

from attitude_tools.bag import BagWriter, qos_profile_yaml
from attitude_tools.ros2cli.bag_info import format_size

T0 = 1_733_285_474_123_456_789  # Dec  4 2024 04:11:14.123456789 UTC
ATTITUDE = "/spacecraft/attitude"
STATUS = "/planner/status"


def ros2(*args):
    return subprocess.run(
        [sys.executable, "-m", "attitude_tools.ros2_cli", *args],
        env=dict(os.environ, TZ="UTC"),
        capture_output=True,
        text=True,
        timeout=60,
    )


def write_bag(bag_dir):
    """3 attitudes over 1.5 s and 2 statuses; the last message 2.000000211 s after T0."""
    with BagWriter(str(bag_dir)) as w:
        w.add_topic(
            ATTITUDE,
            "geometry_msgs/msg/QuaternionStamped",
            qos_profile_yaml("reliable", "volatile", 10),
        )
        w.add_topic(STATUS, "std_msgs/String", qos_profile_yaml("reliable", "transient_local", 1))
        for i in range(3):
            msg = QuaternionStamped()
            msg.quaternion.w = 1.0
            w.write(ATTITUDE, serialize_message(msg), T0 + i * 750_000_000)
        w.write(STATUS, serialize_message(String(data="tracking")), T0 + 100)
        w.write(STATUS, serialize_message(String(data="arrived")), T0 + 2_000_000_211)
    return bag_dir


def dir_size(path):
    return sum(e.stat().st_size for e in os.scandir(path) if e.is_file())


def test_info_of_a_bag_directory(tmp_path):
    bag = write_bag(tmp_path / "run_bag")
    res = ros2("bag", "info", str(bag))
    assert res.returncode == 0, res.stderr
    assert res.stderr == ""
    assert res.stdout == (
        "\n"
        "Files:             run_bag_0.mcap\n"
        f"Bag size:          {format_size(dir_size(bag))}\n"
        "Storage id:        mcap\n"
        "ROS Distro:        jazzy\n"
        "Duration:          2.000000211s\n"
        "Start:             Dec  4 2024 04:11:14.123456789 (1733285474.123456789)\n"
        "End:               Dec  4 2024 04:11:16.123457000 (1733285476.123457000)\n"
        "Messages:          5\n"
        "Topic information: Topic: /spacecraft/attitude | Type: geometry_msgs/msg/QuaternionStamped"
        " | Count: 3 | Serialization Format: cdr\n"
        "                   Topic: /planner/status | Type: std_msgs/msg/String | Count: 2"
        " | Serialization Format: cdr\n"
        "Service:           0\n"
        "Service information: \n"
    )
    assert 10_000 < dir_size(bag) < 1024**2  # so the size line above is in KiB
    assert " KiB\n" in res.stdout


def test_info_of_one_mcap_file_has_no_distro(tmp_path):
    bag = write_bag(tmp_path / "b")
    res = ros2("bag", "info", str(bag / "b_0.mcap"))
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    assert lines[1] == "Files:             b_0.mcap"
    assert lines[2] == f"Bag size:          {format_size(os.path.getsize(bag / 'b_0.mcap'))}"
    assert lines[4] == "ROS Distro:        unknown"
    assert lines[8] == "Messages:          5"


@pytest.mark.parametrize(
    "size, text",
    [
        (0, "0 B"),
        (1023, "1023 B"),
        (1024, "1.0 KiB"),
        (16_896, "16.5 KiB"),
        (int(1.25 * 1024**2), "1.2 MiB"),  # rosbag2's printf rounding: to even
        (3 * 1024**3, "3.0 GiB"),
        (2048 * 1024**4, "2048.0 TiB"),
    ],
)
def test_size_format_is_rosbag2s(size, text):
    assert format_size(size) == text


def test_missing_bag_is_an_error_naming_it(tmp_path):
    missing = tmp_path / "no_such_bag"
    res = ros2("bag", "info", str(missing))
    assert res.returncode != 0
    assert res.stdout == ""
    assert f"'{missing}' does not exist" in res.stderr


def test_unfinished_bag_is_an_error_naming_the_recovery(tmp_path):
    bag = write_bag(tmp_path / "b")
    cut = tmp_path / "cut"
    cut.mkdir()
    shutil.copy(bag / "metadata.yaml", cut / "metadata.yaml")
    data = (bag / "b_0.mcap").read_bytes()
    (cut / "b_0.mcap").write_bytes(data[: len(data) // 2])
    res = ros2("bag", "info", str(cut))
    assert res.returncode == 1
    assert res.stdout == ""
    assert "b_0.mcap" in res.stderr and "attitude-bag-recover" in res.stderr


def test_directory_without_mcap_and_other_bag_verbs(tmp_path):
    res = ros2("bag", "info", str(tmp_path))
    assert res.returncode == 1
    assert "no MCAP file" in res.stderr and str(tmp_path) in res.stderr
    res = ros2("bag", "record", "-a")
    assert res.returncode == 2
    assert "invalid choice" in res.stderr
