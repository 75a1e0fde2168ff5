"""The moving sky (attitude_core.models.sky): margins from the limb against a brute-force
sampler, windowed cones that hold the true ones, static skies equal to the paper's
geometry, rate bounds that bound."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude_core.config.scenario_loader import load_scenario, parse_scenario
from attitude_core.models.constraints import ConeGeometry, KeepInCones
from attitude_core.models.ephemeris import body_directions
from attitude_core.yamlio import load_strict

ROOT = Path(__file__).resolve().parents[2]

LEO = ROOT / "scenarios" / "leo_star_tracker.yaml"
MOVER = ROOT / "scenarios" / "moving_object.yaml"


def _brute_margins(sc, t, sigma):
    """Every constraint's margin, written out from the scenario's records with SciPy and
    the unvectorised ephemeris (no shared code with Sky but the ephemeris functions)."""
    out = []
    body_to_inertial = Rotation.from_mrp(sigma)  # C_NB: body vectors in inertial axes
    for inst in sc.instruments:
        s_n = body_to_inertial.apply(np.array(inst.boresight_body))
        for obj in sc.bright_objects:
            if obj.name not in inst.avoids:
                continue
            if obj.ephemeris is not None:
                from attitude_core.models.ephemeris import parse_epoch_utc

                c, r = body_directions(obj.ephemeris, parse_epoch_utc(sc.epoch_utc), sc.orbit, t)
                radius = np.degrees(float(r))
            else:
                rate = (
                    obj.rate_inertial_rad_s if obj.rate_inertial_rad_s is not None else np.zeros(3)
                )
                turn = Rotation.from_rotvec(np.asarray(rate) * t)
                c, radius = turn.apply(np.array(obj.direction_inertial)), 0.0
            excl = dict(inst.exclusion_deg).get(obj.name, inst.half_angle_deg)
            angle = np.degrees(np.arccos(np.clip(np.dot(s_n, c), -1.0, 1.0)))
            out.append(angle - excl - radius)
    return np.array(out)


@pytest.mark.parametrize("path", [LEO, MOVER])
def test_moving_margins_equal_a_brute_force_sampler(path):
    sc = load_scenario(path)
    rng = np.random.default_rng(4)
    t = rng.uniform(0.0, sc.sim_time_s, 40)
    sigma = Rotation.random(40, rng=rng).as_mrp()
    got = sc.sky.constraint_margins_deg(t, sigma)
    want = np.array([_brute_margins(sc, tk, sk) for tk, sk in zip(t, sigma, strict=True)])
    # The Sun and Moon come from a 60 s table (linear): within 1e-3 deg of the ephemeris.
    np.testing.assert_allclose(got, want, atol=1e-3, rtol=0.0)
    assert got.shape == (40, len(sc.constraint_names))


def test_windowed_cones_hold_every_true_cone_of_the_window():
    sc = load_scenario(MOVER)
    rng = np.random.default_rng(5)
    for t0, window in ((0.0, 6.0), (37.0, 50.0), (120.0, 0.0)):
        geometry = sc.sky.geometry(t0, window)
        sigma = Rotation.random(400, rng=rng).as_mrp()
        windowed = geometry.constraint_margins_deg(sigma)
        for t in np.linspace(t0, t0 + window, 7):
            true = sc.sky.constraint_margins_deg(np.full(len(sigma), t), sigma)
            assert np.all(windowed <= true + 1e-9), (t0, window, t)
    # Tight for a fixed object, and about half the sweep for the mover.
    slack = sc.sky.constraint_margins_deg(np.full(len(sigma), 37.0), sigma) - sc.sky.geometry(
        37.0, 0.0
    ).constraint_margins_deg(sigma)
    assert np.abs(slack).max() < 1e-9


def test_a_static_sky_is_the_papers_geometry():
    sc = load_scenario(ROOT / "scenarios" / "two_instruments.yaml")
    assert sc.sky.static
    legacy = ConeGeometry(
        sc.boresights_body,
        sc.half_angles_deg,
        sc.directions_inertial,
        inflation_deg=2.0,
        samples=180,
        keep_in=KeepInCones.none(),
    )
    ours = sc.cone_geometry(inflation_deg=2.0, samples=180)
    sigma = Rotation.random(50, rng=np.random.default_rng(6)).as_mrp()
    np.testing.assert_array_equal(
        ours.constraint_margins_deg(sigma), legacy.margins_deg(sigma).reshape(50, -1)
    )
    for s in sigma[:10]:
        a, b = ours.closest_obstacle(s), legacy.closest_obstacle(s)
        assert (a.distance, a.constraint) == (b.distance, b.constraint)
        assert ours.min_margin_deg_single(s) == legacy.min_margin_deg_single(s)
    # The margins of any time are those of t = 0.
    np.testing.assert_array_equal(
        sc.sky.constraint_margins_deg(np.full(50, 99.0), sigma), ours.constraint_margins_deg(sigma)
    )


def test_rate_bounds_bound_the_sampled_motion():
    sc = load_scenario(LEO)
    t = np.arange(0.0, sc.sim_time_s, 0.5)
    dirs, radii = sc.sky.object_directions(t)
    step = np.degrees(np.arccos(np.clip(np.einsum("tjk,tjk->tj", dirs[1:], dirs[:-1]), -1, 1)))
    rate = (step + np.abs(np.diff(radii, axis=0))) / 0.5
    assert np.all(rate.max(axis=0) <= sc.sky.rate_bounds_deg_s)
    earth = sc.bright_object_names.index("earth")
    # Nadir turns at the orbital rate: 360 deg per period.
    assert rate[:, earth].mean() == pytest.approx(360.0 / sc.orbit.period_s, rel=1e-3)
    assert radii[0, earth] == pytest.approx(68.02, abs=0.01)  # the Earth's disc from 500 km


def _doc(path):
    return load_strict(path.read_text())["/**"]["ros__parameters"]


def test_per_object_exclusions_and_avoids_define_the_constraints():
    doc = _doc(ROOT / "scenarios" / "two_instruments.yaml")
    doc["instruments"]["camera"]["avoids"] = ["sun"]
    doc["instruments"]["star_tracker"]["exclusion_deg"] = {"moon": 7.5}
    sc = parse_scenario(doc, str(ROOT / "scenarios" / "x.yaml"))
    assert sc.constraint_names == ("star_tracker/sun", "star_tracker/moon", "camera/sun")
    sigma = Rotation.random(20, rng=np.random.default_rng(7)).as_mrp()
    margins = sc.sky.constraint_margins_deg(np.zeros(20), sigma)
    inertial = Rotation.from_mrp(sigma)
    c = sc.directions_inertial
    angle = np.degrees(np.arccos(np.clip(inertial.apply([1.0, 0.0, 0.0]) @ c.T, -1, 1)))
    np.testing.assert_allclose(margins[:, 0], angle[:, 0] - 20.0, atol=1e-9)
    np.testing.assert_allclose(margins[:, 1], angle[:, 1] - 7.5, atol=1e-9)
    cam = np.degrees(
        np.arccos(np.clip(inertial.apply(np.array(sc.instruments[1].boresight_body)) @ c[0], -1, 1))
    )
    np.testing.assert_allclose(margins[:, 2], cam - 15.0, atol=1e-9)
    # The planner's geometry has the same three constraints and margins.
    np.testing.assert_allclose(sc.cone_geometry().constraint_margins_deg(sigma), margins, atol=1e-9)
