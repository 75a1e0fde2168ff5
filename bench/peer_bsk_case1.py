"""Case 1 closed loop built from Basilisk's compiled modules, timed; run by
``bench/peer_bench.py`` with the Basilisk bench environment's interpreter (``bsk`` is not
in the project's lock).

Run: .bench-venv/bsk/bin/python bench/peer_bsk_case1.py [--repeats N] [--grid N] [--trajectory F]

The loop, one task at dt = 0.1 s, 150 s simulated (1500 steps), in this order each step:
``spacecraft.Spacecraft`` (rigid hub, J = diag(10, 10, 10) kg m^2, sigma_BN0 = [0, 0,
0.25], at rest; its RK4 over the step), ``simpleNav`` (no noise), Basilisk's constrained
attitude maneuver planner ``constrainedAttitudeManeuver`` (CAM: A* on an MRP grid, the
path B-spline interpolated; it plans in its Reset and gives the reference each step),
``attTrackingError``, ``mrpFeedback`` and ``extForceTorque`` (the command applied over
the next step, as our loop holds it). A recorder keeps the spacecraft state message.

The CAM takes one keep-out object direction (its keep-out celestial body message) and up
to 10 body boresights. Case 1 has one boresight (the star tracker, [1, 0, 0] body,
20 deg) against three objects. With C = C_BN, the constraint ``s_B . C c_j < cos beta``
reads ``c_j . C^T s_B < cos beta``: the same constraint for the inverse attitude C^T
(MRP -sigma) with the objects as "body boresights" and the star tracker as the single
"object". So the CAM plans the inverse problem (start -sigma_0, goal -sigma_d, keep-out
boresights c_1, c_2, c_3, keep-out direction s_B), which holds all three cones at its
grid nodes exactly as the direct problem would; its grid is symmetric under sigma ->
-sigma and its distance cost is too. Between its plan (Reset) and the first step the
B-spline's control points and nodes are negated, once, in Python, so that the CAM
itself gives the reference of the direct problem every step (its rates follow from
sigma and sigma-dot). Nothing in Python runs per step.

Timed per run, in one process after a warm-up run: build (modules, messages, wiring),
init (``InitializeSimulation``: the CAM's plan, the rest's resets) and the 1500-step
``ExecuteSimulation``. Printed: one JSON line (medians, minima, per-step figure, the
flown path's minimum angle between the boresight and each object, the arrival).
Not a test: timings depend on the machine.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

import Basilisk
import numpy as np
from Basilisk.architecture import messaging
from Basilisk.fswAlgorithms import attTrackingError, constrainedAttitudeManeuver, mrpFeedback
from Basilisk.simulation import extForceTorque, simpleNav, spacecraft
from Basilisk.utilities import SimulationBaseClass, macros

# Case 1 (scenarios/case1.yaml)
J = 10.0  # kg m^2, J = diag(J, J, J)
SIGMA_0 = [0.0, 0.0, 0.25]
SIGMA_D = [0.0, -0.2, -0.7]
BORESIGHT_B = [1.0, 0.0, 0.0]
HALF_ANGLE_DEG = 20.0
OBJECTS_N = [[0.0, -0.981, -0.196], [-1.0, 0.0, 0.0], [0.958, 0.0, 0.287]]
DT_S = 0.1
SIM_TIME_S = 150.0
N_STEPS = round(SIM_TIME_S / DT_S)
# Our law u = -Kp sigma_BR - Kd omega_BR with Kp = 5.5 J, Kd = 3.1 J. mrpFeedback's is
# u = -(K sigma_BR + P omega_BR_B) - I (omega_BN x omega_RN - domega_RN) + omega x I omega
# (with controlLawType 1; Ki < 0 turns the integral off): K multiplies sigma (N m) and
# P multiplies the rate error (N m s), so K = 5.5 J = 55, P = 3.1 J = 31. The feedback's
# own inertia (its vehicle configuration message) is zero, which drops the feed-forward
# and gyroscopic terms: the same PD law as ours, to the term (with J isotropic the
# gyroscopic term omega x J omega is zero anyway).
K_SIGMA = 5.5 * J
P_RATE = 3.1 * J
# The CAM's B-spline lasts 4 S / avgOmega (S: the waypoint path's MRP length, 4 S about
# its rotation angle): 0.06 rad/s is our Case 1's mean rate (175 deg in 50 s).
AVG_OMEGA = 0.06
GRID_N = 8  # the CAM's grid fineness (its example's value; at most 20)
ARRIVAL_TOL_DEG = 0.5  # Case 1's arrival: attitude error and rate within these from then on
ARRIVAL_TOL_RAD_S = 1e-3


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def build(grid_n=GRID_N):
    """The simulation, its modules and its recorder (nothing run yet)."""
    sim = SimulationBaseClass.SimBaseClass()
    sim.SetProgressBar(False)
    proc = sim.CreateNewProcess("proc")
    proc.addTask(sim.CreateNewTask("loop", macros.sec2nano(DT_S)))

    sc = spacecraft.Spacecraft()
    sc.ModelTag = "case1"
    sc.hub.mHub = 100.0  # kg, no bearing on the attitude (no gravity, no offset)
    sc.hub.r_BcB_B = [[0.0], [0.0], [0.0]]
    sc.hub.IHubPntBc_B = [[J, 0.0, 0.0], [0.0, J, 0.0], [0.0, 0.0, J]]
    sc.hub.sigma_BNInit = [[s] for s in SIGMA_0]
    sc.hub.omega_BN_BInit = [[0.0], [0.0], [0.0]]

    torque = extForceTorque.ExtForceTorque()
    torque.ModelTag = "torque"
    sc.addDynamicEffector(torque)

    nav = simpleNav.SimpleNav()
    nav.ModelTag = "nav"

    cam = constrainedAttitudeManeuver.ConstrainedAttitudeManeuver(grid_n)
    cam.ModelTag = "cam"
    cam.sigma_BN_goal = [-s for s in SIGMA_D]  # the inverse problem (module docstring)
    cam.omega_BN_B_goal = [0.0, 0.0, 0.0]
    cam.avgOmega = AVG_OMEGA
    cam.BSplineType = 0  # interpolation through the waypoints
    cam.costFcnType = 0  # A* on the MRP distance (symmetric under sigma -> -sigma)
    for c in OBJECTS_N:
        cam.appendKeepOutDirection(_unit(c).tolist(), np.radians(HALF_ANGLE_DEG))
    start = messaging.SCStatesMsgPayload()
    start.sigma_BN = [-s for s in SIGMA_0]
    start.omega_BN_B = [0.0, 0.0, 0.0]
    start.r_BN_N = [0.0, 0.0, 0.0]
    start_msg = messaging.SCStatesMsg().write(start)
    tracker = messaging.SpicePlanetStateMsgPayload()
    tracker.PositionVector = list(BORESIGHT_B)  # a direction: the spacecraft sits at 0
    tracker_msg = messaging.SpicePlanetStateMsg().write(tracker)
    plan_config = messaging.VehicleConfigMsgPayload()
    plan_config.ISCPntB_B = [J, 0.0, 0.0, 0.0, J, 0.0, 0.0, 0.0, J]
    plan_config_msg = messaging.VehicleConfigMsg().write(plan_config)
    # No keep-in zone: the CAM leaves its constraint flags unset (garbage) and reads a
    # keep-in message only once written, so the flag is cleared here and the message it
    # asks to be linked is never written.
    cam.constraints.keepIn = False
    no_keep_in = messaging.SpicePlanetStateMsg()
    cam.scStateInMsg.subscribeTo(start_msg)
    cam.keepOutCelBodyInMsg.subscribeTo(tracker_msg)
    cam.keepInCelBodyInMsg.subscribeTo(no_keep_in)
    cam.vehicleConfigInMsg.subscribeTo(plan_config_msg)

    error = attTrackingError.attTrackingError()
    error.ModelTag = "error"

    control = mrpFeedback.mrpFeedback()
    control.ModelTag = "control"
    control.K = K_SIGMA
    control.P = P_RATE
    control.Ki = -1.0
    control.controlLawType = 1
    control_config = messaging.VehicleConfigMsgPayload()
    control_config.ISCPntB_B = [0.0] * 9  # no feed-forward (see K_SIGMA)
    control_config_msg = messaging.VehicleConfigMsg().write(control_config)

    nav.scStateInMsg.subscribeTo(sc.scStateOutMsg)
    error.attNavInMsg.subscribeTo(nav.attOutMsg)
    error.attRefInMsg.subscribeTo(cam.attRefOutMsg)
    control.guidInMsg.subscribeTo(error.attGuidOutMsg)
    control.vehConfigInMsg.subscribeTo(control_config_msg)
    torque.cmdTorqueInMsg.subscribeTo(control.cmdTorqueOutMsg)

    # Higher priority first: the plant, then the flight software, then the torque read
    # (applied over the next step).
    for model, priority in ((sc, 60), (nav, 50), (cam, 40), (error, 30), (control, 20)):
        sim.AddModelToTask("loop", model, priority)
    sim.AddModelToTask("loop", torque, 10)
    rec = sc.scStateOutMsg.recorder()
    sim.AddModelToTask("loop", rec)
    # The stand-alone messages must outlive the run: the modules hold only their addresses.
    keep = (start_msg, tracker_msg, no_keep_in, plan_config_msg, control_config_msg)
    return sim, cam, rec, keep


def to_direct(cam):
    """Negate the CAM's B-spline (control points, nodes, samples): its reference becomes
    the direct problem's (module docstring). Linear in the control points, so sigma,
    sigma-dot and sigma-ddot all change sign."""
    out = cam.Output
    for name in ("C1", "C2", "C3", "X1", "X2", "X3", "XD1", "XD2", "XD3", "XDD1", "XDD2", "XDD3"):
        setattr(out, name, (-np.asarray(getattr(out, name), dtype=float)).tolist())


def run_once(grid_n=GRID_N):
    t0 = time.perf_counter()
    sim, cam, rec, keep = build(grid_n)
    t1 = time.perf_counter()
    sim.InitializeSimulation()  # the CAM's plan
    to_direct(cam)
    t2 = time.perf_counter()
    sim.ConfigureStopTime(macros.sec2nano(SIM_TIME_S))
    sim.ExecuteSimulation()
    t3 = time.perf_counter()
    del keep
    return (t1 - t0, t2 - t1, t3 - t2), cam, rec


def _dcm(sigma):
    """C_BN of each MRP row."""
    s = np.asarray(sigma, dtype=float)
    s2 = np.sum(s * s, axis=1)[:, None, None]
    tilde = np.zeros((len(s), 3, 3))
    tilde[:, 0, 1], tilde[:, 0, 2], tilde[:, 1, 2] = -s[:, 2], s[:, 1], -s[:, 0]
    tilde = tilde - np.transpose(tilde, (0, 2, 1))
    eye = np.eye(3)[None]
    return eye + (8 * tilde @ tilde - 4 * (1 - s2) * tilde) / (1 + s2) ** 2


def angles_deg(sigma_bn):
    """Angle between the boresight and each object, deg, per sample (rows: samples)."""
    boresight_n = np.einsum("kij,i->kj", _dcm(sigma_bn), _unit(BORESIGHT_B))  # C_BN^T s_B
    objects = np.array([_unit(c) for c in OBJECTS_N])
    return np.degrees(np.arccos(np.clip(boresight_n @ objects.T, -1.0, 1.0)))


def _error_deg(sigma_bn, sigma_d):
    c = _dcm(sigma_bn) @ _dcm(np.asarray([sigma_d]))[0].T  # C_BD
    return np.degrees(np.arccos(np.clip((np.trace(c, axis1=1, axis2=2) - 1) / 2, -1.0, 1.0)))


def flight(cam, rec):
    """The recorded flight: its margins per object (at the samples), its arrival (Case 1's
    tolerances), the rotation flown and the plan's figures."""
    t = np.asarray(rec.times(), dtype=float) * 1e-9
    sigma = np.asarray(rec.sigma_BN, dtype=float)
    omega = np.asarray(rec.omega_BN_B, dtype=float)
    ang = angles_deg(sigma)
    err = _error_deg(sigma, SIGMA_D)
    rate = np.linalg.norm(omega, axis=1)
    bad = np.flatnonzero((err > ARRIVAL_TOL_DEG) | (rate > ARRIVAL_TOL_RAD_S))
    arrival = None
    if len(bad) == 0 or bad[-1] < len(t) - 1:
        arrival = float(t[0 if len(bad) == 0 else bad[-1] + 1])
    spline_t = np.asarray(cam.Output.T, dtype=float).ravel()
    return {
        "samples": len(t),
        "min_angle_deg_per_object": [round(float(a), 3) for a in ang.min(axis=0)],
        "min_margin_deg": round(float(ang.min() - HALF_ANGLE_DEG), 3),
        "t_min_margin_s": round(float(t[int(np.argmin(ang.min(axis=1)))]), 2),
        "outside_cones": bool(ang.min() > HALF_ANGLE_DEG),
        "arrival_s": None if arrival is None else round(arrival, 2),
        "final_error_deg": float(err[-1]),
        "rotation_deg": float(np.degrees(np.sum(rate[:-1]) * DT_S)),
        "peak_rate_rad_s": float(rate.max()),
        "plan_waypoints": int(cam.path.N),
        "plan_duration_s": round(float(spline_t[-1]), 2) if len(spline_t) else None,
    }


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--grid", type=int, default=GRID_N, help="the CAM's grid fineness N")
    parser.add_argument(
        "--trajectory", help="write the last run's recorded t, sigma_BN, omega_BN_B here (.npz)"
    )
    args = parser.parse_args()
    run_once(args.grid)  # warm-up
    runs = [run_once(args.grid) for _ in range(args.repeats)]
    build_s, init_s, loop_s = ([r[0][i] for r in runs] for i in range(3))
    total_s = [sum(r[0]) for r in runs]
    _, cam, rec = runs[-1]
    if args.trajectory:
        np.savez(
            args.trajectory,
            t=np.asarray(rec.times(), dtype=float) * 1e-9,
            sigma_bn=np.asarray(rec.sigma_BN, dtype=float),
            omega_b=np.asarray(rec.omega_BN_B, dtype=float),
        )
    result = {
        "basilisk": Basilisk.__version__,
        "grid_n": args.grid,
        "avg_omega_rad_s": AVG_OMEGA,
        "repeats": args.repeats,
        "steps": N_STEPS,
        "run_s": statistics.median(total_s),
        "run_s_min": min(total_s),
        "build_s": statistics.median(build_s),
        "plan_s": statistics.median(init_s),
        "plan_s_min": min(init_s),
        "loop_s": statistics.median(loop_s),
        "loop_s_min": min(loop_s),
        "step_us": 1e6 * statistics.median(loop_s) / N_STEPS,
        "step_us_min": 1e6 * min(loop_s) / N_STEPS,
        "flight": flight(cam, rec),
    }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
