"""Benchmark of the guidance on real actuators: time to the rest-to-rest bound on the
wheel scenarios, and outcomes of random slews with drawn torque and rate limits.

Run: .venv/bin/python bench/limits_bench.py [--slews N] [--seed S]

1. For every ``scenarios/*_wheels.yaml``: the offline closed loop's arrival time, the
   bound ``T*`` along the rotation flown and ``time_ratio_to_bound`` (aim: <= 1.3), the
   dense body margin and the peak torque and rate against their bounds.
2. ``N`` random slews (default 60): start and goal attitudes uniform over SO(3), 1-3
   instruments (random boresights, half-angles 10-35 deg), 2-6 bright objects (random
   directions), start and goal at least 3 deg outside every cone, per-axis torque bounds
   drawn in [0.01, 0.1] N m and a rate bound in [0.02, 0.1] rad/s, Case 1's inertia and
   gains. Each drawn scenario goes through the scenario loader and is flown twice: by
   the closed-loop guidance, and by the open-loop FEPF (one planner step per state, no
   time scaling, the controller's command scaled into the bound) as the reference.
   Outcomes: ``reached`` (arrived, body margin > 0), ``violated`` (body margin <= 0),
   ``stuck`` and ``not reached``.

Sim-time figures only (arrival times, margins), so they do not depend on the machine.
Not a test.
"""

from __future__ import annotations

import argparse
import collections
import glob
import math
import os
import time

import numpy as np
import yaml
from scipy.spatial.transform import Rotation

from attitude_core.closed_loop import run_closed_loop
from attitude_core.control import PdGains, commanded_torque
from attitude_core.dynamics import RigidBody
from attitude_core.fepf import FepfPlanner
from attitude_core.metrics import dense_min_margin_deg
from attitude_core.scenario import (
    ScenarioError,
    flatten_parameters,
    loads_scenario,
    scenario_yaml,
)
from attitude_core.status import PlannerStatus
from attitude_core.trajectory import RunResult, summarize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
AIM_RATIO = 1.3
MIN_END_MARGIN_DEG = 3.0
OUTCOMES = ("reached", "violated", "stuck", "not reached")


def outcome(summary: dict) -> str:
    if summary["min_margin_deg"] <= 0.0:
        return "violated"
    if summary["reached"]:
        return "reached"
    if summary["planner_stuck"]:
        return "stuck"
    return "not reached"


def wheel_scenarios() -> list[dict]:
    rows = []
    for path in sorted(glob.glob(f"{ROOT}/scenarios/*_wheels.yaml")):
        with open(path, encoding="utf-8") as f:
            sc = loads_scenario(f.read(), path)
        s = summarize(run_closed_loop(sc))
        rows.append(s)
        ratio = s["time_ratio_to_bound"]
        t_reach = s["t_reach_s"] or float("nan")
        print(
            f"  {s['scenario']:<20} {outcome(s):<11} t_reach {t_reach:7.1f} s"
            f"  T* {s['time_bound_s']:7.1f} s  time_ratio_to_bound "
            f"{ratio if ratio is not None else float('nan'):5.3f}"
            f" (aim <= {AIM_RATIO})  margin {s['min_margin_deg']:6.2f} deg"
            f"  torque/bound {s['peak_torque_to_bound']:.3f}"
            f"  rate/bound {s['peak_rate_to_bound']:.3f}"
        )
    return rows


def base_parameters() -> dict:
    with open(f"{ROOT}/scenarios/case1.yaml", encoding="utf-8") as f:
        doc = yaml.safe_load(f)
    flat = flatten_parameters(doc["/**"]["ros__parameters"])
    return {k: v for k, v in flat.items() if not k.startswith(("instruments", "bright_objects"))}


def unit(rng: np.random.Generator) -> list[float]:
    v = rng.normal(size=3)
    return [float(x) for x in v / np.linalg.norm(v)]


def draw(rng: np.random.Generator, index: int, base: dict) -> tuple[object, int]:
    """One random slew scenario (through the loader) and the number of redraws."""
    redraws = 0
    while True:
        flat = dict(base)
        n_inst, n_obj = int(rng.integers(1, 4)), int(rng.integers(2, 7))
        flat["scenario_name"] = f"random_{index}"
        flat["instruments.names"] = [f"instrument_{i}" for i in range(n_inst)]
        for i in range(n_inst):
            flat[f"instruments.instrument_{i}.boresight_body"] = unit(rng)
            flat[f"instruments.instrument_{i}.half_angle_deg"] = float(rng.uniform(10.0, 35.0))
        flat["bright_objects.names"] = [f"object_{j}" for j in range(n_obj)]
        for j in range(n_obj):
            flat[f"bright_objects.object_{j}.direction_inertial"] = unit(rng)
        flat["initial_mrp"] = [float(x) for x in Rotation.random(random_state=rng).as_mrp()]
        flat["desired_mrp"] = [float(x) for x in Rotation.random(random_state=rng).as_mrp()]
        torque = [float(x) for x in rng.uniform(0.01, 0.1, size=3)]
        rate = float(rng.uniform(0.02, 0.1))
        flat["actuators.max_torque_nm"] = torque
        flat["actuators.max_rate_rad_s"] = rate
        alpha = min(torque) / 10.0
        flat["sim_time_s"] = float(round(min(2.5 * math.pi / rate + 4.0 * rate / alpha + 60, 1500)))
        try:
            sc = loads_scenario(scenario_yaml(flat), f"<random slew {index}>")
        except ScenarioError:
            redraws += 1
            continue
        exact = sc.keep_out()
        ends = min(
            exact.min_margin_deg_single(sc.initial_mrp), exact.min_margin_deg_single(sc.desired_mrp)
        )
        if ends < MIN_END_MARGIN_DEG:
            redraws += 1
            continue
        return sc, redraws


