"""Each node's parameter table: its own rows, and the scenario keys it reads.

A node declares exactly these (``attitude_ros.params.declare_node_parameters``). Every
node that reads the scenario still validates the whole scenario file with the one
loader, so a file is accepted or refused identically everywhere; scenario keys a node
does not read are validated but not declared on it.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Generic, TypeVar

from attitude_core.config.parameters import (
    Bounds,
    NodeParameterError,
    Param,
    ParamKind,
    dotted_fields,
    typed_values,
    values_from,
)
from attitude_core.config.scenario_flatten import is_ros_builtin, scenario_keys
from attitude_core.config.scenario_schema import GROUPS
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.time_mode import TimeMode

__all__ = [
    "NodeParameters",
    "NoParams",
    "ControllerParams",
    "SimulatorParams",
    "RecorderParams",
    "PLANNER",
    "CONTROLLER",
    "SIMULATOR",
    "RECORDER",
    "ESTIMATOR",
    "EstimatorParams",
    "LifecycleParams",
    "LIFECYCLE",
    "MANAGER",
    "ManagerParams",
]


P = TypeVar("P")


@dataclass(frozen=True)
class NoParams:
    """A node without parameters of its own."""


@dataclass(frozen=True)
class ControllerFault:
    drop_torque_fraction: float  # test mode: share of torque messages dropped
    seed: int


@dataclass(frozen=True)
class ControllerParams:
    fault: ControllerFault


@dataclass(frozen=True)
class LockstepParams:
    expected_subscribers: int
    resend_period_s: float
    torque_timeout_s: float
    max_held_steps: int


@dataclass(frozen=True)
class RealtimeParams:
    torque_stale_s: float


@dataclass(frozen=True)
class SimulatorFault:
    wheel_torque_fraction: float  # test mode: a plant weaker than the scenario says


@dataclass(frozen=True)
class SimulatorParams:
    time_mode: TimeMode
    lockstep: LockstepParams
    realtime: RealtimeParams
    startup_timeout_s: float
    fault: SimulatorFault


@dataclass(frozen=True)
class EstimatorParams:
    star_tracker_wait_s: float


@dataclass(frozen=True)
class RecorderParams:
    output_dir: str
    stop_on_planner_status: tuple[str, ...]
    stop_delay_s: float
    plant_timeout_s: float
    scenario_file: str


@dataclass(frozen=True)
class LifecycleParams:
    """The rows every managed node of the table declares, before its own."""

    autostart: bool
    plant_nodes: tuple[str, ...]


LIFECYCLE_ROWS = (
    Param(
        "autostart",
        ParamKind.BOOL,
        "configure and activate at start-up (nav2's convention); false: come up "
        "unconfigured and wait for a lifecycle manager",
        False,
    ),
    Param(
        "plant_nodes",
        ParamKind.STR_LIST,
        "fully qualified names of the nodes adopted as the plant (any namespace): only "
        "they, and the node table's own, may publish the plant's topics (empty: a plant "
        "in the run's namespace); set by the lifecycle manager before activation",
        ("",),
        read_only=False,
    ),
)


@dataclass(frozen=True)
class NodeParameters(Generic[P]):
    """``own``: the node's own rows; ``values``: the dataclass a node reads them as
    (``params.lockstep.resend_period_s``; its fields are the rows' keys, checked here).
    ``scenario``: the scenario keys it declares (a key ending in ``.*`` stands for the
    per-name keys of that group); ``None``: the node takes no scenario."""

    own: tuple[Param, ...]
    scenario: tuple[str, ...] | None
    values: type[P]

    def __post_init__(self) -> None:
        rows, fields = [row.key for row in self.own], dotted_fields(self.values)
        if sorted(rows) != sorted(fields):
            raise TypeError(
                f"{self.values.__name__}: fields {sorted(fields)} differ from the rows "
                f"{sorted(rows)}"
            )

    def typed(self, values: dict[str, Any]) -> P:
        """The node's own values (dotted keys, :func:`values_from`) as :attr:`values`."""
        return typed_values(self.values, values)

    def own_values(self, given: Mapping[str, Any], source: str) -> P:
        """The node's own values from ``given`` (defaults for absent keys), checked by
        the rows; a :class:`NodeParameterError` names the key."""
        return self.typed(values_from(self.own, given, source))

    def refuse_unknown(self, names: Iterable[str], source: str) -> None:
        """Refuse a name that is neither the node's own, nor a scenario key (a shared
        ``/**`` parameters file may be given to it), nor one rclpy declares by itself."""
        own = [row.key for row in self.own + LIFECYCLE_ROWS]
        scenario = {row.key for row in scenario_keys()}
        for name in names:
            if name in own or name in scenario or is_ros_builtin(name):
                continue
            if name.split(".", 1)[0] in GROUPS:
                continue
            close = difflib.get_close_matches(name, own, n=1, cutoff=0.6)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise NodeParameterError(source, name, "unknown parameter" + hint)

    def reads_scenario_key(self, key: str) -> bool:
        if self.scenario is None:
            return False
        for pattern in self.scenario:
            if key == pattern or (pattern.endswith(".*") and key.startswith(pattern[:-1])):
                return True
        return False


PLANNER = NodeParameters(
    values=NoParams,
    own=(),
    scenario=(
        "scenario_name",
        "dt_s",
        "inertia_kgm2",
        "desired_mrp",
        "instruments.*",
        "bright_objects.*",
        "keep_in.*",
        "planner.*",
        "actuators.*",
        "arrival.*",
        "sensors.*",
        "fdir.*",
    ),
)

CONTROLLER = NodeParameters(
    values=ControllerParams,
    own=(
        Param(
            "fault.drop_torque_fraction",
            ParamKind.FLOAT,
            "test mode: fraction of torque messages dropped",
            0.0,
            Bounds(0.0, 0.9),
        ),
        Param("fault.seed", ParamKind.INT, "test mode: seed of the drops", 0),
    ),
    scenario=(
        "scenario_name",
        "dt_s",
        "inertia_kgm2",
        "controller.*",
        "actuators.max_torque_nm",
        "fdir.*",
    ),
)

SIMULATOR = NodeParameters(
    values=SimulatorParams,
    own=(
        Param(
            "time_mode",
            ParamKind.STR,
            "lockstep (sim time, waits for each torque) or realtime (wall-clock steps)",
            TimeMode.LOCKSTEP.value,
            choices=TimeMode,
        ),
        Param(
            "lockstep.expected_subscribers",
            ParamKind.INT,
            "listeners of /spacecraft/attitude to wait for before the first step (planner "
            "and controller, plus each recorder or probe); in both time modes",
            2,
            Bounds(1, 100),
        ),
        Param(
            "lockstep.resend_period_s",
            ParamKind.FLOAT,
            "re-send the state when its torque has not arrived after this wall time, s",
            0.2,
            Bounds(0.001, 60.0),
        ),
        Param(
            "lockstep.torque_timeout_s",
            ParamKind.FLOAT,
            "hold the last torque and advance after this wall time without torque, s",
            2.0,
            Bounds(0.001, 600.0),
        ),
        Param(
            "lockstep.max_held_steps",
            ParamKind.INT,
            "steps in a row the last torque is held after timeouts before zero torque",
            1,
            Bounds(0, 1_000_000),
        ),
        Param(
            "realtime.torque_stale_s",
            ParamKind.FLOAT,
            "real time: a torque older than this (wall time since arrival) is stale, s",
            0.5,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "startup_timeout_s",
            ParamKind.FLOAT,
            "give up when the graph is not connected after this wall time, s",
            60.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "fault.wheel_torque_fraction",
            ParamKind.FLOAT,
            "test mode: the plant's wheels saturate at this fraction of the declared "
            "actuators.max_torque_nm (a plant weaker than the scenario says)",
            1.0,
            Bounds(0.001, 1.0),
        ),
    ),
    scenario=(
        "scenario_name",
        "sim_time_s",
        "dt_s",
        "inertia_kgm2",
        "initial_mrp",
        "initial_rate_rad_s",
        "actuators.max_torque_nm",
        "sensors.*",
        "fdir.*",
        "link.*",
    ),
)

ESTIMATOR = NodeParameters(
    values=EstimatorParams,
    own=(
        Param(
            "star_tracker_wait_s",
            ParamKind.FLOAT,
            "wall time to wait for a star tracker sample due at a gyro sample's stamp before "
            "filtering the step without it (the sample was lost), s",
            0.5,
            Bounds(0.0, 60.0),
        ),
    ),
    scenario=("scenario_name", "dt_s", "sensors.*"),
)

RECORDER = NodeParameters(
    values=RecorderParams,
    own=(
        Param("output_dir", ParamKind.PATH, "bag directory to create"),
        Param(
            "stop_on_planner_status",
            ParamKind.STR_LIST,
            "planner statuses that end the recording (empty: record until shut down)",
            ("",),
            check=lambda names: next(
                (
                    f"{n!r} is not a planner status {[s.value for s in PlannerStatus]}"
                    for n in names
                    if n and n not in set(PlannerStatus)
                ),
                None,
            ),
        ),
        Param(
            "stop_delay_s",
            ParamKind.FLOAT,
            "after a stop status, keep recording this much more run time (stamps), s",
            1.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "plant_timeout_s",
            ParamKind.FLOAT,
            "fail when no state (/spacecraft/attitude) arrives within this wall time, s "
            "(0: wait for ever)",
            0.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "scenario_file",
            ParamKind.PATH,
            "scenario file stored in the bag as the attachment scenario.yaml",
            "",
        ),
    ),
    scenario=None,
)

LIFECYCLE = NodeParameters(values=LifecycleParams, own=LIFECYCLE_ROWS, scenario=None)
"""Declared by every managed node (``attitude_ros.node_base.StackNode``) at construction."""


@dataclass(frozen=True)
class ManagerParams:
    node_names: tuple[str, ...]
    plant_nodes: tuple[str, ...]
    plant_topics: tuple[str, ...]
    plant_timeout_s: float
    transition_timeout_s: float
    hold: bool


MANAGER = NodeParameters(
    values=ManagerParams,
    own=(
        Param(
            "node_names",
            ParamKind.STR_LIST,
            "fully qualified names of the managed nodes, in activation order",
        ),
        Param(
            "plant_nodes",
            ParamKind.STR_LIST,
            "the plant's nodes, by fully qualified name (empty: adopt the single node that "
            "publishes every one of plant_topics)",
            ("",),
        ),
        Param(
            "plant_topics",
            ParamKind.STR_LIST,
            "the state topics a plant publishes, to adopt one (empty: no plant to find)",
            ("",),
        ),
        Param(
            "plant_timeout_s",
            ParamKind.FLOAT,
            "wall time to wait for the plant's nodes before activation, s",
            60.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "transition_timeout_s",
            ParamKind.FLOAT,
            "wall time for each node's services, transitions and run identity, s",
            60.0,
            Bounds(0.1, 3600.0),
        ),
        Param(
            "hold",
            ParamKind.BOOL,
            "stop after configure and the checks; activate on a line 'activate' on stdin",
            False,
        ),
    ),
    scenario=None,
)
"""The lifecycle manager's table (``attitude_bringup lifecycle_manager``)."""
