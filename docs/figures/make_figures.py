"""Draw the moving-sky figures of docs/planner_design.md (offline runs, about 10 s).

Run: .venv/bin/python docs/figures/make_figures.py
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from attitude_core.config.scenario_loader import load_scenario, parse_scenario
from attitude_core.contract.status import PlannerStatus
from attitude_core.loop.closed_loop import run_closed_loop
from attitude_core.yamlio import load_strict

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]


def moving_versus_frozen() -> None:
    path = ROOT / "scenarios" / "moving_object.yaml"
    moving = load_scenario(path)
    doc = load_strict(path.read_text())["/**"]["ros__parameters"]
    del doc["bright_objects"]["mover"]["rate_inertial_rad_s"]
    frozen = parse_scenario(doc, str(path))
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    for sc, label in (
        (moving, "planned on the moving sky"),
        (frozen, "planned on the sky frozen at t = 0"),
    ):
        run = run_closed_loop(sc)
        margins = moving.sky.constraint_margins_deg(run.t, run.sigma_bn)  # the true sky
        ax.plot(run.t, margins.min(axis=1), label=label)
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set(xlabel="t, s", ylabel="smallest body margin, deg (true sky)", xlim=(0, 80))
    ax.set_title("moving_object.yaml: an object at 0.4 deg/s across Case 1's path")
    ax.legend()
    fig.tight_layout()
    fig.savefig(HERE / "moving_sky_margins.png", dpi=110)


def goal_blocked() -> None:
    sc = load_scenario(ROOT / "scenarios" / "leo_goal_blocked.yaml")
    run = run_closed_loop(sc)
    body = sc.sky.constraint_margins_deg(run.t, run.sigma_bn)
    goal = sc.sky.constraint_margins_deg(run.t, 0.0 * run.sigma_bn + sc.desired_mrp)
    fig, ax = plt.subplots(figsize=(7.0, 3.6))
    for k, name in enumerate(sc.constraint_names):
        ax.plot(run.t, body[:, k], label=f"body, {name}")
    earth = sc.constraint_names.index("star_tracker/earth")
    ax.plot(run.t, goal[:, earth], "k--", label="goal, star_tracker/earth")
    blocked = run.planner_status == PlannerStatus.BLOCKED.code
    ax.fill_between(run.t, -20, 80, where=blocked, color="0.9", label="status blocked")
    ax.axhline(0.0, color="k", lw=0.8)
    ax.set(xlabel="t, s", ylabel="margin from the limb, deg", ylim=(-20, 80))
    ax.set_title("leo_goal_blocked.yaml: the Earth covers the goal from 62 s")
    ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(HERE / "goal_blocked.png", dpi=110)


if __name__ == "__main__":
    moving_versus_frozen()
    goal_blocked()
