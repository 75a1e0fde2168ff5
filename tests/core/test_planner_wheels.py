"""The planner's side of a wheel array (``PlannerStepper`` with ``wheels.*``), fed the
states, wheel states and controller commands of an offline wheel run: a wheel that
stops answering re-budgets the slew exactly as the offline loop does, whether the
controller's command of a step comes before or after the next state (DDS does not
order two writers), and a slew the wheels left cannot fly becomes infeasible."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from attitude_core.assembly.guidance_limits import slew_envelope
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import NS_PER_S
from attitude_core.fsw.guidance.guidance_base import ImmediateExecutor
from attitude_core.fsw.guidance.profile_limits import GuidanceLimits
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.runtime.planner_stepper import PlannerStepper

ROOT = Path(__file__).resolve().parents[2]
PYRAMID = (ROOT / "scenarios" / "case1_rw_pyramid.yaml").read_text()
FAILS_AT_S = 30.0
STEPS = 340  # past the failure and its detection


def _feed(text: str, late_commands: bool) -> tuple[PlannerStepper, list[float], list[str]]:
    """The offline run's first STEPS states through a stepper; the rate cap after each."""
    sc = loads_scenario(text)
    run = run_closed_loop(sc)
    w = run.wheels
    assert w is not None
    stepper = PlannerStepper(sc, executor=ImmediateExecutor())
    dt_ns = round(sc.dt_s * NS_PER_S)
    caps, logs = [], []
    pending = None
    for k in range(STEPS):
        effort = w.applied_nm[k - 1] if k > 0 else np.zeros(len(sc.wheels))
        step = stepper.step(
            k * dt_ns, run.sigma_bn[k], run.omega_b[k], wheels=(w.speed_rad_s[k], effort)
        )
        logs += [text for _, text in step.logs]
        if pending is not None:  # the previous step's command, after this state
            logs += [text for _, text in stepper.wheel_command(*pending)]
        pending = (k * dt_ns, w.commanded_nm[k])
        if not late_commands:
            logs += [text for _, text in stepper.wheel_command(*pending)]
            pending = None
        assert stepper.guidance is not None
        caps.append(stepper.guidance.limits.max_rate_rad_s)
    stepper.close()
    return stepper, caps, logs


def test_a_failed_wheel_rebudgets_the_slew_as_the_offline_loop_in_either_order():
    text = PYRAMID + f"    wheels.rw2.fails_at_s: {FAILS_AT_S}\n"
    sc = loads_scenario(text)
    on_time, caps, logs = _feed(text, late_commands=False)
    late, caps_late, _ = _feed(text, late_commands=True)
    k_fail = int(round(FAILS_AT_S / sc.dt_s))
    assert caps[k_fail - 1] == caps[0]  # nothing before the failure
    changed = next(k for k, c in enumerate(caps) if c != caps[0])
    assert k_fail < changed <= k_fail + 2  # judged on the step flown at the failure
    assert caps[-1] < caps[0]
    assert any("['rw2'] stopped answering" in line for line in logs)
    assert list(on_time.wheels.watch.usable) == [True, False, True, True]
    # a command after the next state is judged when it comes: one state later at most
    assert caps_late[-1] == caps[-1]
    assert list(late.wheels.watch.usable) == [True, False, True, True]
    # the bounds are the offline loop's: the envelope of the wheels left, at that state
    run = run_closed_loop(sc)
    env = slew_envelope(sc, run.sigma_bn[changed], run.wheels.speed_rad_s[changed], [1, 0, 1, 1])
    assert caps[changed] == GuidanceLimits.from_wheels(sc.inertia_kgm2, env).max_rate_rad_s


def test_wheels_left_on_two_axes_make_the_planner_say_infeasible():
    text = re.sub(r"(\n(\s+)rw([34]):\n)", rf"\1\2  fails_at_s: {FAILS_AT_S}\n", PYRAMID)
    stepper, _, logs = _feed(text, late_commands=False)
    assert stepper.guidance is not None
    assert stepper.guidance.status is PlannerStatus.INFEASIBLE
    assert "span 2 of the 3 body axes" in stepper.guidance.reason
    assert any(line.startswith("infeasible: wheels:") for line in logs)
