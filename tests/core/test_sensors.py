"""Sensor models: reproducibility, the star tracker's schedule and outages, and the noise
statistics of both sensors against their spec (SciPy's Rotation as the oracle)."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from attitude_core.models.quaternion import quat_conj, quat_from_rotvec, quat_mul, rotvec_from_quat
from attitude_core.models.sensor_spec import SensorSpec, star_tracker_due, star_tracker_sample_steps
from attitude_core.world.sensors import SensorSuite

ARCSEC = math.radians(1.0 / 3600.0)
DT = 0.1
SIGMA = np.array([0.3, -0.5, 0.6])  # ~150 deg: body and inertial axes far apart
OMEGA = np.array([0.01, -0.02, 0.015])


def spec(**overrides):
    values = dict(
        seed=7,
        star_tracker_noise_rad=(20 * ARCSEC, 20 * ARCSEC, 120 * ARCSEC),
        star_tracker_rate_hz=4.0,
        gyro_noise_rad_s=1e-4,
        gyro_bias_rad_s=(2e-4, -1e-4, 3e-4),
        gyro_bias_walk_rad_s2=1e-6,
    )
    values.update(overrides)
    return SensorSpec(**values)


def run(s, n, sigma=SIGMA, omega=OMEGA):
    suite = SensorSuite(s, DT)
    return [suite.measure(k * DT, sigma, omega) for k in range(n)]


def sample_times(ms):
    return [round(m.t_s, 9) for m in ms if m.star_tracker_quat is not None]


def test_quaternion_helpers_match_scipy():
    rots = Rotation.random(50, random_state=3)
    for p, q in zip(rots[:25], rots[25:], strict=True):
        composed = Rotation.from_quat(quat_mul(p.as_quat(), q.as_quat()))
        assert (composed.inv() * (p * q)).magnitude() < 1e-12
        assert (Rotation.from_quat(quat_conj(p.as_quat())) * p).magnitude() < 1e-12
        v = p.as_rotvec()
        np.testing.assert_allclose(quat_from_rotvec(v), p.as_quat(canonical=True), atol=1e-12)
        np.testing.assert_allclose(rotvec_from_quat(p.as_quat()), v, atol=1e-12)
        np.testing.assert_allclose(rotvec_from_quat(-p.as_quat()), v, atol=1e-12)
    tiny = np.array([1e-9, -2e-9, 3e-10])
    np.testing.assert_allclose(rotvec_from_quat(quat_from_rotvec(tiny)), tiny, rtol=1e-9)


def test_reproducible_from_the_seed():
    a, b, c = run(spec(), 60), run(spec(), 60), run(spec(seed=8), 60)
    for ma, mb in zip(a, b, strict=True):
        np.testing.assert_array_equal(ma.gyro_rad_s, mb.gyro_rad_s)
        assert (ma.star_tracker_quat is None) == (mb.star_tracker_quat is None)
        if ma.star_tracker_quat is not None:
            np.testing.assert_array_equal(ma.star_tracker_quat, mb.star_tracker_quat)
    assert all(
        not np.array_equal(ma.gyro_rad_s, mc.gyro_rad_s) for ma, mc in zip(a, c, strict=True)
    )
    quats = [(ma.star_tracker_quat, mc.star_tracker_quat) for ma, mc in zip(a, c, strict=True)]
    assert all(not np.array_equal(qa, qc) for qa, qc in quats if qa is not None)


def test_star_tracker_schedule_4hz_at_0p1s():
    ms = run(spec(), 21)
    assert sample_times(ms) == [0.0, 0.3, 0.5, 0.8, 1.0, 1.3, 1.5, 1.8, 2.0]
    assert star_tracker_sample_steps(4.0, DT, 21).tolist() == [0, 3, 5, 8, 10, 13, 15, 18, 20]
    assert [k for k in range(21) if star_tracker_due(k * DT, 4.0, DT)] == [
        0, 3, 5, 8, 10, 13, 15, 18, 20
    ]  # fmt: skip
    # The count over a long run is the rate's: 4 per second.
    assert star_tracker_sample_steps(4.0, DT, 10_000).size == 4 * 1000


@pytest.mark.parametrize("rate_hz", [10.0, 25.0])
def test_star_tracker_at_or_above_the_step_rate_samples_every_step(rate_hz):
    ms = run(spec(star_tracker_rate_hz=rate_hz), 50)
    assert all(m.star_tracker_quat is not None for m in ms)
    assert star_tracker_sample_steps(rate_hz, DT, 50).tolist() == list(range(50))


def test_outage_windows_have_no_sample():
    ms = run(spec(star_tracker_outages_s=((1.0, 2.0), (2.9, 3.05))), 41)
    times = sample_times(ms)
    assert times == [0.0, 0.3, 0.5, 0.8, 2.0, 2.3, 2.5, 2.8, 3.3, 3.5, 3.8, 4.0]
    assert all(not (1.0 <= t < 2.0 or 2.9 <= t < 3.05) for t in times)
    # An outage from t = 0: no sample until the first period that starts after it.
    assert sample_times(run(spec(star_tracker_outages_s=((0.0, 0.4),)), 11))[:2] == [0.5, 0.8]


def test_star_tracker_error_is_a_body_frame_rotation_with_the_declared_sigmas():
    n = 6000
    noise = np.array([20.0, 20.0, 120.0]) * ARCSEC
    ms = run(
        spec(star_tracker_rate_hz=10.0, star_tracker_noise_rad=tuple(noise)), n, omega=0 * OMEGA
    )
    truth = Rotation.from_mrp(SIGMA)
    q = np.array([m.star_tracker_quat for m in ms])
    assert np.all(q[:, 3] >= 0.0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-14)
    delta = (truth.inv() * Rotation.from_quat(q)).as_rotvec()  # body axes
    std = delta.std(axis=0)
    # 6000 samples: the std's relative sampling error is 1/sqrt(2n) ~ 0.9 %.
    np.testing.assert_allclose(std, noise, rtol=0.05)
    assert np.all(np.abs(delta.mean(axis=0)) < 4 * noise / math.sqrt(n))
    corr = np.corrcoef(delta.T)
    assert np.all(np.abs(corr[np.triu_indices(3, 1)]) < 0.05)
    # In inertial axes the error is the body error rotated by C_NB: the boresight's large
    # error moves to the inertial axes along body z (not what an inertial draw would give).
    inertial = (Rotation.from_quat(q) * truth.inv()).as_rotvec()
    c_nb = truth.as_matrix()
    expected = np.sqrt(c_nb**2 @ noise**2)
    assert np.max(np.abs(expected / noise - 1.0)) > 1.0
    np.testing.assert_allclose(inertial.std(axis=0), expected, rtol=0.05)


def test_gyro_mean_offset_is_the_bias_and_spread_the_noise():
    n = 5000
    ms = run(spec(gyro_bias_walk_rad_s2=0.0), n)
    err = np.array([m.gyro_rad_s for m in ms]) - OMEGA
    np.testing.assert_allclose(err.mean(axis=0), [2e-4, -1e-4, 3e-4], atol=4 * 1e-4 / math.sqrt(n))
    np.testing.assert_allclose(err.std(axis=0), 1e-4, rtol=0.05)
    # Consecutive samples are independent (white noise).
    assert abs(np.corrcoef(err[:-1, 0], err[1:, 0])[0, 1]) < 0.05


def test_zero_gyro_noise_gives_rate_plus_bias():
    suite = SensorSuite(spec(gyro_noise_rad_s=0.0), DT)
    for k in range(20):
        bias = suite.bias_rad_s  # the bias this sample carries
        m = suite.measure(k * DT, SIGMA, OMEGA)
        np.testing.assert_allclose(m.gyro_rad_s, OMEGA + bias, atol=1e-18)
        assert not np.array_equal(suite.bias_rad_s, bias)  # walked for the next sample


def test_bias_random_walk_variance_grows_like_sigma_u_squared_t():
    sigma_u, seeds, n = 1e-5, 200, 500
    drift = np.empty((seeds, n, 3))
    for seed in range(seeds):
        suite = SensorSuite(spec(seed=seed, gyro_bias_walk_rad_s2=sigma_u), DT)
        b0 = suite.bias_rad_s
        for k in range(n):
            suite.measure(k * DT, SIGMA, OMEGA)
            drift[seed, k] = suite.bias_rad_s - b0  # after k + 1 walk steps
    for k in (9, 99, 499):
        t = (k + 1) * DT
        var = float(np.mean(drift[:, k] ** 2))  # zero-mean walk, 600 walks
        # relative sampling error of the variance sqrt(2/600) ~ 6 %: 4 sigma
        assert var == pytest.approx(sigma_u**2 * t, rel=0.25), (t, var)
    # and the growth is linear: increments over disjoint spans are independent
    late = drift[:, 499] - drift[:, 249]
    assert abs(np.corrcoef(late.ravel(), drift[:, 249].ravel())[0, 1]) < 0.15


def test_measure_needs_increasing_time():
    suite = SensorSuite(spec(), DT)
    suite.measure(0.0, SIGMA, OMEGA)
    with pytest.raises(ValueError, match="increase"):
        suite.measure(0.0, SIGMA, OMEGA)


def test_spec_problems_name_the_field():
    assert spec().problem() is None
    assert spec(gyro_noise_rad_s=0.0, gyro_bias_walk_rad_s2=0.0).problem() is None
    assert spec(seed=np.int64(3), star_tracker_rate_hz=np.float64(2.0)).problem() is None
    bad = {
        "seed": dict(seed=-1),
        "star_tracker_noise_rad": dict(star_tracker_noise_rad=(1e-4, 0.0, 1e-4)),
        "star_tracker_rate_hz": dict(star_tracker_rate_hz=0.0),
        "gyro_noise_rad_s": dict(gyro_noise_rad_s=-1e-4),
        "gyro_bias_rad_s": dict(gyro_bias_rad_s=(0.0, math.nan, 0.0)),
        "gyro_bias_walk_rad_s2": dict(gyro_bias_walk_rad_s2=-1.0),
        "gyro_bias_prior_rad_s": dict(gyro_bias_prior_rad_s=0.0),
        "star_tracker_outages_s[1]": dict(star_tracker_outages_s=((1.0, 2.0), (3.0, 3.0))),
    }
    for field, overrides in bad.items():
        message = spec(**overrides).problem()
        assert message is not None and message.startswith(field + ":"), (field, message)
    assert "every element must be > 0" in spec(**bad["star_tracker_noise_rad"]).problem()
    assert spec(star_tracker_rate_hz="4").problem().startswith("star_tracker_rate_hz:")
    with pytest.raises(ValueError, match="star_tracker_rate_hz"):
        SensorSuite(spec(star_tracker_rate_hz=-1.0), DT)
