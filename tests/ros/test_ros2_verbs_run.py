"""The ``ros2`` shim's verbs on a real ``attitude-run``: a real-time run held after
configure (``--hold``) reports its nodes ``inactive`` through ``ros2 lifecycle get``,
is activated by SIGUSR1, and meanwhile ``ros2 topic list|echo|hz`` see the contract;
after it, ``ros2 bag info`` lists the bag's message counts as the bag holds them."""

from __future__ import annotations

import json
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from support import ATTITUDE_RUN, needs_workspace

from attitude_core.config import node_graph
from attitude_core.contract import topics as t
from attitude_tools.bag import read_bag
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
NS = "/verbs_run"
DEADLINE_S = 120.0
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


def shim(env, *args, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "attitude_tools.ros2_cli", *args],
        env=env, capture_output=True, text=True, timeout=timeout,
    )  # fmt: skip


def until(what, get, done, deadline_s=DEADLINE_S):
    end = time.monotonic() + deadline_s
    while True:
        value = get()
        if done(value):
            return value
        assert time.monotonic() < end, f"timed out waiting for {what}: {value}"
        time.sleep(0.5)


def test_verbs_during_and_after_a_held_real_time_run(tmp_path, ros_env):
    env = ros_env(ros_environment())
    text = (ROOT / "scenarios" / "case1.yaml").read_text()
    scenario = tmp_path / "case1_40s.yaml"
    scenario.write_text(text.replace("sim_time_s: 150.0", "sim_time_s: 40.0"))
    out = tmp_path / "run"
    run = subprocess.Popen(
        [ATTITUDE_RUN, str(scenario), "--out", str(out), "--mode", "realtime",
         "--run-namespace", NS, "--hold"],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        planner = f"{NS}/{node_graph.PLANNER.node_name}"
        # Held after configure: every node inactive, as the standard service says.
        for spec in node_graph.NODES:
            name = f"{NS}/{spec.node_name}"
            until(name, lambda n=name: shim(env, "lifecycle", "get", n),
                  lambda r: r.stdout.strip() == "inactive [2]")  # fmt: skip
        assert run.poll() is None
        run.send_signal(signal.SIGUSR1)  # the operator's go
        until("active", lambda: shim(env, "lifecycle", "get", planner).stdout.strip(),
              lambda s: s == "active [3]")  # fmt: skip
        listed = shim(env, "topic", "list", "-t")
        assert listed.returncode == 0, listed.stderr
        for topic in (t.ATTITUDE, t.ANGULAR_VELOCITY, t.TORQUE, t.TARGET_MRP):
            assert re.search(rf"^{re.escape(topic)} \[", listed.stdout, re.M), listed.stdout
        echo = shim(env, "topic", "echo", "--once", t.ATTITUDE)
        assert echo.returncode == 0, echo.stderr
        msg = yaml.safe_load(echo.stdout.split("---")[0])
        q = msg["quaternion"]
        assert msg["header"]["frame_id"] == "inertial"
        assert abs(q["x"] ** 2 + q["y"] ** 2 + q["z"] ** 2 + q["w"] ** 2 - 1.0) < 1e-6
        hz = shim(env, "topic", "hz", t.ATTITUDE, "--window", "20", "--count", "2")
        assert hz.returncode == 0, hz.stderr
        rates = [float(r) for r in re.findall(r"^average rate: ([0-9.]+)$", hz.stdout, re.M)]
        assert rates and 5.0 < rates[-1] < 15.0, hz.stdout  # dt_s = 0.1 s of wall time
        assert re.search(r"^\tmin: [0-9.]+s max: [0-9.]+s std dev: [0-9.]+s window: \d+$",
                         hz.stdout, re.M), hz.stdout  # fmt: skip
        stdout, stderr = run.communicate(timeout=DEADLINE_S)
    finally:
        if run.poll() is None:
            run.kill()
    assert f"activate with `kill -USR1 {run.pid}`" in stdout, stdout + stderr
    assert run.returncode == 1, stdout + stderr  # 40 s end before the arrival (about 71 s)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["end_reason"] == "scenario time ended" and summary["failure"] is None
    assert summary["min_margin_deg"] > 0.0
    info = shim(env, "bag", "info", str(out / "bag"))
    assert info.returncode == 0, info.stderr
    counts: dict[str, int] = {}
    for msg in read_bag(str(out / "bag")):
        counts[msg.topic] = counts.get(msg.topic, 0) + 1
    for topic, count in counts.items():
        line = re.search(rf"Topic: {re.escape(topic)} \| Type: \S+ \| Count: (\d+) \|", info.stdout)
        assert line is not None and int(line.group(1)) == count, (topic, info.stdout)
    total = re.search(r"^Messages:\s+(\d+)$", info.stdout, re.M)
    assert total is not None and int(total.group(1)) == sum(counts.values())


def test_a_transition_the_manager_did_not_ask_for_ends_the_run_named(tmp_path, ros_env):
    """An operator deactivates the controller by hand (``ros2 lifecycle set``) in a
    real-time run: the manager names it as the run's failure, and the bag keeps the
    run up to then, with zero torque applied after the deactivation."""
    env = ros_env(ros_environment())
    out = tmp_path / "run"
    run = subprocess.Popen(
        [ATTITUDE_RUN, str(ROOT / "scenarios" / "case1.yaml"), "--out", str(out), "--quiet",
         "--mode", "realtime", "--run-namespace", NS],
        env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    controller = f"{NS}/{node_graph.CONTROLLER.node_name}"
    simulator = f"{NS}/{node_graph.SIMULATOR.node_name}"
    try:
        until("active", lambda: shim(env, "lifecycle", "get", simulator).stdout.strip(),
              lambda s: s == "active [3]")  # fmt: skip
        stepping = shim(env, "topic", "echo", "--once", t.APPLIED_TORQUE)  # a step applied
        assert stepping.returncode == 0, stepping.stderr
        res = shim(env, "lifecycle", "set", controller, "deactivate")
        assert res.returncode == 0 and "Transitioning successful" in res.stdout, res
        _, stderr = run.communicate(timeout=DEADLINE_S)
    finally:
        if run.poll() is None:
            run.kill()
    assert run.returncode == 1, stderr
    summary = json.loads((out / "summary.json").read_text())
    failure = summary["failure"]
    assert controller in failure and "unexpected transition" in failure, failure
    assert summary["min_margin_deg"] > 0.0 and summary["steps_recorded"] >= 1
