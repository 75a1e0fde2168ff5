"""The offline loop flown on an estimate (``sensors.*``): the guidance and the controller
see the MEKF's estimate only, and the true body is what is judged.

Each case is a scenario of ``scenarios/`` with sensors added (good and coarse star
trackers, gyro noise, bias and bias walk, with and without actuator limits, one and two
instruments). Judged on the true state the loop records: the body never violates
(dense margin), arrives within the true tolerances, the guidance declares it, and the
final error is within the bound the sensor noise allows; the loop was fed the estimate
(it differs from the truth by about the filter's error, never by nothing).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from attitude_core.assembly.guidance import guidance_from_scenario, prepare_guidance
from attitude_core.config.scenario import ScenarioError
from attitude_core.config.scenario_loader import load_scenario, parse_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import principal_angle, relative
from attitude_core.record.metrics import dense_min_margin_deg
from attitude_core.record.summary import summarize
from attitude_core.world.rigid_body import RigidBody

ROOT = Path(__file__).resolve().parents[2]
SCENARIOS = ROOT / "scenarios"

GOOD = {
    "seed": 3,
    "star_tracker": {"noise_arcsec": [30.0, 6.0, 6.0], "rate_hz": 4.0},
    "gyro": {"noise_rad_s": 1.0e-4, "bias_rad_s": [2.0e-4, -3.0e-4, 1.0e-4]},
}
COARSE = {
    "seed": 5,
    "star_tracker": {"noise_arcsec": [1080.0, 360.0, 360.0], "rate_hz": 2.0},
    "gyro": {
        "noise_rad_s": 3.0e-4,
        "bias_rad_s": [1.0e-3, -5.0e-4, 7.0e-4],
        "bias_walk_rad_s2": 3.0e-6,
        "bias_prior_rad_s": 2.0e-3,
    },
}
FAST_TRACKER = {  # every step, a poor gyro with a large drifting bias
    "seed": 9,
    "star_tracker": {"noise_arcsec": [60.0, 60.0, 60.0], "rate_hz": 10.0},
    "gyro": {"noise_rad_s": 5.0e-4, "bias_rad_s": [-2.0e-3, 1.0e-3, 1.5e-3],
             "bias_walk_rad_s2": 1.0e-5, "bias_prior_rad_s": 3.0e-3},
}  # fmt: skip

CASES = [
    ("case1", GOOD),
    ("case1", COARSE),
    ("case1_wheels", GOOD),
    ("case1_wheels", COARSE),
    ("case2_wheels", FAST_TRACKER),
    ("two_instruments", COARSE),
    ("four_objects", FAST_TRACKER),
]


def _params(name: str) -> dict:
    doc = yaml.safe_load((SCENARIOS / f"{name}.yaml").read_text())
    return doc["/**"]["ros__parameters"]


def _with_sensors(name: str, sensors: dict):
    params = _params(name)
    params["sensors"] = sensors
    return parse_scenario(params, f"{name}+sensors", SCENARIOS)


@pytest.fixture(scope="module", params=CASES, ids=lambda c: f"{c[0]}-seed{c[1]['seed']}")
def flown(request):
    name, sensors = request.param
    sc = _with_sensors(name, sensors)
    run = run_closed_loop(sc)
    return sc, run, summarize(run).to_json()


def test_the_loop_was_fed_the_estimate_not_the_truth(flown):
    sc, run, _ = flown
    est = run.estimate
    assert est is not None and np.isfinite(est.sigma_bn).all()
    err = np.degrees(principal_angle(relative(est.sigma_bn, run.sigma_bn)))
    # never the truth itself, and about as far from it as the filter says
    assert np.median(err) > 1e-3 * sc.knowledge.attitude_3sigma_deg
    assert np.percentile(err, 50) < sc.knowledge.attitude_3sigma_deg
    rate_err = np.linalg.norm(est.omega_b - run.omega_b, axis=1)
    assert np.median(rate_err) > 0.0


def test_the_true_body_never_violates_and_arrives(flown):
    sc, run, summary = flown
    margin, _ = dense_min_margin_deg(sc.sky, run.t, run.sigma_bn, run.omega_b)
    assert margin > 0.0
    assert summary["min_margin_deg"] == pytest.approx(margin)
    assert summary["reached"], summary
    assert not summary["planner_stuck"]


def test_the_guidance_declares_the_arrival_and_keeps_it(flown):
    _, run, summary = flown
    arrived = np.flatnonzero(run.planner_status == PlannerStatus.ARRIVED.code)
    assert len(arrived), "never declared arrived"
    assert summary["t_plan_arrival_s"] is not None
    # no flapping on noise: once declared, the arrival holds to the end
    assert (run.planner_status[arrived[0] :] == PlannerStatus.ARRIVED.code).all()


def test_the_final_error_is_within_the_bound_the_noise_allows(flown):
    sc, run, summary = flown
    tol = sc.true_arrival
    assert summary["final_attitude_error_deg"] <= tol.attitude_tol_deg
    assert summary["final_rate_rad_s"] <= tol.rate_tol_rad_s
    # and the guidance's (on the estimate) is no tighter than the knowledge
    assert sc.guidance_arrival.attitude_tol_deg >= sc.knowledge.attitude_3sigma_deg


def test_the_start_is_held_while_the_filter_settles(flown):
    sc, run, _ = flown
    settle = sc.knowledge.settle_s
    assert settle > 0.0
    before = run.t < settle
    start = run.sigma_t[0]
    # the guidance starts from the first estimate (as the planner node from its first state)
    np.testing.assert_allclose(start, run.estimate.sigma_bn[0], atol=1e-12)
    moved = np.degrees(principal_angle(relative(run.sigma_t[before], start)))
    assert moved.max() < 1e-9  # the target holds the start
    after = np.degrees(principal_angle(relative(run.sigma_t[~before], start)))
    assert after.max() > 1.0  # then the slew goes


def test_the_summary_reports_the_estimate(flown):
    sc, run, summary = flown
    assert summary["knowledge_3sigma_deg"] == pytest.approx(sc.knowledge.attitude_3sigma_deg)
    e = summary["estimation_error_deg"]
    assert 0.0 < e["median"] <= e["p99"] <= e["max"]
    # the filter is consistent: the mean NEES (6 states) near 6, most steps in the 95 % band
    assert 2.0 < summary["filter_nees_mean"] < 15.0
    assert summary["filter_nees_in_95pct"] > 0.75


def test_the_buffer_holds_the_knowledge():
    """The planner's buffer is the declared margin plus the settled 3-sigma."""
    from attitude_core.assembly.guidance import buffer_deg

    plain = load_scenario(SCENARIOS / "case1.yaml")
    sensed = _with_sensors("case1", COARSE)
    k = sensed.knowledge.attitude_3sigma_deg
    assert k > 0.1
    assert buffer_deg(sensed, sensed.initial_mrp) == pytest.approx(
        buffer_deg(plain, plain.initial_mrp) + k
    )


