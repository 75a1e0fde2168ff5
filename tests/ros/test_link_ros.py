"""A link that drops or dies, through the ROS 2 graph: the simulator's rehearsal link
(``link.*``) between the plant and the stack, real nodes over real DDS, judged on the
recorded truth (``/spacecraft/truth/*``) read back by an independent MCAP reader
(``mcap_ros2``): no keep-out violation on the body, the watchdog's faults on the record,
and a run whose link dies ending by itself in safe mode with the lost state named.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from bag_checks import assert_finished_and_consistent, mcap_path
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from support import needs_workspace

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.topics import TRUTH_ANGULAR_VELOCITY, TRUTH_ATTITUDE
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import mrp_from_quat
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


def case2_with(tmp_path: Path, name: str, link: dict) -> Path:
    doc = yaml.safe_load((ROOT / "scenarios" / "case2.yaml").read_text())
    doc["/**"]["ros__parameters"].update(scenario_name=name, link=link)
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def attitude_run(scenario: Path, out: Path, env, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [str(BIN / "attitude-run"), str(scenario), "--out", str(out), "--quiet", *args],
        env=env, capture_output=True, text=True, timeout=600,
    )  # fmt: skip


def recorded_truth(out: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t, sigma_BN, omega_B)`` of every step from ``/spacecraft/truth/*``, read by
    ``mcap_ros2`` (not the project's reader), ``t`` from the first stamp."""
    att: dict[int, tuple] = {}
    rate: dict[int, tuple] = {}
    topics = [TRUTH_ATTITUDE, TRUTH_ANGULAR_VELOCITY]
    with open(mcap_path(out / "bag"), "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(topics=topics):
            stamp = msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec
            if channel.topic == TRUTH_ATTITUDE:
                q = msg.quaternion
                att[stamp] = (q.x, q.y, q.z, q.w)
            else:
                rate[stamp] = (msg.vector.x, msg.vector.y, msg.vector.z)
    stamps = sorted(set(att) & set(rate))
    assert stamps == sorted(att), "a truth attitude without its rate"
    t = (np.array(stamps) - stamps[0]) * 1e-9
    quat = np.array([att[s] for s in stamps])
    return t, mrp_from_quat(quat), np.array([rate[s] for s in stamps])


def test_lockstep_outage_is_flown_as_offline_and_safe_on_the_recorded_truth(tmp_path, ros_env):
    """Three seconds without a state at t = 20 s: reached, the body out of every cone,
    the fault on the record, and the recorded truth the offline loop's behind the same
    link, step for step (the lockstep run is deterministic)."""
    scenario = case2_with(tmp_path, "case2_outage", {"outages": [20.0, 3.0]})
    out = tmp_path / "run"
    run = attitude_run(scenario, out, ros_env(ros_environment()))
    assert run.returncode == 0, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reached"] and summary["failure"] is None
    assert [(f["kind"], f["t_start_s"], f["t_end_s"]) for f in summary["faults"]] == [
        ("state_lost", 20.2, 23.0)
    ]
    assert_finished_and_consistent(out / "bag")
    sc = load_scenario(scenario)
    t, sigma, omega = recorded_truth(out)
    margin, _ = dense_min_margin_deg(sc.sky, t, sigma, omega)
    assert margin > 0.0 and margin == pytest.approx(summary["min_margin_deg"], abs=1e-9)
    offline = run_closed_loop(sc)
    n = min(len(t), len(offline.t))
    assert n > 500
    np.testing.assert_allclose(sigma[:n], offline.sigma_bn[:n], rtol=0, atol=1e-9)


def test_lockstep_link_that_dies_ends_in_safe_mode_naming_the_lost_state(tmp_path, ros_env):
    scenario = case2_with(tmp_path, "case2_dead", {"outages": [20.0, 1.0e6]})
    out = tmp_path / "run"
    run = attitude_run(scenario, out, ros_env(ros_environment()), "--settle-s", "5.0")
    assert run.returncode == 1, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["end_reason"] == "safe mode"
    assert "/spacecraft/attitude" in summary["failure"] and "safe mode" in summary["failure"]
    kinds = [(f["kind"], f["t_start_s"]) for f in summary["faults"]]
    assert kinds == [("state_lost", 20.2), ("safe_mode", 29.9)]
    assert_finished_and_consistent(out / "bag")
    sc = load_scenario(scenario)
    t, sigma, omega = recorded_truth(out)
    assert t[-1] == pytest.approx(29.9 + 5.0, abs=0.2)  # recorded to safe mode + settle
    margin, _ = dense_min_margin_deg(sc.sky, t, sigma, omega)
    assert margin > 0.0
    assert np.degrees(np.linalg.norm(omega[-1])) < 0.5


def test_realtime_dead_link_to_a_plant_that_holds_the_last_torque_ends_by_itself(tmp_path, ros_env):
    """Real time, the link dead from t = 5 s, the simulator holding the last torque for an
    hour (a bench's wheel drives): the stack brakes on its prediction, commands a zero,
    and the run ends by itself well under a minute after the loss, exit 1; the body
    never enters a cone and ends nearly at rest."""
    scenario = case2_with(tmp_path, "case2_dead_rt", {"outages": [5.0, 1.0e6]})
    out = tmp_path / "run"
    t0 = time.monotonic()
    run = attitude_run(
        scenario, out, ros_env(ros_environment()), "--mode", "realtime", "--settle-s", "2.0",
        "--param", "simulator:realtime.torque_stale_s:=3600.0",
    )  # fmt: skip
    wall = time.monotonic() - t0
    assert run.returncode == 1, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["end_reason"] == "safe mode", summary["failure"]
    assert wall < 5.0 + 45.0, f"{wall:.1f} s"
    sc = load_scenario(scenario)
    t, sigma, omega = recorded_truth(out)
    margin, _ = dense_min_margin_deg(sc.sky, t, sigma, omega)
    assert margin > 0.0
    assert np.degrees(np.linalg.norm(omega[-1])) < 0.5
    assert [f["kind"] for f in summary["faults"]] == ["state_lost", "safe_mode"]
