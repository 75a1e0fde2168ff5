"""rosbag2 MCAP bags read back without rclpy: messages decoded, attachments, metadata.

Decodes with ``mcap_ros2`` from the schemas stored in the bag. A finished bag is read
through its MCAP summary (:func:`read_bag`); the records of a file whose writer died
are streamed front to back as far as intact (:func:`stream_records`, used by
:func:`read_attachment` and ``attitude_tools.bag.recovery.recover_messages``).
"""

from __future__ import annotations

import contextlib
import heapq
import os
from collections.abc import Iterator
from typing import Any, NamedTuple, cast

from mcap.reader import make_reader
from mcap.records import Attachment, Channel, Chunk, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap_ros2.decoder import DecoderFactory

from attitude_core.yamlio import load_safe
from attitude_tools.bag.layout import MCAP_MAGIC, METADATA_FILE

__all__ = [
    "BagMessage",
    "bag_info",
    "is_finished",
    "mcap_files",
    "read_attachment",
    "read_bag",
    "stream_records",
]


class BagMessage(NamedTuple):
    """One decoded message of a bag."""

    topic: str
    type_name: str
    log_time_ns: int
    publish_time_ns: int
    msg: Any


def bag_info(bag_dir: str) -> dict[str, Any]:
    """The ``rosbag2_bagfile_information`` mapping of a bag's metadata.yaml."""
    path = os.path.join(os.fspath(bag_dir), METADATA_FILE)
    with open(path, encoding="utf-8") as f:
        doc = load_safe(f)
    if not isinstance(doc, dict) or "rosbag2_bagfile_information" not in doc:
        raise ValueError(f"{path} has no rosbag2_bagfile_information")
    return cast(dict[str, Any], doc["rosbag2_bagfile_information"])


def mcap_files(bag_dir: str) -> list[str]:
    """The bag's storage files: from metadata.yaml, else every ``*.mcap`` in the directory."""
    bag_dir = os.fspath(bag_dir)
    if os.path.isfile(os.path.join(bag_dir, METADATA_FILE)):
        names = [os.path.basename(p) for p in bag_info(bag_dir)["relative_file_paths"]]
    else:
        names = sorted(n for n in os.listdir(bag_dir) if n.endswith(".mcap"))
    if not names:
        raise FileNotFoundError(f"no MCAP file in bag {bag_dir!r}")
    return [os.path.join(bag_dir, n) for n in names]


def is_finished(path: str) -> bool:
    """True when an MCAP file ends with its closing magic (its writer finished it)."""
    with open(path, "rb") as f:
        if f.seek(0, os.SEEK_END) < 2 * len(MCAP_MAGIC):
            return False
        f.seek(-len(MCAP_MAGIC), os.SEEK_END)
        return f.read() == MCAP_MAGIC


def read_bag(bag_dir: str, topics: list[str] | None = None) -> Iterator[BagMessage]:
    """Decoded messages of a finished bag in log-time order (optionally only ``topics``).

    Decodes with ``mcap_ros2`` from the schemas stored in the bag. A bag whose
    writer died before ``close`` has no MCAP summary: use
    ``attitude_tools.bag.recovery.recover_messages``.
    """
    with contextlib.ExitStack() as stack:
        streams = []
        for path in mcap_files(bag_dir):
            if not is_finished(path):
                raise ValueError(
                    f"{path} is not a finished MCAP file (its writer was killed?): "
                    "read it with recover_messages"
                )
            f = stack.enter_context(open(path, "rb"))
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            streams.append(
                BagMessage(
                    channel.topic,
                    schema.name if schema else "",
                    message.log_time,
                    message.publish_time,
                    decoded,
                )
                for schema, channel, message, decoded in reader.iter_decoded_messages(
                    topics=topics, log_time_order=True
                )
            )
        yield from heapq.merge(*streams, key=lambda m: m.log_time_ns)


_MESSAGE_RECORDS = (Schema, Channel, Message)


def stream_records(path: str, kinds: tuple[type, ...] = _MESSAGE_RECORDS) -> Iterator[Any]:
    """The records of the given kinds of an MCAP file, in file order.

    Stops quietly at a truncated or damaged end (a writer killed mid-file).
    """
    open_chunks = any(k in kinds for k in _MESSAGE_RECORDS)
    with open(path, "rb") as f:
        records = StreamReader(f, emit_chunks=True).records
        while True:
            try:
                record = next(records)
                # A chunk is only yielded once all its bytes were read; its CRC catches the rest.
                if isinstance(record, Chunk):
                    inner = breakup_chunk(record, validate_crc=True) if open_chunks else []
                else:
                    inner = [record]
            except StopIteration:
                return
            except Exception:  # noqa: BLE001 - truncated or damaged tail: stop there
                return
            for item in inner:
                if isinstance(item, kinds):
                    yield item


def read_attachment(bag_dir: str, name: str) -> bytes:
    """Data of the attachment ``name`` (see ``BagWriter.add_attachment``); KeyError if absent.

    Works on unfinished bags too (attachments are written straight to the file).
    """
    for path in mcap_files(bag_dir):
        if is_finished(path):
            with open(path, "rb") as f:
                found = [a.data for a in make_reader(f).iter_attachments() if a.name == name]
        else:
            found = [a.data for a in stream_records(path, (Attachment,)) if a.name == name]
        if found:
            return found[0]
    raise KeyError(f"no attachment {name!r} in bag {os.fspath(bag_dir)!r}")
