"""attitude-report on bags written here from offline runs (no ROS): keep-in cones and
reaction wheels, their figures, table and summary."""

import base64
import html
import json
from pathlib import Path

import numpy as np
import pytest
from report_helpers import ROOT, assert_valid_figure, summary_cells

from attitude_tools.report.figures import FIGURES
from attitude_tools.report.geometry import mrp_surface
from attitude_tools.report.html import format_value

KEEP_IN_SCENARIO = ROOT / "scenarios" / "keep_in.yaml"


def _eigenaxis_run(scenario_path: Path, seconds: float = 30.0, dt: float = 0.1):
    """The straight eigenaxis slew from the scenario's start to its goal (SciPy slerp):
    (t, sigma_bn, omega_b) sampled every ``dt``."""
    from scipy.spatial.transform import Rotation, Slerp

    from attitude_core.config.scenario_loader import load_scenario

    sc = load_scenario(scenario_path)
    ends = Rotation.from_mrp(np.array([sc.initial_mrp, sc.desired_mrp]))  # active: C_NB
    n = int(round(seconds / dt))
    t = np.arange(n + 1) * dt
    path = Slerp([0.0, seconds], ends)(t)
    rate = (ends[0].inv() * ends[1]).as_rotvec() / seconds  # body axes, constant
    return t, path.as_mrp(), np.tile(rate, (n + 1, 1))


def _write_run_bag(bag_dir: Path, scenario_text: str, t, sigma, omega, wheels=None) -> None:
    """A bag like the recorder's: state, applied torque and planner target per stamp,
    and the scenario attached; with ``wheels`` (names, ``WheelRecord``) the wheel topics
    as the contract has them (the applied efforts of the step that ended at the stamp)."""
    from geometry_msgs.msg import QuaternionStamped, Vector3Stamped, WrenchStamped
    from rclpy.serialization import serialize_message
    from sensor_msgs.msg import JointState

    from attitude_core.contract import topics
    from attitude_core.models.mrp import quat_from_mrp
    from attitude_tools.bag import BagWriter

    def stamped(msg, ns, frame):
        msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, 10**9)
        msg.header.frame_id = frame
        return msg

    with BagWriter(str(bag_dir)) as bag:
        for name in (
            topics.ATTITUDE,
            topics.ANGULAR_VELOCITY,
            topics.APPLIED_TORQUE,
            topics.TARGET_MRP,
            topics.TARGET_RATE,
            *(topics.WHEEL_TOPICS if wheels is not None else ()),
        ):
            bag.add_topic(name, topics.topic(name).type_name)
        quats = quat_from_mrp(sigma)
        for k in range(len(t)):
            ns = int(round(t[k] * 1e9))
            q = stamped(QuaternionStamped(), ns, "inertial")
            q.quaternion.x, q.quaternion.y, q.quaternion.z, q.quaternion.w = map(float, quats[k])
            w = stamped(Vector3Stamped(), ns, "body")
            w.vector.x, w.vector.y, w.vector.z = map(float, omega[k])
            target = stamped(Vector3Stamped(), ns, "inertial")
            target.vector.x, target.vector.y, target.vector.z = map(float, sigma[k])
            torque = stamped(WrenchStamped(), ns, "body")
            target_rate = stamped(Vector3Stamped(), ns, "target")
            log = 1_700_000_000_000_000_000 + ns
            for name, msg in (
                (topics.ATTITUDE, q),
                (topics.ANGULAR_VELOCITY, w),
                (topics.APPLIED_TORQUE, torque),
                (topics.TARGET_MRP, target),
                (topics.TARGET_RATE, target_rate),
            ):
                bag.write(name, serialize_message(msg), log)
            if wheels is not None:
                names, record = wheels
                state = stamped(JointState(), ns, "body")
                state.name = list(names)
                state.velocity = [float(x) for x in record.speed_rad_s[k]]
                applied = record.applied_nm[k - 1] if k > 0 else np.zeros(len(names))
                state.effort = [float(x) for x in applied]
                command = stamped(JointState(), ns, "body")
                command.name = list(names)
                command.effort = [float(x) for x in record.commanded_nm[k]]
                bag.write(topics.WHEEL_STATES, serialize_message(state), log)
                bag.write(topics.WHEEL_TORQUE, serialize_message(command), log)
        bag.add_attachment("scenario.yaml", scenario_text.encode(), "application/yaml")


