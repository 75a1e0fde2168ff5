"""Foxglove's own readers decode every message of our bags (``tools/foxglove_decode``).

``decode.mjs`` reads an MCAP file with ``@mcap/core`` (indexed, then streaming; chunks
decompressed by ``@mcap/support``), parses each schema with ``@foxglove/rosmsg`` and
decodes every message with ``@foxglove/rosmsg2-serialization``, as the Foxglove app does.
The Node packages are installed here with ``npm ci`` from the tool's lock file into the
pytest cache (``.pytest_cache/d/foxglove_decode``, git-ignored), again only when the lock
file or Node's major version changes. Without ``node``/``npm`` the tests fail (CI has
them); without the npm registry (and nothing cached) they skip.

* a lockstep wheel run (``case1_rw_pyramid``): every topic decoded, every message of its
  exact length (``--exact-length``), the counts those of our reader (``read_bag``) and
  of metadata.yaml; the first wheel states and wheel commands (name, velocity, effort,
  stamp) exactly our reader's;
* bags of our writer with lz4, zstd and no chunk compression: JointState values exact;
* a message cut short fails the tool; one that its schema does not describe but that
  decodes all the same (Foxglove shows it) fails it with ``--exact-length``.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import re
import shutil
import subprocess
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest
from support import ROOT, attitude_run, needs_workspace

from attitude_core.contract.topics import WHEEL_STATES, WHEEL_TORQUE
from attitude_tools.bag import BagWriter, bag_info, read_bag
from attitude_tools.bag.reader import mcap_files

TOOL = ROOT / "tools" / "foxglove_decode"
LOCK_FILES = ("package.json", "package-lock.json")
PYRAMID = ROOT / "scenarios" / "case1_rw_pyramid.yaml"
JOINT_STATE = "sensor_msgs/msg/JointState"
NODE_MIN_MAJOR = 18
NPM_TIMEOUT_S = 300  # within pytest-timeout (600 s), setup included
# npm's error codes (and wording) when the registry cannot be reached
OFFLINE = re.compile(
    r"E(NOTFOUND|AI_AGAIN|CONNREFUSED|CONNRESET|TIMEDOUT|NETUNREACH|HOSTUNREACH|"
    r"SOCKETTIMEOUT)|ERR_SOCKET_TIMEOUT|network (request|connectivity)|\bE50[234]\b"
)
T0 = 1_700_000_000_000_000_000


@dataclass
class Decoded:
    """One run of ``decode.mjs``: its exit code, its JSON summary and its stderr."""

    returncode: int
    summary: dict[str, Any]
    stderr: str

    @property
    def topics(self) -> dict[str, dict[str, Any]]:
        return self.summary["topics"]


def _cache_dir(config: pytest.Config, tmp_path_factory: pytest.TempPathFactory) -> Path:
    cache = getattr(config, "cache", None)
    if cache is not None:  # None with -p no:cacheprovider: install afresh each session
        return Path(cache.mkdir("foxglove_decode"))
    return tmp_path_factory.mktemp("foxglove_decode")


def _install(cache: Path, node: str, npm: str) -> None:
    """``npm ci`` of the tool's lock file in ``cache``, unless done for this lock file and
    Node major already; skip when the registry cannot be reached."""
    version = subprocess.run([node, "--version"], capture_output=True, text=True, check=True)
    major = int(version.stdout.strip().lstrip("v").split(".")[0])
    if major < NODE_MIN_MAJOR:
        pytest.fail(
            f"node {version.stdout.strip()} is too old: >= {NODE_MIN_MAJOR} needed", pytrace=False
        )
    digest = hashlib.sha256(f"node {major}\n".encode())
    for name in LOCK_FILES:
        digest.update((TOOL / name).read_bytes())
    stamp = cache / "installed.sha256"
    with open(cache / ".lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # one install at a time (parallel sessions)
        if (
            stamp.exists()
            and stamp.read_text() == digest.hexdigest()
            and (cache / "node_modules").is_dir()
        ):
            return
        stamp.unlink(missing_ok=True)
        for name in LOCK_FILES:
            shutil.copyfile(TOOL / name, cache / name)
        env = dict(os.environ, npm_config_update_notifier="false", npm_config_fund="false")
        args = [npm, "ci", "--ignore-scripts", "--no-audit", "--prefer-offline"]
        try:
            proc = subprocess.run(
                args, cwd=cache, env=env, capture_output=True, text=True, timeout=NPM_TIMEOUT_S
            )
        except subprocess.TimeoutExpired:
            pytest.skip(f"npm ci did not finish in {NPM_TIMEOUT_S} s: npm registry unreachable?")
        output = proc.stdout + proc.stderr
        if proc.returncode != 0 and OFFLINE.search(output):
            first_lines = " | ".join(output.strip().splitlines()[:4])
            pytest.skip(
                f"npm registry unreachable, Foxglove's readers not installed: {first_lines}"
            )
        assert proc.returncode == 0, f"{' '.join(args)} in {cache} failed:\n{output}"
        stamp.write_text(digest.hexdigest())


@pytest.fixture(scope="module")
def foxglove_decode(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Callable[..., Decoded]:
    """``decode(mcap_path, *options, first=3)``: ``tools/foxglove_decode/decode.mjs`` run
    on the file with the pinned Node packages (installed once, cached)."""
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        pytest.fail(
            "node and npm are needed to check the bags with Foxglove's readers (missing: "
            f"{', '.join(n for n, p in (('node', node), ('npm', npm)) if p is None)}); "
            f"install Node.js >= {NODE_MIN_MAJOR} with npm",
            pytrace=False,
        )
    cache = _cache_dir(request.config, tmp_path_factory)
    _install(cache, node, npm)
    script = cache / "decode.mjs"
    # the repository's script, every session; replaced whole (a parallel session may run it)
    staged = cache / f".decode.mjs.{os.getpid()}"
    shutil.copyfile(TOOL / "decode.mjs", staged)
    os.replace(staged, script)

    def decode(mcap: Path | str, *options: str, first: int = 3) -> Decoded:
        proc = subprocess.run(
            [node, str(script), str(mcap), "--first", str(first), *options],
            capture_output=True,
            text=True,
            timeout=300,
        )
        try:
            summary = json.loads(proc.stdout)
        except json.JSONDecodeError:
            pytest.fail(f"decode.mjs printed no JSON (exit {proc.returncode}):\n{proc.stderr}")
        return Decoded(proc.returncode, summary, proc.stderr)

    return decode


def _sample(message: Any) -> dict[str, Any]:
    """A JointState message of our reader as decode.mjs prints one."""
    msg = message.msg
    return {
        "log_time_ns": str(message.log_time_ns),
        "stamp_ns": str(msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec),
        "frame_id": msg.header.frame_id,
        "name": list(msg.name),
        "position": list(msg.position),
        "velocity": list(msg.velocity),
        "effort": list(msg.effort),
    }


def _assert_samples_are_ours(decoded: Decoded, bag: Path, topic: str, first: int) -> list:
    """Foxglove's first ``first`` messages of a JointState topic are our reader's, exactly
    (matched by log time: ties may come in either order); returns ours."""
    ours = [_sample(m) for m in read_bag(str(bag), topics=[topic])]
    got = decoded.topics[topic]["first"]
    assert len(got) == min(first, len(ours))
    assert [g["log_time_ns"] for g in got] == [o["log_time_ns"] for o in ours[: len(got)]]
    for sample in got:
        assert sample in [o for o in ours if o["log_time_ns"] == sample["log_time_ns"]]
    return ours[: len(got)]


@pytest.mark.ros
@pytest.mark.slow
@needs_workspace
def test_foxglove_decodes_every_message_of_a_wheel_run(tmp_path, ros_domain, foxglove_decode):
    out = tmp_path / "run"
    proc = attitude_run(PYRAMID, out, ros_domain, timeout=540)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    bag = out / "bag"
    (mcap,) = mcap_files(str(bag))
    first = 10
    decoded = foxglove_decode(mcap, "--exact-length", first=first)
    assert decoded.returncode == 0, decoded.stderr
    assert decoded.summary["errors"] == []
    assert decoded.summary["profile"] == "ros2"

    ours = Counter(m.topic for m in read_bag(str(bag)))
    fox = {topic: entry["decoded"] for topic, entry in decoded.topics.items()}
    assert {t: n for t, n in fox.items() if n} == dict(ours)
    metadata = {
        row["topic_metadata"]["name"]: row["message_count"]
        for row in bag_info(str(bag))["topics_with_message_count"]
    }
    assert fox == metadata  # every recorded topic, the empty ones too
    for entry in decoded.topics.values():
        assert entry["decoded"] == entry["stream_decoded"] == entry["statistics_count"]
    assert decoded.summary["messages_decoded"] == sum(ours.values())

    assert ours[WHEEL_STATES] > first and ours[WHEEL_TORQUE] > first
    for topic in (WHEEL_STATES, WHEEL_TORQUE):
        assert decoded.topics[topic]["schema"] == JOINT_STATE
        samples = _assert_samples_are_ours(decoded, bag, topic, first)
        assert all(len(s["name"]) == 4 and len(s["effort"]) == 4 for s in samples)
    states = decoded.topics[WHEEL_STATES]["first"]
    assert all(len(s["velocity"]) == 4 for s in states)
    assert any(e != 0.0 for s in states for e in s["effort"])  # not only the zeros at start


def _joint_state(i: int) -> Any:
    from sensor_msgs.msg import JointState

    msg = JointState(
        name=[f"rw{k}" for k in range(1, 5)],
        velocity=[(-1.0) ** k * (i + 0.1 * k) / 3.0 for k in range(4)],
        effort=[1e-3 * (i - k) / 7.0 for k in range(4)],
    )
    msg.header.stamp.sec, msg.header.stamp.nanosec = 1000 + i // 10, (i % 10) * 100_000_000
    msg.header.frame_id = "body"
    return msg


@pytest.mark.slow
@pytest.mark.parametrize("compression", ["none", "lz4", "zstd"])
def test_foxglove_decodes_compressed_bags_of_our_writer(tmp_path, foxglove_decode, compression):
    from rclpy.serialization import serialize_message
    from std_msgs.msg import String

    bag = tmp_path / "bag"
    with BagWriter(str(bag), chunk_size=1024, compression=compression) as writer:
        writer.add_topic(WHEEL_STATES, JOINT_STATE)
        writer.add_topic("/planner/status", "std_msgs/msg/String")
        writer.add_topic("/unused", "std_msgs/msg/String")
        for i in range(60):
            writer.write(WHEEL_STATES, serialize_message(_joint_state(i)), T0 + i)
            if i % 3 == 0:
                writer.write("/planner/status", serialize_message(String(data="x" * i)), T0 + i)
    (mcap,) = mcap_files(str(bag))
    decoded = foxglove_decode(mcap, first=25)
    assert decoded.returncode == 0, decoded.stderr
    assert decoded.summary["chunk_compression"] == ["" if compression == "none" else compression]
    assert decoded.summary["chunks"] > 1
    fox = {topic: entry["decoded"] for topic, entry in decoded.topics.items()}
    assert fox == {WHEEL_STATES: 60, "/planner/status": 20, "/unused": 0}
    _assert_samples_are_ours(decoded, bag, WHEEL_STATES, 25)


def _bag_of(tmp_path: Path, payloads: list[bytes]) -> Path:
    """A bag of our writer: ``payloads`` on the wheel command topic; its MCAP file."""
    bag = tmp_path / "bag"
    with BagWriter(str(bag)) as writer:
        writer.add_topic(WHEEL_TORQUE, JOINT_STATE)
        for i, data in enumerate(payloads):
            writer.write(WHEEL_TORQUE, data, T0 + i)
    (mcap,) = mcap_files(str(bag))
    return Path(mcap)


@pytest.mark.slow
def test_foxglove_decode_fails_on_a_message_cut_short(tmp_path, foxglove_decode):
    from rclpy.serialization import serialize_message

    whole = serialize_message(_joint_state(0))
    decoded = foxglove_decode(_bag_of(tmp_path, [whole, whole[:60]]))
    assert decoded.returncode == 1
    assert decoded.topics[WHEEL_TORQUE]["decoded"] == 1
    assert decoded.topics[WHEEL_TORQUE]["statistics_count"] == 2
    assert any("does not decode" in e for e in decoded.summary["errors"])
    assert any("Statistics record counts 2" in e for e in decoded.summary["errors"])


@pytest.mark.slow
def test_foxglove_decode_exact_length_fails_on_data_its_schema_does_not_describe(
    tmp_path, foxglove_decode
):
    from geometry_msgs.msg import Vector3Stamped
    from rclpy.serialization import serialize_message

    mcap = _bag_of(tmp_path, [serialize_message(Vector3Stamped())])
    lenient = foxglove_decode(mcap)  # Foxglove decodes it, ignoring the bytes left over
    assert lenient.returncode == 0, lenient.stderr
    assert lenient.topics[WHEEL_TORQUE]["max_bytes_left"] > 3
    strict = foxglove_decode(mcap, "--exact-length")
    assert strict.returncode == 1
    assert strict.topics[WHEEL_TORQUE]["decoded"] == 0
    assert any("left undecoded" in e for e in strict.summary["errors"])
