"""Compare the FEPF rotation-axis forms (eq. 10) and gamma on the scenarios.

Run: .venv/bin/python bench/planner_variants.py [--gammas 0,30,60,90] [--scenarios case1,case2]
For each scenario, both planner variants are run closed-loop with each rotation-axis
form ("paper": o ~ sigma_c_hat x sigma; "goal_plane": o ~ sigma_a_hat x sigma_c_hat) and
each gamma; prints arrival time, stuck flag, minimum margin, path length and peak torque.
The table in docs/planner_design.md was produced with this script.
"""

import argparse
import dataclasses
import os

from attitude_core.config.scenario_loader import load_scenario
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.record.summary import summarize

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--gammas", default="0,10,30,45,60,75,90")
    parser.add_argument("--scenarios", default="case1,case2,case1_paper,case2_paper")
    args = parser.parse_args()
    gammas = [float(g) for g in args.gammas.split(",")]
    print(
        "| scenario | variant | axis | gamma deg | reached | t_reach s | stuck | "
        "min margin deg | path MRP | peak torque N m |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in args.scenarios.split(","):
        base = load_scenario(f"{ROOT}/scenarios/{name}.yaml")
        for axis in ("paper", "goal_plane"):
            for gamma in gammas:
                cfg = dataclasses.replace(base.planner, direction_axis=axis, gamma_deg=gamma)
                s = summarize(run_closed_loop(dataclasses.replace(base, planner=cfg))).to_json()
                t = f"{s['t_reach_s']:.1f}" if s["t_reach_s"] is not None else "-"
                print(
                    f"| {name} | {cfg.variant} | {axis} | {gamma:.0f} | {s['reached']} | {t} | "
                    f"{s['planner_stuck']} | {s['min_margin_deg']:.2f} | "
                    f"{s['path_length_mrp']:.3f} | {s['peak_torque_nm']:.2f} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