@pytest.fixture(scope="module")
def keep_in_run(tmp_path_factory):
    """The keep_in scenario's direct eigenaxis slew (which leaves the sun sensor's cone),
    recorded to a bag and rebuilt by the report's loader."""
    from attitude_tools.report.data import load_run

    run_dir = tmp_path_factory.mktemp("keep_in_report") / "run"
    run_dir.mkdir()
    t, sigma, omega = _eigenaxis_run(KEEP_IN_SCENARIO)
    _write_run_bag(run_dir / "bag", KEEP_IN_SCENARIO.read_text(encoding="utf-8"), t, sigma, omega)
    return load_run(str(run_dir))


def _keep_in_reference(run, k: int = 0) -> np.ndarray:
    """max_angle - angle(C_BN^T a, d) of the recorded attitudes, from SciPy's rotation."""
    from scipy.spatial.transform import Rotation

    sc = run.scenario
    axes = Rotation.from_mrp(np.array(run.run.sigma_bn)).apply(np.array(sc.keep_in_axes_body[k]))
    d = sc.keep_in_directions_inertial[k]
    return sc.keep_in_max_angles_deg[k] - np.degrees(np.arccos(np.clip(axes @ d, -1.0, 1.0)))


def _unit_from_ra_dec(ra, dec) -> np.ndarray:
    ra, dec = np.radians(ra), np.radians(dec)
    return np.stack([np.cos(dec) * np.cos(ra), np.cos(dec) * np.sin(ra), np.sin(dec)], -1)


def _with_gid(fig, gid):
    return [a for a in fig.findobj() if a.get_gid() == gid]


def test_keep_in_run_summary_covers_the_keep_in_cone(keep_in_run):
    sc = keep_in_run.scenario
    assert sc.keep_in_names == ("sun_sensor",)  # the scenario attached to the bag
    reference = _keep_in_reference(keep_in_run)
    assert reference[0] > 5.0 and reference[-1] > 5.0 and reference.min() < -5.0  # leaves it
    per = keep_in_run.summary["min_margin_deg_per_pair"]
    assert list(per) == list(sc.constraint_names)
    assert per["keep_in/sun_sensor"] == pytest.approx(reference.min(), abs=1e-9)
    assert keep_in_run.summary["min_margin_deg"] <= reference.min() + 1e-9  # dense: all of them


def test_keep_in_margin_figure_plots_the_geometry_margin_of_the_recorded_attitudes(keep_in_run):
    import matplotlib.pyplot as plt

    from attitude_tools.report.figures.context import FigureContext
    from attitude_tools.report.figures.margin import fig_margin

    ctx = FigureContext([keep_in_run], mrp_grid=24)
    assert [c.key for c in ctx.keep_ins] == ["keep_in/sun_sensor"]
    fig = fig_margin(ctx)
    try:
        (line,) = _with_gid(fig, "keep_in/sun_sensor/margin")
        assert line.get_label() == "keep_in/sun_sensor"
        np.testing.assert_allclose(line.get_xdata(), keep_in_run.run.t)
        np.testing.assert_allclose(line.get_ydata(), _keep_in_reference(keep_in_run), atol=1e-9)
        assert "keep_in/sun_sensor" in [t.get_text() for t in fig.axes[0].get_legend().get_texts()]
    finally:
        plt.close(fig)
    # Compared with another run: a keep-in panel with both runs' series.
    other = FigureContext([keep_in_run, keep_in_run], mrp_grid=24)
    fig = fig_margin(other)
    try:
        lines = _with_gid(fig, "keep_in/sun_sensor/margin")
        assert len(lines) == 2
        for line in lines:
            np.testing.assert_allclose(line.get_ydata(), _keep_in_reference(keep_in_run), atol=1e-9)
        assert "keep_in/sun_sensor (keep-in)" in [ax.get_title() for ax in fig.axes]
    finally:
        plt.close(fig)


