"""rosbag2 (Jazzy) MCAP bags without rclpy: writing, reading, recovery, and the run
rebuilt from a bag.

``writer`` (:class:`BagWriter`, ``metadata.yaml``), ``reader`` (:func:`read_bag`,
:func:`bag_info`, :func:`read_attachment`), ``recovery`` (:func:`recover_messages`,
``recover_bag`` and ``attitude-bag-recover``), ``msgdefs`` (message definitions and type
hashes), ``layout`` (file names), ``run_record`` (a run rebuilt from a bag). The public
names of the first three are re-exported here.
"""

from attitude_tools.bag import msgdefs
from attitude_tools.bag.layout import METADATA_FILE, RESERVE_FILE
from attitude_tools.bag.reader import BagMessage, bag_info, read_attachment, read_bag
from attitude_tools.bag.recovery import recover_messages
from attitude_tools.bag.writer import (
    BAG_FORMAT_VERSION,
    BagWriteError,
    BagWriter,
    bagfile_information,
    qos_profile_yaml,
    write_metadata_yaml,
)

__all__ = [
    "BAG_FORMAT_VERSION",
    "METADATA_FILE",
    "RESERVE_FILE",
    "BagMessage",
    "BagWriteError",
    "BagWriter",
    "bag_info",
    "bagfile_information",
    "msgdefs",
    "qos_profile_yaml",
    "read_attachment",
    "read_bag",
    "recover_messages",
    "write_metadata_yaml",
]
