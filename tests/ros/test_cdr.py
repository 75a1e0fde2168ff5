"""The raw reading of the loop's stamped messages (``attitude_ros.cdr``) against rclpy's
own serialization: every frame length (the alignment of the doubles), any float, both
byte orders; malformed bytes refused with a reason."""

from __future__ import annotations

import math
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from attitude_ros.cdr import FLOATS, CdrError, joint_state, stamped

floats = st.floats(allow_nan=True, allow_infinity=True, width=64)
frames = st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=24)
secs = st.integers(-(2**31), 2**31 - 1)
nanosecs = st.integers(0, 2**32 - 1)


def message(type_name: str, sec: int, nanosec: int, frame: str, values: list[float]):
    from attitude_ros import contract as c

    msg = c.message_class(type_name)()
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.header.frame_id = frame
    if type_name.endswith("QuaternionStamped"):
        q = msg.quaternion
        q.x, q.y, q.z, q.w = values
    elif type_name.endswith("Vector3Stamped"):
        v = msg.vector
        v.x, v.y, v.z = values
    else:
        f, t = msg.wrench.force, msg.wrench.torque
        f.x, f.y, f.z, t.x, t.y, t.z = values
    return msg


def same(a: tuple[float, ...], b: list[float]) -> bool:
    return all((math.isnan(x) and math.isnan(y)) or x == y for x, y in zip(a, b, strict=True))


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(sorted(FLOATS)), secs, nanosecs, frames, st.data())
def test_stamped_reads_what_rclpy_serializes(type_name, sec, nanosec, frame, data):
    from rclpy.serialization import serialize_message

    values = data.draw(st.lists(floats, min_size=FLOATS[type_name], max_size=FLOATS[type_name]))
    raw = serialize_message(message(type_name, sec, nanosec, frame, values))
    got_sec, got_nanosec, got_frame, got = stamped(raw, FLOATS[type_name])
    assert (got_sec, got_nanosec, got_frame) == (sec, nanosec, frame)
    assert same(got, values)


@given(secs, nanosecs, frames, st.lists(floats, min_size=3, max_size=3))
def test_stamped_reads_big_endian_cdr(sec, nanosec, frame, values):
    text = frame.encode() + b"\x00"
    body = struct.pack(">iII", sec, nanosec, len(text)) + text
    body += b"\x00" * (-len(body) % 8) + struct.pack(">3d", *values)
    got_sec, got_nanosec, got_frame, got = stamped(b"\x00\x00\x00\x00" + body, 3)
    assert (got_sec, got_nanosec, got_frame) == (sec, nanosec, frame)
    assert same(got, values)


def test_malformed_bytes_are_refused_with_a_reason():
    from rclpy.serialization import serialize_message

    good = serialize_message(message("geometry_msgs/msg/Vector3Stamped", 1, 2, "body", [1, 2, 3]))
    assert stamped(good, 3)[:3] == (1, 2, "body")
    cases = {
        "not a plain CDR message": [b"", good[:10], b"\x00\x07\x00\x00" + good[4:]],
        "frame_id of": [
            good[:12] + struct.pack("<I", 1000) + good[16:],  # longer than the message
            good[:12] + struct.pack("<I", 0) + good[16:],  # no NUL at all
            good[:12] + struct.pack("<I", 4) + good[16:],  # the NUL is not where it says
        ],
        "floats": [good[:-1], good[:-24]],  # the doubles cut short
        "not UTF-8": [good[:16] + b"\xff\xfe\xfd\xfc" + good[20:]],
    }
    for reason, bad in cases.items():
        for data in bad:
            with pytest.raises(CdrError, match=reason):
                stamped(data, 3)


names = st.lists(st.text(st.characters(codec="utf-8", exclude_characters="\x00"), max_size=9))


@settings(max_examples=300, deadline=None)
@given(secs, nanosecs, frames, names, st.data())
def test_joint_state_reads_what_rclpy_serializes(sec, nanosec, frame, joint_names, data):
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    msg = JointState()
    msg.header.stamp.sec, msg.header.stamp.nanosec = sec, nanosec
    msg.header.frame_id = frame
    msg.name = joint_names
    arrays = [data.draw(st.lists(floats, max_size=5)) for _ in range(3)]
    msg.position, msg.velocity, msg.effort = arrays
    got_sec, got_nanosec, got_frame, got = joint_state(serialize_message(msg))
    assert (got_sec, got_nanosec, got_frame) == (sec, nanosec, frame)
    assert got.name == tuple(joint_names)
    for read_back, sent in zip((got.position, got.velocity, got.effort), arrays, strict=True):
        assert same(read_back, sent)


def test_joint_state_refuses_truncated_bytes():
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    msg = JointState(name=["rw1", "rw2"], velocity=[1.0, 2.0], effort=[0.1, 0.2])
    msg.header.frame_id = "body"
    raw = serialize_message(msg)
    assert joint_state(raw)[3].effort == (0.1, 0.2)
    for cut in (84, 60, 30):  # inside effort, inside velocity, inside the names
        with pytest.raises(CdrError):
            joint_state(raw[:cut])
