"""Finish a bag whose writer died: ``attitude-bag-recover BAG_DIR`` (``ros2 bag reindex``).

A writer killed before ``BagWriter.close`` leaves an MCAP file without its summary
and footer (``mcap`` and ``rosbags`` refuse it) and a provisional ``metadata.yaml``
(zero counts). :func:`recover_bag` finishes such a bag **in place**:

* the file's intact prefix (header, schemas, channels, every chunk whose CRC checks
  and whose message indexes are complete, attachments) is kept byte for byte, so the
  raw CDR, channels with their metadata (QoS, type hash), schemas, the
  ``scenario.yaml`` attachment and log/publish times are the original ones;
* the incomplete tail (the chunk being written when the writer died, at most one
  flush interval of messages, which no reader can use) is cut off;
* the ``rosbag2`` metadata record, data end, summary (schemas, channels, statistics,
  chunk, attachment and metadata indexes, summary offsets), footer and magic are
  appended, as the ``mcap`` Writer writes them; ``metadata.yaml`` is rebuilt from the
  file (its ``custom_data`` kept, ``recovered: 'true'`` added) and replaced atomically.

In place rather than a rewritten copy: on a full disk there is no room for a second
copy (the writer's ``.reserve`` file, removed here, leaves room for the summary).
It is crash safe by being repeatable: interrupted at any point, the file is still
an intact prefix plus an unreadable tail, and a previous attempt's data end and
summary are cut off again. A finished bag is left unchanged.

:func:`recover_messages` reads such a bag without changing it: the messages of every
complete chunk, as far as the file is intact.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import io
import os
import struct
import sys
import zlib
from collections import defaultdict
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, TypeVar

import yaml
from mcap.data_stream import ReadDataStream, RecordBuilder
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import make_reader
from mcap.records import (
    Attachment,
    AttachmentIndex,
    Channel,
    Chunk,
    ChunkIndex,
    DataEnd,
    Footer,
    McapRecord,
    Message,
    MessageIndex,
    Metadata,
    MetadataIndex,
    Schema,
    Statistics,
    SummaryOffset,
)
from mcap.stream_reader import breakup_chunk
from mcap_ros2.decoder import DecoderFactory

from attitude_core.runtime.recording import EXIT_DISK_FULL
from attitude_core.yamlio import dump_safe, load_safe
from attitude_tools.bag.layout import MCAP_MAGIC, METADATA_FILE, RESERVE_FILE
from attitude_tools.bag.reader import BagMessage, bag_info, is_finished, mcap_files, stream_records
from attitude_tools.bag.writer import (
    QosProfile,
    TopicRow,
    bagfile_information,
    parse_qos,
    write_metadata_yaml,
)

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

__all__ = [
    "NotABagError",
    "Recovery",
    "describe",
    "main",
    "recover_bag",
    "recover_messages",
    "run_fields",
    "run_failure",
]

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT = 0, 1, 2
ROSBAG2_METADATA = "rosbag2"
_Record = TypeVar("_Record", bound=McapRecord)


class NotABagError(ValueError):
    """The path is not a bag directory (no directory, no MCAP file, not MCAP)."""


@dataclass
class Recovery:
    """What :func:`recover_bag` found and did."""

    bag_dir: str
    recovered: bool  # False: the bag was finished already, nothing changed
    message_count: int = 0
    start_ns: int | None = None
    end_ns: int | None = None
    counts: dict[str, int] = field(default_factory=dict)
    dropped_bytes: int = 0  # the incomplete tail cut off

    @property
    def span_s(self) -> float:
        if self.start_ns is None or self.end_ns is None:
            return 0.0
        return (self.end_ns - self.start_ns) / 1e9


@dataclass
class _Scan:
    """The intact prefix of an unfinished MCAP file and what it holds."""

    keep: int = 0  # bytes kept
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    attachment_indexes: list[AttachmentIndex] = field(default_factory=list)
    metadata_indexes: list[MetadataIndex] = field(default_factory=list)
    counts: dict[int, int] = field(default_factory=lambda: defaultdict(int))
    start_ns: int | None = None
    end_ns: int | None = None

    def add_message(self, channel_id: int, log_time: int) -> None:
        self.counts[channel_id] += 1
        self.start_ns = log_time if self.start_ns is None else min(self.start_ns, log_time)
        self.end_ns = log_time if self.end_ns is None else max(self.end_ns, log_time)


_READERS = {
    Opcode.SCHEMA: Schema.read,
    Opcode.CHANNEL: Channel.read,
    Opcode.CHUNK: Chunk.read,
    Opcode.MESSAGE_INDEX: MessageIndex.read,
    Opcode.ATTACHMENT: Attachment.read,
    Opcode.METADATA: Metadata.read,
}


def _scan(data: bytes, path: str) -> _Scan:
    """Walk the records of an unfinished MCAP file and find its intact prefix."""
    if not data.startswith(MCAP_MAGIC):
        raise NotABagError(f"{path} is not an MCAP file (no MCAP magic at its start)")
    scan = _Scan()
    pos, n = len(MCAP_MAGIC), len(data)
    if pos + 9 > n or data[pos] != Opcode.HEADER:
        raise NotABagError(f"{path} has no MCAP header: nothing to recover")
    pending: tuple[ChunkIndex, set[int], list[Message]] | None = None
    while pos + 9 <= n:
        opcode, length = struct.unpack_from("<BQ", data, pos)
        end = pos + 9 + length
        if end > n or opcode in (Opcode.DATA_END, Opcode.FOOTER):
            break  # truncated, or the summary of an interrupted recovery: cut here
        if opcode == Opcode.HEADER:
            if pos != len(MCAP_MAGIC):
                break
            scan.keep = pos = end
            continue
        if opcode == Opcode.MESSAGE:
            reader = ReadDataStream(io.BytesIO(data[pos + 9 : end]))
            record = Message.read(reader, length)
        elif opcode in _READERS:
            try:
                record = _READERS[opcode](ReadDataStream(io.BytesIO(data[pos + 9 : end])))
            except (McapError, struct.error, ValueError, UnicodeDecodeError):
                break
        else:
            break  # a record a writer never puts in the data section: damaged
        if pending is not None:
            if not isinstance(record, MessageIndex):
                break  # a chunk without all its message indexes: cut before it
            index, expected, messages = pending
            index.message_index_offsets[record.channel_id] = pos
            expected.discard(record.channel_id)
            if not expected:
                index.message_index_length = end - (index.chunk_start_offset + index.chunk_length)
                _commit_chunk(scan, index, messages)
                scan.keep, pending = end, None
            pos = end
            continue
        if isinstance(record, Schema):
            scan.schemas.setdefault(record.id, record)
        elif isinstance(record, Channel):
            scan.channels.setdefault(record.id, record)
        elif isinstance(record, Message):
            scan.add_message(record.channel_id, record.log_time)
        elif isinstance(record, Chunk):
            try:
                inner = breakup_chunk(record, validate_crc=True)
            except Exception:  # noqa: BLE001 - any damage inside the chunk: cut before it
                break
            messages = []
            for item in inner:
                if isinstance(item, Schema):
                    scan.schemas.setdefault(item.id, item)
                elif isinstance(item, Channel):
                    scan.channels.setdefault(item.id, item)
                elif isinstance(item, Message):
                    messages.append(item)
            index = ChunkIndex(
                message_start_time=record.message_start_time,
                message_end_time=record.message_end_time,
                chunk_start_offset=pos,
                chunk_length=end - pos,
                message_index_offsets={},
                message_index_length=0,
                compression=record.compression,
                compressed_size=len(record.data),
                uncompressed_size=record.uncompressed_size,
            )
            expected = {m.channel_id for m in messages}
            if expected:
                pending = (index, expected, messages)
                pos = end
                continue
            _commit_chunk(scan, index, messages)
        elif isinstance(record, Attachment):
            scan.attachment_indexes.append(
                AttachmentIndex(
                    offset=pos,
                    length=end - pos,
                    log_time=record.log_time,
                    create_time=record.create_time,
                    data_size=len(record.data),
                    name=record.name,
                    media_type=record.media_type,
                )
            )
        elif isinstance(record, Metadata):
            if record.name == ROSBAG2_METADATA:
                break  # written at close, right before the summary: rewritten below
            scan.metadata_indexes.append(
                MetadataIndex(offset=pos, length=end - pos, name=record.name)
            )
        else:  # a stray message index
            break
        scan.keep = pos = end
    return scan


def _commit_chunk(scan: _Scan, index: ChunkIndex, messages: list[Message]) -> None:
    scan.chunk_indexes.append(index)
    for m in messages:
        scan.add_message(m.channel_id, m.log_time)


def _summary(scan: _Scan, summary_start: int) -> bytes:
    """Summary section, footer and closing magic, as ``mcap.writer.Writer.finish`` writes."""
    builder = RecordBuilder()
    offsets: list[SummaryOffset] = []

    def group(opcode: Opcode, records: Iterable[_Record]) -> None:
        start = builder.count
        for record in records:
            record.write(builder)
        offsets.append(SummaryOffset(opcode, summary_start + start, builder.count - start))

    statistics = Statistics(
        message_count=sum(scan.counts.values()),
        schema_count=len(scan.schemas),
        channel_count=len(scan.channels),
        attachment_count=len(scan.attachment_indexes),
        metadata_count=len(scan.metadata_indexes),
        chunk_count=len(scan.chunk_indexes),
        message_start_time=scan.start_ns or 0,
        message_end_time=scan.end_ns or 0,
        channel_message_counts=dict(scan.counts),
    )
    group(Opcode.SCHEMA, sorted(scan.schemas.values(), key=lambda s: s.id))
    group(Opcode.CHANNEL, sorted(scan.channels.values(), key=lambda c: c.id))
    group(Opcode.STATISTICS, [statistics])
    group(Opcode.CHUNK_INDEX, scan.chunk_indexes)
    group(Opcode.ATTACHMENT_INDEX, scan.attachment_indexes)
    group(Opcode.METADATA_INDEX, scan.metadata_indexes)
    summary_offset_start = summary_start + builder.count
    for offset in offsets:
        offset.write(builder)
    summary: bytes = builder.end()  # type: ignore[no-untyped-call]
    crc = zlib.crc32(summary)
    crc = zlib.crc32(
        struct.pack("<BQQQ", Opcode.FOOTER, 8 + 8 + 4, summary_start, summary_offset_start), crc
    )
    Footer(summary_start, summary_offset_start, crc).write(builder)
    footer: bytes = builder.end()  # type: ignore[no-untyped-call]
    return summary + footer + MCAP_MAGIC


def _topics(scan: _Scan) -> list[TopicRow]:
    """metadata.yaml topics from the file's channels (QoS and type hash from their metadata)."""
    topics: list[TopicRow] = []
    for channel in sorted(scan.channels.values(), key=lambda c: c.id):
        schema = scan.schemas.get(channel.schema_id)
        try:
            qos: list[QosProfile] = parse_qos(channel.metadata.get("offered_qos_profiles", ""))
        except (TypeError, ValueError):
            qos = []
        type_hash = channel.metadata.get("topic_type_hash", "")
        topics.append((channel.topic, schema.name if schema else "", qos, type_hash))
    return topics


