"""The shim's graph verbs (``ros2 topic|node|lifecycle|param``) against a known graph.

Each test reserves a ROS domain of its own, starts ``ros2_verbs_graph.py`` (a talker with
parameters and two lifecycle nodes) there in a process of its own, and runs the shim as
``python -m attitude_tools.ros2_cli ...`` in subprocesses over real DDS. Discovery on a
loaded machine takes its time: list-like checks are retried until a generous deadline;
the only timing assertion is the loose rate of ``topic hz``.
"""

from __future__ import annotations

import re
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml
from ros2_verbs_graph import FRAME, QUATERNION, TOPIC

HELPER = Path(__file__).with_name("ros2_verbs_graph.py")
TALKER, LIFECYCLE, STUBBORN = "/verbs/talker", "/verbs/lifecycle", "/verbs/stubborn"
DEADLINE_S = 90.0


def shim(env, *args, timeout=120):
    return subprocess.run(
        [sys.executable, "-m", "attitude_tools.ros2_cli", *args],
        env=env,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def shim_until(env, args, done, deadline_s=DEADLINE_S):
    """Run the shim until ``done(result)`` (discovery may be slow); the last result."""
    end = time.monotonic() + deadline_s
    while True:
        res = shim(env, *args)
        if done(res) or time.monotonic() > end:
            return res
        time.sleep(0.5)


def read_line_until(proc, pattern, deadline_s=DEADLINE_S):
    """Lines of ``proc``'s stdout up to the first that matches ``pattern`` (fails after the
    deadline or at EOF)."""
    end, lines = time.monotonic() + deadline_s, []
    while time.monotonic() < end:
        ready, _, _ = select.select([proc.stdout], [], [], 1.0)
        if not ready:
            continue
        line = proc.stdout.readline()
        if not line:
            break
        lines.append(line)
        if re.search(pattern, line):
            return lines
    pytest.fail(f"no line matching {pattern!r} from {proc.args}; got {lines!r}", pytrace=False)


def stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


@pytest.fixture
def graph(ros_env, tmp_path):
    """The environment of a domain where ros2_verbs_graph.py runs (ready)."""
    env = ros_env()
    env.pop("AMENT_PREFIX_PATH", None)  # the verbs need only rclpy and the messages
    with open(tmp_path / "graph.log", "w") as log:
        proc = subprocess.Popen(
            [sys.executable, str(HELPER)], env=env, stdout=subprocess.PIPE, stderr=log, text=True
        )
    try:
        read_line_until(proc, "^ready$")
        yield env
    finally:
        stop(proc)


def lines_of(res):
    return res.stdout.splitlines()


def test_topic_list_with_and_without_types(graph):
    res = shim_until(graph, ["topic", "list", "-t"], lambda r: TOPIC in r.stdout)
    assert res.returncode == 0, res.stderr
    lines = lines_of(res)
    assert f"{TOPIC} [geometry_msgs/msg/QuaternionStamped]" in lines
    assert lines == sorted(lines)
    plain = lines_of(shim_until(graph, ["topic", "list"], lambda r: TOPIC in r.stdout))
    assert TOPIC in plain and all("[" not in line for line in plain)
    assert plain == [line.split(" [")[0] for line in lines if line.split(" [")[0] in plain]


def test_topic_echo_once_prints_the_published_message_as_yaml(graph):
    res = shim(graph, "topic", "echo", "--once", "--topic-wait", "60", TOPIC)
    assert res.returncode == 0, res.stderr
    assert res.stdout.endswith("\n---\n") and res.stdout.count("---\n") == 1
    doc = yaml.safe_load(res.stdout.split("---\n")[0])
    assert doc["quaternion"] == QUATERNION
    assert doc["header"]["frame_id"] == FRAME
    assert doc["header"]["stamp"]["nanosec"] == 500
    sec = doc["header"]["stamp"]["sec"]
    assert res.stdout == (
        f"header:\n  stamp:\n    sec: {sec}\n    nanosec: 500\n  frame_id: {FRAME}\n"
        "quaternion:\n  x: 0.125\n  y: -0.25\n  z: 0.5\n  w: 0.8\n---\n"
    )
    typed = shim(
        graph,
        "topic",
        "echo",
        TOPIC,
        "geometry_msgs/msg/QuaternionStamped",
        "--once",
        "--qos-reliability",
        "best_effort",
    )
    assert typed.returncode == 0, typed.stderr
    assert yaml.safe_load(typed.stdout.split("---\n")[0])["quaternion"] == QUATERNION


REPORT = re.compile(
    r"average rate: (\d+\.\d{3})\n\tmin: \d+\.\d{3}s max: \d+\.\d{3}s "
    r"std dev: \d+\.\d{5}s window: (\d+)\n"
)


def test_topic_hz_reports_the_rate(graph):
    res = shim(graph, "topic", "hz", TOPIC, "--count", "2", "--window", "20", "--topic-wait", "60")
    assert res.returncode == 0, res.stderr
    reports = REPORT.findall(res.stdout)
    assert len(reports) == 2, res.stdout
    assert REPORT.sub("", res.stdout).strip() in (
        "",
        f"WARNING: topic [{TOPIC}] does not appear to be published yet",
    )
    for rate, window in reports:
        assert 7.0 <= float(rate) <= 13.0, res.stdout  # 10 Hz +- 30 %
        assert 1 <= int(window) <= 20


@pytest.mark.parametrize("verb, first", [("hz", "^average rate"), ("echo", "^---$")])
def test_ctrl_c_ends_echo_and_hz_with_status_0(graph, verb, first):
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "attitude_tools.ros2_cli",
            "topic",
            verb,
            TOPIC,
            "--topic-wait",
            "60",
        ],
        env=graph,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        read_line_until(proc, first)
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=60)
    finally:
        stop(proc)
    assert proc.returncode == 0, err
    assert "Traceback" not in err


