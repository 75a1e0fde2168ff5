"""Message <-> NumPy conversions and stamp arithmetic (no node state).

Stamps are handled as integer nanoseconds so that lockstep stamps ``k * dt`` are exact.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
import numpy.typing as npt
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue

from attitude_core.contract import diagnostics
from attitude_core.contract.diagnostics import PlannerDiagnostics
from attitude_core.contract.faults import Fault
from attitude_core.contract.goals import GOAL_DIAGNOSTIC_NAME, GoalReport
from attitude_core.contract.status import DiagnosticLevel, PlannerStatus
from attitude_core.contract.topics import NS_PER_S, Stamp
from attitude_core.contract.topics import stamp_ns as stamp_ns  # re-exported for the nodes
from attitude_core.contract.topics import topic as contract_topic
from attitude_core.models.mrp import Vec3Like, mrp_from_quat_single, quat_from_mrp_single

# ROS messages, nodes and loggers are typed Any: the message packages ship no type
# information, and only their attributes are used here.


def set_stamp(stamp: Stamp, ns: int) -> None:
    """Write integer nanoseconds into a ``builtin_interfaces/Time`` in place."""
    stamp.sec, stamp.nanosec = divmod(int(ns), NS_PER_S)


def stamp_msg(ns: int) -> Any:
    """A ``builtin_interfaces/Time`` of integer nanoseconds."""
    from builtin_interfaces.msg import Time

    t = Time()
    set_stamp(t, ns)
    return t


def vector3(v: Any) -> npt.NDArray[np.float64]:
    """``geometry_msgs/Vector3`` -> array (3,)."""
    return np.array((v.x, v.y, v.z))


def set_vector3(v: Any, a: Vec3Like) -> None:
    v.x, v.y, v.z = float(a[0]), float(a[1]), float(a[2])


def quaternion_xyzw(q: Any) -> npt.NDArray[np.float64]:
    return np.array((q.x, q.y, q.z, q.w))


def set_quaternion_from_mrp(q: Any, sigma_bn: Vec3Like) -> None:
    """Body orientation in the inertial frame, ``(x, y, z, w)`` with ``w >= 0``."""
    q.x, q.y, q.z, q.w = quat_from_mrp_single(sigma_bn)


def mrp_from_quaternion(q: Any) -> npt.NDArray[np.float64]:
    """``sigma_BN`` (``|sigma| <= 1``) from a quaternion message (normalised first)."""
    return mrp_from_xyzw(q.x, q.y, q.z, q.w)


def mrp_from_xyzw(x: float, y: float, z: float, w: float) -> npt.NDArray[np.float64]:
    """``sigma_BN`` (``|sigma| <= 1``) from a quaternion's ``(x, y, z, w)`` (normalised)."""
    return np.array(mrp_from_quat_single(x, y, z, w))


def init_imu(msg: Any, gyro_noise_rad_s: float) -> None:
    """A gyro-only ``sensor_msgs/Imu`` (conventions in :mod:`attitude_core.contract.topics`):
    the white-noise variance on the rate's diagonal, orientation and acceleration marked
    not provided (-1)."""
    var = float(gyro_noise_rad_s) ** 2
    msg.angular_velocity_covariance = [var, 0.0, 0.0, 0.0, var, 0.0, 0.0, 0.0, var]
    msg.orientation_covariance = [-1.0] + [0.0] * 8
    msg.linear_acceleration_covariance = [-1.0] + [0.0] * 8


def init_star_tracker(msg: Any, noise_rad: Sequence[float]) -> None:
    """A star tracker ``PoseWithCovarianceStamped``: the rotation block (rows and columns
    3-5, about body x, y, z) holds the noise variances; the position is unused."""
    cov = [0.0] * 36
    for i in range(3):
        cov[(3 + i) * 6 + 3 + i] = float(noise_rad[i]) ** 2
    msg.pose.covariance = cov


def star_tracker_noise_rad(msg: Any) -> tuple[float, float, float] | None:
    """The 1-sigma noise a star tracker message declares (None: none declared)."""
    cov = msg.pose.covariance
    var = [float(cov[(3 + i) * 6 + 3 + i]) for i in range(3)]
    if not all(math.isfinite(v) and v > 0.0 for v in var):
        return None
    return (math.sqrt(var[0]), math.sqrt(var[1]), math.sqrt(var[2]))


def reject(node: Any, topic: str, reason: str, count: int | None = None) -> None:
    """Log, throttled, a refused incoming message; count it in ``node.rejected`` unless
    the caller's core already counted it (``count``: the total so far)."""
    if count is None:
        node.rejected += 1
        count = node.rejected
    node.get_logger().warning(
        f"rejected {topic} message ({count} so far): {reason}", throttle_duration_sec=1.0
    )


def log_events(logger: Any, events: Iterable[tuple[str, str]]) -> None:
    """Log the ``(level, text)`` pairs a core state machine returned."""
    for level, text in events:  # one call site per severity, as rclpy's logger requires
        if level == "error":
            logger.error(text)
        elif level == "warning":
            logger.warning(text)
        else:
            logger.info(text)


