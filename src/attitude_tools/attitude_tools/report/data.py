"""A recorded run for the report: rebuilt from its bag alone, with its summary figures.

The summary is ``attitude_tools.bag.run_record.summarize_bag`` of the run rebuilt from the bag
(what ``attitude-run`` computes for ``summary.json``), plus ``time_mode``
(``lockstep`` when every state stamp is a ``/clock`` time, ``realtime`` when the
stamps are wall-clock times, else unknown).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from attitude_core.config.scenario import Scenario
from attitude_core.contract.topics import CLOCK, stamp_ns
from attitude_core.record.trajectory import RunResult
from attitude_tools.bag.reader import read_bag
from attitude_tools.bag.run_record import BagRun, run_from_bag, summarize_bag

__all__ = ["ReportRun", "BagError", "load_run", "SUMMARY_KEYS", "PAIR_KEY"]

# The figures the report shows, in table order (``summarize`` names, then the recording's).
SUMMARY_KEYS = (
    "scenario",
    "planner_variant",
    "time_mode",
    "reached",
    "t_reach_s",
    "t_plan_arrival_s",
    "planner_stuck",
    "min_margin_deg",
    "t_min_margin_s",
    "min_margin_deg_per_pair",
    "path_length_mrp",
    "target_path_length_mrp",
    "peak_torque_nm",
    "peak_rate_rad_s",
    "rotation_deg",
    "time_bound_s",
    "time_ratio_to_bound",
    "peak_torque_to_bound",
    "peak_rate_to_bound",
    "final_rate_rad_s",
    "final_attitude_error_deg",
    "faults",
    "knowledge_3sigma_deg",
    "estimation_error_deg_p99",
    "planner_step_us_median",
    "planner_step_us_p99",
    "steps_recorded",
    "steps_per_s",
    "sim_time_s",
    "dt_s",
)
PAIR_KEY = "min_margin_deg_per_pair"


class BagError(Exception):
    """A run directory whose bag is missing or cannot be read."""


@dataclass
class ReportRun:
    label: str
    run_dir: str
    bag_dir: str
    bag_run: BagRun
    summary: dict[str, Any]  # SUMMARY_KEYS, JSON-ready (non-finite floats as None)

    @property
    def run(self) -> RunResult:
        return self.bag_run.run

    @property
    def scenario(self) -> Scenario:
        return self.bag_run.run.scenario


def _json_ready(v: Any) -> Any:
    if isinstance(v, dict):
        return {k: _json_ready(x) for k, x in v.items()}
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, (int, np.integer)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if math.isfinite(v) else None
    return v


def _time_mode(bag_dir: str, stamps_ns: npt.NDArray[np.int64]) -> str | None:
    clock = {stamp_ns(m.msg.clock) for m in read_bag(bag_dir, [CLOCK])}
    if clock and set(stamps_ns.tolist()) <= clock:
        return "lockstep"
    if int(stamps_ns[0]) > 10**18:  # nanoseconds since the epoch (after 2001): wall clock
        return "realtime"
    return None


def load_run(run_dir: str, label: str | None = None) -> ReportRun:
    """Rebuild the run of ``run_dir/bag`` from the bag alone; BagError names the path."""
    bag_dir = os.path.join(os.path.abspath(run_dir), "bag")
    if not os.path.isdir(bag_dir):
        raise BagError(f"no bag directory at {bag_dir}")
    try:
        bag_run = run_from_bag(bag_dir)
        time_mode = _time_mode(bag_dir, bag_run.stamps_ns)
    except Exception as err:
        raise BagError(f"cannot read the bag at {bag_dir}: {err}") from err
    full = summarize_bag(bag_run)
    full["time_mode"] = time_mode
    full["estimation_error_deg_p99"] = (full["estimation_error_deg"] or {}).get("p99")
    summary = _json_ready({k: full[k] for k in SUMMARY_KEYS})
    sc = bag_run.run.scenario
    if label is None:
        label = f"{sc.name} ({sc.planner.variant})"
    return ReportRun(label, os.path.abspath(run_dir), bag_dir, bag_run, summary)