def open_loop(sc) -> RunResult:
    """The reference: the open-loop FEPF (one planner step per state), torque scaled."""
    wall0 = time.perf_counter()
    n, dt = sc.n_steps, sc.dt_s
    planner = FepfPlanner.from_scenario(sc)
    gains = PdGains(sc.kp, sc.kd)
    body = RigidBody(sc.inertia_kgm2, sc.initial_mrp, sc.initial_rate_rad_s)
    cols = {k: np.empty((n + 1, 3)) for k in ("s", "w", "u", "st", "wt")}
    d_obs, status, step = np.empty(n + 1), np.empty(n + 1, dtype=np.int8), np.zeros(n + 1)
    for k in range(n + 1):
        target = planner.step()
        u = commanded_torque(
            gains, body.sigma_bn, body.omega_b, target.sigma_t, target.omega_t,
            sc.actuators.max_torque_nm,
        )  # fmt: skip
        cols["s"][k], cols["w"][k], cols["u"][k] = body.sigma_bn, body.omega_b, u
        cols["st"][k], cols["wt"][k] = target.sigma_t, target.omega_t
        d_obs[k], status[k] = target.obstacle_distance_mrp, target.status.code
        if k < n:
            body.step(u, dt)
    t = dt * np.arange(n + 1)
    return RunResult(
        sc, t, cols["s"], cols["w"], cols["u"], cols["st"], cols["wt"], d_obs, status, step,
        time.perf_counter() - wall0,
    )  # fmt: skip


def percentiles(values: list[float]) -> str:
    if not values:
        return "n/a"
    p = np.percentile(values, [50, 90, 100])
    return f"median {p[0]:.3f}  p90 {p[1]:.3f}  max {p[2]:.3f}"


def random_slews(n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    base = base_parameters()
    counts = {
        "closed-loop guidance": collections.Counter(),
        "open-loop FEPF": collections.Counter(),
    }
    ratios, margins, torque_over, rate_over, redraws = [], [], [], [], 0
    false_arrivals = 0
    worst: list[tuple[float, int, str]] = []
    wall0 = time.perf_counter()
    for i in range(n):
        sc, r = draw(rng, i, base)
        redraws += r
        run = run_closed_loop(sc)
        s = summarize(run)
        o = outcome(s)
        counts["closed-loop guidance"][o] += 1
        counts["open-loop FEPF"][outcome(summarize(open_loop(sc)))] += 1
        margins.append(s["min_margin_deg"])
        torque_over.append(s["peak_torque_to_bound"])
        rate_over.append(s["peak_rate_to_bound"])
        if s["time_ratio_to_bound"] is not None:
            ratios.append(s["time_ratio_to_bound"])
        # A planner 'arrived' with the body off the goal would be a false arrival.
        arrived = run.planner_status == PlannerStatus.ARRIVED.code
        if arrived.any() and not s["reached"]:
            false_arrivals += 1
        worst.append((s["min_margin_deg"], i, o))
        margin, _ = dense_min_margin_deg(sc.keep_out(), run.t, run.sigma_bn, run.omega_b)
        assert margin == s["min_margin_deg"]
    wall = time.perf_counter() - wall0
    print(f"  {n} slews, seed {seed}, {redraws} redraws (ends within 3 deg of a cone), "
          f"{wall:.0f} s wall")  # fmt: skip
    print(f"  {'':<22}" + "".join(f"{o:>13}" for o in OUTCOMES))
    for name, c in counts.items():
        print(f"  {name:<22}" + "".join(f"{c[o]:>13}" for o in OUTCOMES))
    print(f"  closed loop: time_ratio_to_bound of reached slews: {percentiles(ratios)}")
    print(f"  closed loop: min body margin, deg: min {min(margins):.2f}  "
          f"median {np.median(margins):.2f}")  # fmt: skip
    print(f"  closed loop: peak |u_i| / bound max {max(torque_over):.3f}; "
          f"peak |omega| / max_rate max {max(rate_over):.3f} (aim <= 1.05)")  # fmt: skip
    print(f"  closed loop: 'arrived' with the body off the goal: {false_arrivals}")
    print("  closed loop: lowest margins: " + ", ".join(
        f"#{i} {m:.2f} deg ({o})" for m, i, o in sorted(worst)[:5]))  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--slews", type=int, default=60)
    parser.add_argument("--seed", type=int, default=11)
    args = parser.parse_args()
    print("limits benchmark: wheel scenarios (offline closed loop)")
    wheel_scenarios()
    print("limits benchmark: random slews with drawn torque and rate limits")
    random_slews(args.slews, args.seed)


if __name__ == "__main__":
    main()
