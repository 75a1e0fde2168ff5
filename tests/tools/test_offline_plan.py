"""``attitude-offline`` with an observation plan: ``summary.json`` ``goals`` and the goal
in force per step in ``timeseries.csv``; a refused target does not fail the run, a
target not reached does; a scenario without goals keeps its columns."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from attitude_core.config.scenario_loader import load_scenario
from attitude_tools.offline import GOAL_COLUMNS, TIMESERIES_COLUMNS, main

ROOT = Path(__file__).resolve().parents[2]
PLAN = ROOT / "scenarios" / "case1_plan.yaml"


def _with_targets(tmp_path: Path, targets: str, sim_time_s: float = 400.0) -> Path:
    text = PLAN.read_text()
    start, end = text.index("    plan:"), text.index("    controller:")
    text = text[:start] + targets + text[end:]
    text = text.replace("sim_time_s: 400.0", f"sim_time_s: {sim_time_s}")
    path = tmp_path / "plan.yaml"
    path.write_text(text)
    return path


def _table(out: Path) -> tuple[list[str], np.ndarray]:
    header = (out / "timeseries.csv").read_text().splitlines()[0].split(",")
    return header, np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1)


def test_a_plan_writes_its_goals_and_the_goal_in_force(tmp_path):
    out = tmp_path / "run"
    assert main([str(PLAN), "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    header, table = _table(out)
    assert header == list(TIMESERIES_COLUMNS) + GOAL_COLUMNS
    index = table[:, header.index("goal_index")].astype(int)
    sc = load_scenario(PLAN)
    for k, goal in enumerate(summary["goals"]):
        rows = index == k
        assert rows.any()
        t = table[rows, 0]
        assert t[0] == goal["t_start_s"] and t[-1] == goal["t_end_s"]
        sigma = table[rows][:, [header.index(f"goal_sigma_{i}") for i in (1, 2, 3)]]
        assert np.all(sigma == sc.plan[k].desired_mrp)
    assert np.all(np.diff(index[index >= 0]) >= 0)  # in order


def test_a_refused_target_is_skipped_and_the_run_succeeds_one_not_reached_fails(tmp_path):
    blind = (
        "    plan:\n      names: [blind, goal]\n"
        "      blind:\n        desired_mrp: [0.0, 0.0, 0.0]\n        dwell_s: 5.0\n"
        "      goal:\n        desired_mrp: [0.0, -0.2, -0.7]\n        dwell_s: 5.0\n"
    )
    out = tmp_path / "refused"
    assert main([str(_with_targets(tmp_path, blind)), "--out", str(out), "--quiet"]) == 0
    goals = json.loads((out / "summary.json").read_text())["goals"]
    assert [g["outcome"] for g in goals] == ["refused", "reached"]
    assert goals[0]["min_margin_deg"] is None and goals[0]["t_start_s"] is None
    short = _with_targets(tmp_path, blind, sim_time_s=20.0)  # too short for the slew
    out = tmp_path / "short"
    assert main([str(short), "--out", str(out), "--quiet"]) == 1
    goals = json.loads((out / "summary.json").read_text())["goals"]
    assert [g["outcome"] for g in goals] == ["refused", "not_reached"]


def test_a_scenario_without_goals_keeps_its_columns(tmp_path):
    out = tmp_path / "case1"
    assert main([str(ROOT / "scenarios" / "case1.yaml"), "--out", str(out), "--quiet"]) == 0
    header, _ = _table(out)
    assert header == list(TIMESERIES_COLUMNS)
    assert json.loads((out / "summary.json").read_text())["goals"] == []
