"""The state watchdog and what the controller flies on without a state
(:mod:`attitude_core.fsw.fdir`): the predictor against the plant, the watchdog's modes
and faults (live and replayed on a record), and the outage control's brake."""

from __future__ import annotations

import numpy as np
import pytest

from attitude_core.contract.faults import Fault, FaultKind
from attitude_core.contract.status import DiagnosticLevel
from attitude_core.fsw.control.pd import PdGains
from attitude_core.fsw.fdir.fdir_config import BRAKED_RATE_RAD_S, FdirConfig
from attitude_core.fsw.fdir.outage_control import OutageControl
from attitude_core.fsw.fdir.state_predictor import StatePredictor
from attitude_core.fsw.fdir.state_watchdog import FdirMode, StateWatchdog, faults_from_stamps
from attitude_core.world.rigid_body import RigidBody

J = np.array([[12.0, 0.4, -0.2], [0.4, 9.0, 0.3], [-0.2, 0.3, 7.0]])
DT, DT_NS = 0.1, 100_000_000
CFG = FdirConfig(0.3, 3.0, 10.0)


def test_config_orders_its_limits_and_judges_ages_in_integer_nanoseconds():
    assert FdirConfig.for_step(0.1).timeout_ns == 300_000_000
    assert not CFG.stale(3 * DT_NS) and CFG.stale(3 * DT_NS + 1)
    for bad in ((0.0, 3.0, 10.0), (3.0, 3.0, 10.0), (0.3, 10.0, 10.0)):
        with pytest.raises(ValueError, match="state_timeout_s < predict_s < safe_after_s"):
            FdirConfig(*bad)


