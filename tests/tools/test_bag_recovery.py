"""Crash-safe bags without ROS processes: the writer's time-based flush, write failures,
and ``bag_recovery.recover_bag`` / ``attitude-bag-recover`` on killed and cut files.

Bags are read back by independent readers: the ``mcap`` library (a finished file with
its summary) and ``rosbags``.
"""

import hashlib
import os
import random
import shutil
import signal
import struct
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
import yaml
from bag_checks import assert_finished_and_consistent, mcap_path
from mcap.reader import make_reader

from attitude_core.runtime.recording import STAMP_AHEAD_LIMIT_S, implausible_stamp
from attitude_tools.bag import (
    RESERVE_FILE,
    BagWriter,
    bag_info,
    msgdefs,
    qos_profile_yaml,
    read_attachment,
    read_bag,
    recover_messages,
)
from attitude_tools.bag.recovery import NotABagError, recover_bag

T0 = 1_700_000_000_000_000_000
QOS = qos_profile_yaml("reliable", "transient_local", 1)
RECOVER = str(Path(sys.prefix) / "bin" / "attitude-bag-recover")


def cdr(value: float) -> bytes:
    """std_msgs/Float64 as raw CDR (little endian)."""
    return b"\x00\x01\x00\x00" + struct.pack("<d", value)


def snapshot(bag_dir: str, dest: Path) -> Path:
    """A copy of a live bag directory: what a SIGKILL at this moment would leave."""
    dest.mkdir()
    for name in os.listdir(bag_dir):
        src = os.path.join(bag_dir, name)
        if os.path.isfile(src):
            shutil.copyfile(src, dest / name)
    return dest


# -- the writer's flush --------------------------------------------------------------


def test_schemas_channels_and_attachment_on_disk_before_any_message(tmp_path):
    bag = BagWriter(str(tmp_path / "early"), flush_interval_s=None)
    bag.add_attachment("scenario.yaml", b"a: 1\n", "application/yaml")
    bag.add_topic("/x", "std_msgs/msg/Float64", QOS)
    killed = snapshot(bag.bag_dir, tmp_path / "killed")
    bag.close()
    result = recover_bag(str(killed))
    assert result.recovered and result.message_count == 0
    assert_finished_and_consistent(killed)
    (topic,) = bag_info(str(killed))["topics_with_message_count"]
    assert topic["topic_metadata"]["offered_qos_profiles"][0]["durability"] == "transient_local"
    assert topic["topic_metadata"]["type_description_hash"] == msgdefs.type_description_hash(
        "std_msgs/msg/Float64"
    )
    assert read_attachment(str(killed), "scenario.yaml") == b"a: 1\n"


@pytest.mark.parametrize("interval_s", [None, 0.1])
def test_time_based_flush_puts_messages_on_disk(tmp_path, interval_s):
    """With a flush interval, written messages reach the file within it (plus a margin for
    a loaded machine); without one (the old behaviour), nothing does before 256 KB."""
    bag = BagWriter(str(tmp_path / "live"), flush_interval_s=interval_s)
    bag.add_topic("/x", "std_msgs/msg/Float64")
    for i in range(10):
        bag.write("/x", cdr(float(i)), T0 + i)
    written = time.monotonic()
    deadline = written + 1.0
    on_disk = []
    while time.monotonic() < deadline:
        on_disk = [m.msg.data for m in recover_messages(bag.bag_dir)]
        if len(on_disk) == 10:
            break
        time.sleep(0.01)
    latency = time.monotonic() - written
    bag.close()
    if interval_s is None:
        assert on_disk == []
    else:
        assert on_disk == [float(i) for i in range(10)], f"not on disk after {latency:.3f} s"
        print(f"flush latency {latency * 1e3:.0f} ms (interval {interval_s * 1e3:.0f} ms)")
        assert latency < 1.0
    assert [m.msg.data for m in read_bag(bag.bag_dir)] == [float(i) for i in range(10)]