def test_runs_are_reproducible_from_the_seed():
    sc = _with_sensors("case1", GOOD)
    a, b = run_closed_loop(sc), run_closed_loop(sc)
    np.testing.assert_array_equal(a.sigma_bn, b.sigma_bn)
    np.testing.assert_array_equal(a.estimate.sigma_bn, b.estimate.sigma_bn)
    other = _with_sensors("case1", {**GOOD, "seed": GOOD["seed"] + 1})
    c = run_closed_loop(other)
    assert not np.array_equal(a.estimate.sigma_bn, c.estimate.sigma_bn)


def test_sensor_keys_are_validated():
    with pytest.raises(ScenarioError, match=r"sensors\.star_tracker\.rate_hz.*missing"):
        _with_sensors("case1", {"seed": 1, "star_tracker": {"noise_arcsec": [1.0, 1.0, 1.0]},
                                "gyro": {"noise_rad_s": 1e-4}})  # fmt: skip
    with pytest.raises(ScenarioError, match=r"sensors\.star_tracker\.noise_arcsec.*> 0"):
        _with_sensors("case1", {**GOOD, "star_tracker": {"noise_arcsec": [1.0, 0.0, 1.0],
                                                         "rate_hz": 4.0}})  # fmt: skip
    with pytest.raises(ScenarioError, match=r"sensors\.gyro\.noise_rad_s"):
        _with_sensors("case1", {**GOOD, "gyro": {"noise_rad_s": -1.0}})


