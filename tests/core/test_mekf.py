"""The MEKF: its algebra against SciPy, and its statistics on simulated sensors.

The truth is a body turning at a constant rate, propagated exactly with SciPy
(``C_NB(t) = C_NB(0) exp([omega x] t)``); the sensors are :class:`SensorSuite`'s. Every
statistical check runs fixed seeds, so it is deterministic; the bounds are the ones the
statistics would have, with the sample correlation taken into account (see
``test_nees_is_chi_square_consistent``).
"""

import copy
import math
from dataclasses import dataclass

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from attitude_core.fsw.estimation.mekf import (
    Estimate,
    Mekf,
    MekfConfig,
    attitude_error_rad,
    nees,
    process_noise,
    steady_state_covariance,
    transition_matrix,
)
from attitude_core.models.mrp import skew
from attitude_core.models.quaternion import quat_from_rotvec, quat_mul
from attitude_core.models.sensor_spec import SensorSpec
from attitude_core.world.sensors import SensorSuite

ARCSEC = math.radians(1.0 / 3600.0)
DT = 0.1
OMEGA = (0.01, -0.02, 0.015)
R0 = Rotation.from_rotvec([0.4, -0.3, 1.0])


def spec(**overrides):
    values = dict(
        seed=0,
        star_tracker_noise_rad=(20 * ARCSEC, 20 * ARCSEC, 120 * ARCSEC),
        star_tracker_rate_hz=4.0,
        gyro_noise_rad_s=1e-4,
        gyro_bias_rad_s=(2e-4, -1e-4, 3e-4),
        gyro_bias_walk_rad_s2=1e-6,
    )
    values.update(overrides)
    return SensorSpec(**values)


@dataclass(repr=False)
class Run:
    t: np.ndarray
    truth: Rotation
    estimates: list
    bias: np.ndarray  # (n, 3) the true bias each gyro sample carried
    tracker: list  # the raw star tracker samples (None between them)
    pre_update: list  # (t, P) the covariance just before the update, from pre_from on

    def attitude_errors(self, start_s=0.0):
        """Body-axes rotation vectors from the estimate to the truth (SciPy)."""
        ks = np.flatnonzero(self.t >= start_s)
        q = np.array([self.estimates[k].quat for k in ks])
        return (Rotation.from_quat(q).inv() * self.truth[ks]).as_rotvec()

    def __repr__(self):  # a failing test's report stays short (no 6000 estimates)
        return f"Run({self.t.size} steps to t = {self.t[-1]:.1f} s)"

    def three_sigma_deg(self):
        return np.array([e.attitude_3sigma_deg for e in self.estimates])


def simulate(s, duration_s, omega=OMEGA, pre_from=None):
    n = round(duration_s / DT) + 1
    t = np.arange(n) * DT
    truth = R0 * Rotation.from_rotvec(np.outer(t, omega))
    sigma = truth.as_mrp()
    suite = SensorSuite(s, DT)
    f = Mekf(MekfConfig.from_spec(s, DT))
    estimates, bias, tracker, pre = [], [], [], []
    for k in range(n):
        bias.append(suite.bias_rad_s)
        m = suite.measure(t[k], sigma[k], omega)
        if pre_from is not None and t[k] >= pre_from - 1e-9 and m.star_tracker_quat is not None:
            pre.append((t[k], copy.deepcopy(f).step(t[k], m.gyro_rad_s).covariance))
        estimates.append(f.step(t[k], m.gyro_rad_s, m.star_tracker_quat))
        tracker.append(m.star_tracker_quat)
    return Run(t, truth, estimates, np.array(bias), tracker, pre)


def worst_phase(pre):
    return max((p for _, p in pre), key=lambda p: np.trace(p[:3, :3]))


# --- algebra ---------------------------------------------------------------------------