def _old_custom_data(bag_dir: str) -> dict[str, str]:
    with contextlib.suppress(OSError, ValueError, KeyError, TypeError, yaml.YAMLError):
        return dict(bag_info(bag_dir).get("custom_data") or {})
    return {}


def _finish_file(path: str, bag_dir: str) -> tuple[_Scan, int, dict[str, Any]]:
    """Finish one unfinished MCAP file in place; (scan, bytes cut off, rosbag2 metadata)."""
    with open(path, "rb") as f:
        data = f.read()
    scan = _scan(data, path)
    file_name = os.path.basename(path)
    custom = _old_custom_data(bag_dir)
    custom["recovered"] = "true"
    counts = {scan.channels[c].topic: k for c, k in scan.counts.items() if c in scan.channels}
    info = bagfile_information(file_name, _topics(scan), counts, scan.start_ns, scan.end_ns, custom)
    builder = RecordBuilder()
    serialized = dump_safe(info)  # as the writer's close writes it
    Metadata(name=ROSBAG2_METADATA, metadata={"serialized_metadata": serialized}).write(builder)
    scan.metadata_indexes.append(
        MetadataIndex(offset=scan.keep, length=builder.count, name=ROSBAG2_METADATA)
    )
    DataEnd(data_section_crc=0).write(builder)
    tail: bytes = builder.end()  # type: ignore[no-untyped-call]
    tail += _summary(scan, scan.keep + len(tail))
    with open(path, "r+b") as f:
        f.truncate(scan.keep)
        f.seek(scan.keep)
        f.write(tail)
        f.flush()
        os.fsync(f.fileno())
    return scan, len(data) - scan.keep, info