def test_flush_adds_no_empty_chunks_and_keeps_the_file_valid(tmp_path):
    bag = BagWriter(str(tmp_path / "f"), flush_interval_s=None)
    bag.add_topic("/x", "std_msgs/msg/Float64")
    for i in range(6):
        bag.write("/x", cdr(float(i)), T0 + i)
        bag.flush()
        bag.flush()  # nothing new: no chunk
    bag.close()
    with open(mcap_path(bag.bag_dir), "rb") as f:
        assert make_reader(f).get_summary().statistics.chunk_count == 6
    assert len(assert_finished_and_consistent(bag.bag_dir)) == 6


def test_reserve_file_released_at_close(tmp_path):
    bag = BagWriter(str(tmp_path / "r"), reserve_bytes=4096)
    reserve = Path(bag.bag_dir) / RESERVE_FILE
    assert reserve.stat().st_size == 4096
    bag.close()
    assert not reserve.exists()
    with pytest.raises(ValueError, match="flush_interval_s"):
        BagWriter(str(tmp_path / "bad"), flush_interval_s=0)


def test_failed_write_stops_the_bag_and_leaves_it_recoverable(tmp_path):
    """A real write failure (the file size limit, EFBIG) in a child process: the writer
    raises BagWriteError naming the file and errno, refuses further writes, releases its
    reserve, records the error in metadata.yaml, and close leaves the file for recovery."""
    bag_dir = tmp_path / "limited"
    child = textwrap.dedent(f"""
        import resource, signal, struct
        from attitude_tools.bag import BagWriter, BagWriteError
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))
        bag = BagWriter({str(bag_dir)!r}, chunk_size=4096, reserve_bytes=64 * 1024)
        bag.add_topic("/x", "std_msgs/msg/Float64")
        n = 0
        try:
            while True:
                bag.write("/x", b"\\x00\\x01\\x00\\x00" + struct.pack("<d", n), {T0} + n)
                n += 1
        except BagWriteError as err:
            print("errno", err.errno, "disk_full", err.disk_full, "file", err.filename)
            try:
                bag.write("/x", b"\\x00\\x01\\x00\\x00" + struct.pack("<d", 0), {T0})
            except BagWriteError:
                print("refused")
            bag.close()
            print("written", n)
        """)
    out = subprocess.run([sys.executable, "-c", child], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    lines = dict(line.split(" ", 1) for line in out.stdout.splitlines() if " " in line)
    assert lines["errno"].startswith("27 disk_full False file ")  # EFBIG
    assert lines["errno"].endswith("limited_0.mcap")
    assert "refused" in out.stdout
    assert not (bag_dir / RESERVE_FILE).exists()
    assert "File too large" in bag_info(str(bag_dir))["custom_data"]["write_error"]
    result = recover_bag(str(bag_dir))
    assert result.recovered
    messages = assert_finished_and_consistent(bag_dir)
    written = int(lines["written"])
    assert 0 < len(messages) <= written
    assert [m.data for m in messages] == [cdr(float(i)) for i in range(len(messages))]


# -- recovery ------------------------------------------------------------------------


def _child_writer(bag_dir: Path, flushed: int, unflushed: int) -> None:
    """A child process writes ``flushed`` messages, flushes, writes ``unflushed`` more and
    is SIGKILLed (no flush thread: the split is exact)."""
    child = textwrap.dedent(f"""
        import os, signal, struct
        from attitude_tools.bag import BagWriter, qos_profile_yaml
        bag = BagWriter({str(bag_dir)!r}, chunk_size=2048, flush_interval_s=None)
        bag.add_attachment("scenario.yaml", b"scenario_name: killed\\n", "application/yaml")
        bag.add_topic("/x", "std_msgs/msg/Float64", {QOS!r})
        bag.add_topic("/y", "std_msgs/msg/Float64")
        for i in range({flushed + unflushed}):
            if i == {flushed}:
                bag.flush()
            data = b"\\x00\\x01\\x00\\x00" + struct.pack("<d", i)
            bag.write("/x" if i % 3 else "/y", data, {T0} + 10 * i, {T0} + 10 * i - 7)
        os.kill(os.getpid(), signal.SIGKILL)
        """)
    out = subprocess.run([sys.executable, "-c", child], capture_output=True, timeout=60)
    assert out.returncode == -signal.SIGKILL, out.stderr.decode()


def test_recover_killed_writer_keeps_raw_cdr_channels_schemas_attachment_and_times(tmp_path):
    bag_dir = tmp_path / "killed"
    _child_writer(bag_dir, 500, 7)
    assert (bag_dir / RESERVE_FILE).exists()  # the writer never closed
    with pytest.raises(ValueError, match="recover_messages"):
        next(read_bag(str(bag_dir)))  # unfinished
    result = recover_bag(str(bag_dir))
    assert result.recovered and result.message_count == 500
    assert (result.start_ns, result.end_ns) == (T0, T0 + 10 * 499)
    assert not (bag_dir / RESERVE_FILE).exists()
    messages = assert_finished_and_consistent(bag_dir)
    assert [m.data for m in messages] == [cdr(float(i)) for i in range(500)]
    assert [(m.log_time, m.publish_time) for m in messages] == [
        (T0 + 10 * i, T0 + 10 * i - 7) for i in range(500)
    ]
    with open(mcap_path(bag_dir), "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        assert channels["/x"].metadata == {
            "offered_qos_profiles": QOS,
            "topic_type_hash": msgdefs.type_description_hash("std_msgs/msg/Float64"),
        }
        assert channels["/y"].metadata["offered_qos_profiles"] == "[]"
        (schema,) = summary.schemas.values()
        assert (schema.name, schema.encoding) == ("std_msgs/msg/Float64", "ros2msg")
        assert schema.data == msgdefs.message_definition("std_msgs/msg/Float64").encode()
        (meta,) = [m for m in reader.iter_metadata() if m.name == "rosbag2"]
    assert yaml.safe_load(meta.metadata["serialized_metadata"])["message_count"] == 500
    info = bag_info(str(bag_dir))
    assert info["custom_data"] == {"recovered": "true"}
    assert {
        t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]
    } == {"/x": 333, "/y": 167}
    assert info["starting_time"]["nanoseconds_since_epoch"] == T0
    assert info["duration"]["nanoseconds"] == 10 * 499
    assert read_attachment(str(bag_dir), "scenario.yaml") == b"scenario_name: killed\n"
    # a second recovery changes nothing
    digest = hashlib.sha256(mcap_path(bag_dir).read_bytes()).hexdigest()
    again = recover_bag(str(bag_dir))
    assert not again.recovered and again.message_count == 500
    assert hashlib.sha256(mcap_path(bag_dir).read_bytes()).hexdigest() == digest