def test_keep_in_cone_and_axis_track_on_the_sky(keep_in_run):
    import matplotlib.pyplot as plt
    from scipy.spatial.transform import Rotation

    from attitude_tools.report.figures.context import FigureContext
    from attitude_tools.report.figures.sky_maps import (
        fig_keepout_inertial,
        fig_trajectory_boresight,
    )

    sc = keep_in_run.scenario
    d, gamma = sc.keep_in_directions_inertial[0], 70.0
    ctx = FigureContext([keep_in_run], mrp_grid=24)
    for build in (fig_keepout_inertial, fig_trajectory_boresight):
        fig = build(ctx)
        try:
            (cone,) = _with_gid(fig, "keep_in/sun_sensor/cone")
            assert cone.get_linestyle() == "--" and cone.get_color() == "tab:green"
            ra, dec = np.asarray(cone.get_xdata()), np.asarray(cone.get_ydata())
            v = _unit_from_ra_dec(ra[np.isfinite(ra)], dec[np.isfinite(dec)])
            angles = np.degrees(np.arccos(np.clip(v @ d, -1.0, 1.0)))
            np.testing.assert_allclose(angles, gamma, atol=1e-9)  # the cone's rim
        finally:
            plt.close(fig)
    fig = fig_trajectory_boresight(ctx)
    try:
        assert len(fig.axes) == 2  # the star tracker's panel and the sun sensor's
        (track,) = _with_gid(fig, "keep_in/sun_sensor/axis")
        ra, dec = np.asarray(track.get_xdata()), np.asarray(track.get_ydata())
        drawn = _unit_from_ra_dec(ra[np.isfinite(ra)], dec[np.isfinite(dec)])
        axis = np.array(sc.keep_in_axes_body[0])
        expected = Rotation.from_mrp(np.array(keep_in_run.run.sigma_bn)).apply(axis)
        np.testing.assert_allclose(drawn, expected, atol=1e-9)
        outside = np.degrees(np.arccos(np.clip(drawn @ d, -1.0, 1.0))) > gamma
        assert outside.any() and not outside[0] and not outside[-1]
    finally:
        plt.close(fig)


def test_keep_in_boundary_in_mrp_space(keep_in_run):
    import matplotlib.pyplot as plt

    from attitude_tools.report.figures.context import FigureContext
    from attitude_tools.report.figures.mrp_space import fig_keepout_mrp
    from attitude_tools.report.geometry import keep_ins_of

    (cone,) = keep_ins_of([keep_in_run.scenario])
    triangles = mrp_surface(cone, n=32)
    verts = triangles.reshape(-1, 3)
    assert np.all(np.linalg.norm(verts, axis=1) <= 1.0 + 1e-9)
    inner = verts[np.linalg.norm(verts, axis=1) < 0.95]
    # On the keep-in cone's rim, to the grid's resolution (spacing 2/31 MRP).
    assert np.max(np.abs(_keep_in_reference_at(keep_in_run.scenario, inner))) < 6.0
    fig = fig_keepout_mrp(FigureContext([keep_in_run], mrp_grid=24))
    try:
        assert len(_with_gid(fig, "keep_in/sun_sensor/surface")) == 1
    finally:
        plt.close(fig)


def _keep_in_reference_at(sc, sigma) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    axes = Rotation.from_mrp(sigma).apply(np.array(sc.keep_in_axes_body[0]))
    d = sc.keep_in_directions_inertial[0]
    return sc.keep_in_max_angles_deg[0] - np.degrees(np.arccos(np.clip(axes @ d, -1.0, 1.0)))


