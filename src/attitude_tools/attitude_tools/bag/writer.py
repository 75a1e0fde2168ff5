"""rosbag2-compatible MCAP bags written without rclpy: raw CDR in, ``metadata.yaml`` beside.

A bag is a directory holding ``metadata.yaml`` and one ``<dir name>_0.mcap`` file,
laid out as ``ros2 bag record -s mcap`` of ROS 2 Jazzy lays it out (metadata
version 9, MCAP profile ``ros2``, schemas ``ros2msg``, channels ``cdr`` with the
``offered_qos_profiles`` and ``topic_type_hash`` channel metadata). rosbags and
mcap_ros2 read it (tested); ``ros2 bag info/play`` should, by construction from
rosbag2's Jazzy sources (no rosbag2 install to test against here).

Crash safety: ``metadata.yaml`` is replaced atomically, a provisional one (zero
counts) exists from the start; schemas and channels are written to the file (outside
chunks, as well as in the first chunk) as soon as a topic is added; the chunk in
progress is finished, flushed and synced every ``flush_interval_s`` of wall time
(0.25 s by default) when it holds messages, so a writer killed at any moment loses at
most that much plus one fsync. ``recover_messages`` reads the complete chunks of a
file whose writer died before ``close``; ``attitude_tools.bag.recovery`` finishes such
a bag. A reserve file (``.reserve``, ``reserve_bytes``) holds back disk space that is
released to finish the file on close or after a failed write (a full disk), so what
was recorded can still be finished.
"""

from __future__ import annotations

import contextlib
import errno
import os
import threading
import time
from collections.abc import Callable
from typing import Any, NamedTuple, ParamSpec, TypeVar

import yaml
from mcap.data_stream import RecordBuilder
from mcap.records import Channel, Schema
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType, Writer

from attitude_core.yamlio import dump_safe, load_safe
from attitude_tools.bag import msgdefs
from attitude_tools.bag.layout import METADATA_FILE, RESERVE_FILE

__all__ = [
    "BAG_FORMAT_VERSION",
    "BagWriteError",
    "BagWriter",
    "QosProfile",
    "TopicRow",
    "bagfile_information",
    "parse_qos",
    "qos_profile_yaml",
    "write_metadata_yaml",
]

BAG_FORMAT_VERSION = 9
"""``rosbag2_storage::BagMetadata::version`` of ROS 2 Jazzy (QoS as YAML lists, enum names)."""

ROS_DISTRO = "jazzy"
TIME_MAX_NS = 2**63 - 1
"""rosbag2's ``starting_time`` of a bag without messages (``nanoseconds::max()``)."""

RMW_DURATION_INFINITE = {"sec": 9223372036, "nsec": 854775807}
"""How Jazzy's rosbag2 records an infinite deadline, lifespan or lease duration."""

_COMPRESSION = {
    "none": CompressionType.NONE,
    "lz4": CompressionType.LZ4,
    "zstd": CompressionType.ZSTD,
}
_RELIABILITY = ("reliable", "best_effort", "system_default", "best_available")
_DURABILITY = ("volatile", "transient_local", "system_default", "best_available")
_QOS_KEYS = (
    "history",
    "depth",
    "reliability",
    "durability",
    "deadline",
    "lifespan",
    "liveliness",
    "liveliness_lease_duration",
    "avoid_ros_namespace_conventions",
)


QosProfile = dict[str, Any]
"""One offered QoS profile as parsed from metadata.yaml or a channel's metadata."""
TopicRow = tuple[str, str, list[QosProfile], str]
"""A topic of ``metadata.yaml``: (name, type, offered QoS profiles, type hash)."""

_P = ParamSpec("_P")
_R = TypeVar("_R")


