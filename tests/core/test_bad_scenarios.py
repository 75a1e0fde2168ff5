"""Malformed scenario files (``tests/bad_scenarios/``): every entry point refuses them.

Each ``tests/bad_scenarios/*.yaml`` is ``scenarios/case1.yaml`` with one defect and a
header naming what the loader must report::

    # expect-key: <dotted key, or - for a file-level error>
    # expect-reason: <a fragment of the reason>
    # defect: <one line>

A new file there is a new test case. For every file: ``load_scenario`` raises a
``ScenarioError`` with that key and reason; ``attitude-offline`` and ``attitude-run``
exit with 2, print the key and the reason on stderr and write nothing (``attitude-run``
validates before it starts any process). A few representative files are also given to
the planner node through the real ``ros2 run``. ``accepted_shadow_set.yaml`` is not a
bad file: ``|sigma_0| > 1`` is accepted through the shadow set (documented decision).
The table of what happens with each file is in ``docs/robustness.md``.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from support import needs_workspace

import attitude_tools.run.cli as attitude_run
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.models.mrp import dcm_from_mrp, shadow
from attitude_tools import offline

ROOT = Path(__file__).resolve().parents[2]
BAD_DIR = ROOT / "tests" / "bad_scenarios"
ACCEPTED = BAD_DIR / "accepted_shadow_set.yaml"
BAD_FILES = sorted(p for p in BAD_DIR.glob("*.yaml") if p != ACCEPTED)
CASE1 = ROOT / "scenarios" / "case1.yaml"


def expectation(path: Path) -> tuple[str | None, str]:
    """(key, reason fragment) from the file's header; key None for a file-level error."""
    head = path.read_text(encoding="utf-8")
    key = re.search(r"^# expect-key: (.+)$", head, re.M)
    reason = re.search(r"^# expect-reason: (.+)$", head, re.M)
    assert key and reason, f"{path.name}: no '# expect-key:' / '# expect-reason:' header"
    key = key.group(1).strip()
    return (None if key == "-" else key), reason.group(1).strip()


def _ids(paths):
    return [p.stem for p in paths]


def _listing(directory: Path) -> list[str]:
    return sorted(str(p.relative_to(directory)) for p in directory.rglob("*"))


def test_the_bad_set_is_large_and_every_file_has_a_header():
    assert len(BAD_FILES) >= 24
    for path in BAD_FILES:
        head = path.read_text(encoding="utf-8").splitlines()[:3]
        assert [line.split(":")[0] for line in head] == [
            "# expect-key",
            "# expect-reason",
            "# defect",
        ], path.name
    assert ACCEPTED.is_file()


# --- (a) the loader ----------------------------------------------------------------------


@pytest.mark.parametrize("path", BAD_FILES, ids=_ids(BAD_FILES))
def test_loader_refuses_naming_the_key_and_the_reason(path):
    key, reason = expectation(path)
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    err = info.value
    assert err.key == key, str(err)
    assert reason in err.reason, str(err)
    assert err.source == str(path)
    where = f"{path}: {key}: " if key is not None else f"{path}: "
    assert str(err) == where + err.reason


