"""Reaction wheel arrays through the ROS 2 graph (``attitude-run``, lockstep), judged from
the bag alone, read with the ``mcap`` library's own ROS 2 decoder (not ours):

* every wheel state stamped like a state, every declared wheel in it; no speed above
  its limit, no applied motor torque above its limit;
* the body out of every cone (dense margin on the recorded attitude), reached, on the
  goal within 0.5 deg at the end;
* without disturbances, the inertial system momentum ``C_NB (J omega + sum g_i Js_i
  Omega_i)`` from the recorded attitude, rate and wheel speeds constant within 1 % of
  the peak wheel momentum; with the gravity gradient, its change equal to the
  integrated gravity-gradient torque (the model on the recorded attitude) within 5 %;
* a wheel failed mid-slew applies nothing from then on, and the slew still ends on the
  goal, safely;
* the lockstep run is the offline run (the same core functions) to 1e-9.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from scipy.spatial.transform import Rotation
from support import needs_workspace

from attitude_core.config.scenario_loader import load_scenario, loads_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import principal_angle, relative
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.world.disturbances import Disturbances
from attitude_tools.run.cli import ros_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


def attitude_run(scenario: Path, out: Path) -> dict:
    proc = subprocess.run(
        [str(BIN / "attitude-run"), str(scenario), "--out", str(out)],
        env=ros_environment(),
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return json.loads((out / "summary.json").read_text())


def read_bag(out: Path) -> dict[str, dict[int, object]]:
    """Messages by topic and stamp (ns), decoded by mcap's own ROS 2 decoder."""
    by_topic: dict[str, dict[int, object]] = {}
    (path,) = (out / "bag").glob("*.mcap")
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            stamp = getattr(msg, "header", None)
            if stamp is None:
                continue
            ns = stamp.stamp.sec * 1_000_000_000 + stamp.stamp.nanosec
            by_topic.setdefault(channel.topic, {})[ns] = msg
    return by_topic


def judge(scenario_path: Path, out: Path, summary: dict) -> dict[str, np.ndarray]:
    """The checks of the module docstring common to every run; the recorded arrays."""
    sc = load_scenario(scenario_path)
    array = sc.wheels
    assert array is not None
    bag = read_bag(out)
    att, rate = bag["/spacecraft/attitude"], bag["/spacecraft/angular_velocity"]
    wheels, commands = bag["/spacecraft/wheel_states"], bag["/controller/wheel_torque"]
    stamps = sorted(s for s in att if s in rate)
    assert set(wheels) == set(stamps), "a wheel state for every state, none else"
    names = list(array.names)
    for s in stamps:
        assert sorted(wheels[s].name) == sorted(names)

    def order(m: object, field: str) -> list[float]:
        got = dict(zip(m.name, getattr(m, field), strict=True))  # type: ignore[attr-defined]
        return [got[n] for n in names]

    speed = np.array([order(wheels[s], "velocity") for s in stamps])
    effort = np.array([order(wheels[s], "effort") for s in stamps])
    command = {s: np.array(order(commands[s], "effort")) for s in commands}
    quat = np.array([[att[s].quaternion.x, att[s].quaternion.y, att[s].quaternion.z,
                      att[s].quaternion.w] for s in stamps])  # fmt: skip
    omega = np.array([[rate[s].vector.x, rate[s].vector.y, rate[s].vector.z] for s in stamps])
    t = (np.array(stamps) - stamps[0]) * 1e-9
    assert np.all(np.abs(speed) <= array.max_speed * (1 + 1e-12)), "a wheel above its speed"
    assert np.all(np.abs(effort) <= array.max_torque * (1 + 1e-12)), "a wheel above its torque"
    sigma = Rotation.from_quat(quat).as_mrp()
    margin, _ = dense_min_margin_deg(sc.cone_geometry(), t, sigma, omega)
    assert margin > 0.0
    assert summary["reached"] and summary["failure"] is None
    final = np.degrees(principal_angle(relative(sigma[-1], sc.desired_mrp)))
    assert final < 0.5
    # the inertial system momentum, from the record alone
    j = np.asarray(sc.inertia_kgm2).reshape(3, 3)
    js = np.array([w.spin_inertia_kgm2 for w in array.wheels])
    g = np.array([w.spin_axis_body for w in array.wheels]).T  # (3, m)
    h_b = omega @ j.T + (speed * js) @ g.T
    c_nb = Rotation.from_quat(quat).as_matrix()  # body -> inertial
    h_n = np.einsum("kij,kj->ki", c_nb, h_b)
    peak_wheel_h = float(np.max(np.abs(speed) * js))
    return {"t": t, "sigma": sigma, "omega": omega, "speed": speed, "effort": effort,
            "h_n": h_n, "peak_wheel_h": np.array(peak_wheel_h), "stamps": np.array(stamps),
            "command": command}  # fmt: skip


