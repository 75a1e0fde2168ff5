"""Helpers of the ROS 2 tests: the example hardware bridge against ``attitude-run``, and
a probe that listens like the recorder.

Imported as ``from ros_helpers import ...`` (pytest puts ``tests/ros/`` on ``sys.path``
for the test modules in it).
"""

from __future__ import annotations

import shutil
import signal
import subprocess
import sys
from pathlib import Path

from support import _attitude_run_args


def start_bridge(
    scenario: Path, env: dict[str, str], log: Path, *params: str, namespace: str = "/"
) -> subprocess.Popen[bytes]:
    """The example hardware bridge (``spacecraft_bridge_example``) on ``scenario``, with
    the node table's state listeners and extra ``-p`` parameters (``"time_mode:=realtime"``),
    in ``namespace`` (a run's, to join it), its output in ``log``. The caller stops it
    (SIGINT) and waits for it."""
    from attitude_core.config.node_graph import state_listeners

    ros2 = shutil.which("ros2", path=env["PATH"])
    assert ros2 is not None
    extra = [arg for param in params for arg in ("-p", param)]
    with open(log, "wb") as out:
        return subprocess.Popen(
            [ros2, "run", "spacecraft_bridge_example", "bridge", "--ros-args",
             "-r", f"__ns:={namespace}", "--params-file", str(scenario), *extra,
             "-p", f"lockstep.expected_subscribers:={state_listeners()}"],
            env=env, stdout=out, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip


def run_with_bridge(
    scenario: Path,
    out: Path,
    env: dict[str, str],
    log: Path,
    run_args: tuple[str, ...] = (),
    bridge_params: tuple[str, ...] = (),
    timeout_s: float = 600.0,
    join: bool = True,
) -> tuple[subprocess.CompletedProcess[str], int]:
    """``attitude-run --plant external`` on ``scenario`` against :func:`start_bridge`; the
    bridge outlives the run and is stopped (SIGINT) after it, as a user would. ``join``:
    the bridge joins the run's namespace (else it stays in the root: ``run_args`` say
    how the run adopts it). Returns the run (return code, stdout, stderr) and the
    bridge's return code."""
    from attitude_core.runtime.run_identity import run_namespace

    namespace = run_namespace() if join else "/"
    joined = ("--run-namespace", namespace) if join else ()
    args = _attitude_run_args(scenario, out, ("--plant", "external", *joined, *run_args))
    run = subprocess.Popen(args, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    bridge = start_bridge(scenario, env, log, *bridge_params, namespace=namespace)
    try:
        stdout, stderr = run.communicate(timeout=timeout_s)
    finally:
        if run.poll() is None:
            run.kill()
        bridge.send_signal(signal.SIGINT)
        bridge.wait(30)
    return subprocess.CompletedProcess(args, run.returncode, stdout, stderr), bridge.returncode


def listen_like_a_recorder(node, on_state, depth: int = 10) -> None:
    """Subscribe ``node`` (a test's probe) to the state, the target and the torque, with
    ``on_state(msg)`` on ``/spacecraft/attitude``: it listens where a recorder listens,
    so the simulator's graph wait counts it as one (``lockstep.expected_subscribers``)."""
    from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from attitude_core.contract.topics import (
        ANGULAR_VELOCITY,
        ATTITUDE,
        TARGET_MRP,
        TARGET_RATE,
        TORQUE,
    )

    qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE)
    node.create_subscription(QuaternionStamped, ATTITUDE, on_state, qos)
    for name in (ANGULAR_VELOCITY, TARGET_MRP, TARGET_RATE):
        node.create_subscription(Vector3Stamped, name, lambda msg: None, qos)
    node.create_subscription(WrenchStamped, TORQUE, lambda msg: None, qos)


def run_bridge_check(
    env: dict, mode: str, launch: str, *extra: str
) -> tuple[int, dict[str, str], list[str]]:
    """``attitude-bridge-check --mode MODE --launch LAUNCH [EXTRA...]``: (exit code, line
    per point, all stdout lines)."""
    tool = Path(sys.prefix) / "bin" / "attitude-bridge-check"
    proc = subprocess.run(
        [str(tool), "--mode", mode, "--launch", launch, *extra],
        env=env,
        capture_output=True,
        text=True,
        timeout=180,
    )
    lines = proc.stdout.splitlines()
    by_point = {}
    for line in lines:
        status, _, rest = line.partition(" ")
        if status in ("PASS", "FAIL", "SKIP"):
            by_point[rest.split(":")[0]] = line
    assert lines and lines[-1].startswith("SUMMARY "), proc.stdout + proc.stderr
    return proc.returncode, by_point, lines