def test_zero_byte_file_is_refused(tmp_path):
    """The one defect a file cannot carry a header for."""
    path = tmp_path / "zero.yaml"
    path.write_bytes(b"")
    with pytest.raises(ScenarioError) as info:
        load_scenario(path)
    assert info.value.key is None and info.value.reason == "file is empty"
    assert offline.main([str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2


# --- (b) attitude-offline and (c) attitude-run: exit 2, message, nothing written ----------


def _check_refused(capsys, prog, path, code, tmp_path, before_tmp, before_bad):
    key, reason = expectation(path)
    out, err = capsys.readouterr()
    assert code == 2, err
    assert out == ""
    assert err.startswith(f"{prog}: error: {path}: "), err
    assert reason in err, err
    if key is not None:
        assert f": {key}: " in err, err
    assert "Traceback" not in err
    assert not (tmp_path / "out").exists()
    assert _listing(tmp_path) == before_tmp  # no temporary run directory left behind
    assert _listing(BAD_DIR) == before_bad


@pytest.mark.parametrize("path", BAD_FILES, ids=_ids(BAD_FILES))
def test_attitude_offline_exits_2_and_writes_nothing(path, tmp_path, capsys):
    before_tmp, before_bad = _listing(tmp_path), _listing(BAD_DIR)
    code = offline.main([str(path), "--out", str(tmp_path / "out"), "--quiet"])
    _check_refused(capsys, "attitude-offline", path, code, tmp_path, before_tmp, before_bad)


@pytest.mark.parametrize("path", BAD_FILES, ids=_ids(BAD_FILES))
def test_attitude_run_exits_2_before_starting_anything(path, tmp_path, capsys, monkeypatch):
    def must_not_run(*args, **kwargs):
        raise AssertionError("attitude-run went past validation on a bad scenario")

    # Validation comes first: no workspace sourcing (a bash process), no node process.
    monkeypatch.setattr(attitude_run, "ros_environment", must_not_run)
    monkeypatch.setattr(attitude_run.NodeGraph, "start", must_not_run)
    before_tmp, before_bad = _listing(tmp_path), _listing(BAD_DIR)
    code = attitude_run.main([str(path), "--out", str(tmp_path / "out"), "--quiet"])
    _check_refused(capsys, "attitude-run", path, code, tmp_path, before_tmp, before_bad)


# --- (d) the planner node, started as a user does: ros2 run ... --params-file FILE --------

# file -> (expected exit code; fragments the output must contain).
# rcl parses the parameters file before our code: a file it cannot parse (YAML syntax
# error, wrong top level, a null value, nested lists) is refused in rclpy.init with
# rcl's own message naming the file and line (exit 2); the others reach our parameter
# check, which exits with 2 naming the key.
NODE_CASES = {
    "yaml_syntax_error": (
        2,
        ["Couldn't parse params file", "yaml_syntax_error.yaml", "line 13"],
    ),  # file level, rcl
    "duplicate_instrument_names": (2, ["instruments.names: duplicate names"]),  # list
    "empty_file": (2, ["instruments.names: missing required key"]),  # file level, ours
    "int_in_float_field": (
        2,
        [
            "dt_s: InvalidParameterTypeException",  # type
            "of type 'INTEGER', expecting type 'DOUBLE'",
        ],
    ),
    "half_angle_95": (2, ["instruments.star_tracker.half_angle_deg:", "out of range"]),  # range
    "start_inside_cone": (2, ["initial_mrp: attitude is inside the keep-out cone"]),  # keep-out
    "unknown_top_level_key": (2, ["sim_time: unknown key; did you mean 'sim_time_s'?"]),  # typo
}


def ros2_run(ros_domain: int, cwd: Path, package: str, executable: str, *ros_args: str):
    """``ros2 run PACKAGE EXECUTABLE --ros-args ROS_ARGS`` on the test's reserved domain,
    localhost discovery; the completed process, or None when the node kept running."""
    env = attitude_run.ros_environment()
    env["ROS_DOMAIN_ID"] = str(ros_domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    shim = Path(sys.prefix) / "bin" / "ros2"
    ros2 = str(shim) if shim.exists() else shutil.which("ros2", path=env["PATH"])
    if ros2 is None:
        pytest.skip("no ros2 command")
    try:
        return subprocess.run(
            [ros2, "run", package, executable, "--ros-args", "-p", "autostart:=true",
             *ros_args],
            env=env, cwd=cwd, stdin=subprocess.DEVNULL, capture_output=True, text=True,
            timeout=60,
        )  # fmt: skip
    except subprocess.TimeoutExpired:
        return None


@pytest.mark.ros
@needs_workspace
@pytest.mark.parametrize("name", sorted(NODE_CASES))
def test_planner_node_refuses_the_file(name, tmp_path, ros_domain):
    path = BAD_DIR / f"{name}.yaml"
    code, fragments = NODE_CASES[name]
    proc = ros2_run(ros_domain, tmp_path, "attitude_planner", "fepf_planner",
                    "--params-file", str(path))  # fmt: skip
    if proc is None:
        pytest.fail(f"the planner node accepted {path.name} and kept running")
    output = proc.stdout + proc.stderr
    assert proc.returncode == code, output
    assert "Traceback" not in output
    key, _ = expectation(path)
    assert key is None or f"{key}:" in output, output
    for fragment in fragments:
        assert fragment in output, output


# Node-own parameters are rows too: a refused value exits 2 naming the key, no traceback.
NODE_PARAMETER_CASES = {
    "time_mode:=1": ("time_mode", "InvalidParameterTypeException"),
    "time_mode:=fast": ("time_mode", "must be one of ['lockstep', 'realtime']"),
    "lockstep.expected_subscribers:=-5": ("lockstep.expected_subscribers", "out of range"),
    "lockstep.resend_period_s:=0.0": ("lockstep.resend_period_s", "out of range"),
}


@pytest.mark.ros
@needs_workspace
@pytest.mark.parametrize("assignment", sorted(NODE_PARAMETER_CASES))
def test_simulator_node_refuses_a_bad_own_parameter(assignment, tmp_path, ros_domain):
    key, fragment = NODE_PARAMETER_CASES[assignment]
    proc = ros2_run(ros_domain, tmp_path, "spacecraft_sim", "rigid_body_sim",
                    "--params-file", str(CASE1), "-p", assignment)  # fmt: skip
    if proc is None:
        pytest.fail(f"the simulator accepted {assignment} and kept running")
    output = proc.stdout + proc.stderr
    assert proc.returncode == 2, output
    assert "Traceback" not in output
    assert f"error: parameter: node '/rigid_body_sim' parameters: {key}: " in output, output
    assert fragment in output, output


# --- the documented decision: |sigma| > 1 is accepted through the shadow set ---------------


def test_mrp_longer_than_one_is_accepted_as_its_shadow_set():
    given = yaml.safe_load(ACCEPTED.read_text())["/**"]["ros__parameters"]["initial_mrp"]
    given = np.array(given)
    assert np.linalg.norm(given) > 1.0
    sc = load_scenario(ACCEPTED)
    np.testing.assert_array_equal(sc.initial_mrp, shadow(given))
    assert np.linalg.norm(sc.initial_mrp) <= 1.0
    np.testing.assert_allclose(dcm_from_mrp(sc.initial_mrp), dcm_from_mrp(given), atol=1e-15)
    case1 = load_scenario(CASE1)  # the same attitude as case1's sigma_0 = [0, 0, 0.25]
    np.testing.assert_array_equal(sc.initial_mrp, case1.initial_mrp)
    np.testing.assert_array_equal(sc.desired_mrp, case1.desired_mrp)