def test_node_list(graph):
    want = {TALKER, LIFECYCLE, STUBBORN}
    res = shim_until(graph, ["node", "list"], lambda r: want <= set(lines_of(r)))
    assert res.returncode == 0, res.stderr
    lines = lines_of(res)
    assert want <= set(lines) and lines == sorted(lines)
    assert not any(line.rsplit("/", 1)[-1].startswith("_") for line in lines)
    every = lines_of(shim_until(graph, ["node", "list", "-a"], lambda r: want <= set(lines_of(r))))
    assert want <= set(every) and any(line.startswith("/_ros2cli_") for line in every)


def test_lifecycle_nodes_get_set_list(graph):
    want = [LIFECYCLE, STUBBORN]
    res = shim_until(graph, ["lifecycle", "nodes"], lambda r: lines_of(r) == want)
    assert (res.returncode, lines_of(res)) == (0, want), res.stderr

    def get(name, expected):
        res = shim(graph, "lifecycle", "get", name)
        assert (res.returncode, res.stdout) == (0, f"{expected}\n"), res.stderr

    def set_(name, transition):
        return shim(graph, "lifecycle", "set", name, transition)

    get(LIFECYCLE, "unconfigured [1]")
    res = set_(LIFECYCLE, "configure")
    assert (res.returncode, res.stdout) == (0, "Transitioning successful\n"), res.stderr
    get(LIFECYCLE, "inactive [2]")
    assert set_(LIFECYCLE, "activate").stdout == "Transitioning successful\n"
    get(LIFECYCLE, "active [3]")
    both = f"{LIFECYCLE}: active [3]\n{STUBBORN}: unconfigured [1]\n"
    res = shim_until(graph, ["lifecycle", "get"], lambda r: r.stdout == both)
    assert (res.returncode, res.stdout) == (0, both), res.stderr

    listed = shim(graph, "lifecycle", "list", LIFECYCLE)
    assert listed.stdout == (  # the goal is the transition state, as the node reports it
        "- deactivate [4]\n\tStart: active\n\tGoal: deactivating\n"
        "- shutdown [7]\n\tStart: active\n\tGoal: shuttingdown\n"
    ), listed.stderr
    res = set_(LIFECYCLE, "cleanup")  # not available from active
    assert res.returncode == 1 and res.stdout == ""
    assert res.stderr.startswith("Unknown transition requested, available ones are:\n")
    assert "- deactivate [4]" in res.stderr

    res = set_(STUBBORN, "configure")  # its on_configure fails
    assert (res.returncode, res.stdout, res.stderr) == (1, "", "Transitioning failed\n")
    get(STUBBORN, "unconfigured [1]")
    assert set_(STUBBORN, "unconfigured_shutdown").returncode == 0  # our constant-name form
    get(STUBBORN, "finalized [4]")


def test_param_list_and_get(graph):
    res = shim_until(graph, ["param", "list", TALKER], lambda r: r.returncode == 0)
    assert res.returncode == 0, res.stderr
    names = lines_of(res)
    assert names == sorted(names) and all(n.startswith("  ") for n in names)
    mine = ["  axes", "  enabled", "  frame", "  gain", "  steps", "  weights"]
    assert [n for n in names if n in mine] == mine
    typed = lines_of(shim(graph, "param", "list", TALKER, "--param-type"))
    assert "  gain (type: double)" in typed and "  axes (type: string array)" in typed
    for name, line in [
        ("frame", "String value is: inertial"),
        ("gain", "Double value is: 0.1"),
        ("steps", "Integer value is: 3"),
        ("enabled", "Boolean value is: True"),
        ("axes", "String values are: ['a', 'b']"),
        ("weights", "Double values are: [1.5, 2.0]"),
    ]:
        res = shim(graph, "param", "get", TALKER, name)
        assert (res.returncode, res.stdout) == (0, f"{line}\n"), (name, res.stderr)
    res = shim(graph, "param", "get", TALKER, "frame", "--hide-type")
    assert res.stdout == "inertial\n"
    res = shim(graph, "param", "get", TALKER, "no_such_parameter")
    assert res.returncode == 1 and res.stdout == ""
    assert "not set" in res.stderr


def test_missing_node_and_topic_are_clear_errors(ros_env):
    env = ros_env()
    for args in (
        ["lifecycle", "get", "/nobody"],
        ["lifecycle", "set", "/nobody", "configure"],
        ["param", "get", "/nobody", "x"],
        ["param", "list", "/nobody"],
    ):
        res = shim(env, *args)
        assert (res.returncode, res.stdout, res.stderr) == (1, "", "Node not found\n"), args
    res = shim(env, "topic", "echo", "/nothing_here", "--topic-wait", "2")
    assert res.returncode == 1 and res.stdout == ""
    assert "/nothing_here" in res.stderr and "Could not determine the type" in res.stderr
    res = shim(env, "topic", "hz", "/nothing_here", "--topic-wait", "2")
    assert res.returncode == 1 and "/nothing_here" in res.stderr
    res = shim(env, "node", "list")
    assert (res.returncode, res.stdout) == (0, "")
    res = shim(env, "topic")  # no sub-verb
    assert res.returncode == 2 and "list" in res.stderr and "echo" in res.stderr
