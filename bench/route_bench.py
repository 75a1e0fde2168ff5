"""Benchmark of the global route (``attitude_core.fsw.guidance.route``): planning time per scenario
over a campaign's drawn scenarios, the one-off roadmap build, and the time to decide
that a slew is infeasible, from a cold process.

Run: .venv/bin/python bench/route_bench.py [--runs N] [--spec campaigns/leo_star_tracker.yaml ...]

For each SPEC, the first ``N`` runs are drawn exactly as ``attitude-campaign`` draws them
and the route each would plan before its first step is planned again here, timed alone
(``RoutePlanner`` construction and ``plan``, with the roadmaps already built: a planner
node builds them before its first state, a campaign worker once; on a moving sky, the
swept cones' geometry too: ``SkyGuide.plan_route``, as the guidance plans it again
during the run). Printed: median, p99
and max against the 100 ms budget, and how the routes were found (direct rotation,
default roadmap, dense roadmap, infeasible). The roadmaps' build time is printed
separately, and ``scenarios/enclosed_goal.yaml`` is decided infeasible in a fresh
Python process: by a second guidance there (the caches warm, as in a planner node,
which prepares them before its first state), by the first one (cold), and the whole
process. Not a test: timings depend on the machine.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from attitude_core.assembly.guidance import (
    moving_sky_guide,
    planner_from_scenario,
    route_planner,
    scenario_eta_s,
)
from attitude_core.fsw.guidance.route import FINE_FACTOR, ROADMAP_NODES, roadmap
from attitude_tools.campaign.draw import base_parameters, draw_run
from attitude_tools.campaign.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]
BUDGET_S = 0.100
DECIDE_BUDGET_S = 1.0

_COLD = """
import time, sys
t0 = time.perf_counter()
from attitude_core.config.scenario_loader import load_scenario
from attitude_core.assembly.guidance import guidance_from_scenario
sc = load_scenario(sys.argv[1])
t1 = time.perf_counter()
g = guidance_from_scenario(sc)
t2 = time.perf_counter()
assert g.status.value == "infeasible", g.status
g2 = guidance_from_scenario(sc)
t3 = time.perf_counter()
print(t1 - t0, t2 - t1, t3 - t2)
"""


def route_times(spec_path: Path, runs: int) -> tuple[np.ndarray, dict[str, int]]:
    spec = load_spec(spec_path)
    base = base_parameters(spec)
    times, kinds = [], {"direct": 0, "roadmap": 0, "dense roadmap": 0, "infeasible": 0}
    for i in range(runs):
        sc = draw_run(spec, base, i, spec.planner_variants[0]).scenario
        buffer = planner_from_scenario(sc).geometry.inflation_deg
        guide = moving_sky_guide(sc, buffer)  # None on a fixed sky
        eta = scenario_eta_s(sc, sc.initial_mrp)
        t0 = time.perf_counter()
        if guide is None:
            route = route_planner(sc, buffer).plan(sc.initial_mrp, sc.desired_mrp)
        else:  # the cones swept over the expected slew: their geometry, planner and route
            route = guide.plan_route(0.0, eta, sc.initial_mrp, sc.desired_mrp)
        times.append(time.perf_counter() - t0)
        if not route.feasible:
            kinds["infeasible"] += 1
        elif route.roadmap_nodes == 0:
            kinds["direct"] += 1
        elif route.roadmap_nodes == ROADMAP_NODES:
            kinds["roadmap"] += 1
        else:
            kinds["dense roadmap"] += 1
    return np.array(times), kinds


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=1000)
    parser.add_argument(
        "--spec",
        action="append",
        default=None,
        help="campaign SPEC (repeatable; default: the two random-slew campaigns)",
    )
    args = parser.parse_args()
    specs = args.spec or [
        str(ROOT / "campaigns" / "random_slews.yaml"),
        str(ROOT / "campaigns" / "random_slews_keep_in.yaml"),
        str(ROOT / "campaigns" / "leo_star_tracker.yaml"),
    ]
    for size in (ROADMAP_NODES, FINE_FACTOR * ROADMAP_NODES):
        t0 = time.perf_counter()
        rm = roadmap(size)
        print(
            f"roadmap {size:6d} attitudes, {len(rm.edges):7d} edges: built in "
            f"{1e3 * (time.perf_counter() - t0):6.1f} ms (once per process)"
        )
    every = []
    for spec in specs:
        times, kinds = route_times(Path(spec), args.runs)
        every.append(times)
        ms = 1e3 * times
        print(
            f"{Path(spec).name}: {len(times)} scenarios, route planning median "
            f"{np.median(ms):.1f} ms, p99 {np.percentile(ms, 99):.1f} ms, max {ms.max():.1f} ms "
            f"(budget {1e3 * BUDGET_S:.0f} ms); {kinds}"
        )
    ms = 1e3 * np.concatenate(every)
    over = int(np.sum(ms > 1e3 * BUDGET_S))
    print(
        f"all: median {np.median(ms):.1f} ms, p99 {np.percentile(ms, 99):.1f} ms, "
        f"max {ms.max():.1f} ms; {over} of {len(ms)} over the budget"
    )
    scenario = ROOT / "scenarios" / "enclosed_goal.yaml"
    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-c", _COLD, str(scenario)], capture_output=True, text=True, check=True
    )
    wall = time.perf_counter() - t0
    imports, cold, warm = (float(x) for x in proc.stdout.split())
    print(
        f"enclosed_goal decided infeasible: {warm:.3f} s by a guidance built in a warm "
        f"process (what a running planner node pays: it builds the FIS tables and the "
        f"roadmaps before its first state); cold, {cold:.3f} s for the first guidance "
        f"(the roadmaps built on the way; an infeasible slew needs no FIS table) after "
        f"{imports:.3f} s of imports; "
        f"{wall:.3f} s for the whole process (budget {DECIDE_BUDGET_S:.0f} s)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
