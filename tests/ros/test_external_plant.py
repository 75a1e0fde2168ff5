"""``attitude-run --plant external`` against a plant that is not ``rigid_body_sim``: the
example bridge (``spacecraft_bridge_example``, a different rigid-body integrator), in a
process of its own, in both time modes. Each run must end by itself after the planner's
arrival plus the settle time, and its bag must make a report.
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
from attitude_core.contract.topics import CLOCK
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
SETTLE_S = 2.0
pytestmark = [
    pytest.mark.ros,
    pytest.mark.slow,
    needs_workspace,
]


@pytest.mark.parametrize("mode, case", [("lockstep", "case1"), ("realtime", "case2")])
def test_attitude_run_against_the_example_bridge(mode, case, tmp_path, ros_env):
    scenario_path = ROOT / "scenarios" / f"{case}.yaml"
    env = ros_env(ros_environment())
    out = tmp_path / "run"
    run, bridge_code = run_with_bridge(
        scenario_path, out, env, tmp_path / "bridge.log",
        run_args=("--mode", mode, "--settle-s", str(SETTLE_S)),
        bridge_params=(f"time_mode:={mode}",), timeout_s=400,
    )  # fmt: skip
    bridge_log = (tmp_path / "bridge.log").read_text()
    assert bridge_code == 0 and "Traceback" not in bridge_log, bridge_log
    assert run.returncode == 0, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["plant"] == "external" and summary["time_mode"] == mode
    assert summary["end_reason"] == "planner finished" and summary["failure"] is None
    assert set(summary["exit_codes"]) == {"recorder", "planner", "controller", "manager"}
    # Joined the run's namespace, the bridge is the single node publishing the state.
    assert summary["plant_node"] == summary["run_namespace"] + "/spacecraft_bridge"
    assert summary["plant_adopted"] is True
    assert summary["reached"] and summary["min_margin_deg"] > 0.0

    bag_run = run_from_bag(str(out / "bag"))
    rec, sc = bag_run.run, load_scenario(scenario_path)
    # Ended by itself: the settle time after the planner's arrival, give or take a step.
    k = int(np.flatnonzero(rec.planner_status == PlannerStatus.ARRIVED.code)[0])
    after_s = (int(bag_run.stamps_ns[-1]) - int(bag_run.stamps_ns[k])) * 1e-9
    assert SETTLE_S - 2 * sc.dt_s <= after_s <= SETTLE_S + 2 * sc.dt_s
    # The body, measured densely on the recorded attitude, stays out of every cone.
    margin, _ = dense_min_margin_deg(sc.cone_geometry(), rec.t, rec.sigma_bn, rec.omega_b)
    assert margin == pytest.approx(summary["min_margin_deg"]) and margin > 0.0
    clock = list(read_bag(str(out / "bag"), [CLOCK]))
    if mode == "lockstep":
        # Stamps k dt; the bridge integrates the same physics as the offline loop.
        np.testing.assert_array_equal(
            bag_run.stamps_ns, round(sc.dt_s * 1e9) * np.arange(len(rec.t))
        )
        offline = run_closed_loop(sc)
        n = len(rec.t)
        np.testing.assert_allclose(rec.sigma_bn, offline.sigma_bn[:n], rtol=0, atol=1e-6)
        assert len(clock) >= n
    else:
        spacing = np.diff(bag_run.stamps_ns) * 1e-9
        assert 0.5 * sc.dt_s < np.median(spacing) < 2.0 * sc.dt_s
        assert clock == []  # real time: no /clock

    report = subprocess.run(
        [str(BIN / "attitude-report"), str(out), "--out", str(tmp_path / "report"), "--quiet"],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip
    assert report.returncode == 0, report.stdout + report.stderr
    html = (tmp_path / "report" / "report.html").read_text()
    assert "<img" in html and summary["scenario"] in html


def test_no_external_plant_fails_clearly_and_keeps_the_logs(tmp_path, ros_env):
    out = tmp_path / "nothing"
    proc = subprocess.run(
        [str(BIN / "attitude-run"), str(ROOT / "scenarios" / "case1.yaml"), "--out", str(out),
         "--quiet", "--plant", "external", "--plant-timeout-s", "3"],
        env=ros_env(ros_environment()), capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "no plant published /spacecraft/attitude within 3 s" in proc.stderr
    assert "Traceback" not in proc.stderr
    # The lifecycle manager looked for the plant after configure, before activation.
    manager_log = (out / "logs" / "manager.log").read_text()
    assert "no plant published /spacecraft/attitude within 3 s" in manager_log
    assert "active" not in (out / "logs" / "recorder.log").read_text()  # never activated
    assert not (out / "logs" / "simulator.log").exists()  # no simulator was started


BRIDGE = "/spacecraft_bridge"


def _check_bag(out: Path, scenario_path: Path, summary: dict) -> None:
    """The recorded body, densely, outside every cone; arrival in the bag."""
    bag_run = run_from_bag(str(out / "bag"))
    rec, sc = bag_run.run, load_scenario(scenario_path)
    margin, _ = dense_min_margin_deg(sc.cone_geometry(), rec.t, rec.sigma_bn, rec.omega_b)
    assert margin == pytest.approx(summary["min_margin_deg"]) and margin > 0.0
    assert PlannerStatus.ARRIVED.code in set(rec.planner_status.tolist())


def test_a_bridge_in_the_root_namespace_is_adopted_by_name_in_real_time(tmp_path, ros_env):
    """The bridge stays where its launch put it (the root); ``--plant-node`` names it."""
    scenario_path = ROOT / "scenarios" / "case2.yaml"
    out = tmp_path / "run"
    run, bridge_code = run_with_bridge(
        scenario_path, out, ros_env(ros_environment()), tmp_path / "bridge.log",
        run_args=("--mode", "realtime", "--settle-s", str(SETTLE_S), "--plant-node", BRIDGE),
        bridge_params=("time_mode:=realtime",), timeout_s=400, join=False,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    assert bridge_code == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["plant_node"] == BRIDGE and summary["plant_nodes"] == [BRIDGE]
    assert summary["plant_adopted"] is False and summary["foreign_publishers"] == []
    assert f"attitude-run: plant named: {BRIDGE}" in run.stderr
    assert summary["time_mode"] == "realtime" and summary["reached"]
    _check_bag(out, scenario_path, summary)


def test_without_a_name_the_single_state_publisher_is_adopted(tmp_path, ros_env):
    """Lockstep, the bridge in the root namespace, the run in ``/hil`` (any namespace)."""
    scenario_path = ROOT / "scenarios" / "case1.yaml"
    out = tmp_path / "run"
    run, bridge_code = run_with_bridge(
        scenario_path, out, ros_env(ros_environment()), tmp_path / "bridge.log",
        run_args=("--mode", "lockstep", "--settle-s", str(SETTLE_S), "--run-namespace", "/hil"),
        timeout_s=400, join=False,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["run_namespace"] == "/hil"
    assert summary["plant_node"] == BRIDGE and summary["plant_adopted"] is True
    assert f"attitude-run: plant adopted: {BRIDGE}" in run.stderr
    _check_bag(out, scenario_path, summary)


def test_a_second_plant_beside_the_named_one_is_refused_and_named(tmp_path, ros_env):
    from ros_helpers import start_bridge

    scenario_path = ROOT / "scenarios" / "case1.yaml"
    env = ros_env(ros_environment())
    stray = start_bridge(scenario_path, env, tmp_path / "stray.log", namespace="/bench")
    try:
        out = tmp_path / "run"
        run, _ = run_with_bridge(
            scenario_path, out, env, tmp_path / "bridge.log",
            run_args=("--plant-node", BRIDGE, "--plant-timeout-s", "60"), timeout_s=300,
            join=False,
        )  # fmt: skip
    finally:
        stray.send_signal(2)
        stray.wait(30)
    assert run.returncode == 1, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert "foreign publisher" in summary["failure"]
    assert "/bench/spacecraft_bridge" in summary["failure"]
    assert not summary["reached"]


@pytest.mark.parametrize(
    "args, message",
    [
        (("--run-namespace", "/"), "root namespace"),
        (("--run-namespace", "hil"), "absolute"),
        (("--plant", "external", "--plant-node", "bsk_bridge"), "fully qualified"),
        (("--plant-node", "/bsk_bridge"), "needs --plant external"),
    ],
)
def test_bad_namespaces_and_plant_names_are_refused_before_anything_starts(tmp_path, args, message):
    out = tmp_path / "never"
    proc = subprocess.run(
        [str(BIN / "attitude-run"), str(ROOT / "scenarios" / "case1.yaml"), "--out", str(out),
         *args],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert proc.returncode == 2 and message in proc.stderr, proc.stderr
    assert not out.exists()