def _finished_info(path: str) -> tuple[int, dict[str, int], int | None, int | None]:
    """(message count, counts by topic, start, end) from a finished file's summary."""
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    if summary is None or summary.statistics is None:
        return 0, {}, None, None
    stats = summary.statistics
    counts = {
        summary.channels[c].topic: k
        for c, k in stats.channel_message_counts.items()
        if c in summary.channels
    }
    if not stats.message_count:
        return 0, counts, None, None
    return stats.message_count, counts, stats.message_start_time, stats.message_end_time


def recover_bag(bag_dir: str) -> Recovery:
    """Finish the bag at ``bag_dir`` if its writer died (see the module docstring).

    Returns what it recovered (``recovered=False``: already finished, unchanged).
    NotABagError if ``bag_dir`` is not a bag; OSError if it cannot be written.
    """
    bag_dir = os.path.abspath(os.fspath(bag_dir))
    if not os.path.isdir(bag_dir):
        raise NotABagError(f"{bag_dir} is not a bag directory (no such directory)")
    try:
        paths = mcap_files(bag_dir)
    except FileNotFoundError as err:
        raise NotABagError(f"{bag_dir} is not a bag directory: {err}") from None
    except (KeyError, TypeError, ValueError, yaml.YAMLError) as err:
        mcaps = sorted(n for n in os.listdir(bag_dir) if n.endswith(".mcap"))
        if not mcaps:
            raise NotABagError(f"{bag_dir}: unreadable {METADATA_FILE} ({err})") from None
        paths = [os.path.join(bag_dir, n) for n in mcaps]  # rebuilt below
    missing = [p for p in paths if not os.path.isfile(p)]
    if missing:
        raise NotABagError(f"{bag_dir} is not a bag directory: {missing[0]} is missing")
    if len(paths) != 1:
        raise NotABagError(f"{bag_dir}: {len(paths)} storage files; only single-file bags")
    path = paths[0]
    with contextlib.suppress(FileNotFoundError):
        os.remove(os.path.join(bag_dir, RESERVE_FILE))  # room for the summary on a full disk
    if is_finished(path):
        count, counts, start, end = _finished_info(path)
        try:
            intact = bag_info(bag_dir)["message_count"] == count
        except (OSError, ValueError, KeyError, TypeError, yaml.YAMLError):
            intact = False
        if intact:
            return Recovery(bag_dir, False, count, start, end, counts)
        with open(path, "rb") as f:  # killed between finishing the file and metadata.yaml
            serialized = {m.name: m.metadata for m in make_reader(f).iter_metadata()}.get(
                ROSBAG2_METADATA, {}
            ).get("serialized_metadata")
        if serialized is None:
            raise NotABagError(f"{path} is finished but holds no rosbag2 metadata")
        write_metadata_yaml(bag_dir, load_safe(serialized))
        return Recovery(bag_dir, True, count, start, end, counts)
    scan, dropped, info = _finish_file(path, bag_dir)
    write_metadata_yaml(bag_dir, info)
    counts = {
        t["topic_metadata"]["name"]: t["message_count"] for t in info["topics_with_message_count"]
    }
    return Recovery(
        bag_dir, True, info["message_count"], scan.start_ns, scan.end_ns, counts, dropped
    )