def qos_profile_yaml(
    reliability: str, durability: str, depth: int, history: str = "keep_last"
) -> str:
    """One offered QoS profile as Jazzy's rosbag2 serializes it (a YAML list of one).

    ``reliability``: ``'reliable'`` or ``'best_effort'``; ``durability``:
    ``'volatile'`` or ``'transient_local'`` (``'system_default'`` and
    ``'best_available'`` are accepted too); ``history``: ``'keep_last'`` (of ``depth``)
    or ``'keep_all'``;
    deadline, lifespan and liveliness lease are infinite, liveliness automatic.
    """
    if reliability not in _RELIABILITY:
        raise ValueError(f"reliability must be one of {_RELIABILITY}, not {reliability!r}")
    if durability not in _DURABILITY:
        raise ValueError(f"durability must be one of {_DURABILITY}, not {durability!r}")
    if history not in ("keep_last", "keep_all"):
        raise ValueError(f"history must be keep_last or keep_all, not {history!r}")
    if isinstance(depth, bool) or not isinstance(depth, int) or depth < 0:
        raise ValueError(f"depth must be an int >= 0, not {depth!r}")
    sec, nsec = RMW_DURATION_INFINITE["sec"], RMW_DURATION_INFINITE["nsec"]
    infinite = f"\n    sec: {sec}\n    nsec: {nsec}"
    return (
        f"- history: {history}\n"
        f"  depth: {depth}\n"
        f"  reliability: {reliability}\n"
        f"  durability: {durability}\n"
        f"  deadline:{infinite}\n"
        f"  lifespan:{infinite}\n"
        f"  liveliness: automatic\n"
        f"  liveliness_lease_duration:{infinite}\n"
        f"  avoid_ros_namespace_conventions: false"
    )


def parse_qos(text: str) -> list[QosProfile]:
    """Offered QoS profiles string -> list of profile mappings (ValueError if malformed)."""
    if not isinstance(text, str):
        raise TypeError(f"offered_qos_profiles must be a YAML string, not {type(text).__name__}")
    if not text.strip():
        return []
    try:
        profiles = load_safe(text)
    except yaml.YAMLError as err:
        raise ValueError(f"offered_qos_profiles is not valid YAML: {err}") from None
    if profiles is None:
        return []
    if not isinstance(profiles, list) or not all(isinstance(p, dict) for p in profiles):
        raise ValueError("offered_qos_profiles must be a YAML list of QoS profile mappings")
    for profile in profiles:
        missing = [k for k in _QOS_KEYS if k not in profile]
        if missing:
            raise ValueError(f"offered_qos_profiles entry lacks {missing}")
    return profiles


class BagWriteError(OSError):
    """A write to the bag failed (e.g. a full disk); the bag is left for recovery.

    ``errno``/``strerror``/``filename`` are those of the underlying OSError.
    """

    @property
    def disk_full(self) -> bool:
        return self.errno in (errno.ENOSPC, errno.EDQUOT)


class _Topic(NamedTuple):
    name: str
    type_name: str
    qos_profiles: list[QosProfile]
    type_hash: str
    channel_id: int