def test_the_predictor_flies_the_plants_body_with_the_commands_in_effect():
    """Commands taking effect on the grid and between grid points (a delayed answer):
    the prediction is the plant's RK4 body with the same zero-order holds, to rounding."""
    rng = np.random.default_rng(3)
    sigma0, omega0 = np.array([0.2, -0.4, 0.6]), np.array([0.05, -0.03, 0.04])
    pred = StatePredictor(J, DT)
    pred.measured(0, sigma0, omega0)
    body = RigidBody(J, sigma0, omega0)
    t_ns = 0
    for k in range(60):
        u = rng.normal(0.0, 0.05, 3)
        split = k % 3 == 0  # a command half a step in: the plant steps twice
        pred.commanded(t_ns + (DT_NS // 2 if split else 0), u)
        if split:
            body.step_reference(pred.torque_at(t_ns), DT / 2)
            body.step_reference(u, DT / 2)
        else:
            body.step_reference(u, DT)
        t_ns += DT_NS
        sigma, omega = pred.predict(t_ns)
        np.testing.assert_allclose(sigma, body.sigma_bn, rtol=0, atol=1e-12)
        np.testing.assert_allclose(omega, body.omega_b, rtol=0, atol=1e-12)


def test_a_delayed_state_restarts_the_prediction_with_the_commands_after_its_stamp():
    pred = StatePredictor(J, DT)
    pred.measured(0, np.zeros(3), np.zeros(3))
    u1, u2 = np.array([0.1, 0.0, 0.0]), np.array([0.0, -0.1, 0.0])
    pred.commanded(0, u1)
    pred.commanded(5 * DT_NS, u2)
    pred.predict(9 * DT_NS)
    body = RigidBody(J, [0.01, 0.0, 0.0], [0.001, 0.0, 0.0])  # the state at 3 dt, late
    pred.measured(3 * DT_NS, body.sigma_bn, body.omega_b)
    for u in (u1, u1, u2, u2, u2, u2):  # 3 dt -> 9 dt: u1 until 5 dt, then u2
        body.step_reference(u, DT)
    sigma, omega = pred.predict(9 * DT_NS)
    np.testing.assert_allclose(sigma, body.sigma_bn, rtol=0, atol=1e-12)
    np.testing.assert_allclose(omega, body.omega_b, rtol=0, atol=1e-12)


def test_watchdog_modes_by_age_and_safe_mode_latches():
    dog = StateWatchdog(CFG)
    assert dog.mode(10 * DT_NS) is FdirMode.NOMINAL  # before any state
    dog.measured(0)
    expect = {
        3 * DT_NS: FdirMode.NOMINAL,
        4 * DT_NS: FdirMode.PREDICTING,
        30 * DT_NS: FdirMode.PREDICTING,
        31 * DT_NS: FdirMode.BRAKING,
        100 * DT_NS: FdirMode.BRAKING,
        101 * DT_NS: FdirMode.SAFE_MODE,
    }
    for now, mode in expect.items():
        assert dog.mode(now) is mode
    mode, opened = dog.check(101 * DT_NS)
    assert mode is FdirMode.SAFE_MODE
    assert [f.kind for f in opened] == [FaultKind.STATE_LOST, FaultKind.SAFE_MODE]
    assert opened[0].t_start_s == pytest.approx(0.3) and opened[1].t_start_s == pytest.approx(10.0)
    dog.measured(102 * DT_NS)  # a state after safe mode: still safe (latched)
    assert dog.mode(103 * DT_NS) is FdirMode.SAFE_MODE
    assert dog.check(200 * DT_NS)[1] == []  # each fault opens once


def test_a_gap_opens_and_closes_one_state_lost_fault_with_its_times():
    dog = StateWatchdog(CFG, origin_ns=0)
    for k in range(20):
        dog.measured(k * DT_NS)
        assert dog.check(k * DT_NS)[1] == []
    opened = []
    for k in range(20, 50):  # states stamped 2.0 .. 4.9 s lost
        opened += dog.check(k * DT_NS)[1]
    assert [f.kind for f in opened] == [FaultKind.STATE_LOST]
    assert opened[0].t_end_s is None and opened[0].t_start_s == pytest.approx(2.2)
    assert opened[0].diagnostic_level is DiagnosticLevel.WARN
    closed = dog.measured(50 * DT_NS, 51 * DT_NS)  # stamped 5.0 s, received at 5.1 s
    assert len(closed) == 1 and closed[0].t_end_s == pytest.approx(5.1)
    assert closed[0].diagnostic_level is DiagnosticLevel.OK
    assert "predicted, then braked" in closed[0].detail
    assert dog.all_faults() == closed
    assert Fault.from_json(closed[0].to_json()) == closed[0]


def test_the_replay_on_a_record_finds_the_faults_the_live_watchdog_found():
    stamps = [k * DT_NS for k in range(300) if not (40 <= k < 70 or k >= 150)]
    live = StateWatchdog(CFG)
    for k in range(300):
        live.check(k * DT_NS)
        if k * DT_NS in stamps:
            live.measured(k * DT_NS)
    live.check(299 * DT_NS)
    replayed = faults_from_stamps(CFG, stamps, 299 * DT_NS)
    assert [(f.kind, f.t_end_s) for f in replayed] == [
        (FaultKind.STATE_LOST, 7.0),
        (FaultKind.STATE_LOST, None),
        (FaultKind.SAFE_MODE, None),
    ]
    assert [(f.kind, f.t_start_s, f.t_end_s) for f in replayed] == [
        (f.kind, f.t_start_s, f.t_end_s) for f in live.all_faults()
    ]


def _spinning(bound=(0.05, 0.05, 0.05)):
    gains = PdGains.from_inertia(J)
    ctl = OutageControl(CFG, gains, bound, J, DT)
    sigma, omega = np.array([0.1, 0.2, -0.1]), np.array([0.03, -0.02, 0.025])
    ctl.measured(0, sigma, omega)
    ctl.answered(0, sigma, np.array([0.01, 0.0, 0.0]))
    return ctl, RigidBody(J, sigma, omega)


def test_a_dead_link_is_braked_on_the_prediction_then_zero_torque_within_the_bound():
    """The body flown on the controller's own answers (the plant holds each): nothing
    while fresh, then the hold, the brake (never beyond the bound), a zero once the
    predicted rate is nulled, and the true body at rest when safe mode comes."""
    ctl, body = _spinning()
    u = np.array([0.01, 0.0, 0.0])
    modes = []
    for k in range(1, 120):
        body.step_reference(u, DT)
        answer = ctl.tick(k * DT_NS)
        if k <= 3:
            assert answer is None
            continue
        assert answer is not None
        modes.append(answer.mode)
        np.testing.assert_allclose(answer.sigma_bn, body.sigma_bn, rtol=0, atol=1e-12)
        assert np.all(np.abs(answer.torque_b) <= 0.05 + 1e-15)
        u = answer.torque_b
    assert modes[0] is FdirMode.PREDICTING and FdirMode.BRAKING in modes
    assert modes[-1] is FdirMode.SAFE_MODE and ctl.safe
    assert np.all(u == 0.0) and ctl.braked
    assert np.linalg.norm(body.omega_b) < BRAKED_RATE_RAD_S


def test_a_state_that_comes_back_ends_the_fault_and_the_answers():
    ctl, _ = _spinning()
    for k in range(1, 25):
        ctl.tick(k * DT_NS)
    closed = ctl.measured(25 * DT_NS, np.zeros(3), np.zeros(3))
    assert [f.kind for f in closed] == [FaultKind.STATE_LOST]
    assert ctl.tick(25 * DT_NS) is None and not ctl.braked
