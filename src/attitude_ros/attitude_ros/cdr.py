"""The loop's stamped messages read from their serialized form (raw subscriptions).

rclpy turns every incoming message into Python message objects (about 12 us for a
``QuaternionStamped`` here); the planner and the controller take their inputs raw and
read the few fields they use with :func:`stamped` (under 1 us). The layout is plain
CDR (XCDR1, what ROS 2's rmw writes): a 4-byte encapsulation header (``00 01``: little
endian, ``00 00``: big endian), then ``std_msgs/Header`` (``int32 sec``, ``uint32
nanosec``, ``string frame_id``: a ``uint32`` length counting its NUL, the bytes, the
NUL) and the message's ``float64`` fields, aligned to 8 bytes from the end of the
encapsulation header. ``tests/ros/test_cdr.py`` checks it against rclpy's own
serialization.
"""

from __future__ import annotations

import struct
from typing import NamedTuple

__all__ = ["FLOATS", "CdrError", "JointValues", "stamped", "read", "joint_state"]

FLOATS = {
    "geometry_msgs/msg/QuaternionStamped": 4,  # x, y, z, w
    "geometry_msgs/msg/Vector3Stamped": 3,  # x, y, z
    "geometry_msgs/msg/WrenchStamped": 6,  # force x, y, z, torque x, y, z
}
"""The ``float64`` fields after the header of each message type :func:`stamped` reads."""

_HEADER = {e: struct.Struct(e + "iII") for e in "<>"}
_FLOATS = {(e, n): struct.Struct(f"{e}{n}d") for e in "<>" for n in set(FLOATS.values())}


class CdrError(ValueError):
    """Serialized bytes that are not the expected message."""


class JointValues(NamedTuple):
    """The body of a ``sensor_msgs/JointState`` after its header."""

    name: tuple[str, ...]
    position: tuple[float, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]


def _header(data: bytes) -> tuple[str, int, int, str, int]:
    """``(endian, sec, nanosec, frame_id, end)`` of a stamped message's header."""
    if len(data) < 16 or data[0] != 0 or data[1] > 1 or data[2:4] != b"\x00\x00":
        raise CdrError(f"not a plain CDR message (header {bytes(data[:4]).hex()})")
    endian = "<" if data[1] else ">"
    sec, nanosec, size = _HEADER[endian].unpack_from(data, 4)
    end = 16 + size
    if size == 0 or end > len(data) or data[end - 1] != 0:
        raise CdrError(f"frame_id of {size} bytes does not fit a {len(data)}-byte message")
    try:
        frame_id = bytes(data[16 : end - 1]).decode("utf-8")
    except UnicodeDecodeError as err:
        raise CdrError(f"frame_id is not UTF-8: {err}") from None
    return endian, sec, nanosec, frame_id, end


def _aligned(pos: int, size: int) -> int:
    """``pos`` aligned to ``size`` bytes from the payload's start (after 4 bytes)."""
    return pos + (-(pos - 4)) % size


MAX_JOINTS = 1024
"""Longest ``JointState`` sequence read (a wheel array is a few)."""


def joint_state(data: bytes) -> tuple[int, int, str, JointValues]:
    """``(sec, nanosec, frame_id, values)`` of a serialized ``sensor_msgs/JointState``;
    :class:`CdrError` naming what is wrong with ``data``."""
    endian, sec, nanosec, frame_id, pos = _header(data)
    u32 = struct.Struct(endian + "I")

    def count(at: int, what: str) -> tuple[int, int]:
        at = _aligned(at, 4)
        if at + 4 > len(data):
            raise CdrError(f"{len(data)} bytes end before the length of {what}")
        (n,) = u32.unpack_from(data, at)
        if n > MAX_JOINTS:
            raise CdrError(f"{what} of {n} elements (at most {MAX_JOINTS})")
        return n, at + 4

    n, pos = count(pos, "name")
    names = []
    for i in range(n):
        size, pos = count(pos, f"name[{i}]")
        end = pos + size
        if size == 0 or end > len(data) or data[end - 1] != 0:
            raise CdrError(f"name[{i}] of {size} bytes does not fit a {len(data)}-byte message")
        try:
            names.append(bytes(data[pos : end - 1]).decode("utf-8"))
        except UnicodeDecodeError as err:
            raise CdrError(f"name[{i}] is not UTF-8: {err}") from None
        pos = end
    arrays = []
    for what in ("position", "velocity", "effort"):
        n, pos = count(pos, what)
        if n:
            pos = _aligned(pos, 8)
        if pos + 8 * n > len(data):
            raise CdrError(f"{len(data)} bytes, {pos + 8 * n} needed for {what}")
        arrays.append(struct.unpack_from(f"{endian}{n}d", data, pos))
        pos += 8 * n
    return sec, nanosec, frame_id, JointValues(tuple(names), *arrays)


def stamped(data: bytes, n_floats: int) -> tuple[int, int, str, tuple[float, ...]]:
    """``(sec, nanosec, frame_id, floats)`` of a header-then-``n_floats``-doubles message
    (:data:`FLOATS`); :class:`CdrError` naming what is wrong with ``data``."""
    endian, sec, nanosec, frame_id, end = _header(data)
    start = _aligned(end, 8)  # float64 aligned to 8 from the payload's start
    values = _FLOATS[endian, n_floats]
    if start + values.size > len(data):
        raise CdrError(f"{len(data)} bytes, {start + values.size} needed for {n_floats} floats")
    return sec, nanosec, frame_id, values.unpack_from(data, start)


def read(data: bytes, n_floats: int) -> tuple[int, str, tuple[float, ...], str | None]:
    """:func:`stamped` with the stamp in integer ns: ``(stamp_ns, frame_id, floats,
    None)``, or ``(0, "", zeros, reason)`` for bytes that are not the message."""
    try:
        sec, nanosec, frame_id, floats = stamped(data, n_floats)
    except CdrError as err:
        return 0, "", (0.0,) * n_floats, str(err)
    return sec * 1_000_000_000 + nanosec, frame_id, floats, None