class BagWriter:
    """rosbag2 bag directory (metadata.yaml + <name>_0.mcap), storage 'mcap', profile 'ros2'.

    ``bag_dir`` must not exist or be an empty directory (FileExistsError otherwise).
    ``chunk_size`` is the MCAP chunk size in bytes; ``compression`` the chunk
    compression, ``'none'``, ``'lz4'`` or ``'zstd'``. ``flush_interval_s``: wall time
    after which a background thread finishes the chunk in progress (if it holds
    messages) and syncs the file (None: only full chunks are written).
    ``reserve_bytes``: disk space held back in ``.reserve`` until close or a failed
    write (0: none). A failed write (OSError) raises :class:`BagWriteError`, then so
    does every later write; ``close`` then leaves the file unfinished for recovery.
    ``custom_data``: the ``custom_data`` mapping of metadata.yaml (str to str).
    Thread-safe; a context manager.
    """

    def __init__(
        self,
        bag_dir: str,
        *,
        chunk_size: int = 256 * 1024,
        compression: str = "none",
        flush_interval_s: float | None = 0.25,
        reserve_bytes: int = 1 << 20,
    ):
        if isinstance(chunk_size, bool) or not isinstance(chunk_size, int) or chunk_size <= 0:
            raise ValueError(f"chunk_size must be a positive int, not {chunk_size!r}")
        if flush_interval_s is not None and not flush_interval_s > 0:
            raise ValueError(f"flush_interval_s must be > 0 or None, not {flush_interval_s!r}")
        if (
            isinstance(reserve_bytes, bool)
            or not isinstance(reserve_bytes, int)
            or reserve_bytes < 0
        ):
            raise ValueError(f"reserve_bytes must be an int >= 0, not {reserve_bytes!r}")
        if compression not in _COMPRESSION:
            raise ValueError(
                f"compression must be one of {sorted(_COMPRESSION)}, not {compression!r}"
            )
        bag_dir = os.path.abspath(os.fspath(bag_dir))
        if os.path.lexists(bag_dir) and not (os.path.isdir(bag_dir) and not os.listdir(bag_dir)):
            raise FileExistsError(f"bag directory {bag_dir!r} exists and is not an empty directory")
        os.makedirs(bag_dir, exist_ok=True)

        self.bag_dir = bag_dir
        self.file_name = f"{os.path.basename(bag_dir)}_0.mcap"
        self._lock = threading.RLock()
        self._topics: dict[str, _Topic] = {}
        self._schema_ids: dict[str, int] = {}
        self._counts: dict[str, int] = {}
        self._start_ns: int | None = None
        self._end_ns: int | None = None
        self._closed = False
        self._error: BagWriteError | None = None
        self._unflushed = 0  # messages in the chunk in progress
        self.custom_data: dict[str, str] = {}
        self.path = os.path.join(bag_dir, self.file_name)
        self._reserve = os.path.join(bag_dir, RESERVE_FILE)
        self._file = open(self.path, "xb")  # noqa: SIM115 - closed by close()
        try:
            if reserve_bytes:
                fd = os.open(self._reserve, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o644)
                try:
                    os.posix_fallocate(fd, 0, reserve_bytes)
                finally:
                    os.close(fd)
            self._mcap = Writer(
                self._file,
                chunk_size=chunk_size,
                compression=_COMPRESSION[compression],
            )
            self._mcap.start(profile="ros2", library=f"attitude_tools.bag; {LIBRARY_IDENTIFIER}")
            self._sync_file()
            self._write_metadata_yaml()
        except BaseException:
            self._file.close()
            self._release_reserve()
            raise
        self._stop_flusher = threading.Event()
        self._flusher: threading.Thread | None = None
        if flush_interval_s is not None:
            self._flusher = threading.Thread(
                target=self._flush_loop,
                args=(float(flush_interval_s),),
                name=f"bag flusher {self.file_name}",
                daemon=True,
            )
            self._flusher.start()

    # -- writing -------------------------------------------------------------------

    def add_topic(self, name: str, type_name: str, offered_qos_profiles: str = "") -> None:
        """Register a topic: its ``ros2msg`` schema (once per type) and its ``cdr`` channel.

        ``offered_qos_profiles`` is a YAML list of QoS profiles (see
        ``qos_profile_yaml``) or ``''``. Adding the same topic again with the same
        type and QoS does nothing; with a different one raises ValueError.
        """
        if not isinstance(name, str) or not name:
            raise ValueError(f"topic name must be a non-empty string, not {name!r}")
        pkg, type_ = msgdefs.normalize_type_name(type_name)
        type_name = f"{pkg}/msg/{type_}"
        profiles = parse_qos(offered_qos_profiles)
        # Jazzy's rosbag2 never stores an empty channel string: an empty list dumps as "[]".
        qos_text = offered_qos_profiles if profiles else "[]"
        with self._lock:
            self._check_open()
            if name in self._topics:
                known = self._topics[name]
                if (known.type_name, known.qos_profiles) != (type_name, profiles):
                    raise ValueError(
                        f"topic {name!r} already added as {known.type_name} with other QoS"
                    )
                return
            # The Writer puts schemas and channels into the next chunk only; they are
            # also written at the top level now (identical records, as MCAP allows), so
            # a bag killed before its first chunk still names its topics.
            records = RecordBuilder()
            if type_name not in self._schema_ids:
                data = msgdefs.message_definition(type_name).encode()
                schema_id = self._guarded(self._mcap.register_schema, type_name, "ros2msg", data)
                self._schema_ids[type_name] = schema_id
                Schema(id=schema_id, name=type_name, encoding="ros2msg", data=data).write(records)
            type_hash = msgdefs.type_description_hash(type_name)
            metadata = {"offered_qos_profiles": qos_text, "topic_type_hash": type_hash}
            channel_id = self._guarded(
                self._mcap.register_channel,
                topic=name,
                message_encoding="cdr",
                schema_id=self._schema_ids[type_name],
                metadata=metadata,
            )
            Channel(
                id=channel_id,
                topic=name,
                message_encoding="cdr",
                schema_id=self._schema_ids[type_name],
                metadata=metadata,
            ).write(records)
            self._guarded(self._file.write, records.end())  # type: ignore[no-untyped-call]
            self._topics[name] = _Topic(name, type_name, profiles, type_hash, channel_id)
            self._counts[name] = 0
            self._write_metadata_yaml()

    def write(
        self, topic: str, data: bytes, log_time_ns: int, publish_time_ns: int | None = None
    ) -> None:
        """Append one message: ``data`` is the raw CDR (4-byte encapsulation header first).

        ``log_time_ns`` is the receive time, ``publish_time_ns`` the send time
        (defaults to ``log_time_ns``), both in ns since the epoch.
        """
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"data must be bytes (serialized CDR), not {type(data).__name__}")
        data = bytes(data)
        if len(data) < 4 or data[0] != 0:
            raise ValueError("data is not CDR: it must start with a 4-byte encapsulation header")
        log_time_ns = _check_time("log_time_ns", log_time_ns)
        if publish_time_ns is None:
            publish_time_ns = log_time_ns
        publish_time_ns = _check_time("publish_time_ns", publish_time_ns)
        with self._lock:
            self._check_open()
            if topic not in self._topics:
                raise KeyError(f"unknown topic {topic!r}: call add_topic first")
            self._guarded(
                self._mcap.add_message,
                channel_id=self._topics[topic].channel_id,
                log_time=log_time_ns,
                data=data,
                publish_time=publish_time_ns,
                sequence=0,
            )
            self._counts[topic] += 1
            self._unflushed += 1
            if self._start_ns is None:
                self._start_ns = self._end_ns = log_time_ns
            else:
                assert self._end_ns is not None  # set together with _start_ns
                self._start_ns = min(self._start_ns, log_time_ns)
                self._end_ns = max(self._end_ns, log_time_ns)

    def add_attachment(self, name: str, data: bytes, media_type: str) -> None:
        """Store a file in the MCAP as an attachment (e.g. the run's scenario YAML).

        rosbag2 ignores attachments; MCAP readers (``mcap``, Foxglove) list them.
        """
        if not isinstance(name, str) or not name:
            raise ValueError(f"attachment name must be a non-empty string, not {name!r}")
        if not isinstance(data, (bytes, bytearray, memoryview)):
            raise TypeError(f"attachment data must be bytes, not {type(data).__name__}")
        now_ns = time.time_ns()
        with self._lock:
            self._check_open()
            self._guarded(
                self._mcap.add_attachment,
                create_time=now_ns,
                log_time=now_ns,
                name=name,
                media_type=media_type,
                data=bytes(data),
            )

    def flush(self) -> None:
        """Finish the chunk in progress (if it holds messages) and sync the file to disk."""
        with self._lock:
            self._check_open()
            if not self._unflushed:
                return
            # Writer.flush (public in mcap >= 1.2) finishes the open chunk early.
            self._guarded(self._mcap.flush)
            self._unflushed = 0

    def close(self) -> None:
        """Finish the MCAP (summary, footer) and write the final metadata.yaml; idempotent.

        After a failed write the file is left unfinished (for
        ``bag_recovery.recover_bag``) and the provisional metadata.yaml is kept.
        """
        self._stop_flusher.set()
        if self._flusher is not None and self._flusher is not threading.current_thread():
            self._flusher.join()
        with self._lock:
            if self._closed:
                return
            self._closed = True
            self._release_reserve()  # the room to finish the file on a full disk
            if self._error is not None:
                with contextlib.suppress(OSError):
                    self._file.close()  # may retry the failed write: nothing more to keep
                return
            try:
                info = self._metadata()
                # The last chunk first: the rosbag2 record then sits right before the
                # data end, where bag_recovery expects it (nothing after it to lose).
                self._mcap.flush()  # type: ignore[no-untyped-call]
                self._mcap.add_metadata("rosbag2", {"serialized_metadata": dump_safe(info)})
                self._mcap.finish()  # type: ignore[no-untyped-call]
                self._file.flush()
                os.fsync(self._file.fileno())
            except OSError as err:
                self._error = _write_error(err, self.path)
                with contextlib.suppress(OSError):
                    self._file.close()
                raise self._error from err
            self._file.close()
            self._write_metadata_yaml()

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    @property
    def message_count(self) -> int:
        """Messages written so far, all topics."""
        with self._lock:
            return sum(self._counts.values())

    @property
    def closed(self) -> bool:
        return self._closed

    @property
    def error(self) -> BagWriteError | None:
        """The write failure that stopped this bag, if any."""
        return self._error

    def update_custom_data(self, **values: str) -> None:
        """Set ``custom_data`` entries and rewrite the provisional metadata.yaml."""
        with self._lock:
            self._check_open()
            self.custom_data.update({k: str(v) for k, v in values.items()})
            try:
                self._write_metadata_yaml()
            except OSError as err:
                raise self._fail(err) from err

    # -- internals -----------------------------------------------------------------

    def _check_open(self) -> None:
        if self._closed:
            raise ValueError(f"bag {self.bag_dir!r} is closed")
        if self._error is not None:
            raise self._error

    def _guarded(self, fn: Callable[_P, _R], *args: _P.args, **kwargs: _P.kwargs) -> _R:
        """Call an MCAP writer method; if it wrote a chunk, push the chunk to the disk.

        An OSError fails the bag (BagWriteError, now and on every later write)."""
        try:
            before = self._file.tell()
            result = fn(*args, **kwargs)
            if self._file.tell() != before:
                self._sync_file()
        except OSError as err:
            raise self._fail(err) from err
        return result

    def _fail(self, err: OSError) -> BagWriteError:
        """Record the first write failure; release the reserve so the bag can be finished."""
        if self._error is None:
            self._error = _write_error(err, self.path)
            self._release_reserve()
            self.custom_data["write_error"] = str(self._error)
            with contextlib.suppress(OSError):  # keep the provisional one if even this fails
                self._write_metadata_yaml()
        return self._error

    def _flush_loop(self, interval_s: float) -> None:
        """Background thread: flush every ``interval_s`` until closed or failed."""
        while not self._stop_flusher.wait(interval_s):
            try:
                self.flush()
            except (ValueError, OSError):  # closed, or failed: write() reports it
                return

    def _release_reserve(self) -> None:
        with contextlib.suppress(FileNotFoundError):
            os.remove(self._reserve)

    def _sync_file(self) -> None:
        self._file.flush()
        os.fsync(self._file.fileno())

    def _metadata(self) -> dict[str, Any]:
        """``rosbag2_bagfile_information`` of this bag so far."""
        with self._lock:
            return bagfile_information(
                self.file_name,
                [(t.name, t.type_name, t.qos_profiles, t.type_hash) for t in self._topics.values()],
                dict(self._counts),
                self._start_ns,
                self._end_ns,
                self.custom_data,
            )

    def _write_metadata_yaml(self) -> None:
        write_metadata_yaml(self.bag_dir, self._metadata())


