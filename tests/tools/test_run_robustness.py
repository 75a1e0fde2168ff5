"""``attitude-run`` when things go wrong around it, with real processes: killed by
SIGKILL (no orphans; the next run recovers the stale staging directory), an output
directory on a read-only, full or forbidden file system, bad ``--param`` values, a node
that refuses its input, and strict JSON summaries. Each ROS test has its own reserved
domain (``ros_domain``)."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import subprocess
import time
from pathlib import Path

import pytest
from support import ATTITUDE_RUN, attitude_run, needs_workspace, run_env, spawn_attitude_run

from attitude_core.runtime.process_identity import OWNER_ENV, ProcessIdentity
from attitude_tools.output.rundir import OWNER_FILE, publish, stage, stale_stages
from attitude_tools.output.strict_json import dumps_strict, finite_only
from attitude_tools.run import cli as run_cli
from attitude_tools.run.stale import salvage_stale_runs

ROOT = Path(__file__).resolve().parents[2]
CASE1 = ROOT / "scenarios" / "case1.yaml"
EXIT_WITHIN_S = 5.0


def _strict(text: str):
    """``json.loads`` that refuses NaN and Infinity."""

    def refuse(name):
        raise ValueError(f"non-standard JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


def _wait(condition, timeout_s: float, what: str, poll_s: float = 0.02):
    """Poll ``condition()`` until truthy; its value. Fails naming ``what`` after timeout."""
    deadline = time.monotonic() + timeout_s
    while True:
        value = condition()
        if value:
            return value
        if time.monotonic() > deadline:
            pytest.fail(f"{what}: not within {timeout_s} s", pytrace=False)
        time.sleep(poll_s)


def _children(pid: int) -> list[ProcessIdentity]:
    """The live child processes of ``pid``."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_bytes()
        except OSError:
            continue
        if int(stat[stat.rindex(b")") + 2 :].split()[1]) == pid:
            child = ProcessIdentity.of(int(entry))
            if child is not None:
                found.append(child)
    return found


def _dead_identity() -> ProcessIdentity:
    """The identity of a process that has exited."""
    p = subprocess.Popen(["sleep", "60"])
    me = ProcessIdentity.of(p.pid)
    p.kill()
    p.wait()
    assert me is not None and not me.alive()
    return me


# --- no orphans ---------------------------------------------------------------------------


def _past_arrival(out: Path, domain: int) -> tuple[subprocess.Popen, list[ProcessIdentity], Path]:
    """``attitude-run`` of Case 1 into ``out`` in a session of its own, mid-run: the
    planner has declared the arrival, so hundreds of steps are in the bag, and the run
    records on (``--settle-s 200``). (A run stopped at the planner's first answer left a
    bag with no complete step under load: the first applied torque comes a step later.)
    Returns the process, its five children (the four nodes and their lifecycle manager)
    and its staging directory; a failed wait kills the run."""
    run = spawn_attitude_run(
        CASE1, out, run_env(domain), "--settle-s", "200.0", start_new_session=True
    )
    try:
        nodes = _wait(lambda: (c := _children(run.pid)) and len(c) == 5 and c, 60, "5 processes")
        stages = list(out.parent.glob(f".tmp-run-{out.name}-*"))
        assert len(stages) == 1, stages
        _wait(
            lambda: "status arrived" in (stages[0] / "logs" / "planner.log").read_text(),
            240,
            "planner arrived",
        )
    except BaseException:
        os.killpg(run.pid, signal.SIGKILL)
        run.wait()
        raise
    return run, nodes, stages[0]


@pytest.mark.ros
@pytest.mark.slow
@needs_workspace
def test_sigkilled_run_leaves_no_orphans_and_the_next_run_recovers(tmp_path, ros_domain):
    """SIGKILL to attitude-run's process group mid-run: its four nodes and their manager
    exit within 5 s
    (parent-death signal), the recorder finishes the bag; the next run into the same
    --out recovers that staging directory as ``out.interrupted-*`` and completes."""
    out = tmp_path / "out"
    run, nodes, staging = _past_arrival(out, ros_domain)
    try:
        os.killpg(run.pid, signal.SIGKILL)
        killed = time.monotonic()
        run.wait(10)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    _wait(lambda: not any(n.alive() for n in nodes), EXIT_WITHIN_S, "every node exited")
    exit_s = time.monotonic() - killed
    print(f"nodes gone {exit_s:.2f} s after attitude-run was SIGKILLed")
    assert not out.exists()
    assert (staging / OWNER_FILE).exists() and (staging / "bag").is_dir()
    assert "bag closed" in (staging / "logs" / "recorder.log").read_text()  # on SIGTERM

    second = attitude_run(CASE1, out, ros_domain)
    assert second.returncode == 0, second.stderr
    assert f"recovered stale staging directory {staging} as" in second.stderr, second.stderr
    (recovered,) = tmp_path.glob("out.interrupted-*")
    summary = _strict((recovered / "summary.json").read_text())
    assert summary["interrupted"] is True and summary["steps_recorded"] > 0
    assert "died before finishing" in summary["failure"]
    assert summary["non_finite"] == {"wall_time_s": "NaN"}  # unknown: null, with the reason
    assert not (recovered / OWNER_FILE).exists()
    assert not list(tmp_path.glob(".tmp-run-*"))
    _strict((out / "summary.json").read_text())


