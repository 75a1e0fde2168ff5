"""Ephemerides and the two-body orbit (attitude_core.models.ephemeris) against independent
knowledge: the March 2026 equinox, astropy's built-in ephemerides, the Moon's range of
distances, Kepler's invariants, and the geometry of a 500 km orbit."""

from __future__ import annotations

import math
import warnings
from collections.abc import Iterator

import astropy.units as u
import erfa
import numpy as np
import pytest
from astropy.coordinates import GCRS, TETE, CartesianRepresentation, get_body
from astropy.time import Time
from astropy.utils import iers
from astropy.utils.exceptions import AstropyWarning

from attitude_core.models.ephemeris import (
    EARTH_RADIUS_KM,
    MOON_RADIUS_KM,
    MU_EARTH_KM3_S2,
    SUN_RADIUS_KM,
    Orbit,
    body_directions,
    parse_epoch_utc,
    sun_moon_geocentric_km,
)

# Leap seconds are known up to the ERFA release; later years are "dubious" (warned).
pytestmark = pytest.mark.filterwarnings("ignore:ERFA function .*dubious year:erfa.ErfaWarning")

EQUINOX_2026 = "2026-03-20T14:46:00Z"  # March equinox 2026, 14:46 UTC
LEO_500 = Orbit(EARTH_RADIUS_KM + 500.0, 0.0, 97.4, 30.0, 0.0, 0.0)
ELLIPSE = Orbit(9000.0, 0.2, 51.6, 40.0, 250.0, 130.0)


@pytest.fixture
def astropy_offline() -> Iterator[None]:
    """Astropy with its bundled IERS tables only: nothing downloaded, no IERS warnings."""
    with iers.conf.set_temp("auto_download", False), warnings.catch_warnings():
        warnings.simplefilter("ignore", AstropyWarning)
        yield