def test_quaternion_product_matches_scipy_composition():
    rots = Rotation.random(40, random_state=11)
    for p, q in zip(rots[:20], rots[20:], strict=True):
        expected = (p * q).as_quat(canonical=True)
        got = np.array(quat_mul(p.as_quat(), q.as_quat()))
        np.testing.assert_allclose(got * np.sign(got[3]), expected, atol=1e-14)
    # body-rate propagation q (x) dq(omega dt) is SciPy's R * exp(omega dt)
    q0, w = R0.as_quat(), np.array(OMEGA)
    np.testing.assert_allclose(
        quat_mul(q0, quat_from_rotvec(w * 7.0)), (R0 * Rotation.from_rotvec(w * 7.0)).as_quat()
    )


@pytest.mark.parametrize(
    "omega", [(0.0, 0.0, 0.0), (1e-7, -2e-7, 5e-8), (0.01, -0.02, 0.015), (0.3, -0.2, 0.5)]
)
@pytest.mark.parametrize("dt", [0.1, 0.7])
def test_transition_matrix_is_the_exact_exponential(omega, dt):
    f = np.zeros((6, 6))
    f[:3, :3] = -skew(omega)
    f[:3, 3:] = -np.eye(3)
    np.testing.assert_allclose(transition_matrix(omega, dt), expm(f * dt), rtol=0, atol=1e-14)


def test_process_noise_is_van_loan_at_zero_rate():
    cfg = MekfConfig(DT, (1e-4, 1e-4, 1e-4), 1e-4, 3e-5, 1e-3)
    sv2, su2, dt = cfg.gyro_noise_rad_s**2 * DT, cfg.gyro_bias_walk_rad_s2**2, 0.35
    f = np.zeros((6, 6))
    f[:3, 3:] = -np.eye(3)
    gqg = np.diag([sv2] * 3 + [su2] * 3)
    b = expm(np.block([[-f, gqg], [np.zeros((6, 6)), f.T]]) * dt)
    qd = b[6:, 6:].T @ b[:6, 6:]
    np.testing.assert_allclose(process_noise(cfg, dt), qd, rtol=1e-10, atol=1e-22)


def test_none_until_the_first_star_tracker_sample_which_initialises_it():
    s = spec(star_tracker_outages_s=((0.0, 1.0),))
    cfg = MekfConfig.from_spec(s, DT)
    f = Mekf(cfg)
    suite = SensorSuite(s, DT)
    sigma = R0.as_mrp()
    for k in range(10):
        m = suite.measure(k * DT, sigma, (0.0, 0.0, 0.0))
        assert m.star_tracker_quat is None and f.step(k * DT, m.gyro_rad_s, None) is None
    assert not f.initialized
    m = suite.measure(1.0, sigma, (0.0, 0.0, 0.0))
    e = f.step(1.0, m.gyro_rad_s, m.star_tracker_quat)
    assert f.initialized and e is not None and e.t_s == 1.0
    np.testing.assert_allclose(e.quat, m.star_tracker_quat, atol=1e-15)
    np.testing.assert_allclose(Rotation.from_mrp(e.sigma_bn).as_quat(), e.quat, atol=1e-14)
    assert np.linalg.norm(e.sigma_bn) <= 1.0 and e.quat[3] >= 0.0
    np.testing.assert_array_equal(e.bias_rad_s, 0.0)
    np.testing.assert_array_equal(e.omega_b, m.gyro_rad_s)
    expected = np.diag(list(np.square(s.star_tracker_noise_rad)) + [1e-6] * 3)
    np.testing.assert_allclose(e.covariance, expected, rtol=1e-15)
    assert e.attitude_3sigma_deg == pytest.approx(
        3 * math.degrees(math.sqrt(np.sum(np.square(s.star_tracker_noise_rad))))
    )