@pytest.mark.slow
def test_keep_in_report_writes_the_cone_into_figures_table_and_summary(keep_in_run, tmp_path):
    from attitude_tools.report.cli import write_report

    out = Path(write_report([keep_in_run], str(tmp_path / "report"), mrp_grid=24))
    for name in FIGURES:
        assert_valid_figure(out / name)
    doc = json.loads((out / "summary.json").read_text())
    shown = doc["runs"][0]["summary"]["min_margin_deg_per_pair"]["keep_in/sun_sensor"]
    assert shown == pytest.approx(_keep_in_reference(keep_in_run).min(), abs=1e-9)
    page = (out / "report.html").read_text(encoding="utf-8")
    cells = summary_cells(page)
    assert cells["min_margin_deg_per_pair/keep_in/sun_sensor"] == [(shown, format_value(shown))]
    assert "keep-in cones: axis (body), direction (inertial), largest angle" in page
    assert "sun_sensor: [0, 0.7071, 0.7071]" in page
    assert 'class="num bad" data-key="min_margin_deg_per_pair/keep_in/sun_sensor"' in page


# --- reaction wheels (no ROS: flown offline, written to a bag, read back) ----------------


@pytest.fixture(scope="module")
def wheel_run(tmp_path_factory):
    """``wheel_run(name)``: (report run, offline run) of scenarios/<name>.yaml cut to 30 s,
    flown offline (``run_closed_loop``), written to a bag with its wheel topics and
    rebuilt by the report's loader, wheels included."""
    from attitude_core.config.scenario_loader import loads_scenario
    from attitude_core.loop.closed_loop import run_closed_loop
    from attitude_tools.report.data import load_run

    cache = {}

    def get(name):
        if name not in cache:
            text = (ROOT / "scenarios" / f"{name}.yaml").read_text(encoding="utf-8")
            text = text.replace("sim_time_s: 400.0", "sim_time_s: 30.0")
            offline = run_closed_loop(loads_scenario(text, name))
            run_dir = tmp_path_factory.mktemp(name)
            _write_run_bag(
                run_dir / "bag",
                text,
                offline.t,
                offline.sigma_bn,
                offline.omega_b,
                wheels=(offline.scenario.wheels.names, offline.wheels),
            )
            run = load_run(str(run_dir))
            np.testing.assert_allclose(run.run.t, offline.t, atol=1e-9)
            rebuilt, flown = run.run.wheels, offline.wheels
            np.testing.assert_array_equal(rebuilt.speed_rad_s, flown.speed_rad_s)
            np.testing.assert_array_equal(rebuilt.applied_nm[:-1], flown.applied_nm[:-1])
            assert np.all(np.isnan(rebuilt.applied_nm[-1]))  # the last step's: not on record
            cache[name] = run, offline
        return cache[name]

    return get


def test_wheel_figure_draws_each_wheel_against_its_limits(wheel_run, keep_in_run):
    import matplotlib.pyplot as plt
    from matplotlib.colors import same_color

    from attitude_core.models.wheel_array import RPM
    from attitude_core.record.wheel_figures import wheel_figures
    from attitude_tools.report.figures.context import FigureContext
    from attitude_tools.report.figures.wheels import fig_wheels

    run, offline = wheel_run("case1_rw_pyramid")
    assert run.scenario.wheels.names == ("rw1", "rw2", "rw3", "rw4")
    fig = fig_wheels(FigureContext([run], mrp_grid=24))
    try:
        assert len(fig.axes) == 3
        assert fig.axes[0].get_ylabel() == "wheel speed (rpm)"
        for i, name in enumerate(run.scenario.wheels.names):
            gid = f"{run.label}/wheel/{name}"
            (speed,) = _with_gid(fig, f"{gid}/speed")
            np.testing.assert_allclose(speed.get_xdata(), run.run.t)
            np.testing.assert_allclose(speed.get_ydata(), offline.wheels.speed_rad_s[:, i] / RPM)
            (torque,) = _with_gid(fig, f"{gid}/torque")
            np.testing.assert_allclose(torque.get_ydata(), run.run.wheels.applied_nm[:, i])
            for part, limit, data in (
                ("speed_limit", 6000.0, speed.get_ydata()),  # max_speed_rpm of the scenario
                ("torque_limit", 0.03, torque.get_ydata()),  # max_torque_nm
            ):
                lines = _with_gid(fig, f"{gid}/{part}")
                assert sorted(line.get_ydata()[0] for line in lines) == pytest.approx(
                    [-limit, limit], rel=1e-12
                )
                for line in lines:  # dashed, grey: every wheel has this limit
                    assert line.get_linestyle() == "--" and same_color(line.get_color(), "0.3")
                assert np.nanmax(np.abs(data)) <= limit * (1.0 + 1e-9)
        # The slew saturates the motors: the applied torque reaches its dashed limit.
        peak = wheel_figures(run.run)["peak_wheel_torque_frac"]
        assert peak > 0.99
        assert np.nanmax(np.abs(run.run.wheels.applied_nm)) / 0.03 == pytest.approx(peak)
        assert f"peak |torque| / limit {peak:.3g}" in [ax.get_title() for ax in fig.axes]
    finally:
        plt.close(fig)
    # Compared with a run without wheels: one column, the wheel run's.
    fig = fig_wheels(FigureContext([keep_in_run, run], mrp_grid=24))
    try:
        assert len(fig.axes) == 3
        assert len(_with_gid(fig, f"{run.label}/wheel/rw1/speed")) == 1
        assert not any(str(a.get_gid()).startswith(keep_in_run.label) for a in fig.findobj())
    finally:
        plt.close(fig)


