"""The planner's side of the state watchdog (:mod:`attitude_core.runtime.planner_stepper`,
:meth:`Guidance.resume`): a gap ends a fault and the guidance goes on from the measured
state without taking the lag for a weak plant; safe mode is reported once and latches."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.faults import FaultKind
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.guidance.guidance_base import ImmediateExecutor
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.models.mrp import angle_between_single
from attitude_core.runtime.planner_stepper import PlannerStepper

ROOT = Path(__file__).resolve().parents[2]
DT_NS = 100_000_000


def test_states_back_after_a_gap_resume_the_guidance_from_the_measured_state():
    sc = load_scenario(ROOT / "scenarios" / "case2.yaml")
    rec = run_closed_loop(sc)  # the states a slew without a gap goes through
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    for k in range(200):
        step = stepper.step(k * DT_NS, rec.sigma_bn[k], rec.omega_b[k])
        assert step.faults == [] and stepper.tick(k * DT_NS).faults == []
    opened = [f for k in range(200, 240) for f in stepper.tick(k * DT_NS).faults]
    assert [f.kind for f in opened] == [FaultKind.STATE_LOST]
    k = 240  # 4 s later; the body a little further along than the target held there
    step = stepper.step(k * DT_NS, rec.sigma_bn[k], rec.omega_b[k])
    assert [f.kind for f in step.faults] == [FaultKind.STATE_LOST]
    assert step.faults[0].t_end_s is not None
    guidance = stepper.guidance
    assert guidance is not None and guidance.derating == 1.0
    # the target restarts at the measured attitude: one step away from it, not 4 s
    assert angle_between_single(step.sigma_t, rec.sigma_bn[k]) < np.radians(0.5)
    for j in range(241, 1000):
        step = stepper.step(j * DT_NS, rec.sigma_bn[min(j, len(rec.t) - 1)], rec.omega_b[-1])
    assert guidance.derating == 1.0
    stepper.close()


def test_safe_mode_is_reported_once_and_every_later_state_gets_the_held_target():
    sc = load_scenario(ROOT / "scenarios" / "case1.yaml")
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    first = stepper.step(0, sc.initial_mrp, np.zeros(3))
    statuses = [stepper.tick(k * DT_NS).status for k in range(1, 102)]
    assert statuses[:-1] == [None] * 100 and statuses[-1] is PlannerStatus.SAFE_MODE
    assert stepper.tick(102 * DT_NS).status is None
    later = stepper.step(103 * DT_NS, sc.initial_mrp, np.zeros(3))
    assert later.held and np.array_equal(later.sigma_t, first.sigma_t)
    stepper.close()
