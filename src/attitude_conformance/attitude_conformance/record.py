"""What a check records and reports, as plain data (no ROS): the checker's input and output.

A message is a :class:`Sample` ``(stamp_ns, frame, values, wall_s)``: the header stamp in
integer nanoseconds, the ``frame_id``, the numbers (quaternion ``(x, y, z, w)``, vector,
torque, or the motor torques the tool commanded in the scenario's wheel order) and the
tool's monotonic receipt (or send) time. A wheel state (``sensor_msgs/JointState``) is a
:class:`JointSample`, its arrays as published (read by name by the checks).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from attitude_core.config.node_parameters import SIMULATOR
from attitude_core.config.scenario import Scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_core.fsw.fdir.fdir_config import FdirConfig
from attitude_core.models.wheel_array import WheelArray

PASS, FAIL, SKIP = "PASS", "FAIL", "SKIP"
POINTS = (
    "qos",
    "plant",
    "stamps",
    "clock",
    "frames",
    "quaternion",
    "torque_step",
    "applied_torque",
    "wheels",
    "resend",
    "stale",
    "link",
    "sigint",
)


class Sample(NamedTuple):
    """One message: stamp (ns), frame_id, values, tool's monotonic time (s)."""

    stamp_ns: int
    frame: str
    values: tuple[float, ...]
    wall_s: float = 0.0


class JointSample(NamedTuple):
    """One ``/spacecraft/wheel_states`` message: stamp (ns), frame_id, ``name``,
    ``velocity``, ``effort`` as published, tool's monotonic time (s)."""

    stamp_ns: int
    frame: str
    names: tuple[str, ...]
    velocity: tuple[float, ...]
    effort: tuple[float, ...]
    wall_s: float = 0.0


class Window(NamedTuple):
    """A stretch where the tool withheld the torque of the state stamped ``stamp_ns``."""

    kind: str  # "resend" or "stale"
    stamp_ns: int
    start_s: float
    end_s: float


def _default(key: str) -> float:
    return next(row.default for row in SIMULATOR.own if row.key == key)


@dataclass(frozen=True)
class BridgeLimits:
    """The bridge's timing parameters the checks assume (the simulator's defaults)."""

    resend_period_s: float = _default("lockstep.resend_period_s")
    torque_timeout_s: float = _default("lockstep.torque_timeout_s")
    max_held_steps: int = int(_default("lockstep.max_held_steps"))
    torque_stale_s: float = _default("realtime.torque_stale_s")


@dataclass(frozen=True)
class Setup:
    """The scenario's numbers the checks use, the time mode and the bridge's limits."""

    mode: str
    dt_s: float
    inertia: np.ndarray
    initial_mrp: np.ndarray
    initial_rate: np.ndarray
    limits: BridgeLimits = BridgeLimits()
    fdir: FdirConfig | None = None  # the stack's state watchdog (None: the step's defaults)
    wheels: WheelArray | None = None  # the scenario's reaction wheels (None: a body torque)

    @classmethod
    def from_scenario(cls, scenario: Scenario, mode: str = TimeMode.LOCKSTEP) -> Setup:
        return cls(
            mode,
            scenario.dt_s,
            np.asarray(scenario.inertia_kgm2, dtype=float).reshape(3, 3),
            np.asarray(scenario.initial_mrp, dtype=float),
            np.asarray(scenario.initial_rate_rad_s, dtype=float),
            fdir=scenario.watchdog,
            wheels=scenario.wheels,
        )

    @property
    def watchdog(self) -> FdirConfig:
        return FdirConfig.for_step(self.dt_s) if self.fdir is None else self.fdir

    @property
    def dt_ns(self) -> int:
        return int(round(self.dt_s * 1e9))

    @property
    def lockstep(self) -> bool:
        return self.mode == TimeMode.LOCKSTEP


@dataclass
class Recording:
    """Everything seen and sent during one check."""

    setup: Setup
    attitude: list[Sample] = field(default_factory=list)
    rate: list[Sample] = field(default_factory=list)
    applied: list[Sample] = field(default_factory=list)
    clock: list[Sample] = field(default_factory=list)  # stamp_ns: the /clock time
    wheel_states: list[JointSample] = field(default_factory=list)
    # sent by the tool: the body torques, or with wheels the motor torques (wheel order)
    torques: list[Sample] = field(default_factory=list)
    # with wheels: stamp -> the order of the wheels in the command's arrays (indices into
    # the scenario's wheel order), when not the scenario's own
    wheel_orders: dict[int, tuple[int, ...]] = field(default_factory=dict)
    windows: list[Window] = field(default_factory=list)
    aborted: str | None = None  # why the script stopped early
    system_offset_s: float | None = None  # this host's time.time() - time.monotonic()


class Result(NamedTuple):
    """The verdict on one contract point."""

    point: str
    status: str  # PASS, FAIL or SKIP
    detail: str

    def line(self) -> str:
        return f"{self.status} {self.point}: {self.detail}"


def summary(results: list[Result], what: str) -> str:
    """The last line of the report."""
    failed = [r.point for r in results if r.status == FAIL]
    counts = {s: sum(r.status == s for r in results) for s in (PASS, FAIL, SKIP)}
    text = f"{counts[PASS]} passed, {counts[FAIL]} failed, {counts[SKIP]} skipped ({what})"
    if failed:
        return f"SUMMARY FAIL: {text}; failed: {', '.join(failed)}"
    return f"SUMMARY PASS: {text}"
