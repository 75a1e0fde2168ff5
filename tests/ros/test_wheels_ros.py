"""The wheel scenarios through the ROS 2 graph: real nodes, real DDS, judged on the bag.

Every ``scenarios/*_wheels.yaml`` through ``attitude-run`` (the project's simulator,
lockstep), and ``case1_wheels`` against the example bridge publishing states at half
and twice the scenario's rate. From the bag alone: the body (dense margin on the
recorded attitude) stays out of every cone, the planner's ``arrived`` comes with the
body on the goal, no commanded or applied torque exceeds the bound, and no body rate
exceeds ``max_rate_rad_s`` by more than 5 %.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from ros_helpers import run_with_bridge
from support import needs_workspace

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import APPLIED_TORQUE, TORQUE
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import principal_angle, relative
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
WHEELS = sorted(p.name for p in (ROOT / "scenarios").glob("*_wheels.yaml"))
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


def recorded_torques(out: Path, topic: str) -> np.ndarray:
    """Every torque recorded on ``topic`` (a ``WrenchStamped``), N m, body axes."""
    return np.array(
        [[m.msg.wrench.torque.x, m.msg.wrench.torque.y, m.msg.wrench.torque.z]
         for m in read_bag(str(out / "bag"), [topic])]
    )  # fmt: skip


def check_bag(out: Path, scenario_path: Path) -> dict:
    """The checks of the module docstring on one run directory; returns its summary."""
    summary = json.loads((out / "summary.json").read_text())
    sc = load_scenario(scenario_path)
    act = sc.actuators
    assert act.max_torque_nm is not None and act.max_rate_rad_s is not None
    rec = run_from_bag(str(out / "bag")).run
    margin, _ = dense_min_margin_deg(sc.cone_geometry(), rec.t, rec.sigma_bn, rec.omega_b)
    assert margin > 0.0 and margin == pytest.approx(summary["min_margin_deg"])
    assert summary["reached"] and summary["failure"] is None
    arrived = np.flatnonzero(rec.planner_status == PlannerStatus.ARRIVED.code)
    assert len(arrived), "the planner never said arrived"
    err = np.degrees(principal_angle(relative(rec.sigma_bn[arrived], sc.desired_mrp)))
    assert err.max() <= 2 * sc.arrival.attitude_tol_deg
    assert np.linalg.norm(rec.omega_b[arrived], axis=1).max() <= 2 * sc.arrival.rate_tol_rad_s
    bound = np.asarray(act.max_torque_nm)
    for name in (TORQUE, APPLIED_TORQUE):
        torques = recorded_torques(out, name)
        assert len(torques) >= len(rec.t) - 1, name
        assert np.all(np.abs(torques) <= bound * (1 + 1e-9)), name
    assert np.linalg.norm(rec.omega_b, axis=1).max() <= 1.05 * act.max_rate_rad_s
    return summary


@pytest.mark.parametrize("name", WHEELS)
def test_wheels_scenario_through_the_graph(name, tmp_path, ros_env):
    scenario_path = ROOT / "scenarios" / name
    out = tmp_path / "run"
    run = subprocess.run(
        [str(BIN / "attitude-run"), str(scenario_path), "--out", str(out), "--quiet"],
        env=ros_env(ros_environment()), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    summary = check_bag(out, scenario_path)
    assert summary["time_ratio_to_bound"] <= 1.3


@pytest.mark.parametrize("state_period_s", [0.05, 0.2])
def test_states_at_another_rate_give_the_same_slew(state_period_s, tmp_path, ros_env):
    """A plant publishing at twice or half the scenario's 10 Hz: same safety and arrival
    as at 10 Hz (the offline loop), within a few steps."""
    scenario_path = ROOT / "scenarios" / "case1_wheels.yaml"
    env = ros_env(ros_environment())
    out = tmp_path / "run"
    run, bridge_code = run_with_bridge(
        scenario_path, out, env, tmp_path / "bridge.log",
        run_args=("--settle-s", "2.0"), bridge_params=(f"dt_s:={state_period_s}",),
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    summary = check_bag(out, scenario_path)
    stamps = run_from_bag(str(out / "bag")).stamps_ns
    assert np.median(np.diff(stamps)) * 1e-9 == pytest.approx(state_period_s)
    reference = summarize(run_closed_loop(load_scenario(scenario_path))).to_json()
    assert summary["t_reach_s"] == pytest.approx(reference["t_reach_s"], rel=0.03)
    assert summary["min_margin_deg"] == pytest.approx(reference["min_margin_deg"], abs=0.5)


def test_a_plant_weaker_than_declared_never_gets_arrived_off_the_goal(tmp_path, ros_env):
    """The simulator's wheels give a tenth of what the scenario declares (a test double
    in a real process): the planner keeps tracking (or says stuck), never ``arrived``
    with the body off the goal, and the run is reported as not reached."""
    scenario_path = ROOT / "scenarios" / "case1_wheels.yaml"
    sc = load_scenario(scenario_path)
    out = tmp_path / "run"
    run = subprocess.run(
        [str(BIN / "attitude-run"), str(scenario_path), "--out", str(out), "--quiet",
         "--param", "simulator:fault.wheel_torque_fraction:=0.1"],
        env=ros_env(ros_environment()), capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    summary = json.loads((out / "summary.json").read_text())
    assert run.returncode == 1 and not summary["reached"], run.stdout + run.stderr
    rec = run_from_bag(str(out / "bag")).run
    applied = recorded_torques(out, APPLIED_TORQUE)
    assert np.abs(applied).max() == pytest.approx(0.003)  # the weak plant did saturate
    err = np.degrees(principal_angle(relative(rec.sigma_bn, sc.desired_mrp)))
    arrived = rec.planner_status == PlannerStatus.ARRIVED.code
    assert not np.any(arrived & (err > 2 * sc.arrival.attitude_tol_deg))
    assert PlannerStatus.from_code(int(rec.planner_status[-1])) in (
        PlannerStatus.TRACKING,
        PlannerStatus.STUCK,
    )
