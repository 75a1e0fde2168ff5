"""attitude-report on a moving sky (no ROS): each scenario flown offline (run_closed_loop),
written to a bag as the recorder writes it (test_report's writer, scenario attached) and
rebuilt by the report's loader; the figures' data checked against the scenario's sky."""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import pytest
from report_helpers import ROOT
from test_report_bags import _unit_from_ra_dec, _with_gid, _write_run_bag

from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_tools.report import sky as report_sky
from attitude_tools.report.cli import write_report
from attitude_tools.report.figures import FIGURES
from attitude_tools.report.figures.context import FigureContext
from attitude_tools.report.figures.margin import fig_margin
from attitude_tools.report.figures.sky_maps import fig_keepout_inertial, fig_trajectory_boresight
from attitude_tools.report.geometry import boresight_inertial

# moving_object, its star tracker avoiding only object_1 (half-angle) and the mover (10 deg).
AVOIDS = (
    "        half_angle_deg: 20.0\n",
    "        half_angle_deg: 20.0\n        avoids: [object_1, mover]\n"
    "        exclusion_deg:\n          mover: 10.0\n",
)


@pytest.fixture(scope="module")
def report_run(tmp_path_factory):
    """``report_run(name, edit=None)``: the report's run of scenarios/<name>.yaml (its
    text edited by ``edit``: (old, new)), flown offline and read back from its bag."""
    from attitude_tools.report.data import load_run

    cache = {}

    def get(name, edit=None):
        if (name, edit) not in cache:
            text = (ROOT / "scenarios" / f"{name}.yaml").read_text(encoding="utf-8")
            text = text if edit is None else text.replace(*edit)
            run = run_closed_loop(loads_scenario(text, name))
            run_dir = tmp_path_factory.mktemp(name)
            _write_run_bag(run_dir / "bag", text, run.t, run.sigma_bn, run.omega_b)
            cache[name, edit] = load_run(str(run_dir))
        return cache[name, edit]

    return get


def _drawn(line) -> np.ndarray:
    """Unit vectors of a sky line's finite points (RA/Dec breaks removed)."""
    ra, dec = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
    return _unit_from_ra_dec(ra[np.isfinite(ra)], dec[np.isfinite(dec)])


def _angles(points, centre) -> np.ndarray:
    return np.degrees(np.arccos(np.clip(points @ np.asarray(centre), -1.0, 1.0)))


@pytest.mark.parametrize("name", ["moving_object", "leo_star_tracker"])
def test_margin_figure_plots_each_constraint_against_the_moving_sky(report_run, name):
    run = report_run(name)
    sc, t, sigma = run.scenario, run.run.t, run.run.sigma_bn
    assert not sc.sky.static
    expected = sc.sky.constraint_margins_deg(t, sigma)
    np.testing.assert_allclose(report_sky.constraint_margins_deg(run), expected, atol=1e-9)
    fig = fig_margin(FigureContext([run], mrp_grid=16))
    try:
        for c, key in enumerate(sc.constraint_names):
            (line,) = _with_gid(fig, f"{key}/margin")
            assert line.get_label() == key
            np.testing.assert_allclose(line.get_xdata(), t)
            np.testing.assert_allclose(line.get_ydata(), expected[:, c], atol=1e-9)
            minimum = pytest.approx(run.summary["min_margin_deg_per_pair"][key], abs=1e-9)
            assert np.min(line.get_ydata()) == minimum
    finally:
        plt.close(fig)
    # Not the sky frozen at t = 0: the moving cones' margins differ from it by degrees.
    frozen = sc.cone_geometry().constraint_margins_deg(sigma)
    assert np.abs(frozen - expected).max() > 1.0


@pytest.mark.parametrize("name", ["moving_object", "leo_star_tracker"])
def test_moving_objects_tracks_and_cones_on_the_sky(report_run, name):
    run = report_run(name)
    sc, sky = run.scenario, run.scenario.sky
    margins = sky.constraint_margins_deg(run.run.t, run.run.sigma_bn)
    t = report_sky.track_times(run)
    assert t[0] == run.run.t[0] and t[-1] == pytest.approx(run.run.t[-1])
    np.testing.assert_allclose(np.diff(t), 1.0, atol=1e-9)  # a point every second
    ctx = FigureContext([run], mrp_grid=16)
    for build in (fig_keepout_inertial, fig_trajectory_boresight):
        fig = build(ctx)
        try:
            for j, obj in enumerate(sc.bright_object_names):
                tracks = _with_gid(fig, f"{obj}/track")
                if not sky.objects[j].moves:
                    assert not tracks  # a fixed object: its cone as on the paper's sky
                    continue
                (track,) = tracks
                drawn = _drawn(track)
                assert len(drawn) == len(t)  # one point per sampled time
                start, end = sky.object_directions(t[0])[0][j], sky.object_directions(t[-1])[0][j]
                np.testing.assert_allclose(drawn[0], start, atol=1e-9)
                np.testing.assert_allclose(drawn[-1], end, atol=1e-9)
            for c, key in enumerate(sc.constraint_names):
                j = int(sky.pair_object[c])
                if not sky.objects[j].moves:
                    continue
                k = int(np.argmin(margins[:, c]))
                for tag, when in (("start", t[0]), ("end", t[-1]), ("closest", run.run.t[k])):
                    (cone,) = _with_gid(fig, f"{key}/cone_{tag}")
                    dirs, radii = sky.object_directions(when)
                    rim = sky.pair_exclusion_deg[c] + radii[j]  # from the limb
                    np.testing.assert_allclose(_angles(_drawn(cone), dirs[j]), rim, atol=1e-6)
                if build is fig_trajectory_boresight:
                    (mark,) = _with_gid(fig, f"{key}/closest_boresight")
                    b = boresight_inertial(run.run.sigma_bn[k : k + 1], sc.boresights_body[0])
                    np.testing.assert_allclose(_drawn(mark), b, atol=1e-9)
        finally:
            plt.close(fig)
    assert len(ctx.instruments()) == ctx.n_instruments == 1  # one panel, whatever its angles


