"""Checks of a recorded bag shared by the bag tests (``tools/test_bag_recovery.py``) and
the recorder crash tests (``ros/test_recording_crash.py``): the bag reads back as a
finished MCAP by independent readers (``mcap``, ``rosbags``).

Imported as ``from bag_checks import ...`` (``tests/`` is on ``sys.path``, see
``support.py``).
"""

from pathlib import Path

from mcap.reader import make_reader
from rosbags.rosbag2 import Reader

from attitude_tools.bag import bag_info


def mcap_path(bag_dir) -> Path:
    """The bag's MCAP file (named in metadata.yaml, else after the directory)."""
    try:
        return Path(bag_dir) / bag_info(str(bag_dir))["relative_file_paths"][0]
    except FileNotFoundError:
        return Path(bag_dir) / f"{Path(bag_dir).name}_0.mcap"


def assert_finished_and_consistent(bag_dir) -> list:
    """The bag reads as a finished MCAP (mcap, rosbags) with metadata.yaml's counts;
    returns its messages (mcap records, file order)."""
    info = bag_info(str(bag_dir))
    with open(mcap_path(bag_dir), "rb") as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        messages = [m for _, _, m in reader.iter_messages()]
    assert summary.statistics.message_count == info["message_count"] == len(messages)
    with Reader(bag_dir) as rb:
        assert rb.message_count == info["message_count"] == sum(1 for _ in rb.messages())
        by_topic = {c.topic: c.msgcount for c in rb.connections}
    assert by_topic == {
        t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]
    }
    return messages
