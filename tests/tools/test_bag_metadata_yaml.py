"""A bag's metadata.yaml, rewritten at every flush of a recording, goes through
libyaml's emitter (``attitude_core.yamlio.dump_safe``)."""

from pathlib import Path

import yaml
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64

from attitude_core.yamlio import dump_safe
from attitude_tools.bag import BagWriter, qos_profile_yaml

T0 = 1_700_000_000_000_000_000


def test_metadata_written_with_libyaml_is_what_the_pure_python_dumper_writes(tmp_path):
    """The same text as PyYAML's pure emitter on a bag's metadata; on strings that need
    quoting, folding or escapes (a write error's text, custom data) the same data read
    back (libyaml folds long escaped strings at other places)."""
    bag_dir = str(tmp_path / "run")
    with BagWriter(bag_dir) as bag:
        bag.add_topic("/a", "std_msgs/msg/Float64", qos_profile_yaml("reliable", "volatile", 10))
        bag.add_topic("/b", "std_msgs/msg/Float64", "")
        for i in range(5):
            bag.write("/a", serialize_message(Float64(data=float(i))), T0 + i)
        bag.update_custom_data(note="a: b")
    text = (Path(bag_dir) / "metadata.yaml").read_text()
    doc = yaml.load(text, Loader=yaml.SafeLoader)
    assert dump_safe(doc) == yaml.safe_dump(doc, sort_keys=False, default_flow_style=False)
    assert dump_safe(doc) == text  # what the writer wrote is libyaml's text
    info = doc["rosbag2_bagfile_information"]
    assert info["message_count"] == 5 and info["custom_data"]["note"] == "a: b"
    info["custom_data"] = {
        "write_error": "[Errno 28] No space left on device: '/tmp/x y/run_0.mcap'",
        "note": "key: value # not a comment\n\ttabbed, 'quoted' and \"double\" " * 4,
        "unicode": "\u00e9\u00e8 \u2013 \U0001f6f0 \x07 bell",
        "empty": "",
        "yes": "yes",
        "number": "0123",
    }
    info["duration"]["nanoseconds"] = 2**64 - 1
    for data in (doc, {"a": [None, True, 1.5e-300, -0.0, float("inf")], "b": {"c": []}}):
        assert yaml.load(dump_safe(data), Loader=yaml.SafeLoader) == data