def test_noise_free_propagation_is_exact_at_irregular_intervals():
    cfg = MekfConfig(DT, (1e-4, 1e-4, 1e-4), 0.0, 0.0, 1e-3)
    f = Mekf(cfg)
    w = np.array([0.05, -0.1, 0.08])
    f.step(0.0, w, R0.as_quat())
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.01, 0.5, 200))
    for tk in t:
        e = f.step(tk, w)
        truth = R0 * Rotation.from_rotvec(w * tk)
        assert attitude_error_rad(e.sigma_bn, truth.as_mrp()) < 1e-12
        np.testing.assert_array_equal(e.omega_b, w)
    # no process noise: the covariance is P0 carried by the one-shot exact Phi(t)
    f_cont = np.zeros((6, 6))
    f_cont[:3, :3] = -skew(w)
    f_cont[:3, 3:] = -np.eye(3)
    phi = expm(f_cont * t[-1])
    expected = phi @ np.diag([1e-8] * 3 + [1e-6] * 3) @ phi.T
    np.testing.assert_allclose(e.covariance, expected, rtol=1e-9, atol=1e-9 * expected.max())


def test_step_needs_increasing_time():
    f = Mekf(MekfConfig.from_spec(spec(), DT))
    f.step(0.0, (0.0, 0.0, 0.0), R0.as_quat())
    with pytest.raises(ValueError, match="increase"):
        f.step(0.0, (0.0, 0.0, 0.0))


def test_nees_and_attitude_error_against_scipy():
    rng = np.random.default_rng(2)
    a = rng.normal(size=(6, 6))
    p = a @ a.T * 1e-8 + np.eye(6) * 1e-9
    est_rot = Rotation.from_rotvec([0.3, 1.0, -2.0])
    truth = est_rot * Rotation.from_rotvec([1e-4, -3e-4, 2e-4])  # body-frame error
    est = Estimate(
        t_s=0.0,
        sigma_bn=est_rot.as_mrp(),
        quat=est_rot.as_quat(canonical=True),
        omega_b=np.zeros(3),
        bias_rad_s=np.array([1e-4, 0.0, -1e-4]),
        covariance=p,
    )
    bias_true = np.array([1.5e-4, -2e-5, -1e-4])
    e = np.concatenate([[1e-4, -3e-4, 2e-4], bias_true - est.bias_rad_s])
    assert nees(est, truth.as_mrp(), bias_true) == pytest.approx(e @ np.linalg.inv(p) @ e)
    assert attitude_error_rad(est.sigma_bn, truth.as_mrp()) == pytest.approx(
        (est_rot.inv() * truth).magnitude(), rel=1e-9
    )


# --- statistics --------------------------------------------------------------------------

NEES_SEEDS = range(10)
NEES_FROM_S, NEES_EVERY = 100.0, 500  # after convergence; one sample per 50 s


@pytest.fixture(scope="module")
def turning_runs():
    """(a): 600 s on the turning body, star tracker (20, 20, 120) arcsec at 4 Hz."""
    return [simulate(spec(seed=seed), 600.0, pre_from=599.0) for seed in NEES_SEEDS]


def test_nees_is_chi_square_consistent(turning_runs):
    """Mean NEES within the two-sided 95 % chi-square bounds of 6 N dof over N.

    NEES samples of one run are correlated: the bias error's correlation time is about
    ``2 sigma_b^2 / sigma_u^2`` ~ 70 s, and the NEES autocorrelation measured on these
    runs is 0.43 at 5 s, 0.15 at 20 s, 0.05 at 50 s. So one sample per 50 s after 100 s
    (11 per run) over 10 seeded runs: N = 110 nearly independent samples. (Every 50th
    step, 5 s apart, would count correlated samples as independent and make the bounds
    too narrow for the spread of the mean.)
    """
    samples = []
    for run in turning_runs:
        sigma = run.truth.as_mrp()
        for k in np.flatnonzero(run.t >= NEES_FROM_S)[::NEES_EVERY]:
            samples.append(nees(run.estimates[k], sigma[k], run.bias[k]))
    n = len(samples)
    assert n == 110
    lo, hi = chi2.ppf([0.025, 0.975], 6 * n) / n
    assert lo < np.mean(samples) < hi, (np.mean(samples), lo, hi)