def _angle_deg(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle between (arrays of) vectors, degrees (atan2: accurate at small angles)."""
    cross = np.linalg.norm(np.cross(a, b), axis=-1)
    return np.degrees(np.arctan2(cross, np.sum(a * b, axis=-1)))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


# --- Sun and Moon ------------------------------------------------------------------------


def test_sun_at_the_march_2026_equinox_is_at_the_true_equinox(astropy_offline: None) -> None:
    epoch = parse_epoch_utc(EQUINOX_2026)
    sun_km, _ = sun_moon_geocentric_km(epoch, 0.0)
    obstime = Time(*epoch, format="jd", scale="utc")
    gcrs = GCRS(CartesianRepresentation(sun_km * u.km), obstime=obstime)
    of_date = gcrs.transform_to(TETE(obstime=obstime))
    ra_deg = (of_date.ra.deg + 180.0) % 360.0 - 180.0
    assert abs(ra_deg) < 0.02 and abs(of_date.dec.deg) < 0.02
    # GCRS axes are those of J2000 (ICRF): the equinox of date has precessed ~0.37 deg.
    off_x_deg = _angle_deg(sun_km, np.array([1.0, 0.0, 0.0]))
    assert 0.1 < off_x_deg < 0.5


def test_sun_and_moon_agree_with_astropy_builtin(astropy_offline: None) -> None:
    rng = np.random.default_rng(20260320)
    days = rng.uniform(0.0, 50.0 * 365.25, 20)  # 2000..2050
    jd1, jd2 = 2451544.5 + np.floor(days), days - np.floor(days)
    when = Time(jd1, jd2, format="jd", scale="utc")
    ref = {
        b: get_body(b, when, ephemeris="builtin").cartesian.xyz.to_value(u.km).T
        for b in ("sun", "moon")
    }
    ours = [sun_moon_geocentric_km((a, b), 0.0) for a, b in zip(jd1, jd2, strict=True)]
    sun, moon = np.array([s for s, _ in ours]), np.array([m for _, m in ours])
    # astropy's are apparent (light time, aberration ~20"), ours geometric
    assert np.all(_angle_deg(sun, ref["sun"]) < 0.01)
    assert np.all(_angle_deg(moon, ref["moon"]) < 0.05)
    for mine, theirs in ((sun, ref["sun"]), (moon, ref["moon"])):
        d_mine, d_ref = np.linalg.norm(mine, axis=1), np.linalg.norm(theirs, axis=1)
        assert np.all(np.abs(d_mine / d_ref - 1.0) < 1e-3)
    au_km = np.linalg.norm(sun, axis=1) / 149_597_870.7
    assert np.all((au_km > 0.983) & (au_km < 1.017))  # perihelion .. aphelion


def test_moon_distance_over_a_year() -> None:
    t = np.arange(0.0, 365.25 * 86_400.0, 6 * 3600.0)
    _, moon = sun_moon_geocentric_km(parse_epoch_utc("2026-01-01T00:00:00Z"), t)
    d = np.linalg.norm(moon, axis=1)
    assert moon.shape == (t.size, 3)
    assert d.min() > 356_000.0 and d.max() < 407_000.0
    assert d.min() < 360_000.0 and d.max() > 404_000.0


# --- Two-body orbit ----------------------------------------------------------------------


def test_state_returns_after_one_period() -> None:
    r0, v0 = ELLIPSE.state_km(0.0)
    r1, v1 = ELLIPSE.state_km(ELLIPSE.period_s)
    assert np.allclose(r1, r0, rtol=0.0, atol=1e-6)
    assert np.allclose(v1, v0, rtol=0.0, atol=1e-9)
    # half a period later it is somewhere else (the check above can fail)
    assert np.linalg.norm(ELLIPSE.state_km(ELLIPSE.period_s / 2.0)[0] - r0) > 1000.0


def test_energy_and_angular_momentum_are_conserved() -> None:
    t = np.linspace(0.0, 3.0 * ELLIPSE.period_s, 100)
    r, v = ELLIPSE.state_km(t)
    a, e = ELLIPSE.semi_major_axis_km, ELLIPSE.eccentricity
    energy = 0.5 * np.sum(v * v, axis=1) - MU_EARTH_KM3_S2 / np.linalg.norm(r, axis=1)
    assert ELLIPSE.specific_energy_km2_s2 == pytest.approx(-MU_EARTH_KM3_S2 / (2.0 * a))
    assert np.allclose(energy, -MU_EARTH_KM3_S2 / (2.0 * a), rtol=1e-9, atol=0.0)
    h = np.cross(r, v)
    assert np.allclose(h, h[0], rtol=0.0, atol=1e-9 * np.linalg.norm(h[0]))
    assert np.linalg.norm(h[0]) == pytest.approx(math.sqrt(MU_EARTH_KM3_S2 * a * (1 - e * e)))
    # the orbit normal is at the inclination from the pole, the node at the RAAN
    n_hat = h[0] / np.linalg.norm(h[0])
    assert math.degrees(math.acos(n_hat[2])) == pytest.approx(ELLIPSE.inclination_deg)
    node_deg = math.degrees(math.atan2(n_hat[0], -n_hat[1]))
    assert node_deg == pytest.approx(ELLIPSE.raan_deg)


def test_initial_radius_follows_the_conic() -> None:
    r0, _ = ELLIPSE.state_km(0.0)
    a, e, nu = ELLIPSE.semi_major_axis_km, ELLIPSE.eccentricity, ELLIPSE.true_anomaly_deg
    expected = a * (1.0 - e * e) / (1.0 + e * math.cos(math.radians(nu)))
    assert np.linalg.norm(r0) == pytest.approx(expected, rel=1e-12)
    r_peri = Orbit(9000.0, 0.2, 51.6, 40.0, 250.0, 0.0).state_km(0.0)[0]
    assert np.linalg.norm(r_peri) == pytest.approx(9000.0 * 0.8, rel=1e-12)


def test_circular_equatorial_orbit_starts_on_x_moving_along_y() -> None:
    a = 7000.0
    r, v = Orbit(a, 0.0, 0.0, 0.0, 0.0, 0.0).state_km(0.0)
    assert np.allclose(r, [a, 0.0, 0.0], rtol=0.0, atol=1e-9)
    assert np.allclose(v, [0.0, math.sqrt(MU_EARTH_KM3_S2 / a), 0.0], rtol=0.0, atol=1e-12)


def test_sun_synchronous_500_km_period() -> None:
    a = 6378.137 + 500.0
    expected = 2.0 * math.pi * math.sqrt(a**3 / 398_600.4418)
    assert abs(LEO_500.period_s - expected) < 1.0
    assert abs(LEO_500.period_s - 5677.0) < 1.0


def test_orbit_problems_name_the_element() -> None:
    assert LEO_500.problem() is None and ELLIPSE.problem() is None
    low = Orbit(7000.0, 0.2, 0.0, 0.0, 0.0, 0.0).problem()  # perigee 5600 km from the centre
    assert low is not None and "perigee altitude" in low and "below the Earth's surface" in low
    assert "eccentricity" in str(Orbit(7000.0, 1.0, 0.0, 0.0, 0.0, 0.0).problem())
    assert "eccentricity" in str(Orbit(7000.0, -0.1, 0.0, 0.0, 0.0, 0.0).problem())
    assert "semi_major_axis_km" in str(Orbit(-7000.0, 0.0, 0.0, 0.0, 0.0, 0.0).problem())


# --- Directions from the spacecraft ------------------------------------------------------


def test_earth_from_500_km_nadir_radius_and_rate() -> None:
    d, radius = body_directions("earth", None, LEO_500, 0.0)
    r0, _ = LEO_500.state_km(0.0)
    assert np.allclose(d, -r0 / np.linalg.norm(r0), atol=1e-15)
    assert float(radius) == pytest.approx(math.asin(6378.137 / 6878.137), rel=1e-12)
    assert abs(math.degrees(float(radius)) - 68.0) < 0.05
    d2, _ = body_directions("earth", None, LEO_500, 1.0)
    rate_deg_s = float(_angle_deg(d, d2))  # over 1 s
    mean_motion_deg_s = math.degrees(math.sqrt(MU_EARTH_KM3_S2 / 6878.137**3))
    assert rate_deg_s == pytest.approx(mean_motion_deg_s, rel=1e-6)
    assert rate_deg_s == pytest.approx(0.0634, abs=5e-4)


def test_sun_and_moon_angular_radii() -> None:
    epoch = parse_epoch_utc(EQUINOX_2026)
    _, sun_radius = body_directions("sun", epoch, None, 0.0)
    _, moon_radius = body_directions("moon", epoch, LEO_500, 0.0)
    # both about a quarter of a degree (the Sun ~16', the Moon 14.7'..16.8' from Earth)
    assert 0.26 < math.degrees(float(sun_radius)) < 0.275
    assert 0.24 < math.degrees(float(moon_radius)) < 0.285
    assert SUN_RADIUS_KM > 100 * MOON_RADIUS_KM


def test_moon_parallax_from_low_orbit() -> None:
    epoch = parse_epoch_utc(EQUINOX_2026)
    t = np.arange(0.0, LEO_500.period_s, 30.0)
    from_sc, _ = body_directions("moon", epoch, LEO_500, t)
    geocentric, _ = body_directions("moon", epoch, None, t)
    parallax_deg = _angle_deg(from_sc, geocentric)
    _, moon = sun_moon_geocentric_km(epoch, t)
    bound_deg = np.degrees(np.arcsin(6878.137 / np.linalg.norm(moon, axis=1)))  # <= 1.11
    assert np.all(parallax_deg <= bound_deg + 1e-9)
    assert parallax_deg.max() > 0.3
    # the Sun's parallax from LEO is below 10 arcsec
    sun_sc, _ = body_directions("sun", epoch, LEO_500, t)
    sun_geo, _ = body_directions("sun", epoch, None, t)
    assert np.all(_angle_deg(sun_sc, sun_geo) < 10.0 / 3600.0)


def test_missing_inputs_are_named() -> None:
    with pytest.raises(ValueError, match="body 'earth' needs an orbit"):
        body_directions("earth", parse_epoch_utc(EQUINOX_2026), None, 0.0)
    with pytest.raises(ValueError, match="needs an epoch"):
        body_directions("moon", None, LEO_500, 0.0)
    with pytest.raises(ValueError, match="unknown body"):
        body_directions("mars", parse_epoch_utc(EQUINOX_2026), LEO_500, 0.0)


# --- Epochs ------------------------------------------------------------------------------


def test_accepted_epoch_forms_agree() -> None:
    ref = sum(parse_epoch_utc("2026-03-20T14:46:00Z"))
    for text in ("2026-03-20T14:46:00+00:00", "2026-03-20T14:46:00", "2026-03-20T16:46:00+02:00",
                 "2026-03-20T09:16:00-05:30", " 2026-03-20T14:46:00.000Z "):  # fmt: skip
        assert abs(sum(parse_epoch_utc(text)) - ref) < 1e-9, text
    later = sum(parse_epoch_utc("2026-03-20T14:46:00.250Z"))
    assert (later - ref) * 86_400.0 == pytest.approx(0.25, abs=1e-4)
    assert ref == pytest.approx(2461120.115277778, abs=1e-9)  # JD of 2026-03-20 14:46 UTC


def test_leap_second_is_accepted_and_counted() -> None:
    before = parse_epoch_utc("2016-12-31T23:59:59Z")
    leap = parse_epoch_utc("2016-12-31T23:59:60Z")
    after = parse_epoch_utc("2017-01-01T00:00:00Z")
    assert sum(before) < sum(leap) < sum(after)
    tt = [sum(erfa.taitt(*erfa.utctai(*jd))) for jd in (before, leap, after)]
    assert (tt[1] - tt[0]) * 86_400.0 == pytest.approx(1.0, abs=1e-4)
    assert (tt[2] - tt[0]) * 86_400.0 == pytest.approx(2.0, abs=1e-4)  # 2 s of TT, not 1


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("yesterday", "not an ISO 8601 date-time"),
        ("2026-13-01T00:00:00Z", "month"),
        ("2026-02-30T00:00:00Z", "day"),
        ("1800-01-01T00:00:00Z", "out of range 1900..2100"),
        ("2100-12-31T23:00:00-02:00", "year 2101 out of range"),
        ("0001-01-01T00:00:00+01:00", "out of range 1900..2100"),
        ("2016-12-30T23:59:60Z", "no leap second"),
    ],
)
def test_bad_epochs_say_why(text: str, reason: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", erfa.ErfaWarning)  # "time is after end of day"
        with pytest.raises(ValueError, match=reason):
            parse_epoch_utc(text)


def test_epochs_past_the_leap_second_table_load_silently_and_continuously() -> None:
    """From 2029 SOFA calls a year "dubious" (leap seconds not yet announced); the
    module holds UTC - TAI and says so in its docstring, not in a warning per call."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        epoch = parse_epoch_utc("2035-06-01T00:00:00Z")
        sun, moon = sun_moon_geocentric_km(epoch, np.array([0.0, 60.0]))
        body_directions("moon", epoch, LEO_500, np.array([0.0, 60.0]))
    # One minute apart: the Sun moves about 0.04 deg/h along the ecliptic, so the
    # held offset changes nothing discontinuous.
    assert _angle_deg(sun[0], sun[1]) == pytest.approx(0.04 / 60.0, rel=0.1)
    assert 356_000.0 < float(np.linalg.norm(moon[0])) < 407_000.0


# --- Vectorised calls --------------------------------------------------------------------


def test_vectorised_calls_equal_scalar_calls() -> None:
    epoch = parse_epoch_utc(EQUINOX_2026)
    t = np.array([0.0, 17.5, 600.0, 4000.0, 86_400.0 * 3.0])
    r, v = ELLIPSE.state_km(t)
    assert r.shape == v.shape == (t.size, 3)
    for i, ti in enumerate(t):
        ri, vi = ELLIPSE.state_km(float(ti))
        assert ri.shape == vi.shape == (3,)
        assert np.allclose(r[i], ri, rtol=0.0, atol=1e-9)
        assert np.allclose(v[i], vi, rtol=0.0, atol=1e-12)
    for body in ("sun", "moon", "earth"):
        d, radius = body_directions(body, epoch, LEO_500, t)
        assert d.shape == (t.size, 3) and radius.shape == (t.size,)
        for i, ti in enumerate(t):
            di, radius_i = body_directions(body, epoch, LEO_500, float(ti))
            assert di.shape == (3,) and np.ndim(radius_i) == 0
            assert np.allclose(d[i], di, rtol=0.0, atol=1e-12)
            assert float(radius_i) == pytest.approx(radius[i], rel=1e-12)
        assert np.allclose(np.linalg.norm(d, axis=1), 1.0, atol=1e-12)