def test_recover_at_any_cut_keeps_exactly_the_complete_chunks(tmp_path):
    """Cut a finished file at random offsets (a kill mid-write, seed printed): recovery
    always gives a valid bag with exactly the messages of the chunks that are whole."""
    source = tmp_path / "src"
    with BagWriter(str(source), chunk_size=1024, flush_interval_s=None) as bag:
        bag.add_topic("/x", "std_msgs/msg/Float64")
        for i in range(400):
            bag.write("/x", cdr(float(i)), T0 + i)
    data = mcap_path(source).read_bytes()
    with open(mcap_path(source), "rb") as f:
        summary = make_reader(f).get_summary()
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    data_end = max(c.chunk_start_offset + c.chunk_length + c.message_index_length for c in chunks)
    seed = random.randrange(2**32)
    print(f"cut seed {seed}")
    rng = random.Random(seed)
    cuts = [rng.randrange(chunks[0].chunk_start_offset, data_end + 1) for _ in range(25)]
    for k, cut in enumerate(cuts + [data_end, chunks[0].chunk_start_offset]):
        bag_dir = tmp_path / f"cut{k}"
        bag_dir.mkdir()
        mcap_path(bag_dir).write_bytes(data[:cut])
        result = recover_bag(str(bag_dir))
        whole = [
            c
            for c in chunks
            if c.chunk_start_offset + c.chunk_length + c.message_index_length <= cut
        ]
        expected = sum(c.message_end_time - c.message_start_time + 1 for c in whole)
        assert result.message_count == expected, (seed, cut)
        messages = assert_finished_and_consistent(bag_dir)
        assert [m.data for m in messages] == [cdr(float(i)) for i in range(expected)], (seed, cut)


