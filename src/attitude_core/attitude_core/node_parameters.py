"""Each node's parameter table: its own rows, and the scenario keys it reads.

A node declares exactly these (``attitude_ros.params.declare_node_parameters``). Every
node that reads the scenario still validates the whole scenario file with the one
loader, so a file is accepted or refused identically everywhere; scenario keys a node
does not read are validated but not declared on it.
"""

from __future__ import annotations

from dataclasses import dataclass

from .parameters import Bounds, Param
from .status import PlannerStatus

__all__ = [
    "NodeParameters",
    "PLANNER",
    "CONTROLLER",
    "SIMULATOR",
    "RECORDER",
    "LOCKSTEP",
    "REALTIME",
    "TIME_MODES",
]

LOCKSTEP, REALTIME = "lockstep", "realtime"
TIME_MODES = (LOCKSTEP, REALTIME)


@dataclass(frozen=True)
class NodeParameters:
    """``own``: the node's own rows. ``scenario``: the scenario keys it declares (a key
    ending in ``.*`` stands for the per-name keys of that group); ``None``: the node
    takes no scenario."""

    own: tuple[Param, ...]
    scenario: tuple[str, ...] | None

    def reads_scenario_key(self, key: str) -> bool:
        if self.scenario is None:
            return False
        for pattern in self.scenario:
            if key == pattern or (pattern.endswith(".*") and key.startswith(pattern[:-1])):
                return True
        return False


PLANNER = NodeParameters(
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
    ),
)

CONTROLLER = NodeParameters(
    own=(
        Param(
            "fault.drop_torque_fraction",
            "float",
            "test mode: fraction of torque messages dropped",
            0.0,
            Bounds(0.0, 0.9),
        ),
        Param("fault.seed", "int", "test mode: seed of the drops", 0),
    ),
    scenario=("scenario_name", "inertia_kgm2", "controller.*", "actuators.max_torque_nm"),
)

SIMULATOR = NodeParameters(
    own=(
        Param(
            "time_mode",
            "str",
            "lockstep (sim time, waits for each torque) or realtime (wall-clock steps)",
            LOCKSTEP,
            choices=TIME_MODES,
        ),
        Param(
            "lockstep.expected_subscribers",
            "int",
            "listeners of /spacecraft/attitude to wait for before the first step (planner "
            "and controller, plus each recorder or probe); in both time modes",
            2,
            Bounds(1, 100),
        ),
        Param(
            "lockstep.resend_period_s",
            "float",
            "re-send the state when its torque has not arrived after this wall time, s",
            0.2,
            Bounds(0.001, 60.0),
        ),
        Param(
            "lockstep.torque_timeout_s",
            "float",
            "hold the last torque and advance after this wall time without torque, s",
            2.0,
            Bounds(0.001, 600.0),
        ),
        Param(
            "lockstep.max_held_steps",
            "int",
            "steps in a row the last torque is held after timeouts before zero torque",
            1,
            Bounds(0, 1_000_000),
        ),
        Param(
            "realtime.torque_stale_s",
            "float",
            "real time: a torque older than this (wall time since arrival) is stale, s",
            0.5,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "startup_timeout_s",
            "float",
            "give up when the graph is not connected after this wall time, s",
            60.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "fault.wheel_torque_fraction",
            "float",
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
    ),
)

RECORDER = NodeParameters(
    own=(
        Param("output_dir", "path", "bag directory to create"),
        Param(
            "stop_on_planner_status",
            "str_list",
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
            "float",
            "after a stop status, keep recording this much more run time (stamps), s",
            1.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "plant_timeout_s",
            "float",
            "fail when no state (/spacecraft/attitude) arrives within this wall time, s "
            "(0: wait for ever)",
            0.0,
            Bounds(0.0, 3600.0),
        ),
        Param(
            "scenario_file",
            "path",
            "scenario file stored in the bag as the attachment scenario.yaml",
            "",
        ),
    ),
    scenario=None,
)