def test_attitude_error_is_unbiased_and_matches_the_covariance(turning_runs):
    errors = np.concatenate([run.attitude_errors(NEES_FROM_S) for run in turning_runs])
    mean, std = errors.mean(axis=0), errors.std(axis=0)
    # ~50 000 correlated samples (a few thousand independent): the mean's standard error
    # is a few hundredths of the std
    assert np.all(np.abs(mean) < 0.1 * std), (mean / ARCSEC, std / ARCSEC)
    p = np.concatenate(
        [[e.covariance[[0, 1, 2], [0, 1, 2]] for e in r.estimates[1000:]] for r in turning_runs]
    )
    np.testing.assert_allclose(std, np.sqrt(p.mean(axis=0)), rtol=0.1)
    assert std[2] > 2.0 * max(std[0], std[1])  # the boresight's worse error shows through


def test_converges_from_a_wrong_initial_bias():
    """(b) The filter starts at b = 0 against a bias of ~1.7e-3 rad/s (1.7 prior sigma)."""
    true_bias = np.array([8e-4, -1.2e-3, 1e-3])
    z = []
    for seed in range(5):
        run = simulate(spec(seed=seed, gyro_bias_rad_s=tuple(true_bias)), 60.0)
        est = run.estimates[-1]
        err = run.bias[-1] - est.bias_rad_s
        sd = np.sqrt(np.diag(est.covariance)[3:])
        assert np.all(np.abs(err) < 3.0 * sd), (seed, err / sd)
        assert np.linalg.norm(err) < 0.02 * np.linalg.norm(true_bias)
        assert np.all(sd < 0.02 * 1e-3)  # the filter knows it: 50x below the prior
        z.extend(err / sd)
    assert 0.5 < np.sqrt(np.mean(np.square(z))) < 1.6  # normalised error ~ N(0, 1)


def test_star_tracker_outage():
    """(c) 5 s without the tracker from t = 300 s."""
    run = simulate(spec(seed=4, star_tracker_outages_s=((300.0, 305.0),)), 320.0)
    s3 = run.three_sigma_deg()
    angle = np.degrees(np.linalg.norm(run.attitude_errors(), axis=1))
    out = np.flatnonzero((run.t >= 300.0) & (run.t < 305.0))
    assert all(run.tracker[k] is None for k in out)
    growing = s3[out[0] - 1 : out[-1] + 1]  # from the last pre-outage step
    assert np.all(np.diff(growing) > 0.0)
    assert np.all(angle[out] <= s3[out])
    sd = np.array([np.sqrt(np.diag(e.covariance)[:3]) for e in run.estimates])

    def cycle_max(values, end_s):  # over one 0.5 s sampling cycle: the same phases
        return values[(run.t >= end_s - 0.5 - 1e-9) & (run.t < end_s + 1e-9)].max(axis=0)

    before = cycle_max(s3, 299.0)
    peak = s3[out[-1]]
    assert peak > 1.4 * before  # the gyro alone for 5 s
    # 2 s after: the well-observed axes x, y are back (1.07x), the boresight z (its steady
    # state averages many poor samples) is still recovering (1.2x); 5 s after, all are.
    assert np.all(cycle_max(sd, 307.0)[:2] < 1.1 * cycle_max(sd, 299.0)[:2])
    assert cycle_max(s3, 307.0) < 1.25 * before
    assert np.all(cycle_max(sd, 310.0) < 1.1 * cycle_max(sd, 299.0))
    assert np.all(angle <= s3)


