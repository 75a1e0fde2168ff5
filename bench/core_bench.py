"""Benchmark of the ROS-free core: planner step time, guidance update time and offline
Case 1 wall time; with sensors (``sensors.*``), the estimator's cost per step (sensor
draw and MEKF step) and the offline run flown on an estimate against the same run on
the truth.

Run: .venv/bin/python bench/core_bench.py [--repeats N]
Prints figures and their ratio to the aims (planner step median <= 50 us, offline
Case 1 <= 0.5 s wall, measured in a warm process as a batch worker runs it), the
guidance update that the planner node calls around each step (no aim of its own), and
the cold command-line run (interpreter start, imports and the one-off FIS table build
included), and the closed-loop step with the compiled kernels against the Python
references (``ATTITUDE_KERNELS=python``, in another process). Not a test: timings
depend on the machine.
"""

import argparse
import dataclasses
import os
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np

from attitude_core import kernels
from attitude_core.assembly.guidance import guidance_from_scenario, planner_from_scenario
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.estimation.mekf import Mekf, MekfConfig
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.world.sensors import SensorSuite

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
AIM_STEP_US = 50.0
AIM_CASE1_WALL_S = 0.5


def planner_step_times(scenario, repeats):
    samples = []
    for _ in range(repeats):
        planner = planner_from_scenario(scenario)
        for _ in range(scenario.n_steps):
            t0 = time.perf_counter_ns()
            out = planner.step()
            samples.append(time.perf_counter_ns() - t0)
            if out.status != PlannerStatus.TRACKING:
                break
    return np.array(samples) / 1e3


def guidance_update_times(scenario, repeats):
    """The planner node's call: one guidance update per state, the body on the FEPF's
    own target path (so the governor never holds)."""
    samples = []
    for _ in range(repeats):
        path = planner_from_scenario(scenario)
        guidance = guidance_from_scenario(scenario)
        for k in range(scenario.n_steps):
            sigma = path.step().sigma_t
            t0 = time.perf_counter_ns()
            out = guidance.update(k * scenario.dt_s, sigma, np.zeros(3))
            samples.append(time.perf_counter_ns() - t0)
            if out.target.status != PlannerStatus.TRACKING:
                break
    return np.array(samples) / 1e3


def estimator_step_times(scenario, repeats):
    """``SensorSuite.measure`` and ``Mekf.step`` per step (us), on a body at rest."""
    draw, filt = [], []
    for _ in range(repeats):
        sensors = SensorSuite(scenario.sensors, scenario.dt_s)
        mekf = Mekf(MekfConfig.from_spec(scenario.sensors, scenario.dt_s))
        sigma, omega = np.asarray(scenario.initial_mrp), np.zeros(3)
        for k in range(scenario.n_steps):
            t0 = time.perf_counter_ns()
            m = sensors.measure(k * scenario.dt_s, sigma, omega)
            t1 = time.perf_counter_ns()
            mekf.step(k * scenario.dt_s, m.gyro_rad_s, m.star_tracker_quat)
            t2 = time.perf_counter_ns()
            draw.append(t1 - t0)
            filt.append(t2 - t1)
    return np.array(draw) / 1e3, np.array(filt) / 1e3


def _offline_wall(scenario, repeats):
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        run_closed_loop(scenario)
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls)


_REFERENCE_RUN = """
import statistics, sys, time
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.config.scenario_loader import load_scenario
sc = load_scenario(sys.argv[1])
run_closed_loop(sc)
walls = []
for _ in range(int(sys.argv[2])):
    t0 = time.perf_counter()
    run_closed_loop(sc)
    walls.append(time.perf_counter() - t0)
print(statistics.median(walls))
"""


def _reference_wall(repeats):
    """Warm offline Case 1 wall median with the Python references (another process)."""
    env = dict(os.environ, **{kernels.ENV: "python"})
    out = subprocess.run(
        [sys.executable, "-c", _REFERENCE_RUN, f"{ROOT}/scenarios/case1.yaml", str(repeats)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout)


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    case1 = load_scenario(f"{ROOT}/scenarios/case1.yaml")
    print(f"core benchmark, {os.cpu_count()} cpu(s), numpy {np.__version__}")
    print("planner step (tracking phase only; arrived steps are trivially cheap)")
    for name in ("case1", "case2", "case1_paper"):
        us = planner_step_times(load_scenario(f"{ROOT}/scenarios/{name}.yaml"), args.repeats)
        med, p99 = np.median(us), np.percentile(us, 99)
        print(
            f"  {name:12s} n={len(us):5d}  median {med:6.1f} us  p99 {p99:6.1f} us  "
            f"median/aim {med / AIM_STEP_US:.2f}"
        )
    print("guidance update (the planner node's call: FEPF, time scaling, governor)")
    for name in ("case1", "case1_wheels"):
        us = guidance_update_times(load_scenario(f"{ROOT}/scenarios/{name}.yaml"), args.repeats)
        med, p99 = np.median(us), np.percentile(us, 99)
        print(f"  {name:12s} n={len(us):5d}  median {med:6.1f} us  p99 {p99:6.1f} us")
    walls = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        run_closed_loop(case1)
        walls.append(time.perf_counter() - t0)
    wall = statistics.median(walls)
    print(
        f"offline case1: {case1.n_steps} steps, {case1.sim_time_s:.0f} s simulated, "
        f"wall median {wall:.3f} s (min {min(walls):.3f})  "
        f"sim/wall {case1.sim_time_s / wall:.0f}x  wall/aim {wall / AIM_CASE1_WALL_S:.2f}"
    )
    per_step = 1e6 * wall / (case1.n_steps + 1)
    reference = _reference_wall(args.repeats)
    print(
        f"closed-loop step (guidance, control, dynamics, record), case1: {per_step:.1f} us "
        f"with the {kernels.ACTIVE} kernels; Python references (ATTITUDE_KERNELS=python) "
        f"{1e6 * reference / (case1.n_steps + 1):.1f} us (reference/this {reference / wall:.2f}x)"
    )
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "attitude_tools.offline",
                f"{ROOT}/scenarios/case1.yaml",
                "--out",
                f"{tmp}/run",
                "--quiet",
            ],
            check=True,
        )
        cold = time.perf_counter() - t0
    print(f"attitude-offline case1 as a command (cold process): {cold:.2f} s wall")
    sensed = load_scenario(f"{ROOT}/scenarios/case1_wheels_sensors.yaml")
    draw, filt = estimator_step_times(sensed, args.repeats)
    print(
        f"estimator per step (case1_wheels_sensors, tracker {sensed.sensors.star_tracker_rate_hz:g}"
        f" Hz): sensor draw median {np.median(draw):.1f} us, MEKF step median "
        f"{np.median(filt):.1f} us (p99 {np.percentile(filt, 99):.1f} us)"
    )
    truth = dataclasses.replace(sensed, sensors=None)
    w_truth, w_est = _offline_wall(truth, args.repeats), _offline_wall(sensed, args.repeats)
    print(
        f"offline case1_wheels: on the truth {w_truth:.3f} s, on the estimate {w_est:.3f} s "
        f"wall median (estimate/truth {w_est / w_truth:.2f}; the slews differ: the estimate's "
        "waits for the filter and arrives on a filtered decision)"
    )


if __name__ == "__main__":
    main()