@pytest.mark.ros
@pytest.mark.slow
@needs_workspace
def test_nodes_stopped_together_with_their_manager_exit_at_once(tmp_path, ros_domain):
    """SIGTERM to the four nodes and their lifecycle manager at once, attitude-run alive
    but silent (stopped): as when the parent-death signal comes from the first of
    attitude-run's threads to die. The manager's bring-down skips the nodes that have
    left the graph instead of waiting a second for each one's answer (8 s for 4 nodes
    and 2 transitions), and every process is gone within 5 s."""
    out = tmp_path / "out"
    run, nodes, _ = _past_arrival(out, ros_domain)
    try:
        os.kill(run.pid, signal.SIGSTOP)
        try:
            for n in nodes:
                os.kill(n.pid, signal.SIGTERM)
            stopped = time.monotonic()
            _wait(lambda: not any(n.alive() for n in nodes), EXIT_WITHIN_S, "every node exited")
            print(f"nodes and manager gone {time.monotonic() - stopped:.2f} s after SIGTERM")
        finally:
            os.kill(run.pid, signal.SIGCONT)
        run.wait(60)
    finally:
        if run.poll() is None:
            os.killpg(run.pid, signal.SIGKILL)
            run.wait()
    # What was recorded is kept: the bag finished, the run published with its steps.
    assert "bag closed" in (out / "logs" / "recorder.log").read_text()
    assert _strict((out / "summary.json").read_text())["steps_recorded"] > 0