def test_interrupted_recovery_is_finished_by_the_next_one(tmp_path):
    bag_dir = tmp_path / "twice"
    _child_writer(bag_dir, 120, 3)
    original = mcap_path(bag_dir).read_bytes()
    recover_bag(str(bag_dir))
    finished = mcap_path(bag_dir).read_bytes()
    # killed while appending the summary: a prefix of the finished file
    for cut in (len(original) + 3, (len(original) + len(finished)) // 2, len(finished) - 1):
        mcap_path(bag_dir).write_bytes(finished[:cut])
        assert recover_bag(str(bag_dir)).message_count == 120
        assert len(assert_finished_and_consistent(bag_dir)) == 120
        assert mcap_path(bag_dir).read_bytes() == finished


def test_finished_bag_with_provisional_metadata_gets_its_metadata_back(tmp_path):
    bag_dir = tmp_path / "meta"
    with BagWriter(str(bag_dir)) as bag:
        bag.add_topic("/x", "std_msgs/msg/Float64")
        for i in range(5):
            bag.write("/x", cdr(float(i)), T0 + i)
        provisional = (bag_dir / "metadata.yaml").read_text()
    (bag_dir / "metadata.yaml").write_text(provisional)  # killed between finish and metadata
    assert bag_info(str(bag_dir))["message_count"] == 0
    result = recover_bag(str(bag_dir))
    assert result.recovered and result.message_count == 5
    assert len(assert_finished_and_consistent(bag_dir)) == 5


def test_not_a_bag(tmp_path):
    with pytest.raises(NotABagError, match="no such directory"):
        recover_bag(str(tmp_path / "missing"))
    (tmp_path / "empty").mkdir()
    with pytest.raises(NotABagError, match="no MCAP file"):
        recover_bag(str(tmp_path / "empty"))
    (tmp_path / "text").mkdir()
    (tmp_path / "text" / "text_0.mcap").write_text("hello")
    with pytest.raises(NotABagError, match="not an MCAP file"):
        recover_bag(str(tmp_path / "text"))


def test_recover_command(tmp_path):
    bag_dir = tmp_path / "cli"
    _child_writer(bag_dir, 60, 2)
    out = subprocess.run([RECOVER, str(bag_dir)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "recovered 60 messages on 2 topics" in out.stdout
    assert len(assert_finished_and_consistent(bag_dir)) == 60
    digest = hashlib.sha256(mcap_path(bag_dir).read_bytes()).hexdigest()
    out = subprocess.run([RECOVER, str(bag_dir)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0 and "already finished (60 messages), unchanged" in out.stdout
    assert hashlib.sha256(mcap_path(bag_dir).read_bytes()).hexdigest() == digest
    (tmp_path / "notabag").mkdir()
    out = subprocess.run(
        [RECOVER, str(tmp_path / "notabag")], capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 2
    assert f"error: {tmp_path / 'notabag'} is not a bag directory" in out.stderr


# -- stamps the recorder refuses as its timeline -------------------------------------


def test_implausible_stamp():
    s = 10**9
    assert implausible_stamp(0, 0, None) is None
    assert implausible_stamp(5, 999_999_999, None) is None
    assert "negative" in implausible_stamp(-5, 0, None)
    assert "negative" in implausible_stamp(-5, 0, 10 * s)
    assert "nanosec" in implausible_stamp(1, 1_000_000_000, None)
    limit = int(STAMP_AHEAD_LIMIT_S)
    assert implausible_stamp(10 + limit, 0, 10 * s) is None  # exactly at the bound
    assert "ahead" in implausible_stamp(10 + limit, 1, 10 * s)
    assert "ahead" in implausible_stamp(1_000_010, 0, 10 * s)
    assert implausible_stamp(1_000_010, 0, None) is None  # no reference yet
    assert implausible_stamp(1, 0, 10 * s) is None  # older stamps are fine


def test_implausible_first_stamp_is_refused_when_the_timelines_are_known():
    """Before any good stamp, a stamp on no timeline a run can have (not simulated time
    of the scenario, not near this host's clock) is refused: it cannot become the
    recording's reference."""
    s = 10**9
    wall = 1_796_000_000 * s
    assert implausible_stamp(0, 0, None, wall, 150.0) is None  # lockstep
    assert implausible_stamp(1_796_000_000, 0, None, wall, 150.0) is None  # real time
    assert "neither" in implausible_stamp(1_000_000, 0, None, wall, 150.0)
    assert "neither" in implausible_stamp(1_796_000_000 + 3600, 0, None, wall, 150.0)
