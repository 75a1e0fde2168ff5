"""``attitude-bridge-check --mode lockstep|realtime``: check a hardware-in-the-loop bridge.

Checks the bridge (a replacement for ``rigid_body_sim``, already running on this
``ROS_DOMAIN_ID`` with ``lockstep.expected_subscribers:=1`` or more, or started by the tool
with ``--launch "ros2 run PKG EXE"``) against the simulator's topic contract. This front
end only checks the arguments, builds the ROS environment
(:func:`attitude_tools.run.environment.ros_environment`) and execs
``ros2 run attitude_conformance bridge_check`` with them as ROS parameters; that node
prints one ``PASS``/``FAIL``/``SKIP <point>: <detail>`` line per contract point and a
summary. Exit code: 0 every point passed, 1 one failed, 2 bad arguments (or no workspace).

A scenario that declares a reaction wheel array (``wheels.*``) checks a wheel plant: the
node answers with motor torques on ``/controller/wheel_torque`` and judges the
``/spacecraft/wheel_states`` too (point ``wheels``; SKIP without wheels).
"""

from __future__ import annotations

import argparse
import os
import shlex
import shutil
import sys
from pathlib import Path

from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_tools.run.environment import ros_environment
from attitude_tools.run.errors import RunError

DEFAULT_SCENARIO = Path(__file__).resolve().parents[4] / "scenarios" / "case1.yaml"


def _quoted(value: str) -> str:
    """A string as a YAML single-quoted scalar: a ROS parameter keeps it a string."""
    return "'" + value.replace("'", "''") + "'"


def node_command(ros2: str, args: argparse.Namespace) -> list[str]:
    """The ``ros2 run`` command line of the checking node."""
    params = {
        "mode": args.mode,
        "scenario": _quoted(str(Path(args.scenario).resolve())),
        "timeout_s": repr(float(args.timeout_s)),
        "launch": _quoted(args.launch or ""),
    }
    ros_args = [arg for key, value in params.items() for arg in ("-p", f"{key}:={value}")]
    return [ros2, "run", "attitude_conformance", "bridge_check", "--ros-args", *ros_args]


def parse(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="attitude-bridge-check",
        description="Check a hardware-in-the-loop bridge (a replacement for rigid_body_sim) "
        "against the topic contract; one PASS/FAIL line per contract point.",
    )
    parser.add_argument(
        "--mode", choices=[m.value for m in TimeMode], required=True, help="the bridge's time mode"
    )
    parser.add_argument(
        "--scenario",
        default=str(DEFAULT_SCENARIO),
        help="scenario the bridge runs: dt_s, inertia, initial state; with wheels.* a wheel "
        "plant is checked (default scenarios/case1.yaml)",
    )
    parser.add_argument(
        "--timeout-s", type=float, default=60.0, help="wall-time limit of the check, s (default 60)"
    )
    parser.add_argument(
        "--launch",
        default=None,
        metavar="COMMAND",
        help='start the bridge with COMMAND (e.g. "ros2 run spacecraft_sim rigid_body_sim"), '
        "given the scenario, the time mode and lockstep.expected_subscribers:=1; it is "
        "stopped with SIGINT at the end (point sigint)",
    )
    args = parser.parse_args(argv)
    if not 1.0 <= args.timeout_s <= 3600.0:
        parser.error(f"--timeout-s must be in [1, 3600], got {args.timeout_s}")
    if args.launch is not None:
        try:
            words = shlex.split(args.launch)
        except ValueError as err:
            parser.error(f"--launch {args.launch!r}: {err}")
        if not words:
            parser.error("--launch: empty command")
    try:
        load_scenario(args.scenario)
    except (ScenarioError, OSError) as err:
        parser.error(f"--scenario: {err}")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse(argv)
    try:
        env = ros_environment()
    except RunError as err:
        print(f"attitude-bridge-check: error: {err}", file=sys.stderr)
        return 2
    ros2 = shutil.which("ros2", path=env["PATH"])
    if ros2 is None:
        print("attitude-bridge-check: error: no `ros2` command on PATH", file=sys.stderr)
        return 2
    sys.stdout.flush()
    os.execvpe(ros2, node_command(ros2, args), env)
    return 2  # not reached


if __name__ == "__main__":
    sys.exit(main())