def describe(result: Recovery) -> str:
    """One line on what :func:`recover_bag` did."""
    if not result.recovered:
        return f"{result.bag_dir}: already finished ({result.message_count} messages), unchanged"
    if result.start_ns is None or result.end_ns is None:
        span = "no messages"
    else:
        span = (
            f"log time {result.start_ns / 1e9:.3f} .. {result.end_ns / 1e9:.3f} s "
            f"({result.span_s:.3f} s)"
        )
    topics = sum(1 for k in result.counts.values() if k)
    return (
        f"{result.bag_dir}: recovered {result.message_count} messages on {topics} topics, "
        f"{span}; {result.dropped_bytes} bytes of incomplete tail cut off"
    )


# -- reading a bag whose writer died -------------------------------------------------


def recover_messages(bag_dir: str, topics: list[str] | None = None) -> Iterator[BagMessage]:
    """Decoded messages of a bag, finished or not, in file order, as far as intact.

    For a bag whose writer was killed (no MCAP summary or footer): reads the MCAP
    files front to back and yields the messages of every complete chunk, stopping
    quietly at the truncated end.
    """
    wanted = None if topics is None else set(topics)
    factory = DecoderFactory()
    for path in mcap_files(bag_dir):
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}
        decoders: dict[int, Callable[[bytes], Any]] = {}
        for record in stream_records(path):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            else:
                channel = channels.get(record.channel_id)
                if channel is None or (wanted is not None and channel.topic not in wanted):
                    continue
                schema = schemas.get(channel.schema_id)
                if record.channel_id not in decoders:
                    decoder = factory.decoder_for(channel.message_encoding, schema)
                    if decoder is None:
                        raise ValueError(
                            f"cannot decode topic {channel.topic!r} ({channel.message_encoding})"
                        )
                    decoders[record.channel_id] = decoder
                yield BagMessage(
                    channel.topic,
                    schema.name if schema else "",
                    record.log_time,
                    record.publish_time,
                    decoders[record.channel_id](record.data),
                )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="attitude-bag-recover",
        description="Finish a rosbag2 MCAP bag whose recorder was killed or crashed "
        "(in place: intact data kept, incomplete tail cut, summary and metadata.yaml "
        "rebuilt). A finished bag is left unchanged.",
    )
    parser.add_argument("bag_dir", help="bag directory (metadata.yaml + <name>_0.mcap)")
    args = parser.parse_args(argv)
    try:
        result = recover_bag(args.bag_dir)
    except NotABagError as err:
        print(f"attitude-bag-recover: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except OSError as err:
        print(f"attitude-bag-recover: error: cannot recover {args.bag_dir}: {err}", file=sys.stderr)
        return EXIT_FAILED
    print(f"attitude-bag-recover: {describe(result)}")
    return EXIT_OK


if __name__ == "__main__":
    raise SystemExit(main())


# -- for attitude-run -----------------------------------------------------------------


def _custom_data(bag_dir: str) -> dict[str, str]:
    return _old_custom_data(bag_dir)


def run_failure(
    failure: str | None,
    recovery: Recovery | None,
    recovery_error: str | None,
    recorder_code: int | None,
    staging_dir: str,
    out_dir: str,
) -> str | None:
    """``attitude-run``'s failure after bag recovery: what happened to the recorder.

    A bag the recorder could not write names the cause from its metadata.yaml
    (``custom_data.write_error``, the staging path shown as ``out_dir``); a recovered
    bag adds "bag recovered"; a bag that could not be recovered says why.
    """
    if recovery_error is not None:
        return f"{failure}; {recovery_error}" if failure else recovery_error
    if recovery is None or not recovery.recovered:
        return failure
    write_error = _custom_data(recovery.bag_dir).get("write_error")
    if write_error:
        write_error = write_error.replace(staging_dir, out_dir)
        full = recorder_code == EXIT_DISK_FULL or f"[Errno {errno.ENOSPC}]" in write_error
        cause = f"disk full: {write_error}" if full else f"bag write failed: {write_error}"
    else:
        cause = failure or f"recorder exited with code {recorder_code}"
    return f"{cause}; bag recovered"


def run_fields(
    recovery: Recovery | None, bag_dir: str, t_s: npt.NDArray[np.float64]
) -> dict[str, Any]:
    """``summary.json`` fields: ``recovered``, ``recovered_span_s`` (first and last step
    of the run time, for a recovered bag) and ``recorder_bad_stamps`` (None: unknown)."""
    recovered = recovery is not None and recovery.recovered
    span = [round(float(t_s[0]), 6), round(float(t_s[-1]), 6)] if recovered and len(t_s) else None
    bad = _custom_data(bag_dir).get("recorder_bad_stamps")
    return {
        "recovered": recovered,
        "recovered_span_s": span,
        "recorder_bad_stamps": int(bad) if bad is not None and bad.isdigit() else None,
    }
