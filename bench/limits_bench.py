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
   gains. The draws are the campaign tool's (through the scenario loader); each is flown
   twice: by the closed-loop guidance, and by the open-loop FEPF (one planner step per
   state, no time scaling, the controller's command scaled into the bound) as the
   reference.
   Outcomes: ``reached`` (arrived, body margin > 0), ``violated`` (body margin <= 0),
   ``stuck`` and ``not reached``.

Sim-time figures only (arrival times, margins), so they do not depend on the machine.
Not a test.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import glob
import math
import os
import time

import numpy as np

from attitude_core.assembly.guidance import planner_from_scenario
from attitude_core.config.scenario_loader import loads_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.fsw.control.pd import PdGains, commanded_torque
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.summary import summarize
from attitude_core.record.trajectory import RunResult
from attitude_core.world.rigid_body import RigidBody
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import CampaignSpec, Range

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
        s = summarize(run_closed_loop(sc)).to_json()
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


def slew_spec(seed: int) -> CampaignSpec:
    """The random slews as a campaign SPEC: the draws are the campaign's
    (:func:`attitude_tools.campaign.draw.draw_run`, through the scenario loader)."""
    return CampaignSpec(
        name="limits_bench",
        runs=1,
        seed=seed,
        base_scenario=f"{ROOT}/scenarios/case1.yaml",
        sim_time_s=None,
        min_end_margin_deg=MIN_END_MARGIN_DEG,
        instrument_count=(1, 3),
        half_angle_deg=Range(10.0, 35.0),
        object_count=(2, 6),
        inertia_scale=None,
        initial_rate_std_rad_s=0.0,
        max_torque_nm=Range(0.01, 0.1),
        max_rate_rad_s=Range(0.02, 0.1),
        planner_variants=("improved",),
        source="<limits_bench>",
    )


def draw(spec: CampaignSpec, base: dict, index: int) -> tuple[object, int]:
    """Random slew ``index`` with a simulated time long enough for its limits, and the
    number of redraws it took."""
    d = draw_run(spec, base, index)
    sc = d.scenario
    rate = sc.actuators.max_rate_rad_s
    alpha = min(sc.actuators.max_torque_nm) / 10.0
    sim_time = float(round(min(2.5 * math.pi / rate + 4.0 * rate / alpha + 60, 1500)))
    return dataclasses.replace(sc, sim_time_s=sim_time), d.refused_by_loader + d.too_close_to_a_cone


def open_loop(sc) -> RunResult:
    """The reference: the open-loop FEPF (one planner step per state), torque scaled."""
    wall0 = time.perf_counter()
    n, dt = sc.n_steps, sc.dt_s
    planner = planner_from_scenario(sc)
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
    spec = slew_spec(seed)
    base = base_parameters(spec)
    counts = {
        "closed-loop guidance": collections.Counter(),
        "open-loop FEPF": collections.Counter(),
    }
    ratios, margins, torque_over, rate_over, redraws = [], [], [], [], 0
    false_arrivals = 0
    worst: list[tuple[float, int, str]] = []
    wall0 = time.perf_counter()
    for i in range(n):
        sc, r = draw(spec, base, i)
        redraws += r
        run = run_closed_loop(sc)
        s = summarize(run).to_json()
        o = outcome(s)
        counts["closed-loop guidance"][o] += 1
        counts["open-loop FEPF"][outcome(summarize(open_loop(sc)).to_json())] += 1
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