def test_steady_state_covariance_at_zero_rate_is_the_filters():
    """(d) The recursion alone against the running filter's pre-update covariance."""
    s = spec(seed=1)
    run = simulate(s, 300.0, omega=(0.0, 0.0, 0.0), pre_from=299.0)
    p_filter = worst_phase(run.pre_update)
    p_ss = steady_state_covariance(MekfConfig.from_spec(s, DT), s.star_tracker_rate_hz)
    scale = np.sqrt(np.outer(np.diag(p_ss), np.diag(p_ss)))
    assert np.max(np.abs(p_filter - p_ss) / scale) < 1e-3
    # the worst phase is the sample after the 0.3 s gap, not the 0.2 s one
    assert np.trace(p_ss[:3, :3]) > 1.01 * min(np.trace(p[:3, :3]) for _, p in run.pre_update)


def test_steady_state_covariance_on_a_turning_body(turning_runs):
    """(d) On the turning body the axes mix; the worst-phase traces still agree."""
    p_ss = steady_state_covariance(MekfConfig.from_spec(spec(), DT), 4.0)
    for run in turning_runs:
        assert [round(t, 6) for t, _ in run.pre_update] == [599.0, 599.3, 599.5, 599.8, 600.0]
        p_filter = worst_phase(run.pre_update)
        for block in (slice(0, 3), slice(3, 6)):
            assert np.trace(p_filter[block, block]) == pytest.approx(
                np.trace(p_ss[block, block]), rel=0.05
            )


def test_far_better_than_the_raw_star_tracker():
    """(e) A coarse tracker (0.3 deg per axis at 2 Hz) with a good gyro."""
    s = spec(
        seed=2,
        star_tracker_noise_rad=(math.radians(0.3),) * 3,
        star_tracker_rate_hz=2.0,
        gyro_noise_rad_s=1e-5,
        gyro_bias_walk_rad_s2=1e-7,
    )
    run = simulate(s, 600.0)
    ks = np.flatnonzero(run.t >= 100.0)
    est_rms = np.sqrt(np.mean(np.sum(run.attitude_errors(100.0) ** 2, axis=1)))
    raw = [(k, q) for k, q in zip(ks, (run.tracker[k] for k in ks), strict=True) if q is not None]
    raw_err = Rotation.from_quat([q for _, q in raw]).inv() * run.truth[[k for k, _ in raw]]
    raw_rms = np.sqrt(np.mean(raw_err.magnitude() ** 2))
    assert raw_rms == pytest.approx(math.radians(0.3) * math.sqrt(3), rel=0.05)
    # at least 2x better is the requirement; the filter's own covariance predicts ~14x
    # (0.038 deg RMS). One 500 s run holds few independent attitude errors at this gain,
    # so the run's RMS scatters by ~20 % about the prediction: 5x is the safe bound.
    predicted = np.sqrt(np.mean([np.trace(run.estimates[k].covariance[:3, :3]) for k in ks]))
    assert raw_rms / predicted > 10.0
    assert est_rms < raw_rms / 5.0, (math.degrees(est_rms), math.degrees(raw_rms))


def test_a_declared_star_tracker_noise_weights_the_update():
    """The noise a tracker declares with its sample (the estimator node) replaces the
    configured one: a larger one moves the estimate less towards the same measurement."""
    from attitude_core.fsw.estimation.mekf import Mekf, MekfConfig

    cfg = MekfConfig(0.1, (1e-4, 1e-4, 1e-4), 1e-5, 0.0, 1e-4)
    q0 = np.array([0.0, 0.0, 0.0, 1.0])
    q1 = Rotation.from_rotvec([2e-4, 0.0, 0.0]).as_quat()
    moved = []
    for noise in (None, (1e-2, 1e-2, 1e-2)):
        f = Mekf(cfg)
        f.step(0.0, np.zeros(3), q0)
        if noise is not None:
            f.set_star_tracker_noise(noise)
        est = f.step(0.1, np.zeros(3), q1)
        moved.append(Rotation.from_quat(est.quat).as_rotvec()[0])
    assert moved[0] > 10 * moved[1] > 0.0
    with pytest.raises(ValueError, match="3 values > 0"):
        Mekf(cfg).set_star_tracker_noise((1e-4, 0.0, 1e-4))
