"""attitude_tools.bag and .msgdefs: rosbag2 (Jazzy) MCAP bags written without rclpy.

Bags are written from real CDR (rclpy's serialize_message) and read back with rosbags
(the reference reader) and with mcap_ros2 through read_bag.
"""

import os
import shutil
import signal
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
from mcap.reader import make_reader
from mcap_ros2._dynamic import generate_dynamic
from rclpy.serialization import serialize_message
from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.metadata import parse_qos
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Float64, String

from attitude_core.yamlio import load_safe
from attitude_tools.bag import (
    BagWriter,
    bag_info,
    msgdefs,
    qos_profile_yaml,
    read_attachment,
    read_bag,
    recover_messages,
)

SHARE = os.path.join(sys.prefix, "share")
SEP = "=" * 80
T0 = 1_700_000_000_000_000_000
INFINITE = QosTime(9223372036, 854775807)
STORE = get_typestore(Stores.ROS2_JAZZY)

HEADER = ["header.stamp.sec", "header.stamp.nanosec", "header.frame_id"]
FIELDS = {
    "geometry_msgs/msg/QuaternionStamped": HEADER + [f"quaternion.{a}" for a in "xyzw"],
    "geometry_msgs/msg/Vector3Stamped": HEADER + [f"vector.{a}" for a in "xyz"],
    "geometry_msgs/msg/WrenchStamped": HEADER
    + [f"wrench.{v}.{a}" for v in ("force", "torque") for a in "xyz"],
    "std_msgs/msg/String": ["data"],
    "std_msgs/msg/Float64": ["data"],
    "rosgraph_msgs/msg/Clock": ["clock.sec", "clock.nanosec"],
}
TOPICS = {
    "/attitude/quaternion": "geometry_msgs/msg/QuaternionStamped",
    "/attitude/rate": "geometry_msgs/msg/Vector3Stamped",
    "/attitude/torque": "geometry_msgs/msg/WrenchStamped",
    "/attitude/status": "std_msgs/msg/String",
    "/attitude/margin_deg": "std_msgs/msg/Float64",
    "/clock": "rosgraph_msgs/msg/Clock",
}
QOS_RELIABLE_LATCHED = qos_profile_yaml("reliable", "transient_local", 1)


def values(msg, type_name):
    """Field values of a message (rclpy, rosbags or mcap_ros2 object) by dotted path."""
    out = []
    for path in FIELDS[type_name]:
        obj = msg
        for name in path.split("."):
            obj = getattr(obj, name)
        out.append(obj)
    return tuple(out)