def bagfile_information(
    file_name: str,
    topics: list[TopicRow],
    counts: dict[str, int],
    start_ns: int | None,
    end_ns: int | None,
    custom_data: dict[str, str] | None = None,
) -> dict[str, Any]:
    """``rosbag2_bagfile_information`` as Jazzy's rosbag2 writes it (key order included).

    ``topics``: (name, type, offered QoS profiles as a list, type hash) in bag order;
    ``counts``: messages per topic; ``start_ns``/``end_ns``: first and last log time
    (None without messages).
    """
    count = sum(counts.values())
    start = TIME_MAX_NS if start_ns is None else start_ns
    duration = 0 if start_ns is None or end_ns is None else end_ns - start_ns
    return {
        "version": BAG_FORMAT_VERSION,
        "storage_identifier": "mcap",
        "duration": {"nanoseconds": duration},
        "starting_time": {"nanoseconds_since_epoch": start},
        "message_count": count,
        "topics_with_message_count": [
            {
                "topic_metadata": {
                    "name": name,
                    "type": type_name,
                    "serialization_format": "cdr",
                    "offered_qos_profiles": qos,
                    "type_description_hash": type_hash,
                },
                "message_count": counts.get(name, 0),
            }
            for name, type_name, qos, type_hash in topics
        ],
        "compression_format": "",
        "compression_mode": "",
        "relative_file_paths": [file_name],
        "files": [
            {
                "path": file_name,
                "starting_time": {"nanoseconds_since_epoch": start},
                "duration": {"nanoseconds": duration},
                "message_count": count,
            }
        ],
        "custom_data": dict(custom_data) if custom_data else None,
        "ros_distro": ROS_DISTRO,
    }


def write_metadata_yaml(bag_dir: str, info: dict[str, Any]) -> None:
    """Replace ``bag_dir``/metadata.yaml atomically (temp file, fsync, os.replace)."""
    text = dump_safe({"rosbag2_bagfile_information": info})
    path = os.path.join(bag_dir, METADATA_FILE)
    tmp = os.path.join(bag_dir, f".{METADATA_FILE}.tmp")
    try:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.remove(tmp)
        raise
    with contextlib.suppress(OSError):
        fd = os.open(bag_dir, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _write_error(err: OSError, path: str) -> BagWriteError:
    """A BagWriteError with ``err``'s errno and text, naming ``path`` when it names none."""
    code = err.errno if err.errno is not None else errno.EIO
    return BagWriteError(code, err.strerror or str(err), err.filename or path)


def _check_time(name: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an int (ns), not {type(value).__name__}")
    if not 0 <= value < 2**64:
        raise ValueError(f"{name} out of range: {value}")
    return value
