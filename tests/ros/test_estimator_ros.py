"""A run with sensors through the ROS 2 graph: the simulator publishes a star tracker and
a gyro, the estimator node (``attitude_estimation``) filters them, and the planner and
the controller answer its estimate. Real nodes, real DDS, judged on the bag's truth.

From the bag alone: the loop was fed the estimate (``/spacecraft/attitude`` is not the
truth, and is about as far from it as the filter says), the true body
(``/spacecraft/truth/*``) never violates, arrives and is declared arrived; the sensor
messages follow their conventions; and in lockstep the recorded truth is the offline
loop's (the same sensors, filter and guidance).
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from support import needs_workspace

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import (
    ATTITUDE,
    IMU,
    STAR_TRACKER,
    TRUTH_ATTITUDE,
    stamp_ns,
)
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import mrp_from_quat, principal_angle, relative
from attitude_core.models.sensor_spec import star_tracker_due
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_tools.bag import read_bag
from attitude_tools.bag.run_record import run_from_bag
from attitude_tools.run.cli import ros_environment
from attitude_tools.run.domain import domain_environment

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(sys.prefix) / "bin"
SCENARIO = ROOT / "scenarios" / "case1_wheels_sensors.yaml"
pytestmark = [pytest.mark.ros, pytest.mark.slow, needs_workspace]


@pytest.fixture(scope="module")
def sensed_run(tmp_path_factory, reserve_ros_domain):
    out = tmp_path_factory.mktemp("sensors") / "run"
    with reserve_ros_domain() as domain:
        run = subprocess.run(
            [str(BIN / "attitude-run"), str(SCENARIO), "--out", str(out), "--quiet"],
            env=domain_environment(domain.id, ros_environment()), capture_output=True,
            text=True, timeout=900,
        )  # fmt: skip
    return run, out


def _quats(out: Path, topic: str) -> dict[int, np.ndarray]:
    found = {}
    for m in read_bag(str(out / "bag"), [topic]):
        q = m.msg.pose.pose.orientation if topic == STAR_TRACKER else m.msg.quaternion
        found[stamp_ns(m.msg.header.stamp)] = np.array([q.x, q.y, q.z, q.w])
    return found


def test_the_run_reaches_the_goal_on_the_truth(sensed_run):
    run, out = sensed_run
    assert run.returncode == 0, run.stdout + run.stderr
    summary = json.loads((out / "summary.json").read_text())
    sc = load_scenario(SCENARIO)
    rec = run_from_bag(str(out / "bag")).run
    truth = _quats(out, TRUTH_ATTITUDE)
    assert len(truth) >= len(rec.t)
    # the record's state is the truth topic's
    first = min(truth)
    np.testing.assert_allclose(rec.sigma_bn[0], mrp_from_quat(truth[first]), atol=1e-12)
    margin, _ = dense_min_margin_deg(sc.sky, rec.t, rec.sigma_bn, rec.omega_b)
    assert margin > 0.0 and margin == pytest.approx(summary["min_margin_deg"])
    assert summary["reached"] and summary["failure"] is None
    arrived = np.flatnonzero(rec.planner_status == PlannerStatus.ARRIVED.code)
    assert len(arrived), "the planner never said arrived"
    assert summary["final_attitude_error_deg"] <= sc.true_arrival.attitude_tol_deg


def test_the_loop_was_fed_the_estimate(sensed_run):
    run, out = sensed_run
    assert run.returncode == 0, run.stdout + run.stderr
    sc = load_scenario(SCENARIO)
    truth, estimate = _quats(out, TRUTH_ATTITUDE), _quats(out, ATTITUDE)
    common = sorted(set(truth) & set(estimate))
    assert len(common) > 100
    err = np.degrees(
        principal_angle(
            relative(
                mrp_from_quat(np.array([estimate[s] for s in common])),
                mrp_from_quat(np.array([truth[s] for s in common])),
            )
        )
    )
    assert np.median(err) > 1e-4  # not the truth
    assert np.median(err) < sc.knowledge.attitude_3sigma_deg  # but close, as the filter says
    summary = json.loads((out / "summary.json").read_text())
    assert summary["estimation_error_deg"]["median"] == pytest.approx(np.median(err), rel=0.05)


def test_the_sensor_messages_follow_their_conventions(sensed_run):
    run, out = sensed_run
    assert run.returncode == 0, run.stdout + run.stderr
    sc = load_scenario(SCENARIO)
    spec = sc.sensors
    imu = list(read_bag(str(out / "bag"), [IMU]))
    assert imu
    msg = imu[0].msg
    assert msg.header.frame_id == "body"
    assert msg.orientation_covariance[0] == -1.0
    assert msg.linear_acceleration_covariance[0] == -1.0
    assert msg.angular_velocity_covariance[0] == pytest.approx(spec.gyro_noise_rad_s**2)
    tracker = _quats(out, STAR_TRACKER)
    imu_stamps = sorted({stamp_ns(m.msg.header.stamp) for m in imu})
    t0 = imu_stamps[0]
    due = [
        s
        for s in imu_stamps
        if star_tracker_due((s - t0) * 1e-9, spec.star_tracker_rate_hz, sc.dt_s)
    ]
    assert set(tracker) == set(due)  # one sample per tracker period, at its schedule
    cov = next(iter(read_bag(str(out / "bag"), [STAR_TRACKER]))).msg.pose.covariance
    for i in range(3):
        assert cov[(3 + i) * 6 + 3 + i] == pytest.approx(spec.star_tracker_noise_rad[i] ** 2)


def test_lockstep_reproduces_the_offline_loop(sensed_run):
    run, out = sensed_run
    assert run.returncode == 0, run.stdout + run.stderr
    rec = run_from_bag(str(out / "bag")).run
    offline = run_closed_loop(load_scenario(SCENARIO))
    n = min(len(rec.t), len(offline.t))
    assert n > 500
    np.testing.assert_allclose(rec.sigma_bn[:n], offline.sigma_bn[:n], atol=1e-6, rtol=0)
    np.testing.assert_allclose(
        rec.estimate.sigma_bn[:n], offline.estimate.sigma_bn[:n], atol=1e-6, rtol=0
    )


def test_the_report_plots_the_estimate_against_the_truth(sensed_run, tmp_path):
    run, out = sensed_run
    assert run.returncode == 0, run.stdout + run.stderr
    report = subprocess.run(
        [str(BIN / "attitude-report"), str(out), "--out", str(tmp_path / "report"), "--quiet"],
        capture_output=True, text=True, timeout=600,
    )  # fmt: skip
    assert report.returncode == 0, report.stdout + report.stderr
    assert (tmp_path / "report" / "estimation.png").is_file()
    assert 'id="estimation.png"' in (tmp_path / "report" / "report.html").read_text()
    import matplotlib.pyplot as plt

    from attitude_tools.report import figures
    from attitude_tools.report.data import load_run

    loaded = load_run(str(out))
    est = loaded.run.estimate
    assert est is not None and np.isfinite(est.attitude_3sigma_deg[1:]).all()
    fig = figures.fig_estimation(figures.FigureContext([loaded], mrp_grid=16))
    try:
        (line,) = [
            a
            for ax in fig.axes
            for a in ax.get_lines()
            if a.get_gid() == f"{loaded.label}/attitude_error"
        ]
        expected = np.degrees(principal_angle(relative(est.sigma_bn, loaded.run.sigma_bn)))
        np.testing.assert_allclose(line.get_ydata(), expected)
        # the filter's 3-sigma bounds the error most of the time (a consistent filter)
        assert np.mean(expected[1:] <= est.attitude_3sigma_deg[1:]) > 0.9
    finally:
        plt.close(fig)


def test_a_bench_that_feeds_its_own_estimate_runs_without_the_estimator(tmp_path, ros_env):
    """``--plant external --external-estimate``: the example bridge publishes its state on
    ``/spacecraft/attitude`` (its estimate, here its truth); no estimator is started, the
    loop answers the bridge, and the guidance keeps the sensors' knowledge bounds."""
    from ros_helpers import run_with_bridge

    out = tmp_path / "run"
    run, _ = run_with_bridge(
        SCENARIO, out, ros_env(ros_environment()), tmp_path / "bridge.log",
        run_args=("--external-estimate", "--settle-s", "2.0"),
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    assert not (out / "logs" / "estimator.log").exists()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["reached"] and summary["min_margin_deg"] > 0.0
    assert not list(read_bag(str(out / "bag"), [IMU]))
    assert summary["knowledge_3sigma_deg"] is None  # no truth topics: the bag's state is all