def test_pyramid_lockstep_is_the_offline_run_and_keeps_its_momentum(tmp_path):
    path = ROOT / "scenarios" / "case1_rw_pyramid.yaml"
    summary = attitude_run(path, tmp_path / "run")
    rec = judge(path, tmp_path / "run", summary)
    drift = np.linalg.norm(rec["h_n"] - rec["h_n"][0], axis=1).max()
    assert drift < 0.01 * float(rec["peak_wheel_h"])
    offline = run_closed_loop(load_scenario(path))
    n = len(rec["t"])
    np.testing.assert_allclose(rec["sigma"], offline.sigma_bn[:n], atol=1e-9)
    assert offline.wheels is not None
    np.testing.assert_allclose(rec["speed"], offline.wheels.speed_rad_s[:n], rtol=1e-9, atol=1e-9)
    assert summary["peak_wheel_speed_frac"] < 1.0 and summary["momentum_error_nms"] < 1e-9


def test_gravity_gradient_momentum_drift_is_the_integrated_torque(tmp_path):
    path = ROOT / "scenarios" / "leo_rw_gravity_gradient.yaml"
    summary = attitude_run(path, tmp_path / "run")
    rec = judge(path, tmp_path / "run", summary)
    sc = load_scenario(path)
    dist = sc.disturbances
    assert isinstance(dist, Disturbances) and dist.orbit is not None
    # the torque held over each step at its start (body axes), taken to inertial axes
    c_nb = Rotation.from_mrp(rec["sigma"]).as_matrix()
    tau_b = np.array(
        [dist.torque_b(float(t), s) for t, s in zip(rec["t"], rec["sigma"], strict=True)]
    )
    tau_n0 = np.einsum("kij,kj->ki", c_nb[:-1], tau_b[:-1])
    tau_n1 = np.einsum("kij,kj->ki", c_nb[1:], tau_b[:-1])
    impulse = np.cumsum(0.5 * np.diff(rec["t"])[:, None] * (tau_n0 + tau_n1), axis=0)
    change = rec["h_n"][-1] - rec["h_n"][0]
    assert np.linalg.norm(impulse[-1]) > 1e-6, "the gravity gradient must load the wheels"
    assert np.linalg.norm(change - impulse[-1]) <= 0.05 * np.linalg.norm(impulse[-1])


def test_a_wheel_failed_mid_slew_applies_nothing_and_the_rest_fly_to_the_goal(tmp_path):
    text = (ROOT / "scenarios" / "case1_rw_pyramid.yaml").read_text()
    sc = loads_scenario(text)
    assert sc.wheels is not None
    failed = sc.wheels.names[1]
    lines = text.splitlines()
    at = next(i for i, line in enumerate(lines) if line.strip() == f"{failed}:")
    indent = " " * (len(lines[at + 1]) - len(lines[at + 1].lstrip()))
    lines.insert(at + 1, f"{indent}fails_at_s: 50.0")
    text = "\n".join(lines).replace("sim_time_s: 400.0", "sim_time_s: 1200.0") + "\n"
    path = tmp_path / "failed.yaml"
    path.write_text(text)
    summary = attitude_run(path, tmp_path / "run")
    rec = judge(path, tmp_path / "run", summary)
    k = list(sc.wheels.names).index(failed)
    after = rec["t"] > 50.0 + 0.1  # efforts of steps that began at or after the failure
    assert np.all(rec["effort"][after, k] == 0.0)
    cmd_after = [
        rec["command"][s][k]
        for s, t in zip(rec["stamps"], rec["t"], strict=True)
        if t > 52.0 and s in rec["command"]
    ]
    assert cmd_after and np.all(np.asarray(cmd_after) == 0.0), "the failed wheel was taken out"
