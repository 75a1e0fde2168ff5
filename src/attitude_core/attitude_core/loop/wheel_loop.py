"""The offline closed loop with a reaction wheel array (``wheels.*``).

One step per ``dt``, as the ROS nodes do it: the state and its wheel state (speeds, and
the motor torques applied over the step that ended there); the planner's wheel budget
(:class:`attitude_core.assembly.guidance_limits.WheelBudget`: the slew re-budgeted on the
wheels left once one ignores its command) and the guidance's target; the PD torque
(eq. 11, unbounded: the array bounds it) as motor torques on the usable wheels
(:class:`attitude_core.fsw.control.wheel_control.WheelControl`); and the plant of hub and
wheels with their own limits and the external torques
(:mod:`attitude_core.world.wheel_plant`). Perfect knowledge, no link (the scenario
refuses both with wheels for now).
"""

from __future__ import annotations

import time

import numpy as np

from attitude_core.assembly.guidance import guidance_from_scenario
from attitude_core.assembly.guidance_limits import WheelBudget
from attitude_core.config.scenario import Scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.fsw.control.wheel_control import WheelControl
from attitude_core.record.trajectory import RunResult, WheelRecord
from attitude_core.world.wheel_plant import WheelPlant

__all__ = ["run_wheel_loop"]


def run_wheel_loop(scenario: Scenario) -> RunResult:
    """Simulate ``scenario`` (which declares ``wheels.*``) over ``sim_time_s``."""
    array = scenario.wheels
    if array is None:
        raise ValueError(f"{scenario.name}: no wheels.* declared")
    wall0 = time.perf_counter()
    n, dt = scenario.n_steps, scenario.dt_s
    gains = PdGains(scenario.kp, scenario.kd)
    plant = WheelPlant(
        scenario.inertia_kgm2,
        array,
        scenario.initial_mrp,
        scenario.initial_rate_rad_s,
        scenario.disturbances,
    )
    guidance = guidance_from_scenario(scenario)
    budget, control = WheelBudget(scenario), WheelControl(array, dt)
    rows, m = n + 1, len(array)
    sigma, omega = np.empty((rows, 3)), np.empty((rows, 3))
    torque, sigma_t, omega_t = np.zeros((rows, 3)), np.empty((rows, 3)), np.zeros((rows, 3))
    d_obs = np.full(rows, np.nan)
    status = np.full(rows, PlannerStatus.TRACKING.code, dtype=np.int8)
    step_s = np.full(rows, np.nan)
    speed, commanded, applied = np.empty((rows, m)), np.zeros((rows, m)), np.zeros((rows, m))
    external = np.zeros((rows, 3))
    effort = np.zeros(m)  # applied over the step that ended at the state
    for k in range(rows):
        t = k * dt
        s_m, w_m = plant.sigma_bn.copy(), plant.omega_b.copy()
        sigma[k], omega[k], speed[k] = s_m, w_m, plant.speeds
        c0 = time.perf_counter()
        limits = budget.measured(s_m, speed[k], effort)
        if limits is not None:  # re-budget the slew on the wheels left
            guidance.limits = limits
        elif budget.infeasible and guidance.reason != budget.infeasible:
            guidance.declare_infeasible(budget.infeasible)  # the target holds
        out = guidance.update(t, s_m, w_m).target
        step_s[k] = time.perf_counter() - c0
        sigma_t[k], omega_t[k] = out.sigma_t, out.omega_t
        status[k], d_obs[k] = out.status.code, out.obstacle_distance_mrp
        tau = commanded_torque(gains, s_m, w_m, sigma_t[k], omega_t[k], None)
        u = control.command(tau, speed[k], effort).motor_torque_nm
        budget.commanded(u, speed[k])
        commanded[k] = u
        if k == n:  # the last row: what would be commanded, nothing flown
            applied[k] = plant.applied(u, t)
            torque[k] = array.body_torque_b(applied[k])
            external[k] = external[k - 1] if k > 0 else 0.0  # held, as the torque rows
            break
        step = plant.step(u, t, dt)
        applied[k], torque[k], external[k] = (
            step.motor_torque_nm,
            step.body_torque_b,
            step.external_b,
        )
        effort = step.motor_torque_nm
    return RunResult(
        scenario,
        dt * np.arange(rows),
        sigma,
        omega,
        torque,
        sigma_t,
        omega_t,
        d_obs,
        status,
        step_s,
        time.perf_counter() - wall0,
        guidance.reason,
        guidance.route_rotation_deg,
        wheels=WheelRecord(speed, commanded, applied, external),
    )
