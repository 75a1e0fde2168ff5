"""``ros2 bag info BAG`` of the shim: rosbag2's (Jazzy) summary of a bag, read with ``mcap``.

``BAG`` is a bag directory (``metadata.yaml`` and its ``.mcap`` files, as
``attitude_tools.bag`` writes and finds them) or one ``.mcap`` file. The fields and their
formats are rosbag2's: Files, Bag size (all files of the directory, ``16.5 KiB``),
Storage id, ROS Distro, Duration, Start and End (local time, ``Dec  4 2026
04:11:14.123456789 (1733285474.123456789)``), Messages, the Topic information table and
the Service lines. Topics, types, counts, times and serialization formats come from the
MCAP summaries (statistics, channels, schemas); file names, storage id and ROS distro
from ``metadata.yaml`` (``unknown`` distro without one). Differs from ros2cli: an MCAP
file without summary (a writer killed) is an error naming ``attitude-bag-recover``
(rosbag2 trusts ``metadata.yaml``); no ``-t``, ``-v``, ``-s``; service event topics are
left out of the table but not listed per service.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from typing import Any, NamedTuple

from mcap.exceptions import McapError
from mcap.reader import make_reader

from attitude_tools.bag.layout import METADATA_FILE
from attitude_tools.bag.reader import bag_info, is_finished, mcap_files
from attitude_tools.ros2cli.cli import fail, parse


class TopicStat(NamedTuple):
    name: str
    type_name: str
    messages: int
    serialization_format: str


class Summary(NamedTuple):
    files: list[str]
    size: int
    storage_id: str
    ros_distro: str
    start_ns: int
    end_ns: int
    topics: list[TopicStat]


def format_size(size: int) -> str:
    """rosbag2's size: bytes as ``N B``, else one decimal of KiB, MiB, GiB or TiB."""
    value, units = float(size), ["B", "KiB", "MiB", "GiB", "TiB"]
    index = 0
    while value >= 1024 and index < len(units) - 1:
        value /= 1024
        index += 1
    return f"{value:.0f} B" if index == 0 else f"{value:.1f} {units[index]}"


def format_seconds(ns: int) -> str:
    """``1733285474.123456789``: seconds, 9 digits of nanoseconds."""
    return f"{ns // 1_000_000_000}.{ns % 1_000_000_000:09d}"


def format_time(ns: int) -> str:
    """rosbag2's time point: local date and time with nanoseconds, then the epoch seconds."""
    local = time.localtime(ns // 1_000_000_000)
    stamp = time.strftime("%b %e %Y %H:%M:%S", local)
    return f"{stamp}.{ns % 1_000_000_000:09d} ({format_seconds(ns)})"


def _mcap_summary(path: str) -> Any:
    if is_finished(path):
        with open(path, "rb") as f:
            summary = make_reader(f).get_summary()
        if summary is not None and summary.statistics is not None:
            return summary
    raise ValueError(
        f"{path} is not a finished MCAP file with a summary (was its writer killed?): "
        "finish the bag with attitude-bag-recover"
    )


def read_summary(bag: str) -> Summary:
    """The facts ``ros2 bag info`` prints, from the bag's MCAP summaries and metadata.yaml."""
    is_dir = os.path.isdir(bag)
    paths = mcap_files(bag) if is_dir else [bag]
    meta = bag_info(bag) if is_dir and os.path.isfile(os.path.join(bag, METADATA_FILE)) else {}
    counts: dict[str, list[Any]] = {}  # topic -> [type, count, encoding]
    starts, ends = [], []
    for path in paths:
        summary = _mcap_summary(path)
        stats = summary.statistics
        if stats.message_count:
            starts.append(stats.message_start_time)
            ends.append(stats.message_end_time)
        for cid, channel in sorted(summary.channels.items()):
            schema = summary.schemas.get(channel.schema_id)
            row = counts.setdefault(
                channel.topic, [schema.name if schema else "", 0, channel.message_encoding]
            )
            row[1] += stats.channel_message_counts.get(cid, 0)
    if is_dir:
        size = sum(e.stat().st_size for e in os.scandir(bag) if e.is_file(follow_symlinks=False))
    else:
        size = os.path.getsize(bag)
    return Summary(
        files=list(meta.get("relative_file_paths") or [os.path.basename(p) for p in paths]),
        size=size,
        storage_id=str(meta.get("storage_identifier") or "mcap"),
        ros_distro=str(meta.get("ros_distro") or "unknown"),
        start_ns=min(starts, default=0),
        end_ns=max(ends, default=0),
        topics=[TopicStat(name, *row) for name, row in counts.items()],
    )


def _is_service_event(topic: TopicStat) -> bool:
    return (
        topic.name.endswith("/_service_event")
        and "/srv/" in topic.type_name
        and topic.type_name.endswith("_Event")
    )


def format_info(s: Summary) -> str:
    """``ros2 bag info``'s text (with its leading empty line, without the final newline)."""
    pad = " " * 19
    table = [t for t in s.topics if not _is_service_event(t)]
    rows = [
        f"Topic: {t.name} | Type: {t.type_name} | Count: {t.messages} | "
        f"Serialization Format: {t.serialization_format}"
        for t in table
    ]
    services = len(s.topics) - len(table)
    lines = [
        "",
        "Files:             " + f"\n{pad}".join(s.files),
        f"Bag size:          {format_size(s.size)}",
        f"Storage id:        {s.storage_id}",
        f"ROS Distro:        {s.ros_distro}",
        f"Duration:          {format_seconds(s.end_ns - s.start_ns)}s",
        f"Start:             {format_time(s.start_ns)}",
        f"End:               {format_time(s.end_ns)}",
        f"Messages:          {sum(t.messages for t in table)}",
        "Topic information: " + f"\n{pad}".join(rows),
        f"Service:           {services}",
        "Service information: ",
    ]
    return "\n".join(lines)


def parser() -> argparse.ArgumentParser:
    top = argparse.ArgumentParser(
        prog="ros2 bag", description="Various rosbag related sub-commands"
    )
    verbs = top.add_subparsers(title="Commands", metavar="<command>")
    p = verbs.add_parser("info", help="Print information about a bag to the screen")
    p.add_argument("bag_path", help="Bag to open (a bag directory or an .mcap file)")
    return top


def main(argv: Sequence[str]) -> int:
    top = parser()
    args = parse(top, argv)
    if isinstance(args, int):
        return args
    if not hasattr(args, "bag_path"):  # no sub-verb
        top.print_help(sys.stderr)
        return 2
    if not os.path.exists(args.bag_path):
        return fail(f"[ERROR] [ros2bag]: Bag path '{args.bag_path}' does not exist!")
    try:
        print(format_info(read_summary(args.bag_path)))
    except (OSError, ValueError, KeyError, McapError) as e:
        return fail(f"[ERROR] [ros2bag]: cannot read bag '{args.bag_path}': {e}")
    return 0