def test_a_gyro_bias_without_the_estimator_offsets_the_pd_equilibrium():
    """What the estimator is for: a PD loop fed the raw gyro (bias ``b``) with perfect
    attitude settles where ``Kp sigma_e = -Kd b`` (eq. 11 at rest): a pointing offset of
    ``4 |Kd/Kp b|`` rad, 0.13 deg for ``b = 1e-3 rad/s`` and the paper's gains. Fed the
    bias-corrected estimate, the same loop settles on the goal."""
    sc = load_scenario(SCENARIOS / "case1.yaml")
    gains = PdGains(sc.kp, sc.kd)
    bias = np.array([1.0e-3, -4.0e-4, 6.0e-4])
    goal, zero = sc.desired_mrp, np.zeros(3)
    body = RigidBody(sc.inertia_kgm2, goal, zero)
    for _ in range(3000):  # 300 s at 0.1 s
        u = commanded_torque(gains, body.sigma_bn, body.omega_b + bias, goal, zero)
        body.step(u, sc.dt_s)
    offset = float(principal_angle(relative(body.sigma_bn, goal)))
    expected = 4.0 * (sc.kd_over_j / sc.kp_over_j) * float(np.linalg.norm(bias))
    assert offset == pytest.approx(expected, rel=0.02)
    assert math.degrees(offset) > 0.1
    # the estimator's bias-corrected rate removes it
    run = run_closed_loop(_with_sensors("case1", {**GOOD, "gyro": {
        "noise_rad_s": 1.0e-4, "bias_rad_s": bias.tolist()}}))  # fmt: skip
    final = math.degrees(float(principal_angle(relative(run.sigma_bn[-1], goal))))
    assert final < 0.25 * math.degrees(offset)


@pytest.mark.parametrize("name", ["case1", "case1_wheels"])
@pytest.mark.parametrize(
    "attitude_deg, rate_rad_s", [(0.03, 1e-4), (0.1, 3e-4), (0.3, 0.0), (0.0, 1e-3)]
)
def test_the_guidance_arrives_on_raw_noisy_states(name, attitude_deg, rate_rad_s):
    """The guidance alone against noise, without the filter: the true state plus white
    attitude noise (per axis, a body-frame rotation) and rate noise is fed to
    ``Guidance`` and ``commanded_torque``, the scenario declaring sensors of that noise.
    The arrival is declared (on the window's means), the derating does not stall the
    slew, and the true body ends near the goal, clear of every cone."""
    from scipy.spatial.transform import Rotation

    params = _params(name)
    params["sensors"] = {
        "seed": 1,
        "star_tracker": {"noise_arcsec": [max(attitude_deg, 1e-3) * 3600.0] * 3, "rate_hz": 10.0},
        "gyro": {"noise_rad_s": rate_rad_s},
    }
    sc = parse_scenario(params, name, SCENARIOS)
    rng = np.random.default_rng(0)
    guidance = guidance_from_scenario(sc)
    gains, limit = PdGains(sc.kp, sc.kd), sc.actuators.max_torque_nm
    body = RigidBody(sc.inertia_kgm2, sc.initial_mrp, sc.initial_rate_rad_s)
    sigma, omega, arrived = [], [], []
    for k in range(sc.n_steps + 1):
        noise = Rotation.from_rotvec(math.radians(attitude_deg) * rng.standard_normal(3))
        measured = (Rotation.from_mrp(body.sigma_bn) * noise).as_mrp()
        rate = body.omega_b + rate_rad_s * rng.standard_normal(3)
        target = guidance.update(k * sc.dt_s, measured, rate).target
        arrived.append(target.status == PlannerStatus.ARRIVED)
        u = commanded_torque(gains, measured, rate, target.sigma_t, target.omega_t, limit)
        sigma.append(body.sigma_bn)
        omega.append(body.omega_b)
        body.step(u, sc.dt_s)
    assert arrived[-1], "never declared arrived (or withdrawn at the end)"
    final = math.degrees(float(principal_angle(relative(body.sigma_bn, sc.desired_mrp))))
    assert final <= sc.arrival.attitude_tol_deg
    t = sc.dt_s * np.arange(len(sigma))
    margin, _ = dense_min_margin_deg(sc.sky, t, np.array(sigma), np.array(omega))
    assert margin > 0.0


def test_an_estimated_start_flies_the_route_prepared_before_the_first_state():
    """The planner node prepares the route from the scenario's start before its first
    state; a first estimate within the first fix's 3-sigma of that start takes it (no
    route planned while the simulator waits for the first torque), one beyond does not."""
    from scipy.spatial.transform import Rotation

    sc = _with_sensors("case1_wheels", COARSE)
    prepared = prepare_guidance(sc)
    first_fix = sc.knowledge.first_fix_3sigma_deg
    assert first_fix > 0.5  # 0.3 deg about x, 0.1 across: 3 sqrt(0.11) deg
    start = Rotation.from_mrp(np.array(sc.initial_mrp))
    for off_deg, taken in ((0.5 * first_fix, True), (2.0 * first_fix, False)):
        sigma_0 = (start * Rotation.from_rotvec([math.radians(off_deg), 0.0, 0.0])).as_mrp()
        guidance = guidance_from_scenario(sc, sigma_0=sigma_0, prepared=prepared)
        assert (guidance.route is prepared.initial_route) is taken