def test_a_pair_not_avoided_is_neither_a_cone_nor_a_margin(report_run, tmp_path):
    run = report_run("moving_object", AVOIDS)
    sc = run.scenario
    assert sc.constraint_names == ("star_tracker/object_1", "star_tracker/mover")
    ctx = FigureContext([run], mrp_grid=16)
    pairs = [(p.key, p.half_angle_deg) for p in ctx.pairs]  # object_2, object_3: none
    assert pairs == [("star_tracker/object_1", 20.0), ("star_tracker/mover", 10.0)]
    fig = fig_trajectory_boresight(ctx)
    try:
        (cone,) = _with_gid(fig, "star_tracker/mover/cone_start")  # 10 deg, not 20
        np.testing.assert_allclose(_angles(_drawn(cone), sc.directions_inertial[3]), 10.0)
        assert "keep-out object_1 20, mover 10 deg" in fig.axes[0].get_title()
    finally:
        plt.close(fig)
    fig = fig_margin(ctx)
    try:
        gids = {a.get_gid() for a in fig.findobj() if a.get_gid()}
        assert gids == {"star_tracker/object_1/margin", "star_tracker/mover/margin"}
    finally:
        plt.close(fig)
    out = write_report([run], str(tmp_path / "report"), dpi=40, mrp_grid=16)
    page = Path(out, "report.html").read_text(encoding="utf-8")
    assert "star_tracker: [1, 0, 0], 20 deg; keep-out: object_1 20 deg, mover 10 deg; " in page
    assert "does not avoid object_2, object_3" in page
    assert "turning at 0.4 deg/s about" in page  # the mover's rate


def test_scenario_table_shows_ephemeris_bodies_exclusions_and_orbit(report_run, tmp_path):
    run = report_run("leo_star_tracker")
    out = write_report([run], str(tmp_path / "report"), dpi=40, mrp_grid=16)
    assert all((tmp_path / "report" / name).is_file() for name in FIGURES)
    page = Path(out, "report.html").read_text(encoding="utf-8")
    for text in (
        "sun: sun (ephemeris, seen from the spacecraft)",
        "earth: earth (ephemeris, seen from the spacecraft)",
        "angular radius 68 deg",  # the Earth from 500 km
        "keep-out: sun 40 deg from the limb, earth 25 deg from the limb, moon 15 deg from",
        "epoch (UTC), orbit</th><td>2026-06-21T06:00:00Z; orbit a 6878.14 km",
        "On a moving sky, a keep-out margin is the angle",
    ):
        assert text in page, text
    table = page[page.index("<h2>Scenario</h2>") : page.index("<h2>Summary</h2>")]
    assert "nan" not in table  # no instrument half-angle: none shown


def test_static_sky_report_is_the_papers(report_run):
    """case1: the cones, margins and labels the report drew before the moving sky."""
    run = report_run("case1")
    sc = run.scenario
    assert sc.sky.static
    ctx = FigureContext([run], mrp_grid=16)
    old_pairs = [  # every instrument/object pair at the instrument's half-angle
        (n, o, float(b), tuple(c))
        for n, b in zip(sc.instrument_names, sc.half_angles_deg, strict=True)
        for o, c in zip(sc.bright_object_names, sc.directions_inertial, strict=True)
    ]
    drawn = [(p.instrument, p.obj, p.half_angle_deg, p.direction_inertial) for p in ctx.pairs]
    assert drawn == old_pairs
    assert not any(p.moving for p in ctx.pairs) and ctx.n_instruments == 1
    static = sc.cone_geometry().margins_deg(run.run.sigma_bn)  # the static formula
    fig = fig_margin(ctx)
    try:
        for i, name in enumerate(sc.instrument_names):
            for j, obj in enumerate(sc.bright_object_names):
                (line,) = _with_gid(fig, f"{name}/{obj}/margin")
                assert line.get_label() == f"{name} / {obj}"
                np.testing.assert_array_equal(line.get_ydata(), static[:, i, j])
    finally:
        plt.close(fig)
    fig = fig_trajectory_boresight(ctx)
    try:
        title = "star_tracker: boresight [1, 0, 0] (body), half-angle 20 deg"
        assert fig.axes[0].get_title() == title
        assert not [a for a in fig.findobj() if str(a.get_gid()).endswith("/track")]
    finally:
        plt.close(fig)
