"""The nodes' environment: the caller's, plus this checkout's colcon workspace when our
packages are not on ``AMENT_PREFIX_PATH`` yet; and the nodes' executables in it."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from attitude_core.config.node_graph import NodeSpec
from attitude_tools.ros2_cli import MultipleExecutables, PackageNotFound, find_executable
from attitude_tools.run.errors import RunError

__all__ = ["default_workspace", "ros_environment", "node_executables"]


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


def node_executables(env: Mapping[str, str], specs: Sequence[NodeSpec[Any]]) -> dict[str, str]:
    """Each node's executable by role: the file ``ros2 run <package> <executable>`` runs,
    found as ros2run and launch_ros find it (the package's prefix in the ament index of
    ``env``, the executable under its ``lib/<package>``). Started directly, a node skips
    a ``ros2`` process start (about 0.05 s of CPU each with the shim, more with ros2cli).
    ``RunError`` naming the package or executable not found."""
    found = {}
    for spec in specs:
        try:
            path = find_executable(spec.package, spec.executable, env)
        except PackageNotFound:
            raise RunError(
                f"package '{spec.package}' not found on AMENT_PREFIX_PATH "
                "(run `bash tools/bootstrap`, or pass --workspace)"
            ) from None
        except MultipleExecutables as err:
            raise RunError(f"several '{spec.executable}' in {spec.package}: {err.paths}") from None
        if path is None:
            raise RunError(f"no executable '{spec.executable}' in package '{spec.package}'")
        found[spec.role] = path
    return found
