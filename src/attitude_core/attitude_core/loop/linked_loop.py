"""The offline closed loop behind a rehearsal link (``link.*``), with the state watchdog.

The same loop as :func:`attitude_core.loop.closed_loop.run_closed_loop`, one step per
``dt`` on the stack's clock ``t_k = k dt``, except that the flight software sees the
body only through the link (:class:`attitude_core.world.link.StateLink`): at each tick
the plant sends its state, and the link delivers the newest state due, or none. A
delivered state (stamp ``s``) is answered as the nodes answer it: the guidance's target
for it, the PD torque (eq. 11), in effect from this tick. Without one, the controller's
outage logic (:class:`attitude_core.fsw.fdir.outage_control.OutageControl`) commands a
torque once the newest state is stale (predicted, braked, zero), and the plant holds the
last torque otherwise, as a plant behind a bench link does. The record keeps the true
body at every step, the target in force and the faults; the run ends at safe mode.

This is the lockstep contract of the simulator node with a link
(:mod:`attitude_core.runtime.sim_stepper`), step for step.
"""

from __future__ import annotations

import time

import numpy as np

from attitude_core.assembly.guidance import guidance_from_scenario, prepare_guidance
from attitude_core.config.scenario import Scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.contract.topics import NS_PER_S
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.fsw.fdir.outage_control import OutageControl
from attitude_core.fsw.fdir.state_watchdog import FdirMode
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.record.trajectory import RunResult
from attitude_core.world.actuator import clip_to_bound
from attitude_core.world.link import StateLink
from attitude_core.world.rigid_body import RigidBody

__all__ = ["run_linked_loop"]


def run_linked_loop(scenario: Scenario) -> RunResult:
    """Simulate ``scenario`` (which declares ``link.*``) to its end or to safe mode."""
    if scenario.link is None:
        raise ValueError(f"{scenario.name}: no link.* declared")
    wall0 = time.perf_counter()
    n, dt = scenario.n_steps, scenario.dt_s
    dt_ns = round(dt * NS_PER_S)
    bound = scenario.actuators.max_torque_nm
    gains = PdGains(scenario.kp, scenario.kd)
    body = RigidBody(scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s)
    link: StateLink[tuple[np.ndarray, np.ndarray]] = StateLink(scenario.link)
    outage = OutageControl(scenario.watchdog, gains, bound, scenario.inertia_kgm2, dt)
    prepared = prepare_guidance(scenario)
    guidance: Guidance | None = None
    first_ns = 0
    rows = n + 1
    sigma, omega = np.empty((rows, 3)), np.empty((rows, 3))
    torque, sigma_t, omega_t = np.zeros((rows, 3)), np.empty((rows, 3)), np.zeros((rows, 3))
    d_obs = np.full(rows, np.nan)
    status = np.full(rows, PlannerStatus.TRACKING.code, dtype=np.int8)
    step_s = np.full(rows, np.nan)
    sigma[0], omega[0] = body.sigma_bn, body.omega_b
    u = np.zeros(3)
    target_sigma, target_omega = body.sigma_bn.copy(), np.zeros(3)
    code, dist = PlannerStatus.TRACKING.code, np.nan
    last = n
    for k in range(rows):
        t_ns = k * dt_ns
        link.send(t_ns, (sigma[k].copy(), omega[k].copy()))
        got = link.receive(t_ns)
        safe = False
        if got is not None and not outage.safe:
            s_ns, (s_m, w_m) = got
            gap = outage.measured(s_ns, s_m, w_m, t_ns)
            t_s = (s_ns - first_ns) / NS_PER_S
            if guidance is None:
                guidance = guidance_from_scenario(scenario, sigma_0=s_m, prepared=prepared)
                first_ns, t_s = s_ns, 0.0
            elif gap:  # states back after a gap: the guidance goes on from this one
                guidance.resume(t_s, s_m, w_m)
            c0 = time.perf_counter()
            out = guidance.update(t_s, s_m, w_m).target
            step_s[k] = time.perf_counter() - c0
            target_sigma = np.array(out.sigma_t, dtype=float)
            target_omega = np.array(out.omega_t, dtype=float)
            code, dist = out.status.code, out.obstacle_distance_mrp
            u = commanded_torque(gains, s_m, w_m, target_sigma, target_omega, bound)
            outage.answered(s_ns, target_sigma, u)
        else:
            answer = outage.tick(t_ns)
            if answer is not None:
                u = answer.torque_b
                safe = answer.mode is FdirMode.SAFE_MODE
                if safe:
                    code = PlannerStatus.SAFE_MODE.code
        applied, _ = clip_to_bound(u, bound)
        torque[k] = applied
        sigma_t[k], omega_t[k] = target_sigma, target_omega
        status[k], d_obs[k] = code, dist
        if safe:
            last = k
            break
        if k < n:
            body.step(applied, dt)
            sigma[k + 1], omega[k + 1] = body.sigma_bn, body.omega_b
    end = last + 1
    faults = outage.watchdog.all_faults()
    return RunResult(
        scenario,
        dt * np.arange(end),
        sigma[:end],
        omega[:end],
        torque[:end],
        sigma_t[:end],
        omega_t[:end],
        d_obs[:end],
        status[:end],
        step_s[:end],
        time.perf_counter() - wall0,
        "" if guidance is None else guidance.reason,
        float("nan") if guidance is None else guidance.route_rotation_deg,
        faults=faults,
    )