@pytest.mark.parametrize("name", ["case1_rw_pyramid", "leo_rw_gravity_gradient"])
def test_wheel_figure_momentum_is_flat_when_free_and_drifts_with_gravity_gradient(wheel_run, name):
    import matplotlib.pyplot as plt

    from attitude_core.record.wheel_figures import inertial_momentum, wheel_figures
    from attitude_tools.report.figures.context import FigureContext
    from attitude_tools.report.figures.wheels import fig_wheels

    run, offline = wheel_run(name)
    h_n = inertial_momentum(offline)
    change = h_n - h_n[0]
    fig = fig_wheels(FigureContext([run], mrp_grid=24))
    try:
        ax = None
        for i in range(3):
            (line,) = _with_gid(fig, f"{run.label}/momentum/{i}")
            np.testing.assert_allclose(line.get_ydata(), change[:, i], atol=1e-12)
            ax = line.axes
        lo, hi = ax.get_ylim()
        assert lo <= change.min() and change.max() <= hi
        size = float(np.linalg.norm(h_n[0]))
        drift = float(np.max(np.abs(change)))
        if name == "case1_rw_pyramid":  # no external torque: constant to rounding
            assert drift < 1e-12 * max(size, 1.0)
            assert hi - lo >= 0.02 * size * (1 - 1e-9)  # shown flat, not magnified rounding
        else:  # the gravity gradient's integral, a few 1e-5 N m over 30 s
            assert drift > 1e-5 and drift > 1e3 * wheel_figures(offline)["momentum_error_nms"]
            assert hi - lo < 3.0 * (change.max() - change.min()) + 0.02 * size
    finally:
        plt.close(fig)


@pytest.mark.slow
def test_wheel_report_has_the_wheel_figure_and_a_run_without_wheels_none(
    wheel_run, keep_in_run, tmp_path
):
    from attitude_tools.report.cli import write_report
    from attitude_tools.report.figures import WHEEL_ARRAY_FIGURES, figures_for

    run, _ = wheel_run("case1_rw_pyramid")
    assert list(figures_for([run])) == [*FIGURES, "wheels.png"]
    out = Path(write_report([run], str(tmp_path / "wheels"), dpi=60, mrp_grid=16))
    assert_valid_figure(out / "wheels.png")
    page = (out / "report.html").read_text(encoding="utf-8")
    title, caption = WHEEL_ARRAY_FIGURES["wheels.png"]
    assert f'<figure id="wheels.png"><h3>{title}</h3>' in page
    assert html.escape(caption) in page
    data = base64.b64encode((out / "wheels.png").read_bytes()).decode("ascii")
    assert f'src="data:image/png;base64,{data}"' in page
    # A run without wheels: the report it had before, no wheel figure or section.
    assert figures_for([keep_in_run]) == FIGURES
    out = Path(write_report([keep_in_run], str(tmp_path / "plain"), dpi=60, mrp_grid=16))
    assert sorted(p.name for p in out.glob("*.png")) == sorted(FIGURES)
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "wheel" not in page.lower()
