"""The offline closed loop: FEPF planner, PD controller and rigid body in one process.

The loop at step ``k`` (``t_k = k dt``): the guidance gives the target
``(sigma_t, omega_t)`` for the body state at ``t_k`` (eqs. 6-10, 12, closed on the
measured state, :mod:`attitude_core.fsw.guidance.guidance`), the controller the torque ``u_k``
from the body state at ``t_k`` (eq. 11), and the body is propagated to ``t_{k+1}`` with
``u_k`` held (eqs. 3-4). While the guidance holds the body on the goal
(:meth:`Guidance.hold_band`) the steps whose states stay inside its arrival band are
taken in one call with the held target (:meth:`LoopPlant.hold`): the same record as a
step at a time. With ``actuators.max_torque_nm`` the controller scales its
command into the bound and the plant clips per axis (:mod:`attitude_core.world.actuator`).
The nodes run the same functions, one per process.

With declared sensors (``sensors.*``) the guidance and the controller are fed the MEKF's
estimate of the body (:class:`attitude_core.loop.sensing.OnboardEstimation`), never the
body itself: the guidance starts from the first estimate, as the planner node starts
from the first state it receives. The record keeps the true state and the estimate side
by side.
"""

from __future__ import annotations

import time

import numpy as np

from attitude_core.assembly.goal_sequence import GoalSequence
from attitude_core.assembly.guidance import guidance_from_scenario, prepare_guidance
from attitude_core.config.scenario import Scenario
from attitude_core.contract.topics import NS_PER_S
from attitude_core.fsw.control.pd import PdGains
from attitude_core.fsw.fdir.tracker_watch import tracker_outages
from attitude_core.fsw.guidance.guidance import Guidance
from attitude_core.loop.linked_loop import run_linked_loop
from attitude_core.loop.loop_plant import loop_plant
from attitude_core.loop.sensing import OnboardEstimation
from attitude_core.loop.wheel_loop import run_wheel_loop
from attitude_core.record.trajectory import Estimates, RunResult
from attitude_core.world.rigid_body import RigidBody

__all__ = ["run_closed_loop"]


def run_closed_loop(scenario: Scenario) -> RunResult:
    """Simulate the whole scenario (``sim_time_s``) and return the sampled trajectory;
        behind a declared link, :func:`attitude_core.loop.linked_loop.run_linked_loop`; with
    wheels, :func:`attitude_core.loop.wheel_loop.run_wheel_loop`."""
    if scenario.link is not None:
        return run_linked_loop(scenario)
    if scenario.wheels is not None:
        return run_wheel_loop(scenario)
    wall0 = time.perf_counter()
    n = scenario.n_steps
    dt = scenario.dt_s
    dt_ns = round(dt * NS_PER_S)
    # A plan (plan.*): its goals one after the other, each with its own guidance.
    guidance: Guidance | GoalSequence | None = None
    if scenario.plan:
        guidance = GoalSequence(scenario, prepare_guidance(scenario))
    elif scenario.sensors is None:
        guidance = guidance_from_scenario(scenario)
    body = RigidBody(scenario.inertia_kgm2, scenario.initial_mrp, scenario.initial_rate_rad_s)
    sigma = np.empty((n + 1, 3))
    omega = np.empty((n + 1, 3))
    torque = np.empty((n + 1, 3))
    sigma_t = np.empty((n + 1, 3))
    omega_t = np.empty((n + 1, 3))
    sigma[0], omega[0] = body.sigma_bn, body.omega_b
    # The controller and the plant: they write the torque, the target and the next
    # body state into the record (row k + 1 of sigma and omega).
    plant = loop_plant(
        PdGains(scenario.kp, scenario.kd),
        scenario.actuators.max_torque_nm,
        body,
        dt,
        sigma,
        omega,
        torque,
        sigma_t,
        omega_t,
    )
    d_obs = np.empty(n + 1)
    status = np.empty(n + 1, dtype=np.int8)
    step_s = np.empty(n + 1)
    onboard = None
    if scenario.sensors is not None:
        blinded = scenario.tracker_blinded if scenario.sensors.star_tracker_instrument else None
        onboard = OnboardEstimation(scenario.sensors, dt, n + 1, blinded)
    clock = time.perf_counter
    k = 0
    while k <= n:
        # The time the planner node derives from the state stamp (k dt in integer ns),
        # to the last bit: the guidance's thresholds then decide alike in both.
        t_k = k * dt_ns / NS_PER_S
        sigma_k, omega_k = sigma[k], omega[k]  # the body at t_k
        sigma_m, omega_m = sigma_k, omega_k  # the state the loop is fed
        if onboard is not None:
            est = onboard.sense(k, t_k, sigma_k, omega_k)
            if est is None:
                raise RuntimeError(f"{scenario.name}: no star tracker fix at t = {t_k} s")
            sigma_m, omega_m = est.sigma_bn, est.omega_b
        if guidance is None:  # the first estimate: the guidance starts from it, with
            # what the planner node prepares before its first state
            guidance = guidance_from_scenario(
                scenario, sigma_0=sigma_m, prepared=prepare_guidance(scenario)
            )
        c0 = clock()
        target = guidance.update(t_k, sigma_m, omega_m).target
        step_s[k] = clock() - c0
        plant.step(k, sigma_m, omega_m, target.sigma_t, target.omega_t)
        d_obs[k] = target.obstacle_distance_mrp
        status[k] = target.status.code
        k += 1
        band = guidance.hold_band() if onboard is None else None
        if band is not None and k <= n:
            # Held on the goal: the same target for every state inside the band, the
            # steps taken in one call (the guidance judges the first state outside it).
            c0 = clock()
            stop = plant.hold(k, n + 1, guidance.goal, target.sigma_t, target.omega_t, *band)
            if stop > k:
                step_s[k:stop] = (clock() - c0) / (stop - k)
                d_obs[k:stop] = target.obstacle_distance_mrp
                status[k:stop] = target.status.code
                guidance.held_to((stop - 1) * dt_ns / NS_PER_S)
                k = stop
    assert guidance is not None  # made at the first step
    goals = []
    if isinstance(guidance, GoalSequence):
        guidance.finish(n * dt_ns / NS_PER_S)
        goals = guidance.reported
    return RunResult(
        scenario,
        dt * np.arange(n + 1),
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
        None
        if onboard is None
        else Estimates(
            onboard.sigma_bn, onboard.omega_b, onboard.attitude_3sigma_deg, onboard.nees
        ),
        faults=[]
        if onboard is None or scenario.sensors is None
        else tracker_outages(onboard.tracker_times, scenario.sensors.star_tracker_rate_hz, n * dt),
        goals=goals,
    )
