"""The simulator's stepping logic without ROS (:mod:`attitude_core.runtime.sim_stepper`).

Tested: the start-up gate (settle time, readiness drops, start-up timeout), the
lockstep handshake (state k stamped k dt, advance only on the torque of that stamp,
re-send, hold, zero torque once stale, recovery, end of the run) and real time (one
step per tick with the latest torque, out-of-order and stale torques, end of the run),
the refusal of non-finite torques, and :class:`StepperConfig`. Every call gets an
explicit wall time ``now`` (monotonic seconds), so nothing sleeps; each new state is
compared with an independent :class:`RigidBody` propagated with the same torques.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from attitude_core.config.node_parameters import SIMULATOR
from attitude_core.config.parameters import values_from
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.time_mode import TimeMode
from attitude_core.models.mrp import to_principal
from attitude_core.runtime.sim_stepper import SETTLE_S, Action, Decision, SimStepper, StepperConfig
from attitude_core.world.rigid_body import RigidBody

ROOT = Path(__file__).resolve().parents[2]
DT = 0.1
DT_NS = 100_000_000
J = np.array([[12.0, 0.4, -0.2], [0.4, 9.0, 0.3], [-0.2, 0.3, 7.0]])  # not diagonal
SIGMA0 = np.array([0.1, -0.2, 0.3])
OMEGA0 = np.array([0.02, -0.01, 0.03])
T0 = 1000.0  # wall time the stepper is created, s
EXACT = 1e-15


LOCKSTEP, REALTIME = TimeMode.LOCKSTEP.value, TimeMode.REALTIME.value
TIME_MODES = (LOCKSTEP, REALTIME)


def make_body() -> RigidBody:
    return RigidBody(J, SIGMA0, OMEGA0)


def make(n_steps: int = 5, **config) -> SimStepper:
    return SimStepper(StepperConfig(DT, n_steps, **config), make_body(), created=T0)


def start(stepper: SimStepper, now: float = T0) -> tuple[Decision, float]:
    """Connect the graph at ``now`` and keep it connected until START; returns the START
    decision and its wall time."""
    assert stepper.poll_graph(now, True).action is Action.WAIT
    t = now + math.ceil((SETTLE_S + 0.01) * 4) / 4  # a multiple of 0.25 s: exact sums
    d = stepper.poll_graph(t, True)
    assert d.action is Action.START
    return d, t


def assert_state(state, k: int, stamp_ns: int, clock_ns: int | None, ref: RigidBody) -> None:
    """``clock_ns`` None: real time, where no /clock is published."""
    assert (state.k, state.stamp_ns, state.clock_ns) == (k, stamp_ns, clock_ns)
    np.testing.assert_allclose(state.sigma_bn, ref.sigma_bn, rtol=0, atol=EXACT)
    np.testing.assert_allclose(state.omega_b, ref.omega_b, rtol=0, atol=EXACT)


def assert_torque(actual, expected) -> None:
    assert actual is not None
    np.testing.assert_array_equal(actual, np.asarray(expected, dtype=float))


def torques(n: int) -> list[np.ndarray]:
    """Distinct non-zero torques, N m."""
    return [np.array([0.02, -0.01, 0.015]) * (k + 1) for k in range(n)]


# --- configuration ---------------------------------------------------------------------


def test_config_refuses_an_unknown_time_mode():
    with pytest.raises(
        ValueError,
        match=r"time_mode must be one of \['lockstep', 'realtime'\], "
        r"got 'wallclock'",
    ):
        StepperConfig(DT, 10, time_mode="wallclock")
    for mode in TIME_MODES:
        assert StepperConfig(DT, 10, time_mode=mode).time_mode == mode


def test_config_from_the_simulator_parameter_table_defaults():
    rows = {p.key: p for p in SIMULATOR.own}
    values = values_from(SIMULATOR.own, {}, "test")
    cfg = StepperConfig.from_parameters(SIMULATOR.typed(values), 0.05, 3000)
    assert (cfg.dt_s, cfg.n_steps) == (0.05, 3000)
    assert cfg.time_mode == rows["time_mode"].default == LOCKSTEP
    assert cfg.resend_period_s == rows["lockstep.resend_period_s"].default
    assert cfg.torque_timeout_s == rows["lockstep.torque_timeout_s"].default
    assert cfg.max_held_steps == rows["lockstep.max_held_steps"].default
    assert cfg.torque_stale_s == rows["realtime.torque_stale_s"].default
    assert cfg.startup_timeout_s == rows["startup_timeout_s"].default
    # The dataclass defaults are the table's defaults.
    assert StepperConfig(0.05, 3000) == cfg


def test_config_from_given_parameter_values():
    given = {
        "time_mode": REALTIME,
        "lockstep.resend_period_s": 0.3,
        "lockstep.torque_timeout_s": 4.0,
        "lockstep.max_held_steps": 7,
        "realtime.torque_stale_s": 1.5,
        "startup_timeout_s": 12.0,
    }
    params = SIMULATOR.typed(values_from(SIMULATOR.own, given, "test"))
    cfg = StepperConfig.from_parameters(params, DT, 9)
    assert cfg == StepperConfig(
        DT,
        9,
        time_mode=REALTIME,
        resend_period_s=0.3,
        torque_timeout_s=4.0,
        max_held_steps=7,
        torque_stale_s=1.5,
        startup_timeout_s=12.0,
    )


def test_from_scenario_takes_the_scenario_body_and_step():
    sc = load_scenario(ROOT / "scenarios" / "case1.yaml")
    values = values_from(SIMULATOR.own, {"lockstep.max_held_steps": 4}, "test")
    s = SimStepper.from_scenario(sc, SIMULATOR.typed(values), created=T0)
    assert s.cfg == StepperConfig(sc.dt_s, sc.n_steps, max_held_steps=4)
    assert s.cfg.n_steps == 1500 and s.dt_ns == round(sc.dt_s * 1e9)
    np.testing.assert_array_equal(s.body.inertia, sc.inertia_kgm2)
    np.testing.assert_array_equal(s.body.sigma_bn, sc.initial_mrp)
    np.testing.assert_array_equal(s.body.omega_b, sc.initial_rate_rad_s)
    assert s.created == T0 and s.k == 0


def test_dt_ns_is_the_rounded_step():
    assert make().dt_ns == DT_NS
    assert SimStepper(StepperConfig(0.3, 1), make_body(), T0).dt_ns == 300_000_000


# --- start-up ---------------------------------------------------------------------------


def test_graph_never_ready_fails_after_startup_timeout():
    s = make(startup_timeout_s=5.0)
    for t in (T0, T0 + 2.5, T0 + 5.0):  # not yet *after* the timeout
        assert s.poll_graph(t, False).action is Action.WAIT
    d = s.poll_graph(T0 + 5.01, False)
    assert d.action is Action.FAIL and d.exit_code == 1
    assert d.logs == [("error", "graph not connected after 5.0 s")]
    assert d.state is None
    assert (s.done, s.exit_code) == (True, 1)
    # Nothing happens any more, not even when the graph connects late.
    assert s.poll_graph(T0 + 6.0, True).action is Action.NONE
    assert s.poll_graph(T0 + 7.0, True).action is Action.NONE
    assert s.on_timer(T0 + 7.0).action is Action.NONE
    assert s.k == 0


def test_connected_graph_is_not_failed_after_the_startup_timeout():
    s = make(startup_timeout_s=5.0)
    assert s.poll_graph(T0 + 10.0, True).action is Action.WAIT
    assert s.poll_graph(T0 + 10.0 + SETTLE_S + 0.01, True).action is Action.START


def test_ready_must_persist_settle_time_and_a_drop_resets_it():
    s = make()
    assert s.poll_graph(T0, True).action is Action.WAIT
    assert s.poll_graph(T0 + 0.5 * SETTLE_S, True).action is Action.WAIT
    assert s.poll_graph(T0 + 0.75 * SETTLE_S, False).action is Action.WAIT  # drop
    t1 = T0 + 0.8 * SETTLE_S
    assert s.poll_graph(t1, True).action is Action.WAIT
    # Past SETTLE_S since the first "ready", but not since the drop: still waiting.
    assert s.poll_graph(T0 + SETTLE_S + 0.01, True).action is Action.WAIT
    assert s.poll_graph(t1 + SETTLE_S - 0.01, True).action is Action.WAIT
    assert s.started_at is None
    d = s.poll_graph(t1 + SETTLE_S + 0.01, True)
    assert d.action is Action.START
    assert s.started_at == t1 + SETTLE_S + 0.01


def test_without_a_drop_start_comes_after_settle_time():
    s = make()
    assert s.poll_graph(T0, True).action is Action.WAIT
    assert s.poll_graph(T0 + SETTLE_S - 0.01, True).action is Action.WAIT
    assert s.poll_graph(T0 + SETTLE_S + 0.01, True).action is Action.START


def test_nothing_happens_before_start():
    s = make()
    assert s.on_timer(T0 + 1.0).action is Action.NONE
    assert s.on_torque(T0 + 1.0, 0, np.ones(3)).action is Action.IGNORE  # no state yet
    assert s.k == 0 and s.waiting_stamp is None


def test_lockstep_start_publishes_state_zero():
    s = make()
    d, _ = start(s)
    assert d.logs == [("info", "graph connected; starting")]
    assert d.applied is None and d.applied_stamp_ns is None and d.exit_code is None
    assert_state(d.state, 0, 0, 0, make_body())
    np.testing.assert_allclose(d.state.sigma_bn, to_principal(SIGMA0), rtol=0, atol=EXACT)
    assert s.waiting_stamp == 0
    # A second poll after the start does nothing.
    assert s.poll_graph(T0 + 5.0, True).action is Action.NONE


def test_realtime_start_publishes_no_state():
    s = make(time_mode=REALTIME)
    d, _ = start(s)
    assert d.state is None and d.logs == [("info", "graph connected; starting")]
    assert s.waiting_stamp is None


# --- lockstep ---------------------------------------------------------------------------


def test_lockstep_torque_with_the_wrong_stamp_is_refused_or_ignored():
    """A torque answering no published state (ahead, negative, a day in the future) is
    refused and counted; a late answer to an earlier state is ignored. Neither moves the
    body, and the real answer still advances it."""
    s = make()
    _, t = start(s)
    ref = make_body()
    u = torques(1)[0]
    assert s.on_torque(t, 0, u).action is Action.ADVANCE  # state 1 is published
    ref.step(u, DT)
    for n, stamp in enumerate((2 * DT_NS, -1, 1, 5 * DT_NS, 86_400 * 10**9), 1):
        d = s.on_torque(t + 0.01, stamp, np.array([1.0, 2.0, 3.0]))
        assert d.action is Action.REJECT and d.state is None and d.applied is None
        assert d.reason.startswith(f"stamp {stamp} ns answers no state")
        assert s.rejected == n
    d = s.on_torque(t + 0.01, 0, np.array([1.0, 2.0, 3.0]))  # late answer to state 0
    assert d.action is Action.IGNORE and s.rejected == 5
    assert s.k == 1 and s.waiting_stamp == DT_NS
    np.testing.assert_array_equal(s.body.sigma_bn, ref.sigma_bn)
    np.testing.assert_array_equal(s.body.omega_b, ref.omega_b)
    assert s.on_torque(t + 0.02, DT_NS, u).action is Action.ADVANCE


def test_torque_beyond_the_plausible_bound_is_refused_never_integrated():
    """``plausible_torque_nm`` (the scenario's ``actuators.max_torque_nm`` when set): a
    torque of 1e300 N m is refused and counted; the state stays finite."""
    for mode in (LOCKSTEP, REALTIME):
        s = make(time_mode=mode, plausible_torque_nm=(0.1, 0.1, 0.1))
        _, t = start(s)
        if mode == REALTIME:
            s.on_timer(t, 0)
        for n, u in enumerate(([1e300, 0.0, 0.0], [0.0, -0.1000001, 0.0]), 1):
            d = s.on_torque(t, 0, np.array(u))
            assert d.action is Action.REJECT and "exceeds the plausible bound" in d.reason
            assert s.rejected == n
        assert s.on_torque(t, 0, np.array([0.1, -0.1, 0.05])).action is not Action.REJECT
        assert np.isfinite(s.body.omega_b).all()


def test_lockstep_matching_torque_advances_like_an_independent_rigid_body():
    s = make(n_steps=10)
    _, t = start(s)
    ref = make_body()
    for k, u in enumerate(torques(4)):
        t += 0.01
        d = s.on_torque(t, k * DT_NS, u)
        assert d.action is Action.ADVANCE and d.logs == []
        ref.step(u, DT)
        assert_state(d.state, k + 1, (k + 1) * DT_NS, (k + 1) * DT_NS, ref)
        assert_torque(d.applied, u)
        assert d.applied_stamp_ns == k * DT_NS  # stamped with the previous state
        assert s.waiting_stamp == (k + 1) * DT_NS
    # Physics: the torque changed the motion, the free body would be elsewhere.
    free = make_body()
    for _ in range(4):
        free.step(np.zeros(3), DT)
    assert np.linalg.norm(ref.omega_b - free.omega_b) > 1e-3


def test_lockstep_first_step_rate_change_is_euler_equation():
    """One step's rate change ~ J^-1 (u - omega x J omega) dt (first order in dt)."""
    s = make()
    start(s)
    u = np.array([0.5, -0.3, 0.2])
    d = s.on_torque(T0 + 1.0, 0, u)
    expected = np.linalg.solve(J, u - np.cross(OMEGA0, J @ OMEGA0)) * DT
    np.testing.assert_allclose(d.state.omega_b - OMEGA0, expected, rtol=2e-2)


def test_lockstep_resend_after_resend_period():
    s = make(resend_period_s=0.2, torque_timeout_s=2.0)
    _, t = start(s)
    assert s.on_torque(t, 0, np.zeros(3)).action is Action.ADVANCE  # the loop has answered
    assert s.on_timer(t + 0.1).action is Action.NONE
    assert s.on_timer(t + 0.19).action is Action.NONE
    d = s.on_timer(t + 0.25)
    assert d.action is Action.RESEND and d.resend and d.state is None and d.applied is None
    assert s.resends == 1
    assert s.on_timer(t + 0.4).action is Action.NONE  # 0.15 s since the re-send
    assert s.on_timer(t + 0.5).action is Action.RESEND
    assert s.resends == 2
    assert s.k == 1 and s.timeouts == 0 and s.waiting_stamp == DT_NS


def test_lockstep_hold_then_zero_then_torque_received_again():
    s = make(n_steps=20, resend_period_s=0.2, torque_timeout_s=2.0, max_held_steps=2)
    _, t = start(s)
    ref = make_body()
    u0, u1 = torques(2)
    t += 0.01
    d = s.on_torque(t, 0, u0)
    ref.step(u0, DT)
    assert d.action is Action.ADVANCE

    # Re-sends do not restart the torque deadline of the state.
    assert s.on_timer(t + 0.25).action is Action.RESEND
    assert s.on_timer(t + 1.9).action is Action.RESEND
    assert s.on_timer(t + 1.99).action is Action.NONE
    # Two steps with the last torque held...
    for k in (1, 2):
        t += 2.01
        d = s.on_timer(t)
        assert d.action is Action.HOLD
        assert d.logs == [
            (
                "warning",
                f"no torque for step {k} after 2.0 s; holding the last torque {u0.tolist()} N m",
            )
        ]
        ref.step(u0, DT)
        assert_torque(d.applied, u0)
        assert d.applied_stamp_ns == k * DT_NS
        assert_state(d.state, k + 1, (k + 1) * DT_NS, (k + 1) * DT_NS, ref)
        assert not s.stale
    # ...then the torque is stale: zero torque, the error logged once.
    for k, logs in (
        (3, [("error", "torque is stale: applying zero torque until a controller answers again")]),
        (4, []),
    ):
        t += 2.01
        d = s.on_timer(t)
        assert d.action is Action.ZERO and d.logs == logs
        ref.step(np.zeros(3), DT)
        assert_torque(d.applied, np.zeros(3))
        assert d.applied_stamp_ns == k * DT_NS
        assert_state(d.state, k + 1, (k + 1) * DT_NS, (k + 1) * DT_NS, ref)
        assert s.stale
    assert s.timeouts == 4
    # An old torque stays ignored; the one for the current state is used and logged.
    assert s.on_torque(t + 0.01, 0, u1).action is Action.IGNORE
    d = s.on_torque(t + 0.02, 5 * DT_NS, u1)
    assert d.action is Action.ADVANCE and d.logs == [("info", "torque received again")]
    ref.step(u1, DT)
    assert_state(d.state, 6, 6 * DT_NS, 6 * DT_NS, ref)
    assert not s.stale and s.held_steps == 0
    # The hold count restarted: the next timeout holds the new torque.
    d = s.on_timer(t + 0.02 + 2.01)
    assert d.action is Action.HOLD
    assert_torque(d.applied, u1)
    assert s.timeouts == 5


def test_lockstep_no_held_steps_means_zero_at_the_first_timeout():
    s = make(max_held_steps=0, torque_timeout_s=1.0)
    _, t = start(s)
    ref = make_body()
    u = torques(1)[0]
    assert s.on_torque(t, 0, u).action is Action.ADVANCE
    ref.step(u, DT)
    d = s.on_timer(t + 1.01)
    assert d.action is Action.ZERO and d.logs[0][0] == "error"
    ref.step(np.zeros(3), DT)
    assert_state(d.state, 2, 2 * DT_NS, 2 * DT_NS, ref)


def test_lockstep_finish_after_exactly_n_steps():
    n = 3
    s = make(n_steps=n, resend_period_s=0.2)
    _, t = start(s)
    assert s.on_timer(t + 0.25).action is Action.RESEND  # counted in the final log
    ref = make_body()
    us = torques(n + 1)
    for k in range(n):
        d = s.on_torque(t + 0.3 + k, k * DT_NS, us[k])
        assert d.action is Action.ADVANCE
        ref.step(us[k], DT)
    assert s.k == n and not s.done
    assert s.on_torque(t + 5.0, n * DT_NS, [np.nan, 0.0, 0.0]).action is Action.REJECT
    d = s.on_torque(t + 5.5, n * DT_NS, us[n])
    assert d.action is Action.FINISH and d.exit_code == 0 and d.state is None
    assert_torque(d.applied, us[n])  # the final applied torque
    assert d.applied_stamp_ns == n * DT_NS
    assert len(d.logs) == 1 and d.logs[0][0] == "info"
    text = d.logs[0][1]
    assert text.startswith(f"scenario time ended: {n} steps in {t + 5.5 - t:.3f} s wall")
    assert text.endswith("1 re-sends, 0 torque timeouts, 1 rejected torques")
    # The body took exactly n steps: the final torque was not integrated.
    assert s.k == n
    np.testing.assert_allclose(s.body.sigma_bn, ref.sigma_bn, rtol=0, atol=EXACT)
    np.testing.assert_allclose(s.body.omega_b, ref.omega_b, rtol=0, atol=EXACT)
    assert (s.done, s.exit_code) == (True, 0)
    # After the end nothing happens.
    assert s.on_timer(t + 10.0).action is Action.NONE
    assert s.poll_graph(t + 10.0, True).action is Action.NONE
    assert s.on_torque(t + 10.0, n * DT_NS, us[0]).action is Action.IGNORE
    assert s.on_torque(t + 10.0, (n + 1) * DT_NS, us[0]).action is Action.IGNORE
    assert s.k == n


def test_lockstep_finish_on_a_timeout_holds_the_last_torque():
    s = make(n_steps=1, torque_timeout_s=1.0)
    _, t = start(s)
    u = torques(1)[0]
    assert s.on_torque(t, 0, u).action is Action.ADVANCE
    d = s.on_timer(t + 1.01)
    assert d.action is Action.FINISH and d.exit_code == 0
    assert [level for level, _ in d.logs] == ["warning", "info"]
    assert_torque(d.applied, u)
    assert d.applied_stamp_ns == DT_NS
    assert s.timeouts == 1 and s.k == 1


def test_lockstep_deadline_without_a_waiting_state_does_nothing():
    """Defensive guard: reachable only with no state awaiting its torque."""
    s = make(torque_timeout_s=1.0)
    _, t = start(s)
    s.waiting_stamp = None
    assert s.on_timer(t + 100.0).action is Action.NONE
    assert s.k == 0 and s.timeouts == 0 and s.resends == 0


# --- real time --------------------------------------------------------------------------


def test_realtime_ticks_step_with_the_latest_torque():
    s = make(n_steps=10, time_mode=REALTIME, torque_stale_s=0.5)
    _, t = start(s)
    ref = make_body()
    clock = 7_000_000_123  # node clock, ns: the stamp of the states
    d = s.on_timer(t, clock)
    assert d.action is Action.ADVANCE and d.applied is None and d.applied_stamp_ns is None
    assert_state(d.state, 0, clock, None, ref)
    previous = clock
    for k, u in enumerate(torques(3), start=1):
        a = s.on_torque(t + 0.05, previous, u)
        assert a.action is Action.ACCEPT and a.logs == [] and a.state is None
        t, clock = t + DT, clock + 99_000_000
        d = s.on_timer(t, clock)
        assert d.action is Action.ADVANCE
        ref.step(u, DT)
        assert_torque(d.applied, u)
        assert d.applied_stamp_ns == previous
        assert_state(d.state, k, clock, None, ref)
        previous = clock
    # No new torque: the last one is held while fresh.
    t += DT
    d = s.on_timer(t, clock + 1)
    ref.step(torques(3)[-1], DT)
    assert d.action is Action.ADVANCE
    assert_state(d.state, 4, clock + 1, None, ref)


def test_realtime_older_torque_is_rejected():
    s = make(time_mode=REALTIME)
    _, t = start(s)
    u_new, u_old = torques(2)
    s.on_timer(t, 499)
    s.on_timer(t, 500)  # states stamped 499 and 500 are published
    assert s.on_torque(t, 500, u_new).action is Action.ACCEPT
    d = s.on_torque(t + 0.01, 499, u_old)
    assert d.action is Action.REJECT
    assert d.reason == "stamp 499 ns is older than the applied torque's 500 ns"
    assert s.rejected == 1
    assert s.on_torque(t + 0.02, 500, u_new).action is Action.ACCEPT  # same stamp: fine
    d = s.on_timer(t + 0.04, 501)
    assert_torque(d.applied, u_new)


def test_realtime_non_finite_torque_is_rejected_and_counted():
    s = make(time_mode=REALTIME)
    _, t = start(s)
    u = torques(1)[0]
    s.on_timer(t, 10)
    s.on_timer(t, 20)
    assert s.on_torque(t, 10, u).action is Action.ACCEPT
    d = s.on_torque(t, 20, np.array([0.0, np.nan, 0.0]))
    assert d.action is Action.REJECT and "non-finite" in d.reason
    assert s.rejected == 1 and s.torque_stamp == 10
    assert_torque(s.on_timer(t + 0.01, 30).applied, u)


def test_realtime_torque_stamped_ahead_is_refused_and_real_answers_still_apply():
    """A torque stamped a day ahead answers no published state: refused and counted; the
    real answers that follow are applied (it never becomes the reference)."""
    s = make(n_steps=10, time_mode=REALTIME)
    _, t = start(s)
    u = torques(1)[0]
    s.on_timer(t, 1_000)
    d = s.on_torque(t, 1_000 + 86_400 * 10**9, np.array([0.01, 0.0, 0.0]))
    assert d.action is Action.REJECT and s.rejected == 1
    assert s.on_torque(t, 1_000, u).action is Action.ACCEPT
    assert_torque(s.on_timer(t + DT, 2_000).applied, u)


def test_realtime_stale_torque_applies_zero_until_a_torque_arrives():
    s = make(n_steps=20, time_mode=REALTIME, torque_stale_s=0.5)
    _, t = start(s)
    ref = make_body()
    u, u2 = torques(2)
    assert s.on_timer(t, 0).action is Action.ADVANCE
    s.on_torque(t, 0, u)
    d = s.on_timer(t + 0.5, 1)  # exactly torque_stale_s old: still fresh
    assert d.action is Action.ADVANCE
    ref.step(u, DT)
    assert_torque(d.applied, u)
    d = s.on_timer(t + 0.51, 2)
    assert d.action is Action.ZERO
    assert d.logs == [
        ("error", "torque is stale: applying zero torque until a controller answers again")
    ]
    ref.step(np.zeros(3), DT)
    assert_torque(d.applied, np.zeros(3))
    assert_state(d.state, 2, 2, None, ref)
    d = s.on_timer(t + 0.61, 3)
    assert d.action is Action.ZERO and d.logs == []
    ref.step(np.zeros(3), DT)
    assert_torque(d.applied, np.zeros(3))
    a = s.on_torque(t + 0.65, 3, u2)
    assert a.action is Action.ACCEPT and a.logs == [("info", "torque received again")]
    d = s.on_timer(t + 0.71, 4)
    assert d.action is Action.ADVANCE and d.logs == []
    ref.step(u2, DT)
    assert_torque(d.applied, u2)
    assert_state(d.state, 4, 4, None, ref)


def test_realtime_finish_after_n_steps_plus_one_ticks():
    n = 3
    s = make(n_steps=n, time_mode=REALTIME)
    _, t = start(s)
    ref = make_body()
    u = torques(1)[0]
    for k in range(n + 1):  # states 0..n: n steps of the body
        d = s.on_timer(t + 0.01 * k, 100 + k)
        if k == 0:
            assert s.on_torque(t, 100, u).action is Action.ACCEPT
        assert d.action is Action.ADVANCE and d.state.k == k
        if k:
            ref.step(u, DT)
        assert_state(d.state, k, 100 + k, None, ref)
    assert not s.done
    d = s.on_timer(t + 1.0, 200)
    assert d.action is Action.FINISH and d.exit_code == 0
    assert d.applied is None and d.state is None
    assert d.logs[0][1].startswith(f"scenario time ended: {n} steps in")
    assert (s.done, s.exit_code) == (True, 0)
    np.testing.assert_allclose(s.body.omega_b, ref.omega_b, rtol=0, atol=EXACT)
    assert s.on_timer(t + 2.0, 300).action is Action.NONE
    assert s.poll_graph(t + 2.0, True).action is Action.NONE


def test_realtime_torque_after_the_end_is_not_accepted():
    s = make(n_steps=0, time_mode=REALTIME)
    _, t = start(s)
    assert s.on_timer(t, 0).action is Action.ADVANCE
    assert s.on_timer(t + DT, 1).action is Action.FINISH
    assert s.on_torque(t + 0.2, 5, np.ones(3)).action in (Action.NONE, Action.IGNORE)