@pytest.mark.ros
@needs_workspace
def test_node_stops_when_the_process_named_by_its_owner_variable_dies(tmp_path, ros_domain):
    """The parent watchdog alone (no parent-death signal): a node started with
    ``ATTITUDE_RUN_OWNER`` naming a process stops cleanly within 5 s of its death."""
    owner = subprocess.Popen(["sleep", "600"])
    identity = ProcessIdentity.of(owner.pid)
    assert identity is not None
    env = run_cli.ros_environment()
    env.update({"ROS_DOMAIN_ID": str(ros_domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"})
    env[OWNER_ENV] = identity.encode()
    ros2 = shutil.which("ros2", path=env["PATH"])
    assert ros2 is not None
    log = tmp_path / "controller.log"
    with open(log, "wb") as f:
        node = subprocess.Popen(
            [ros2, "run", "attitude_controller", "pd_controller", "--ros-args",
             "-p", "autostart:=true", "--params-file", str(CASE1)],
            env=env, stdout=f, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
        )  # fmt: skip
    try:
        _wait(lambda: "Kp =" in log.read_text(), 60, "controller up", poll_s=0.05)
        assert node.poll() is None
        owner.kill()
        owner.wait()
        code = node.wait(EXIT_WITHIN_S)
    finally:
        for p in (owner, node):
            if p.poll() is None:
                p.kill()
                p.wait()
    assert code == 0, log.read_text()
    assert f"(pid {owner.pid}) is gone: shutting down" in log.read_text()


# --- stale staging directories ------------------------------------------------------------


def _fake_stage(parent: Path, out: Path, owner: ProcessIdentity, name: str) -> Path:
    path = parent / name
    path.mkdir()
    record = {"owner": owner.encode(), "out": str(out), "started_utc": "2020-01-02T03:04:05Z"}
    (path / OWNER_FILE).write_text(json.dumps(record))
    return path


def test_stale_staging_is_cleaned_and_a_live_or_foreign_one_is_left(tmp_path):
    out = tmp_path / "out"
    dead = _dead_identity()
    empty = _fake_stage(tmp_path, out, dead, ".tmp-run-out-dead1")
    (empty / "logs").mkdir()
    live = _fake_stage(tmp_path, out, ProcessIdentity.current(), ".tmp-run-out-live1")
    other = _fake_stage(tmp_path, tmp_path / "out-b", dead, ".tmp-run-out-b-dead2")
    legacy = tmp_path / ".tmp-run-out-noowner"  # no owner file: never touched
    legacy.mkdir()
    assert stale_stages(out, ".tmp-run-") == [empty]
    lines = salvage_stale_runs(out, ".tmp-run-")
    assert len(lines) == 1 and lines[0].startswith(f"cleaned stale staging directory {empty}")
    assert f"pid {dead.pid}" in lines[0]
    assert not empty.exists() and live.exists() and other.exists() and legacy.exists()
    assert not out.exists()


def test_stale_staging_with_an_unreadable_bag_is_kept_not_deleted(tmp_path):
    out = tmp_path / "out"
    stale = _fake_stage(tmp_path, out, _dead_identity(), ".tmp-run-out-dead1")
    (stale / "bag").mkdir()
    (stale / "bag" / "bag_0.mcap").write_bytes(b"not an mcap file")
    (line,) = salvage_stale_runs(out, ".tmp-run-")
    kept = tmp_path / "out.interrupted-20200102T030405Z"
    assert line.startswith(f"kept stale staging directory {stale} as {kept}, not summarized")
    assert (kept / "bag" / "bag_0.mcap").read_bytes() == b"not an mcap file"
    assert not stale.exists() and not (kept / OWNER_FILE).exists()


def test_stage_names_its_out_and_owner_and_publish_drops_the_owner(tmp_path):
    out = tmp_path / "result"
    tmp = stage(out, ".tmp-run-")
    assert tmp.name.startswith(".tmp-run-result-")
    record = json.loads((tmp / OWNER_FILE).read_text())
    assert record["out"] == str(out)
    assert ProcessIdentity.decode(record["owner"]) == ProcessIdentity.current()
    publish(tmp, out)
    assert out.is_dir() and not (out / OWNER_FILE).exists()


# --- output directory errors --------------------------------------------------------------


@contextlib.contextmanager
def _tmpfs(path: Path, options: str):
    """A tmpfs mounted at ``path`` with ``options``; unmounted at the end. Skips when this
    process cannot mount (not root, no CAP_SYS_ADMIN)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    path.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {done.stderr.strip()}")
    try:
        yield path
    finally:
        if subprocess.run(["umount", str(path)], check=False).returncode != 0:
            subprocess.run(["umount", "-l", str(path)], check=False)


def _refused(result, out: Path, cause: str, where: Path) -> None:
    assert result.returncode == 2, (result.returncode, result.stderr)
    assert f"attitude-run: error: --out {out}: " in result.stderr, result.stderr
    assert str(where) in result.stderr and cause in result.stderr, result.stderr
    assert "Traceback" not in result.stderr


@needs_workspace
@pytest.mark.parametrize("sub", ["out", "a/b/out"])
def test_read_only_out_is_refused_before_the_run(tmp_path, ros_domain, sub):
    with _tmpfs(tmp_path / "ro", "ro,size=1m") as ro:
        out = ro / sub
        result = attitude_run(CASE1, out, ros_domain, timeout=120)
        _refused(result, out, "cannot write in", ro)
        assert "Read-only file system" in result.stderr
        assert os.listdir(ro) == []


@needs_workspace
def test_full_disk_out_is_refused_and_nothing_is_left(tmp_path, ros_domain):
    with _tmpfs(tmp_path / "full", "size=1m") as full:
        with open(full / "filler", "wb") as f, contextlib.suppress(OSError):
            while True:  # until ENOSPC
                f.write(b"\0" * 65536)
                f.flush()
        out = full / "out"
        result = attitude_run(CASE1, out, ros_domain, timeout=120)
        _refused(result, out, "No space left on device", full)
        assert os.listdir(full) == ["filler"]
        (full / "filler").unlink()  # room now, but less than a run's minimum
        result = attitude_run(CASE1, out, ros_domain, timeout=120)
        _refused(result, out, "not enough free space", full)
        assert "at least 64 MiB needed" in result.stderr
        assert os.listdir(full) == []


@needs_workspace
def test_out_without_permission_is_refused_and_nothing_is_left(tmp_path, ros_domain):
    """As root, permissions are bypassed: run attitude-run as root without the
    capabilities that bypass them (CAP_DAC_OVERRIDE, CAP_DAC_READ_SEARCH) into a
    directory owned by another user, mode 0755. (An unprivileged user cannot run our
    interpreter here: it lives under /root.)"""
    setpriv = shutil.which("setpriv")
    if os.geteuid() != 0 or setpriv is None:
        pytest.skip("needs root and setpriv(1) to drop the DAC override capabilities")
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o755)
    os.chown(locked, 65534, 65534)
    os.chmod(tmp_path, 0o755)
    out = locked / "out"
    args = [ATTITUDE_RUN, str(CASE1), "--out", str(out), "--quiet"]
    result = subprocess.run(
        [setpriv, "--bounding-set=-dac_override,-dac_read_search", *args],
        env=run_env(ros_domain),
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    _refused(result, out, "Permission denied", locked)
    assert os.listdir(locked) == []


# --- node-only parameters -----------------------------------------------------------------

BAD_PARAMS = {
    "simulator:time_mode:=1": "--param simulator: time_mode: expected string, got integer 1",
    "simulator:lockstep.expected_subscribers:=-5": (
        "--param simulator: lockstep.expected_subscribers: must be in [1, 100], got -5"
    ),
    "recorder:stop_delay:=1.0": (
        "--param recorder: stop_delay: unknown parameter; did you mean 'stop_delay_s'?"
    ),
    "simulator:time_mod:=lockstep": "--param simulator: time_mod: unknown key",
    "planner:planner.variant:=bogus": "--param planner: planner.variant: must be one of",
    "planner:planner.variant:=paper": "--param planner: planner.variant: a scenario key: set it",
}


@pytest.mark.parametrize("param", list(BAD_PARAMS))
def test_bad_param_exits_2_before_anything_is_written_or_started(
    param, tmp_path, capsys, monkeypatch
):
    def must_not_run(*args, **kwargs):
        raise AssertionError("attitude-run went past the --param check")

    monkeypatch.setattr(run_cli, "ros_environment", must_not_run)  # sources the workspace
    monkeypatch.setattr(run_cli.NodeGraph, "start", must_not_run)
    code = run_cli.main([str(CASE1), "--out", str(tmp_path / "out"), "--param", param])
    err = capsys.readouterr().err
    assert code == 2
    assert f"attitude-run: error: {BAD_PARAMS[param]}" in err
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize(
    "param", ["simulator:lockstep.torque_timeout_s:=0.5", "controller:fault.seed:=7"]
)
def test_good_param_passes_the_check(param, tmp_path, monkeypatch):
    class Reached(Exception):
        pass

    def stop_here(*args, **kwargs):
        raise Reached

    monkeypatch.setattr(run_cli, "ros_environment", stop_here)
    with pytest.raises(Reached):
        run_cli.main([str(CASE1), "--out", str(tmp_path / "out"), "--param", param])


@pytest.mark.ros
@needs_workspace
def test_node_refusing_its_input_mid_run_makes_attitude_run_exit_2(tmp_path, ros_domain):
    """A node that exits 2 (bad input it found) makes attitude-run exit 2 with that
    node's error line. The simulator is replaced by a stand-in that refuses at once: an
    install prefix first on ``AMENT_PREFIX_PATH`` whose ament index lists
    ``spacecraft_sim``, the executable ``ros2 run`` (and attitude-run) would take."""
    from attitude_tools.run.environment import ros_environment

    line = "[rigid_body_sim] error: parameter: lockstep.max_held_steps: refused by the test"
    prefix = tmp_path / "stand_in"
    index = prefix / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / "spacecraft_sim").write_text("")
    fake = prefix / "lib" / "spacecraft_sim" / "rigid_body_sim"
    fake.parent.mkdir(parents=True)
    fake.write_text(f'#!/bin/bash\necho "{line}" >&2\nexit 2\n')
    fake.chmod(0o755)
    env = {**ros_environment(), **run_env(ros_domain)}  # the workspace on the index
    env["AMENT_PREFIX_PATH"] = f"{prefix}{os.pathsep}{env['AMENT_PREFIX_PATH']}"
    out = tmp_path / "out"
    result = subprocess.run(
        [ATTITUDE_RUN, str(CASE1), "--out", str(out), "--quiet"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert result.returncode == 2, result.stderr
    assert f"attitude-run: error: simulator exited with code 2: {line}" in result.stderr
    assert "Traceback" not in result.stderr


# --- strict JSON --------------------------------------------------------------------------


def test_non_finite_values_become_null_with_the_reason():
    import numpy as np

    record = {
        "min_margin_deg": float("nan"),
        "final_rate": [0.1, float("inf"), np.float64(-np.inf)],
        "per_pair": {"a/b": np.float64("nan"), "a/c": np.float64(2.5)},
        "reached": np.bool_(False),
        "failure": None,
    }
    doc = _strict(dumps_strict(record))
    assert doc["min_margin_deg"] is None and doc["final_rate"] == [0.1, None, None]
    assert doc["per_pair"] == {"a/b": None, "a/c": 2.5} and doc["reached"] is False
    assert doc["non_finite"] == {
        "min_margin_deg": "NaN",
        "final_rate.1": "Infinity",
        "final_rate.2": "-Infinity",
        "per_pair.a/b": "NaN",
    }
    assert "non_finite" not in _strict(dumps_strict({"x": 1.0}))
    clean, found = finite_only({"x": [1.0, 2.0]})
    assert clean == {"x": [1.0, 2.0]} and found == {}
