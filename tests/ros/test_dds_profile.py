"""The stack's Fast DDS discovery profile (attitude_ros.dds_profile): its numbers are
attitude_core.runtime.discovery's, Fast DDS parses it, and it is applied only where
the user has not chosen a profile or another RMW."""

from __future__ import annotations

import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest

from attitude_core.runtime import discovery
from attitude_ros import dds_profile

NS = {"f": "http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles"}


def _seconds(element) -> float:
    sec = element.find("f:sec", NS)
    nanosec = element.find("f:nanosec", NS)
    return (0 if sec is None else int(sec.text)) + (
        0 if nanosec is None else int(nanosec.text)
    ) * 1e-9


def test_the_profile_holds_the_discovery_numbers():
    root = ET.parse(dds_profile.PROFILE_FILE).getroot()
    participant = root.find("f:participant", NS)
    assert participant.get("is_default_profile") == "true"
    config = participant.find("f:rtps/f:builtin/f:discovery_config", NS)
    assert _seconds(config.find("f:leaseAnnouncement", NS)) == discovery.ANNOUNCEMENT_PERIOD_S
    assert _seconds(config.find("f:leaseDuration", NS)) == discovery.LEASE_DURATION_S
    assert discovery.PROBE_WAIT_S >= 2 * discovery.ANNOUNCEMENT_PERIOD_S


def test_fast_dds_parses_the_profile(ros_env):
    """A node created with the profile: Fast DDS reports no XML error (it names every
    element it does not know) and the participant comes up."""
    from attitude_tools.run.environment import ros_environment

    env = ros_env(ros_environment())  # the workspace on the paths, as a node has it
    for name in dds_profile.PROFILE_ENV_VARS:
        env.pop(name, None)
    code = (
        "from attitude_ros import dds_profile; import rclpy; "
        "assert dds_profile.apply() is not None; rclpy.init(); "
        "n = rclpy.create_node('profile_check'); print('up', n.get_name()); rclpy.shutdown()"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=60
    )
    assert out.returncode == 0, out.stderr
    assert "up profile_check" in out.stdout
    assert "XMLPARSER" not in out.stderr and "Error" not in out.stderr, out.stderr


@pytest.mark.parametrize(
    ("environ", "applied"),
    [
        ({}, True),
        ({"RMW_IMPLEMENTATION": "rmw_fastrtps_cpp"}, True),
        ({"RMW_IMPLEMENTATION": "rmw_fastrtps_dynamic_cpp"}, True),
        ({"RMW_IMPLEMENTATION": ""}, True),  # unset: Fast DDS, Jazzy's default
        ({"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"}, False),
        ({"FASTRTPS_DEFAULT_PROFILES_FILE": "/etc/mine.xml"}, False),
        ({"FASTDDS_DEFAULT_PROFILES_FILE": "/etc/mine.xml"}, False),
        ({"ATTITUDE_DDS_PROFILE": "off"}, False),
        ({"ATTITUDE_DDS_PROFILE": "OFF "}, False),
    ],
)
def test_applied_only_where_nothing_else_is_chosen(environ, applied):
    env = dict(environ)
    before = dict(env)
    result = dds_profile.apply(env)
    if applied:
        assert result == str(dds_profile.PROFILE_FILE)
        assert env == {**before, "FASTRTPS_DEFAULT_PROFILES_FILE": str(dds_profile.PROFILE_FILE)}
    else:
        assert result is None and env == before  # the user's choice is left whole
