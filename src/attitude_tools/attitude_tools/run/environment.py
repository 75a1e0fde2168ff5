"""The nodes' environment: the caller's, plus this checkout's colcon workspace when our
packages are not on ``AMENT_PREFIX_PATH`` yet."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from attitude_tools.run.errors import RunError

__all__ = ["default_workspace", "ros_environment"]


def default_workspace() -> Path:
    """``ros2_ws/install`` of the checkout this package is installed from (editable)."""
    return Path(__file__).resolve().parents[4] / "ros2_ws" / "install"


def ros_environment(workspace: str | None = None) -> dict[str, str]:
    """Environment for the nodes: the caller's, plus the colcon workspace when our packages
    are not on ``AMENT_PREFIX_PATH`` yet (sourced once, as ``install/setup.bash`` does).

    The virtualenv's prefix is on ``AMENT_PREFIX_PATH`` (rclpy and the message packages of
    the PyPI wheels live there); discovery defaults to this host
    (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``) unless the caller set it.
    """
    env = dict(os.environ)
    env.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    env["PYTHONUNBUFFERED"] = "1"
    venv_bin = str(Path(sys.prefix) / "bin")
    if venv_bin not in env.get("PATH", "").split(os.pathsep):
        env["PATH"] = env.get("PATH", "") + os.pathsep + venv_bin
    prefixes = [p for p in env.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    if (
        any(
            (Path(p) / "share/ament_index/resource_index/packages/attitude_planner").exists()
            for p in prefixes
        )
        and workspace is None
    ):
        return env
    ws = Path(workspace) if workspace else default_workspace()
    setup = ws / "setup.bash"
    if not setup.is_file():
        raise RunError(
            f"colcon workspace not built: {setup} does not exist "
            "(run `bash tools/bootstrap`, or pass --workspace)"
        )
    if sys.prefix not in prefixes:
        prefixes.append(sys.prefix)
    env["AMENT_PREFIX_PATH"] = os.pathsep.join(prefixes)
    out = subprocess.run(
        ["bash", "-c", 'set +u; source "$1" >/dev/null && env -0', "_", str(setup)],
        env=env,
        capture_output=True,
        check=False,
    )
    if out.returncode != 0:
        raise RunError(f"sourcing {setup} failed: {out.stderr.decode(errors='replace')}")
    sourced = dict(item.split("=", 1) for item in out.stdout.decode().split("\0") if "=" in item)
    for key in ("AMENT_PREFIX_PATH", "PYTHONPATH", "PATH", "COLCON_PREFIX_PATH", "LD_LIBRARY_PATH"):
        if key in sourced:
            env[key] = sourced[key]
    return env