def stamp(i):
    return Time(sec=1_700_000_000 + i // 10, nanosec=(i % 10) * 100_000_000 + 7)


def make_message(type_name, i):
    """A distinct, fully populated message number i of type_name."""
    if type_name == "geometry_msgs/msg/QuaternionStamped":
        m = QuaternionStamped()
        m.header.stamp, m.header.frame_id = stamp(i), "N"
        m.quaternion.x, m.quaternion.y, m.quaternion.z, m.quaternion.w = 0.1 * i, -0.2, 0.3, 0.9
    elif type_name == "geometry_msgs/msg/Vector3Stamped":
        m = Vector3Stamped()
        m.header.stamp, m.header.frame_id = stamp(i), "B"
        m.vector.x, m.vector.y, m.vector.z = 1e-3 * i, -2.5e-4, 3.0
    elif type_name == "geometry_msgs/msg/WrenchStamped":
        m = WrenchStamped()
        m.header.stamp, m.header.frame_id = stamp(i), "body"
        m.wrench.force.x, m.wrench.force.y, m.wrench.force.z = -1.0, 2.0 * i, 1e-9
        m.wrench.torque.x, m.wrench.torque.y, m.wrench.torque.z = 0.01 * i, -0.02, 0.4
    elif type_name == "std_msgs/msg/String":
        m = String(data=f"slew {i}: ω ≤ 2 deg/s")
    elif type_name == "std_msgs/msg/Float64":
        m = Float64(data=15.78 + i)
    else:
        m = Clock(clock=stamp(i))
    return m


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A bag of all six types, interleaved, one message out of log-time order."""
    bag_dir = str(tmp_path_factory.mktemp("bags") / "run")
    written = []  # (topic, type, log_time_ns, publish_time_ns, expected values)
    with BagWriter(bag_dir, chunk_size=4096) as bag:
        for topic, type_name in TOPICS.items():
            qos = QOS_RELIABLE_LATCHED if topic == "/attitude/quaternion" else ""
            bag.add_topic(topic, type_name, qos)
        for i in range(60):
            topic, type_name = list(TOPICS.items())[i % len(TOPICS)]
            log_time = T0 + 10_000_000 * i + (5_000_000 * 12 if i == 7 else 0)
            msg = make_message(type_name, i)
            bag.write(topic, serialize_message(msg), log_time, log_time - 1000)
            written.append((topic, type_name, log_time, log_time - 1000, values(msg, type_name)))
        assert bag.message_count == 60
    by_time = sorted(written, key=lambda w: w[2])
    return bag_dir, written, by_time


def test_rosbags_reads_every_field_in_order(recorded):
    bag_dir, written, by_time = recorded
    with Reader(bag_dir) as reader:
        assert reader.message_count == len(written)
        assert {c.topic: c.msgtype for c in reader.connections} == TOPICS
        counts = {c.topic: c.msgcount for c in reader.connections}
        assert counts == {t: sum(w[0] == t for w in written) for t in TOPICS}
        got = [
            (c.topic, c.msgtype, t, values(STORE.deserialize_cdr(raw, c.msgtype), c.msgtype))
            for c, t, raw in reader.messages()
        ]
    assert got == [(w[0], w[1], w[2], w[4]) for w in by_time]


def test_read_bag_decodes_every_field_in_order(recorded):
    bag_dir, _, by_time = recorded
    got = [
        (m.topic, m.type_name, m.log_time_ns, m.publish_time_ns, values(m.msg, m.type_name))
        for m in read_bag(bag_dir)
    ]
    assert got == by_time
    only = [m.topic for m in read_bag(bag_dir, topics=["/clock"])]
    assert only == ["/clock"] * sum(w[0] == "/clock" for w in by_time)


def test_metadata_yaml_matches_rosbag2_jazzy(recorded):
    bag_dir, written, by_time = recorded
    info = bag_info(bag_dir)
    start, end = by_time[0][2], by_time[-1][2]
    assert info["version"] == 9
    assert info["storage_identifier"] == "mcap"
    assert info["message_count"] == len(written)
    assert info["starting_time"] == {"nanoseconds_since_epoch": start}
    assert info["duration"] == {"nanoseconds": end - start}
    assert info["relative_file_paths"] == ["run_0.mcap"]
    assert info["files"] == [
        {
            "path": "run_0.mcap",
            "starting_time": {"nanoseconds_since_epoch": start},
            "duration": {"nanoseconds": end - start},
            "message_count": len(written),
        }
    ]
    assert (info["compression_format"], info["compression_mode"]) == ("", "")
    assert info["custom_data"] is None and info["ros_distro"] == "jazzy"
    topics = {t["topic_metadata"]["name"]: t for t in info["topics_with_message_count"]}
    assert list(topics) == list(TOPICS)
    for name, entry in topics.items():
        meta = entry["topic_metadata"]
        assert entry["message_count"] == sum(w[0] == name for w in written)
        assert meta["type"] == TOPICS[name] and meta["serialization_format"] == "cdr"
        # the real RIHS01 hash, as rosidl and rosbags compute it
        assert meta["type_description_hash"] == STORE.hash_rihs01(TOPICS[name])
    assert sorted(os.listdir(bag_dir)) == ["metadata.yaml", "run_0.mcap"]


def test_metadata_read_with_libyaml_is_what_the_pure_python_loader_reads(recorded):
    bag_dir, _, _ = recorded
    text = (Path(bag_dir) / "metadata.yaml").read_text()
    pure = yaml.load(text, Loader=yaml.SafeLoader)["rosbag2_bagfile_information"]
    assert bag_info(bag_dir) == pure
    assert load_safe(text) == {"rosbag2_bagfile_information": pure}
    with pytest.raises(yaml.YAMLError):
        load_safe("topics: [a, b\n")


def test_qos_same_in_channel_and_metadata(recorded):
    bag_dir, written, _ = recorded
    info = {
        t["topic_metadata"]["name"]: t["topic_metadata"]
        for t in bag_info(bag_dir)["topics_with_message_count"]
    }
    with open(os.path.join(bag_dir, "run_0.mcap"), "rb") as f:
        summary = make_reader(f).get_summary()
    for channel in summary.channels.values():
        assert channel.message_encoding == "cdr"
        assert channel.metadata["topic_type_hash"] == info[channel.topic]["type_description_hash"]
        from_channel = yaml.safe_load(channel.metadata["offered_qos_profiles"])
        assert from_channel == info[channel.topic]["offered_qos_profiles"]
    assert info["/attitude/quaternion"]["offered_qos_profiles"] == yaml.safe_load(
        QOS_RELIABLE_LATCHED
    )
    expected = Qos(
        QosHistory.KEEP_LAST,
        1,
        QosReliability.RELIABLE,
        QosDurability.TRANSIENT_LOCAL,
        INFINITE,
        INFINITE,
        QosLiveliness.AUTOMATIC,
        INFINITE,
        False,
    )
    with Reader(bag_dir) as reader:
        conn = next(c for c in reader.connections if c.topic == "/attitude/quaternion")
        assert conn.ext.offered_qos_profiles == [expected]
        # the known trap: a QoS mismatch between the two places makes rosbags yield nothing
        n = sum(1 for _ in reader.messages(connections=[conn]))
    assert n == sum(w[0] == "/attitude/quaternion" for w in written) > 0


def test_qos_profile_yaml_parses_like_rosbag2():
    text = qos_profile_yaml("best_effort", "volatile", 10)
    assert parse_qos(text) == [
        Qos(
            QosHistory.KEEP_LAST,
            10,
            QosReliability.BEST_EFFORT,
            QosDurability.VOLATILE,
            INFINITE,
            INFINITE,
            QosLiveliness.AUTOMATIC,
            INFINITE,
            False,
        )
    ]
    profile = yaml.safe_load(text)[0]
    assert profile["history"] == "keep_last" and profile["liveliness"] == "automatic"
    bad_args = [
        ("reliable", "latched", 1),
        ("RELIABLE", "volatile", 1),
        ("reliable", "volatile", -1),
    ]
    for bad in bad_args:
        with pytest.raises(ValueError):
            qos_profile_yaml(*bad)


def test_schema_text_of_quaternion_stamped(recorded):
    bag_dir, _, _ = recorded
    text = msgdefs.message_definition("geometry_msgs/msg/QuaternionStamped")
    for section in (
        "MSG: std_msgs/Header\n",
        "MSG: builtin_interfaces/Time\n",
        "MSG: geometry_msgs/Quaternion\n",
    ):
        assert text.count(f"{SEP}\n{section}") == 1
    assert text.count(SEP) == 3
    with open(os.path.join(SHARE, "geometry_msgs/msg/QuaternionStamped.msg")) as f:
        assert text.startswith(f.read())
    assert msgdefs.message_definition("geometry_msgs/QuaternionStamped") == text
    with open(os.path.join(bag_dir, "run_0.mcap"), "rb") as f:
        schemas = {s.name: s for s in make_reader(f).get_summary().schemas.values()}
    assert set(schemas) == set(TOPICS.values())
    stored = schemas["geometry_msgs/msg/QuaternionStamped"]
    assert stored.encoding == "ros2msg" and stored.data.decode() == text


def _msg(pkg, name):
    with open(os.path.join(SHARE, pkg, "msg", name + ".msg"), newline="") as f:
        return f.read()


def _section(name):
    pkg, type_ = name.split("/")
    return f"\n{SEP}\nMSG: {name}\n" + _msg(pkg, type_)


def test_message_definition_arrays_constants_same_package_types():
    # NavSatFix: float64[9], uint8 constants, bare same-package NavSatStatus (int8 constants)
    text = msgdefs.message_definition("sensor_msgs/msg/NavSatFix")
    assert text == (
        _msg("sensor_msgs", "NavSatFix")
        + _section("sensor_msgs/NavSatStatus")
        + _section("std_msgs/Header")
        + _section("builtin_interfaces/Time")
    )
    joint_state = msgdefs.message_definition("sensor_msgs/msg/JointState")  # string[], float64[]
    assert joint_state == (
        _msg("sensor_msgs", "JointState")
        + _section("std_msgs/Header")
        + _section("builtin_interfaces/Time")
    )
    for name, definition in (
        ("sensor_msgs/msg/NavSatFix", text),
        ("sensor_msgs/msg/JointState", joint_state),
    ):
        assert name in generate_dynamic(name, definition)
        assert get_types_from_msg(definition, name)


@pytest.fixture
def demo_prefix(tmp_path, monkeypatch):
    """An install prefix with a package demo_msgs using every field form."""
    msg_dir = tmp_path / "share" / "demo_msgs" / "msg"
    msg_dir.mkdir(parents=True)
    (msg_dir / "Sample.msg").write_text(
        textwrap.dedent("""\
        # Every field form. A comment naming a type: geometry_msgs/Twist twist
        int8 MODE_IDLE=0
        int8 MODE_SLEW = 1  # constant with spaces
        string LABEL_DEFAULT="slew # not a comment"
        Header header
        string<=10 label
        wstring wide_name
        float64[3] axis
        int32[] counts
        uint8[<=5] flags
        string<=8[<=2] short_names
        Part[] parts
        Part main_part
        builtin_interfaces/Duration timeout
        geometry_msgs/Vector3[<=2] rates
        """)
    )
    (msg_dir / "Part.msg").write_text("builtin_interfaces/Time stamp\nfloat32 mass_kg 1.5\n")
    (msg_dir / "Broken.msg").write_text("NoSuchType thing\n")
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    return tmp_path


def test_message_definition_every_field_form(demo_prefix):
    text = msgdefs.message_definition("demo_msgs/msg/Sample")
    sample = (demo_prefix / "share/demo_msgs/msg/Sample.msg").read_text()
    part = (demo_prefix / "share/demo_msgs/msg/Part.msg").read_text()
    # nested types sorted by name, depth first, each once (Time under Part, not under Header)
    assert text == (
        sample
        + _section("builtin_interfaces/Duration")
        + f"\n{SEP}\nMSG: demo_msgs/Part\n"
        + part
        + _section("builtin_interfaces/Time")
        + _section("geometry_msgs/Vector3")
        + _section("std_msgs/Header")
    )
    assert "geometry_msgs/Twist" not in text.split(SEP, 1)[1]


def test_message_definition_not_found(demo_prefix):
    with pytest.raises(LookupError) as err:
        msgdefs.message_definition("demo_msgs/msg/Missing")
    assert "demo_msgs/msg/Missing" in str(err.value)
    assert str(demo_prefix / "share" / "demo_msgs" / "msg") in str(err.value)
    with pytest.raises(LookupError, match="demo_msgs/msg/Broken.*demo_msgs/msg/NoSuchType"):
        msgdefs.message_definition("demo_msgs/msg/Broken")
    with pytest.raises(ValueError):
        msgdefs.message_definition("not a type")


def test_existing_bag_dir_is_refused(tmp_path):
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("x")
    with pytest.raises(FileExistsError, match="full"):
        BagWriter(str(full))
    (tmp_path / "file").write_text("x")
    with pytest.raises(FileExistsError, match="file"):
        BagWriter(str(tmp_path / "file"))
    (tmp_path / "empty").mkdir()
    BagWriter(str(tmp_path / "empty")).close()
    assert bag_info(str(tmp_path / "empty"))["message_count"] == 0


def test_provisional_metadata_and_write_errors(tmp_path):
    bag = BagWriter(str(tmp_path / "b"))
    info = bag_info(str(tmp_path / "b"))
    assert info["message_count"] == 0 and info["topics_with_message_count"] == []
    assert info["starting_time"]["nanoseconds_since_epoch"] == 2**63 - 1
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    assert (
        bag_info(str(tmp_path / "b"))["topics_with_message_count"][0]["topic_metadata"][
            "offered_qos_profiles"
        ]
        == []
    )
    bag.add_topic("/clock", "rosgraph_msgs/msg/Clock")  # same again: no-op
    with pytest.raises(ValueError):
        bag.add_topic("/clock", "std_msgs/msg/String")
    data = serialize_message(Clock(clock=stamp(3)))
    with pytest.raises(KeyError, match="/nope"):
        bag.write("/nope", data, T0)
    with pytest.raises(TypeError):
        bag.write("/clock", "not bytes", T0)
    with pytest.raises(ValueError):
        bag.write("/clock", b"\x7fnot cdr", T0)
    with pytest.raises(ValueError):
        bag.add_topic("/q", "geometry_msgs/msg/QuaternionStamped", "not: [a, qos, list")
    bag.write("/clock", data, T0)
    bag.close()
    bag.close()  # idempotent
    with pytest.raises(ValueError):
        bag.write("/clock", data, T0)
    assert [values(m.msg, "rosgraph_msgs/msg/Clock") for m in read_bag(str(tmp_path / "b"))] == [
        values(Clock(clock=stamp(3)), "rosgraph_msgs/msg/Clock")
    ]


def test_attachment(tmp_path):
    bag_dir = str(tmp_path / "att")
    scenario = b"/**:\n  ros__parameters:\n    scenario_name: case1\n"
    with BagWriter(bag_dir) as bag:
        bag.add_attachment("scenario.yaml", scenario, "application/yaml")
        bag.add_topic("/x", "std_msgs/msg/Float64")
        bag.write("/x", serialize_message(Float64(data=1.5)), T0)
        with open(os.path.join(bag_dir, "att_0.mcap"), "rb") as f:
            snapshot = f.read()
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / "killed_0.mcap").write_bytes(snapshot)
    assert read_attachment(bag_dir, "scenario.yaml") == scenario
    assert read_attachment(str(killed), "scenario.yaml") == scenario
    with pytest.raises(KeyError, match="other.yaml"):
        read_attachment(bag_dir, "other.yaml")
    with open(os.path.join(bag_dir, "att_0.mcap"), "rb") as f:
        attachments = list(make_reader(f).iter_attachments())
    assert [(a.name, a.media_type, a.data) for a in attachments] == [
        ("scenario.yaml", "application/yaml", scenario)
    ]
    with Reader(bag_dir) as reader:
        assert [STORE.deserialize_cdr(raw, c.msgtype).data for c, _, raw in reader.messages()] == [
            1.5
        ]
    assert [m.msg.data for m in recover_messages(bag_dir)] == [1.5]


def test_close_after_exception_finishes_mcap(tmp_path):
    bag_dir = str(tmp_path / "crash")
    with pytest.raises(RuntimeError), BagWriter(bag_dir, chunk_size=256) as bag:
        bag.add_topic("/x", "std_msgs/msg/Float64")
        for i in range(20):
            bag.write("/x", serialize_message(Float64(data=float(i))), T0 + i)
        raise RuntimeError("node crashed")
    assert [m.msg.data for m in read_bag(bag_dir)] == [float(i) for i in range(20)]
    with Reader(bag_dir) as reader:
        assert reader.message_count == 20 == sum(1 for _ in reader.messages())


@pytest.mark.parametrize("compression", ["lz4", "zstd"])
def test_chunk_compression(tmp_path, compression):
    bag_dir = str(tmp_path / compression)
    with BagWriter(bag_dir, chunk_size=512, compression=compression) as bag:
        bag.add_topic("/status", "std_msgs/msg/String")
        for i in range(30):
            bag.write("/status", serialize_message(String(data=f"step {i} " * 5)), T0 + i)
    expected = [f"step {i} " * 5 for i in range(30)]
    assert [m.msg.data for m in read_bag(bag_dir)] == expected
    with Reader(bag_dir) as reader:
        assert [
            STORE.deserialize_cdr(raw, c.msgtype).data for c, _, raw in reader.messages()
        ] == expected


def _write_float_bag(bag_dir, n, chunk_size=512):
    """Float64 values 0..n-1 at T0 + i, returns the open writer (caller closes)."""
    bag = BagWriter(bag_dir, chunk_size=chunk_size)
    bag.add_topic("/x", "std_msgs/msg/Float64")
    for i in range(n):
        bag.write("/x", serialize_message(Float64(data=float(i))), T0 + i)
    return bag


def _complete_chunk_end_times(mcap_path, size):
    """message_end_time of each chunk (with its message indexes) within the first size bytes."""
    with open(mcap_path, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    return [
        c.message_end_time
        for c in chunks
        if c.chunk_start_offset + c.chunk_length + c.message_index_length <= size
    ]


def test_recover_unfinished_file(tmp_path):
    bag = _write_float_bag(str(tmp_path / "live"), 100)
    mcap_path = os.path.join(bag.bag_dir, bag.file_name)
    with open(mcap_path, "rb") as f:
        snapshot = f.read()  # what a SIGKILL would leave: no summary, open chunk lost
    bag.close()
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / "killed_0.mcap").write_bytes(snapshot)
    ends = _complete_chunk_end_times(mcap_path, len(snapshot))
    k = sum(1 for i in range(100) if T0 + i <= max(ends))
    assert 0 < k < 100
    with pytest.raises(ValueError, match="recover_messages"):
        next(read_bag(str(killed)))
    got = list(recover_messages(str(killed)))
    assert [m.msg.data for m in got] == [float(i) for i in range(k)]
    assert {(m.topic, m.type_name) for m in got} == {("/x", "std_msgs/msg/Float64")}
    assert [m.log_time_ns for m in got] == [T0 + i for i in range(k)]


def test_recover_file_truncated_mid_chunk(tmp_path):
    bag = _write_float_bag(str(tmp_path / "cut"), 100)
    bag.close()
    mcap_path = os.path.join(bag.bag_dir, bag.file_name)
    with open(mcap_path, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    last = chunks[-2]  # cut inside the second last chunk
    cut = last.chunk_start_offset + last.chunk_length // 2
    with open(mcap_path, "r+b") as f:
        f.truncate(cut)
    k = sum(1 for i in range(100) if T0 + i <= chunks[-3].message_end_time)
    assert [m.msg.data for m in recover_messages(bag.bag_dir)] == [float(i) for i in range(k)]
    assert [m.msg.data for m in recover_messages(bag.bag_dir, topics=["/other"])] == []


def test_recover_after_sigkill(tmp_path):
    bag_dir = str(tmp_path / "sigkill")
    child = textwrap.dedent(f"""
        import os, signal, struct, sys
        from attitude_tools.bag import BagWriter
        assert "rclpy" not in sys.modules
        bag = BagWriter({bag_dir!r}, chunk_size=512)
        bag.add_topic("/x", "std_msgs/msg/Float64")
        for i in range(200):
            bag.write("/x", b"\\x00\\x01\\x00\\x00" + struct.pack("<d", i), {T0} + i)
        assert "rclpy" not in sys.modules
        os.kill(os.getpid(), signal.SIGKILL)
        """)
    result = subprocess.run([sys.executable, "-c", child], capture_output=True, timeout=60)
    assert result.returncode == -signal.SIGKILL, result.stderr.decode()
    info = bag_info(bag_dir)  # the provisional metadata.yaml survived
    assert info["topics_with_message_count"][0]["topic_metadata"]["name"] == "/x"
    got = [m.msg.data for m in recover_messages(bag_dir)]
    assert 0 < len(got) < 200
    assert got == [float(i) for i in range(len(got))]
    # the hand-made CDR of the child equals rclpy's
    assert serialize_message(Float64(data=3.0)) == b"\x00\x01\x00\x00" + struct.pack("<d", 3.0)


def test_library_does_not_import_rclpy():
    code = (
        "import sys, attitude_tools.bag, attitude_tools.bag.msgdefs; print('rclpy' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert out.stdout.strip() == "False", out.stderr


def test_copied_bag_still_reads(recorded, tmp_path):
    bag_dir, written, _ = recorded
    copy = shutil.copytree(bag_dir, tmp_path / "copy")
    assert sum(1 for _ in read_bag(str(copy))) == len(written)


def test_steps_per_s_is_the_stepping_rate_after_the_loops_first_answer():
    """A first state that waits for a peer still matching (re-sent meanwhile) is start-up:
    the rate counts from the state after the first answer, as the bare ring counts after
    its warm-up."""
    import numpy as np

    from attitude_core.config.scenario_loader import load_scenario
    from attitude_core.loop.closed_loop import run_closed_loop
    from attitude_tools.bag.run_record import BagRun, summarize_bag

    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    sc = load_scenario(os.path.join(root, "scenarios", "case1.yaml"))
    run = run_closed_loop(sc)
    n = len(run.t)
    stamps = np.arange(n, dtype=np.int64) * 100_000_000
    wall = 10**18 + 2 * 10**6 * np.arange(n, dtype=np.int64)  # 500 steps/s
    wall[1:] += 700 * 10**6  # the first answer came 0.7 s late
    summary = summarize_bag(BagRun(run, stamps, wall, 0))
    assert summary["steps_recorded"] == n
    assert summary["steps_per_s"] == pytest.approx(500.0, rel=1e-12)