def bad_frame(msg: Any, topic: str) -> str | None:
    """Reason a stamped message is in the wrong frame for its contract topic, else None."""
    return bad_frame_id(msg.header.frame_id, contract_topic(topic).frame)


def bad_frame_id(frame_id: str, expected: str | None) -> str | None:
    """Reason ``frame_id`` is not the ``expected`` frame (None: any), else None."""
    if expected is not None and frame_id != expected:
        return f"frame_id {frame_id!r}, expected {expected!r}"
    return None


def bad_vector(values: Sequence[float] | npt.NDArray[np.float64], name: str) -> str | None:
    """Reason a vector read from a message is unusable (non-finite), else None."""
    if not all(math.isfinite(x) for x in values):
        return f"{name} has a non-finite element {list(values)}"
    return None


def bad_quaternion(q: Any, tolerance: float = 1e-3) -> str | None:
    """Reason a quaternion message is unusable: non-finite, zero or not of unit norm."""
    return bad_quaternion_xyzw(q.x, q.y, q.z, q.w, tolerance)


def bad_quaternion_xyzw(
    x: float, y: float, z: float, w: float, tolerance: float = 1e-3
) -> str | None:
    """:func:`bad_quaternion` of a quaternion's ``(x, y, z, w)``."""
    norm = math.sqrt(x * x + y * y + z * z + w * w)
    if abs(norm - 1.0) <= tolerance:  # finite and of unit norm (NaN compares False)
        return None
    reason = bad_vector((x, y, z, w), "orientation")
    return reason or f"orientation quaternion has norm {norm:.6g}, not 1"


def log_faults(logger: Any, faults: Iterable[Fault], prefix: str = "") -> None:
    """Log each fault at its ``/diagnostics`` level (an ended one as info)."""
    for fault in faults:
        text = f"{prefix}{fault.kind}: {fault.detail}"
        level = fault.diagnostic_level
        if level >= DiagnosticLevel.ERROR:
            logger.error(text)
        elif level == DiagnosticLevel.WARN:
            logger.warning(text)
        else:
            logger.info(text)


def fault_diagnostics(stamp: Any, fault: Fault) -> Any:
    """A ``/diagnostics`` message of one fault's start (its kind's level) or end (OK):
    status ``fdir/<kind>``, the detail as message (:mod:`attitude_core.contract.faults`)."""
    status = DiagnosticStatus(
        name=fault.diagnostic_name,
        hardware_id=diagnostics.HARDWARE_ID,
        level=bytes([fault.diagnostic_level]),
        message=fault.detail,
        values=[KeyValue(key=k, value=v) for k, v in fault.diagnostic_values()],
    )
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp
    return msg


def goal_diagnostics(stamp: Any, goal: GoalReport) -> Any:
    """A ``/diagnostics`` message of one goal report: status ``planner/goal``, its
    outcome's level, the outcome and reason as message, the report's key/values
    (:mod:`attitude_core.contract.goals`)."""
    why = f": {goal.reason}" if goal.reason else ""
    status = DiagnosticStatus(
        name=GOAL_DIAGNOSTIC_NAME,
        hardware_id=diagnostics.HARDWARE_ID,
        level=bytes([goal.outcome.level]),
        message=f"{goal.name} {goal.outcome.value}{why}",
        values=[KeyValue(key=k, value=v) for k, v in goal.diagnostic_values()],
    )
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = stamp
    return msg


def event_diagnostics(
    stamp: Any, faults: Iterable[Fault], goals: Iterable[GoalReport]
) -> list[Any]:
    """The ``/diagnostics`` messages of a step's events: the faults it ended or opened
    (:func:`fault_diagnostics`) and its goal reports (:func:`goal_diagnostics`)."""
    return [fault_diagnostics(stamp, f) for f in faults] + [
        goal_diagnostics(stamp, g) for g in goals
    ]


class DiagnosticsOut:
    """The planner's ``/diagnostics`` message, built once and refilled each step: one
    ``DiagnosticStatus`` named as the contract says, its level and message from the
    status, the report's key/values in :data:`~attitude_core.contract.diagnostics.KEYS`
    order."""

    def __init__(self) -> None:
        self.values = [KeyValue(key=key, value="") for key in diagnostics.KEYS]
        self.status = DiagnosticStatus(
            name=diagnostics.STATUS_NAME, hardware_id=diagnostics.HARDWARE_ID, values=self.values
        )
        self.msg = DiagnosticArray(status=[self.status])
        self.level: PlannerStatus | None = None

    def fill(self, stamp: Any, report: PlannerDiagnostics) -> Any:
        """The message of ``report`` stamped ``stamp`` (the same object each call)."""
        if report.status is not self.level:
            self.level = report.status
            self.status.level = bytes([report.status.level])
            self.status.message = report.status.value
        for kv, (_, value) in zip(self.values, report.values(), strict=True):
            kv.value = value
        self.msg.header.stamp = stamp
        return self.msg
