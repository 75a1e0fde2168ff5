"""The simulator's lockstep behind a rehearsal link (:mod:`attitude_core.runtime.sim_stepper`):
what it publishes and which answer it waits for at each step, so the run is
deterministic: a delivered state's answer (``/clock`` after it), a stale tick's answer,
or none (the last torque held, the next step at once)."""

from __future__ import annotations

import math

import numpy as np

from attitude_core.fsw.fdir.fdir_config import FdirConfig
from attitude_core.models.link_spec import LinkSpec
from attitude_core.runtime.sim_stepper import SETTLE_S, Action, SimStepper, StepperConfig
from attitude_core.world.rigid_body import RigidBody

DT, DT_NS = 0.1, 100_000_000
J = np.diag([10.0, 8.0, 6.0])
T0 = 100.0


def body():
    return RigidBody(J, [0.1, -0.2, 0.3], [0.01, 0.0, -0.02])


def stepper(link: LinkSpec, mode: str = "lockstep") -> SimStepper:
    cfg = StepperConfig(DT, 40, time_mode=mode, link=link, fdir=FdirConfig.for_step(DT))
    return SimStepper(cfg, body(), created=T0)


def test_lockstep_waits_for_the_answer_it_knows_is_coming():
    s = stepper(LinkSpec(outages=((0.25, 1.0),)))  # states stamped 0.3 .. 1.2 s withheld
    ref = body()
    s.poll_graph(T0, True)
    now = T0 + math.ceil((SETTLE_S + 0.01) * 4) / 4
    d = s.poll_graph(now, True)
    assert d.action is Action.START and d.state is not None and d.state.stamp_ns == 0
    assert d.clocks == [] and d.truth is not None and s.waiting_stamp == 0
    u = np.array([0.001, -0.002, 0.0005])
    log = []
    for _ in range(30):
        if d.more:
            d = s.step_on(now)
        else:
            d = s.on_torque(now, s.waiting_stamp, u)
        ref.step(u, DT)
        log.append((s.k, d.action, d.clocks, d.state, s.waiting_stamp, d.more))
        np.testing.assert_array_equal(d.truth.sigma_bn, ref.sigma_bn)
        assert d.truth.stamp_ns == s.k * DT_NS
    by_k = {
        k: (action, clocks, state, waiting, more) for k, action, clocks, state, waiting, more in log
    }
    # k = 1, 2: delivered at once; the previous tick's /clock goes out first
    assert by_k[1][1] == [0] and by_k[1][2].stamp_ns == DT_NS and by_k[1][3] == DT_NS
    # k = 3, 4, 5: withheld, not yet stale (the newest is 0.2 s): /clock, step on
    assert by_k[3][1] == [2 * DT_NS, 3 * DT_NS] and by_k[3][2] is None and by_k[3][4]
    assert by_k[4][0] is Action.LINK_HOLD and by_k[4][4] and by_k[5][4]
    # k = 6: 0.4 s old, stale: the tick's answer is awaited, stamped with the tick
    assert by_k[6][1] == [6 * DT_NS] and by_k[6][3] == 6 * DT_NS and not by_k[6][4]
    # k = 13: the first state after the outage, its /clock after its answer
    assert by_k[13][2].stamp_ns == 13 * DT_NS and by_k[13][1] == [] and by_k[13][3] == 13 * DT_NS
    assert s.link is not None and s.link.withheld == 10


def test_a_resend_while_awaiting_a_tick_repeats_its_clock_alone():
    s = stepper(LinkSpec(outages=((0.05, 100.0),)))
    s.poll_graph(T0, True)
    now = T0 + 0.25
    s.poll_graph(now, True)
    d = s.on_torque(now, 0, np.zeros(3))
    while d.more:
        d = s.step_on(now)
    assert s.tick_wait and s.waiting_stamp == 4 * DT_NS
    r = s.on_timer(now + 0.5)
    assert r.action is Action.RESEND and r.clocks == [4 * DT_NS] and not r.resend_state


def test_realtime_takes_a_ticks_answer_stamped_within_a_step_of_the_last_state():
    s = stepper(LinkSpec(outages=((0.15, 100.0),)), mode="realtime")
    s.poll_graph(T0, True)
    assert s.poll_graph(T0 + 0.25, True).action is Action.START
    base = 5_000_000_000
    for k in range(5):
        d = s.on_timer(T0 + 1 + k * DT, base + k * DT_NS)
        assert d.truth is not None and d.truth.stamp_ns == base + k * DT_NS
        assert (d.state is not None) == (k < 2)  # withheld from 0.15 s on
    tick = base + 4 * DT_NS + DT_NS // 2
    assert s.on_torque(T0 + 2, tick, np.zeros(3)).action is Action.ACCEPT
    far = base + 6 * DT_NS
    assert s.on_torque(T0 + 2, far, np.zeros(3)).action is Action.REJECT
