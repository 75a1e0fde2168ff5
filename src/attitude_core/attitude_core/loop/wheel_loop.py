"""The offline closed loop with a reaction wheel array (``wheels.*``).

One step per ``dt``: the guidance's target for the body's state, the PD torque (eq. 11,
unbounded: the array bounds it), the motor torques allocated on the usable wheels
(:mod:`attitude_core.fsw.control.wheel_allocation`), and the plant of hub and wheels
with their own limits and the external torques (:mod:`attitude_core.world.wheel_plant`).
The wheels' applied torques come back as a wheel plant reports them; a wheel that
ignores its command is taken out (:mod:`attitude_core.fsw.control.wheel_health`) and
the guidance re-budgets the rest of the slew on the wheels left, from their measured
speeds (:func:`attitude_core.assembly.guidance_limits.slew_envelope`). Perfect
knowledge, no link (the scenario refuses both with wheels for now).
"""

from __future__ import annotations

import time

import numpy as np

from attitude_core.assembly.guidance import guidance_from_scenario
from attitude_core.assembly.guidance_limits import slew_envelope
from attitude_core.config.scenario import Scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.fsw.control.wheel_allocation import allocate, wheel_bounds
from attitude_core.fsw.control.wheel_health import WheelHealth
from attitude_core.fsw.guidance.profile_limits import GuidanceLimits
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
    health = WheelHealth(len(array))
    rows, m = n + 1, len(array)
    sigma, omega = np.empty((rows, 3)), np.empty((rows, 3))
    torque, sigma_t, omega_t = np.zeros((rows, 3)), np.empty((rows, 3)), np.zeros((rows, 3))
    d_obs = np.full(rows, np.nan)
    status = np.full(rows, PlannerStatus.TRACKING.code, dtype=np.int8)
    step_s = np.full(rows, np.nan)
    speed, commanded, applied = np.empty((rows, m)), np.zeros((rows, m)), np.zeros((rows, m))
    external = np.zeros((rows, 3))
    for k in range(rows):
        t = k * dt
        s_m, w_m = plant.sigma_bn.copy(), plant.omega_b.copy()
        sigma[k], omega[k], speed[k] = s_m, w_m, plant.speeds
        c0 = time.perf_counter()
        out = guidance.update(t, s_m, w_m).target
        step_s[k] = time.perf_counter() - c0
        sigma_t[k], omega_t[k] = out.sigma_t, out.omega_t
        status[k], d_obs[k] = out.status.code, out.obstacle_distance_mrp
        tau = commanded_torque(gains, s_m, w_m, sigma_t[k], omega_t[k], None)
        lower, upper = wheel_bounds(array, plant.speeds, health.usable)
        u = allocate(array, tau, lower, upper).motor_torque_nm
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
        health.observe(u, step.motor_torque_nm, speed[k], array.max_speed)
        if health.changed:  # re-budget the slew on the wheels left
            env = slew_envelope(scenario, plant.sigma_bn, plant.speeds, health.usable)
            guidance.limits = GuidanceLimits.from_wheels(scenario.inertia_kgm2, env)
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
