"""The stack's Fast DDS discovery profile, applied to a node's process before
``rclpy.init`` (see :mod:`attitude_core.runtime.discovery`).

:func:`apply` points Fast DDS at ``fastdds_discovery.xml`` beside this module, unless
the process already names a profile file (``FASTDDS_DEFAULT_PROFILES_FILE`` or
``FASTRTPS_DEFAULT_PROFILES_FILE``: the user's profile wins, whole), runs another RMW
than Fast DDS, or sets ``ATTITUDE_DDS_PROFILE=off``. The profile changes discovery
timing only: no QoS, transport or security setting.
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path

__all__ = ["PROFILE_FILE", "PROFILE_ENV_VARS", "OFF_ENV", "apply"]

PROFILE_FILE = Path(__file__).resolve().with_name("fastdds_discovery.xml")
PROFILE_ENV_VARS = ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")
OFF_ENV = "ATTITUDE_DDS_PROFILE"
FAST_DDS_RMWS = ("rmw_fastrtps_cpp", "rmw_fastrtps_dynamic_cpp")


def apply(environ: MutableMapping[str, str] = os.environ) -> str | None:
    """Set the profile in ``environ`` (default: this process's); the file set, or None
    when it does not apply (see the module docstring)."""
    if environ.get(OFF_ENV, "").strip().lower() == "off":
        return None
    if (environ.get("RMW_IMPLEMENTATION") or FAST_DDS_RMWS[0]) not in FAST_DDS_RMWS:
        return None
    if any(environ.get(name) for name in PROFILE_ENV_VARS):
        return None
    environ["FASTRTPS_DEFAULT_PROFILES_FILE"] = str(PROFILE_FILE)
    return str(PROFILE_FILE)
