"""The recorder's timeline, without rclpy: at which log time each raw message is
written to the bag, and when the recording may stop.

Stamped messages are logged at their own stamp; unstamped ones (status, margin), a
``/diagnostics`` identity stamped zero and messages whose stamp is implausible
(:func:`attitude_core.runtime.recording.implausible_stamp`, judged against the latest
plausible stamp received, also past the recording's stop: a loop that runs on until it
is brought down is no stray) at the latest stamp recorded, held until the first one
arrives. Implausible stamps are counted; a warning is
given at once, then at most every ``BAD_STAMP_WARN_EVERY_S`` of wall time.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from attitude_core.config.scenario_flatten import is_ros_builtin
from attitude_core.config.scenario_loader import scenario_yaml
from attitude_core.contract.topics import DIAGNOSTICS, NS_PER_S, Topic
from attitude_core.runtime.recording import StopRule, implausible_stamp
from attitude_ros import contract as c
from attitude_tools.bag.writer import BagWriteError, BagWriter, qos_profile_yaml

__all__ = [
    "BAD_STAMP_WARN_EVERY_S",
    "Recorded",
    "Timeline",
    "add_contract_topics",
    "open_bag",
    "raw_stamp",
    "scenario_attachment",
]

BAD_STAMP_WARN_EVERY_S = 5.0
"""Wall time between two warnings about implausible stamps (the first is logged at once)."""


def raw_stamp(data: bytes) -> tuple[int, int]:
    """(sec, nanosec) of a CDR message whose first field is a ``builtin_interfaces/Time``."""
    endian = "<" if data[1] & 1 else ">"
    sec, nanosec = struct.unpack_from(endian + "iI", data, 4)
    return sec, nanosec


def open_bag(output_dir: str, scenario_text: str | None) -> BagWriter:
    """A new bag with every contract topic (the QoS its publishers offer) and the scenario
    attached as ``scenario.yaml``."""
    writer = BagWriter(output_dir)
    if scenario_text:
        writer.add_attachment("scenario.yaml", scenario_text.encode(), "application/yaml")
    add_contract_topics(writer)
    return writer


def add_contract_topics(writer: BagWriter) -> None:
    """Every contract topic in the bag (an operator's goal under ``/planner/goal``), with
    the QoS its publishers offer."""
    for topic in c.TOPICS + c.COMMAND_TOPICS:
        writer.add_topic(
            topic.name,
            topic.type_name,
            qos_profile_yaml(
                "reliable",
                "transient_local" if topic.latched else "volatile",
                c.qos(topic).depth,
                "keep_last" if topic.latched else "keep_all",
            ),
        )


def scenario_attachment(scenario_file: str, given: dict[str, Any]) -> str | None:
    """The scenario to attach: ``scenario_file``, else the scenario parameters ``given``
    to the recorder (the nodes' ``--params-file``), else None."""
    if scenario_file:
        with open(scenario_file, encoding="utf-8") as f:
            return f.read()
    flat = {key: value for key, value in given.items() if not is_ros_builtin(key)}
    return scenario_yaml(flat) if flat else None


@dataclass(frozen=True)
class Recorded:
    """``log_time_ns``: the stamp a stamped message was written at (None: held or
    written at the latest stamp); ``past_stop``: it was not written, the recording has
    reached its stop."""

    log_time_ns: int | None = None
    past_stop: bool = False


_HELD = Recorded()  # the common outcomes, shared (the dataclass is frozen)
_PAST_STOP = Recorded(past_stop=True)


class Timeline:
    """Writes raw messages to ``writer`` on the run's timeline (see the module docstring)."""

    def __init__(
        self,
        writer: BagWriter,
        stop: StopRule,
        scenario_time_s: float | None,
        warn: Callable[[str], None],
    ) -> None:
        self.writer, self.stop, self.scenario_time_s, self.warn = (
            writer,
            stop,
            scenario_time_s,
            warn,
        )
        self.last_stamp_ns: int | None = None  # the latest stamp recorded
        self.timeline_ns: int | None = None  # the latest plausible stamp, past the stop too
        self.unstamped: list[tuple[str, bytes, int]] = []  # before the first stamp
        self.bad_stamps, self._bad_warned_at = 0, -float("inf")
        self.write_error: BagWriteError | None = None  # the first failed write; then no more
        self._drain_count = -1

    def failed(self) -> BagWriteError | None:
        """The first failed write, the background flusher's included."""
        if self.write_error is None and self.writer.error is not None:
            self.write_error = self.writer.error
        return self.write_error

    def flush(self) -> bool:
        """Finish the chunk now (a full disk shows now); False when the write failed."""
        try:
            self.writer.flush()
        except BagWriteError as err:
            self.write_error = self.write_error or err
            return False
        return True

    def drained(self) -> bool:
        """True when nothing was written since the previous call (then flushed)."""
        count = self.writer.message_count
        drained, self._drain_count = count == self._drain_count, count
        if drained and self.write_error is None:
            self.flush()
        return drained

    def close(self) -> None:
        """Close the bag with the count of implausible stamps in its metadata."""
        self.writer.custom_data["recorder_bad_stamps"] = str(self.bad_stamps)
        try:
            self.writer.close()
        except BagWriteError as err:
            self.write_error = self.write_error or err

    def record(self, topic: Topic, data: bytes, wall_ns: int, now_s: float) -> Recorded:
        """Write one message received at ``wall_ns`` (monotonic ``now_s``); nothing once a
        write has failed (:attr:`write_error`)."""
        if self.write_error is not None:
            return _HELD
        try:
            return self._record(topic, data, wall_ns, now_s)
        except BagWriteError as err:
            self.write_error = err
            return _HELD

    def _record(self, topic: Topic, data: bytes, wall_ns: int, now_s: float) -> Recorded:
        name, bad, unstamped = topic.name, None, not topic.stamped
        if topic.stamped:
            sec, nanosec = raw_stamp(data)
            # A zero stamp on /diagnostics: a node's run identity before its first state.
            unstamped = name == DIAGNOSTICS and sec == 0 and nanosec == 0
            if not unstamped:  # judged against the run's timeline, which goes on past the stop
                bad = implausible_stamp(
                    sec, nanosec, self.timeline_ns, wall_ns, self.scenario_time_s
                )
            if bad is not None:
                self.on_bad_stamp(name, sec, nanosec, bad, now_s)
        if unstamped or bad is not None:  # logged at the latest stamp: on the timeline
            if self.last_stamp_ns is None:
                self.unstamped.append((name, data, wall_ns))
            else:
                self.writer.write(name, data, self.last_stamp_ns, wall_ns)
            return _HELD
        log_time = sec * NS_PER_S + nanosec
        self.timeline_ns = max(log_time, self.timeline_ns or log_time)
        if not self.stop.on_stamped(name, log_time, now_s):
            return _PAST_STOP
        self.last_stamp_ns = max(log_time, self.last_stamp_ns or log_time)
        if self.unstamped:
            for held in self.unstamped:
                self.writer.write(held[0], held[1], log_time, held[2])
            self.unstamped.clear()
        self.writer.write(name, data, log_time, wall_ns)
        return Recorded(log_time_ns=log_time)

    def on_bad_stamp(self, topic: str, sec: int, nanosec: int, why: str, now_s: float) -> None:
        """Count a message with an implausible stamp; warn, throttled."""
        self.bad_stamps += 1
        if now_s - self._bad_warned_at < BAD_STAMP_WARN_EVERY_S:
            return
        self._bad_warned_at = now_s
        at = (
            "held until the first stamp"
            if self.last_stamp_ns is None
            else (f"recorded at the latest stamp {self.last_stamp_ns / NS_PER_S:.3f} s")
        )
        self.warn(
            f"implausible stamp on {topic}: sec={sec} nanosec={nanosec} ({why}); {at}; "
            f"{self.bad_stamps} implausible stamps so far"
        )
        self.writer.update_custom_data(recorder_bad_stamps=str(self.bad_stamps))
